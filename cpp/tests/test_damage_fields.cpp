// The damage-field-gradient partition (Homel & Herbold 2017): the kernel
// field's gradient vanishes for uniform damage and points at a damaged band
// (U1, U2), surface flags of a rectangle (U4), a band splits its two sides
// at every node between them (U2), a fully damaged particle without a
// gradient takes the side of its nearest neighbour with one, zero damage
// runs with the bits of one field (U5), and so do fully damaged particles
// too few to make a node separable, colliding bodies of one group conserve
// momentum with equal and opposite contact forces, and results do not
// depend on the thread count or on a restart; the neighbour lists hold
// every pair within the kernel radius until they are stale.
#include "disks.h"
#include "helpers.h"
#include "pfmpm/contact/coulomb.h"
#include "pfmpm/fields/kernel.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <vector>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// A rectangle [x0, x1] x [y0, y1] of particles, `n` per cell of side h per
/// direction, body 0, unit density.
Particles make_rectangle(double x0, double y0, double x1, double y1, double h, int n)
{
  const double d = h / n;
  const int nx = static_cast<int>(std::lround((x1 - x0) / d)), ny = static_cast<int>(std::lround((y1 - y0) / d));
  Particles P(static_cast<std::size_t>(nx) * ny);
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
    {
      const std::size_t p = static_cast<std::size_t>(i) * ny + j;
      P.x[2 * p] = x0 + (i + 0.5) * d;
      P.x[2 * p + 1] = y0 + (j + 0.5) * d;
      P.mass[p] = P.volume[p] = d * d;
    }
  return P;
}

/// Momentum scale: sum of M_p |v_p|.
double momentum_scale(const Particles& P)
{
  double s = 0;
  for (std::size_t i = 0; i < P.size(); ++i)
    s += P.mass[i] * std::hypot(P.v[2 * i], P.v[2 * i + 1]);
  return s;
}

/// A block [1, 5] x [1, 3] (h = 0.25, 2 per cell) with a fully damaged band
/// across x = 3, |x - 3| < `band` (surface-flagged particles; one cell wide
/// by default), its halves pulled apart and sheared, with one group of
/// friction 0.3.
struct BandedBlock
{
  Grid<2> grid{2, {24, 16}, 0.25, {0.0, 0.0}};
  Particles P = make_rectangle(1.0, 1.0, 5.0, 3.0, 0.25, 2);
  std::unique_ptr<Solver<2>> solver;

  explicit BandedBlock(std::optional<DamageGradientOptions> options = DamageGradientOptions{},
                       double band = 0.125)
  {
    add_model_columns(P, false);
    for (std::size_t p = 0; p < P.size(); ++p)
    {
      const double x = P.x[2 * p], y = P.x[2 * p + 1];
      P.v[2 * p] = x < 3.0 ? -0.02 : 0.02;
      P.v[2 * p + 1] = 0.01 * std::sin(3.0 * x) + (x < 3.0 ? 0.01 : -0.01);
      P.f64("strain")[3 * p] = 1e-3 * std::cos(2.0 * y);
    }
    std::vector<double> friction;
    if (options)
      friction = {0.3};
    StepConfig step(2e-3);
    step.friction = friction;
    if (options)
    {
      step.partition = Partition::damage_gradient;
      step.damage = *options;
    }
    solver = std::make_unique<Solver<2>>(grid, P, elastic(100.0, 0.3, 1.0), step);
    if (options)
      for (std::size_t p = 0; p < P.size(); ++p)
        if (std::abs(P.x[2 * p] - 3.0) < band)
          P.i32("surface")[p] = 1;
  }
};
} // namespace

TEST(KernelField, UniformDamageHasZeroGradient)
{
  // U1: any particle set, free surfaces included.
  const Grid<2> grid(2, {24, 24}, 0.25, {0.0, 0.0});
  Particles P = make_disks({{3.0, 3.0, 1.7, 0.0, 0.0}}, 0.125);
  const double radius = std::sqrt(2.0) * 0.25;
  for (double d : {0.0, 0.37, 1.0})
  {
    const KernelField f = kernel_damage_field(grid, P.x, std::vector<double>(P.size(), d), radius);
    for (std::size_t p = 0; p < P.size(); ++p)
    {
      EXPECT_EQ(f.D[p], d);
      EXPECT_LT(std::hypot(f.grad[2 * p], f.grad[2 * p + 1]), 1e-12 / radius);
      EXPECT_GE(f.S[p], 1.0);
    }
  }
}

TEST(KernelField, LatticeSums)
{
  // The card's table (shared/homel-herbold-method.md section 9).
  EXPECT_NEAR(lattice_kernel_sum(2, 0.5, std::sqrt(2.0)), 7.588, 5e-4);
  EXPECT_NEAR(lattice_kernel_sum(2, 1.0 / 3.0, std::sqrt(2.0)), 16.949, 5e-4);
}

TEST(KernelField, GradientPointsAtADamagedBand)
{
  // U2: one row of D = 1 at y = 2.0625 in a block; within r_p of the band and
  // away from its ends, the gradients point at it along its normal.
  const Grid<2> grid(2, {32, 16}, 0.25, {0.0, 0.0});
  const Particles P = make_rectangle(1.0, 1.0, 7.0, 3.0, 0.25, 2);
  const double radius = std::sqrt(2.0) * 0.25, band = 2.0625;
  std::vector<double> damage(P.size(), 0.0);
  for (std::size_t p = 0; p < P.size(); ++p)
    damage[p] = std::abs(P.x[2 * p + 1] - band) < 0.01 ? 1.0 : 0.0;
  const KernelField f = kernel_damage_field(grid, P.x, damage, radius);
  int seen = 0;
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    const double x = P.x[2 * p], dy = P.x[2 * p + 1] - band;
    if (std::abs(dy) < 0.01 || std::abs(dy) >= radius || x < 1.0 + radius || x > 7.0 - radius)
      continue;
    const double gx = f.grad[2 * p], gy = f.grad[2 * p + 1];
    EXPECT_LT(gy * dy, 0.0) << "towards the band";
    EXPECT_LT(std::atan2(std::abs(gx), std::abs(gy)), M_PI / 180.0) << "along its normal";
    ++seen;
  }
  EXPECT_GT(seen, 100);
}

namespace
{
/// Every pair within `cutoff` of positions x, by brute force: per particle, sorted.
std::vector<std::vector<std::int32_t>> pairs_within(const std::vector<double>& x, double cutoff)
{
  const std::size_t n = x.size() / 2;
  std::vector<std::vector<std::int32_t>> out(n);
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t q = 0; q < n; ++q)
      if (q != p && std::hypot(x[2 * q] - x[2 * p], x[2 * q + 1] - x[2 * p + 1]) <= cutoff)
        out[p].push_back(static_cast<std::int32_t>(q));
  return out;
}

/// Whether every pair of `needed` is in `list`.
bool holds(const NeighbourList<2>& list, const std::vector<std::vector<std::int32_t>>& needed)
{
  for (std::size_t p = 0; p < needed.size(); ++p)
  {
    const auto listed = list.of(p);
    for (std::int32_t q : needed[p])
      if (!std::binary_search(listed.begin(), listed.end(), q))
        return false;
  }
  return true;
}
} // namespace

TEST(KernelField, ThreeDimensionsOnAPlaneIsTheTwoDimensionalFieldAndALinearDamageAGradientAlongIt)
{
  // A 7^3 cubic lattice of spacing 0.5 with p at its centre, radius 1.2:
  // (1) the particles of p's z plane alone, in 3D, give the 2D field's bits
  // and no z gradient; (2) uniform damage, zero gradient exactly; (3) a
  // linear damage D = D_p + a . (x - x_p): by the lattice's symmetry D-bar =
  // D_p and grad D-bar = k a, one factor k for every direction.
  const double h = 0.5, radius = 1.2;
  std::vector<double> x3, x2, plane_damage, uniform, linear;
  std::vector<std::int32_t> all, plane;
  const double a[3] = {0.3, -0.7, 0.45};
  std::size_t centre = 0;
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j)
      for (int k = 0; k < 7; ++k)
      {
        const double p[3] = {i * h, j * h, k * h};
        if (i == 3 && j == 3 && k == 3)
          centre = x3.size() / 3;
        all.push_back(static_cast<std::int32_t>(x3.size() / 3));
        x3.insert(x3.end(), p, p + 3);
        uniform.push_back(0.4);
        linear.push_back(0.5 + a[0] * (p[0] - 1.5) + a[1] * (p[1] - 1.5) + a[2] * (p[2] - 1.5));
      }
  // The z = 1.5 plane, in 3D (its indices in x3) and in 2D.
  std::vector<double> damage3(x3.size() / 3, 0.0);
  std::vector<std::int32_t> list2;
  std::size_t centre2 = 0;
  for (std::size_t q = 0; q < x3.size() / 3; ++q)
  {
    damage3[q] = std::sin(3.0 * x3[3 * q]) * std::cos(2.0 * x3[3 * q + 1]) + 0.5;
    if (x3[3 * q + 2] == 1.5)
    {
      if (q == centre)
        centre2 = x2.size() / 2;
      plane.push_back(static_cast<std::int32_t>(q));
      list2.push_back(static_cast<std::int32_t>(x2.size() / 2));
      x2.push_back(x3[3 * q]);
      x2.push_back(x3[3 * q + 1]);
      plane_damage.push_back(damage3[q]);
    }
  }
  const KernelValue<3> f3 = kernel_field<3>(centre, plane.data(), static_cast<std::int64_t>(plane.size()),
                                            x3.data(), damage3.data(), radius);
  const KernelValue<2> f2 = kernel_field<2>(centre2, list2.data(), static_cast<std::int64_t>(list2.size()),
                                            x2.data(), plane_damage.data(), radius);
  EXPECT_EQ(f3.S, f2.S);
  EXPECT_EQ(f3.D, f2.D);
  EXPECT_EQ(f3.grad[0], f2.grad[0]);
  EXPECT_EQ(f3.grad[1], f2.grad[1]);
  EXPECT_EQ(f3.grad[2], 0.0);
  EXPECT_GT(std::abs(f2.grad[0]), 1e-3); // a field that varies

  const auto n = static_cast<std::int64_t>(all.size());
  const KernelValue<3> u = kernel_field<3>(centre, all.data(), n, x3.data(), uniform.data(), radius);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(u.grad[c], 0.0);
  EXPECT_EQ(u.D, 0.4);
  const KernelValue<3> l = kernel_field<3>(centre, all.data(), n, x3.data(), linear.data(), radius);
  EXPECT_NEAR(l.D, 0.5, 1e-15);
  const double k = l.grad[0] / a[0];
  EXPECT_GT(k, 0.0);
  for (int c = 1; c < 3; ++c)
    EXPECT_NEAR(l.grad[c] / a[c], k, 1e-13 * k) << c;
}

TEST(NeighbourList, ListsEveryPairWithinTheCutoffSorted)
{
  // A jittered lattice, 2 per cell, and cutoffs below, at and above a cell.
  const Grid<2> grid(2, {20, 16}, 0.25, {0.0, 0.0});
  Particles P = make_rectangle(0.5, 0.5, 4.5, 3.5, 0.25, 2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05);
  for (double& x : P.x)
    x += jitter(rng);
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, P.x), P.size());
  for (double cutoff : {0.2, 0.25, 0.4243})
  {
    NeighbourList<2> list;
    list.build(grid, sort, P.x, cutoff);
    const auto expected = pairs_within(P.x, cutoff);
    for (std::size_t p = 0; p < P.size(); ++p)
    {
      const std::vector<std::int32_t> got(list.of(p).begin(), list.of(p).end());
      EXPECT_EQ(got, expected[p]) << "particle " << p << ", cutoff " << cutoff;
    }
  }
}

TEST(NeighbourList, StaysValidUnderCommonMotionOnly)
{
  // Built with cutoff r + 2 delta. A rigid translation far beyond the skin
  // keeps the list (each block of cells moves as a whole); so does a
  // displacement below delta everywhere. Relative motion of more than 2 delta
  // makes it stale; whenever the list is not stale, it holds every pair now
  // within r.
  const Grid<2> grid(2, {40, 16}, 0.25, {0.0, 0.0});
  const Particles start = make_rectangle(1.0, 1.0, 5.0, 3.0, 0.25, 2);
  const double r = std::sqrt(2.0) * 0.25, delta = 0.1 * r;
  auto moved = [&](auto&& u)
  {
    std::vector<double> x = start.x;
    for (std::size_t p = 0; p < start.size(); ++p)
      u(&x[2 * p]);
    return x;
  };
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, start.x), start.size());
  auto check = [&](const std::vector<double>& x, bool expect_stale, const char* what)
  {
    NeighbourList<2> list;
    list.build(grid, sort, start.x, r + 2.0 * delta);
    list.moved(1e3); // past the cheap bound: the exact tests decide
    CellSort now;
    ASSERT_EQ(now.sort(grid, x), start.size());
    const bool stale = list.stale(grid, now, x, delta);
    EXPECT_EQ(stale, expect_stale) << what;
    if (!stale)
      EXPECT_TRUE(holds(list, pairs_within(x, r))) << what;
  };
  check(moved([](double* x) { x[0] += 3.3; x[1] -= 0.4; }), false, "rigid translation");
  check(moved([&](double* x) { x[0] += 0.9 * delta * std::sin(7.0 * x[1]); }), false,
        "below the skin");
  // Two halves translating apart or sliding past each other: only where
  // they meet is the motion relative, by 2.5 delta.
  check(moved([&](double* x) { x[0] += x[0] < 3.0 ? -1.25 * delta : 1.25 * delta; }), true,
        "halves parting");
  check(moved([&](double* x) { x[1] += x[0] < 3.0 ? -1.25 * delta : 1.25 * delta; }), true,
        "halves sliding");
  // A stretch of 4 % of the 4 mm block: its ends move by 2.3 delta, but
  // two particles of a block of cells and the blocks around it (1.5 mm
  // across) by under 2 delta relative to each other.
  check(moved([](double* x) { x[0] = 3.0 + 1.04 * (x[0] - 3.0); }), false, "uniform stretch");
}

TEST(DamageFields, SurfaceFlagsOfARectangle)
{
  // U4: with S < 0.99 S_bulk, exactly the two outer particle rows of a 2 per
  // cell rectangle are flagged; its corner particle has S / S_bulk = 0.470.
  Grid<2> grid(2, {24, 20}, 0.25, {0.0, 0.0});
  Particles P = make_rectangle(1.0, 1.0, 5.0, 4.0, 0.25, 2);
  StepConfig step(1e-3);
  step.friction = {0.0};
  step.partition = Partition::damage_gradient;
  step.damage = DamageGradientOptions{};
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), step);
  const std::vector<double> ratio = solver.detect_surfaces({0.125}, 0.99);
  const std::vector<std::int32_t>& flag = P.i32("surface");
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    const double x = P.x[2 * p], y = P.x[2 * p + 1];
    const double edge = std::min({x - 1.0, 5.0 - x, y - 1.0, 4.0 - y}); // 0.0625 + 0.125 k
    EXPECT_EQ(flag[p], edge < 0.25 ? 1 : 0) << x << ", " << y;
    if (std::abs(x - 1.0625) < 1e-9 && std::abs(y - 1.0625) < 1e-9)
      EXPECT_NEAR(ratio[p], 0.470, 5e-4);
  }
}

TEST(DamageFields, BandSplitsItsTwoSides)
{
  // U2: at every node that particles from both sides of the band map to,
  // the two sides are in different fields.
  BandedBlock b;
  b.solver->prepare();
  const DamageFields<2>& fields = *b.solver->damage_fields();
  const std::vector<std::uint32_t>& mask = fields.masks();
  std::map<std::pair<int, int>, std::set<std::pair<int, int>>> at; // node -> (half, side)
  for (std::size_t p = 0; p < b.P.size(); ++p)
  {
    const double x = b.P.x[2 * p];
    if (std::abs(x - 3.0) < 0.125)
      continue; // the band itself
    const int cx = static_cast<int>(x / 0.25), cy = static_cast<int>(b.P.x[2 * p + 1] / 0.25);
    for (int i = 0; i < 9; ++i)
      at[{cx + i / 3, cy + i % 3}].insert({x < 3.0 ? 0 : 1, (mask[p] >> i) & 1});
  }
  int straddling = 0;
  for (const auto& [node, sides] : at)
  {
    std::set<int> halves;
    for (const auto& [half, side] : sides)
      halves.insert(half);
    if (halves.size() < 2)
      continue;
    ++straddling;
    for (int side = 0; side < 2; ++side)
      EXPECT_FALSE(sides.count({0, side}) && sides.count({1, side}))
          << "node " << node.first << ", " << node.second;
  }
  EXPECT_GT(straddling, 10);
}

TEST(DamageFields, FlatFailedParticlesTakeTheSideOfTheirNearestSlopedNeighbour)
{
  // A band three cells wide (particle columns x = 2.6875 ... 3.3125): the
  // two middle columns, x = 2.9375 and 3.0625, see only fully damaged
  // particles within r_p = 0.354 (zero gradient). Each takes the side of
  // its nearest neighbour with a gradient: the band's edge column on its
  // own side, 0.125 away (the other edge is 0.25 away), in the same cell,
  // so the two have the same mask. The edges' gradients point opposite
  // ways, so at the nodes both middle columns map to, away from the
  // block's top and bottom, the two columns are in different fields.
  BandedBlock b(DamageGradientOptions{}, 0.375);
  b.solver->prepare();
  const DamageFields<2>& fields = *b.solver->damage_fields();
  const std::vector<std::uint32_t>& mask = fields.masks();
  const std::vector<double>& grad = b.P.f64("damage_gradient");
  std::map<std::pair<long, long>, std::size_t> at; // (x, y) in 1/16 -> particle
  for (std::size_t p = 0; p < b.P.size(); ++p)
    at[{std::lround(16 * b.P.x[2 * p]), std::lround(16 * b.P.x[2 * p + 1])}] = p;
  const NodeBlock& block = b.grid.block();
  const int width = block.width;
  auto node = [&](std::size_t p, int i)
  {
    const int cx = static_cast<int>(b.P.x[2 * p] / b.grid.h()),
              cy = static_cast<int>(b.P.x[2 * p + 1] / b.grid.h());
    return std::pair<int, int>{block.first(cx, b.grid.nodes()[0]) + i / width,
                               block.first(cy, b.grid.nodes()[1]) + i % width};
  };
  int rows = 0, opposite = 0;
  for (long y = 17; y < 48; y += 2) // y = 1.0625 ... 2.9375
  {
    const std::size_t left = at.at({47, y}), right = at.at({49, y});         // x = 2.9375, 3.0625
    const std::size_t left_edge = at.at({45, y}), right_edge = at.at({51, y}); // x = 2.8125, 3.1875
    for (const std::size_t p : {left, right})
      EXPECT_TRUE(grad[2 * p] == 0.0 && grad[2 * p + 1] == 0.0) << "y = " << y / 16.0;
    EXPECT_NE(grad[2 * left_edge], 0.0);
    EXPECT_NE(grad[2 * right_edge], 0.0);
    EXPECT_EQ(mask[left], mask[left_edge]) << "y = " << y / 16.0;
    EXPECT_EQ(mask[right], mask[right_edge]) << "y = " << y / 16.0;
    ++rows;
    if (y < 24 || y > 40)
      continue; // near the block's top and bottom the nodal gradients tilt
    for (int i = 0; i < width * width; ++i)
      for (int j = 0; j < width * width; ++j)
        if (node(left, i) == node(right, j))
        {
          EXPECT_NE(mask[left] >> i & 1u, mask[right] >> j & 1u)
              << "node " << node(left, i).first << ", " << node(left, i).second;
          ++opposite;
        }
  }
  EXPECT_EQ(rows, 16);
  EXPECT_GT(opposite, 10);
}

TEST(DamageFields, ZeroDamageRunsAsOneField)
{
  // U5: no damage and no surface flags: the bits of the single field.
  auto run = [](bool damage)
  {
    BandedBlock b(damage ? std::optional<DamageGradientOptions>{DamageGradientOptions{}} : std::nullopt);
    if (damage)
      std::fill(b.P.i32("surface").begin(), b.P.i32("surface").end(), 0);
    b.solver->advance(300);
    return b.P;
  };
  const Particles one = run(false), split = run(true);
  EXPECT_TRUE(same_bits(one.x, split.x));
  EXPECT_TRUE(same_bits(one.v, split.v));
  EXPECT_TRUE(same_bits(one.stress, split.stress));
}

TEST(DamageFields, LoneFailedParticlesRunAsOneField)
{
  // Eq. 21 needs both sides' mean damage above D-bar_min, so a node where
  // the mean of all its particles' is not above it cannot separate: a few
  // fully damaged particles apart from each other (each about a tenth of
  // its nodes' mass) open no node, split none, and the run has the single
  // field's bits.
  auto run = [](bool damage)
  {
    BandedBlock b(damage ? std::optional<DamageGradientOptions>{DamageGradientOptions{}} : std::nullopt);
    if (damage)
    {
      std::vector<std::int32_t>& surface = b.P.i32("surface");
      std::fill(surface.begin(), surface.end(), 0);
      for (std::size_t p = 0; p < b.P.size(); ++p)
        for (const double cx : {1.9375, 3.0625, 4.1875})
          if (std::hypot(b.P.x[2 * p] - cx, b.P.x[2 * p + 1] - 2.0625) < 0.01)
            surface[p] = 1;
      EXPECT_EQ(std::count(surface.begin(), surface.end(), 1), 3);
    }
    int split = 0;
    for (int step = 0; step < 300; ++step)
    {
      b.solver->advance(1);
      split += damage ? b.solver->contact_stats()->split : 0;
    }
    EXPECT_EQ(split, 0);
    return b.P;
  };
  const Particles one = run(false), split = run(true);
  EXPECT_TRUE(same_bits(one.x, split.x));
  EXPECT_TRUE(same_bits(one.v, split.v));
  EXPECT_TRUE(same_bits(one.stress, split.stress));
}

TEST(DamageFields, BandParts)
{
  // The two halves are pulled apart: the band's nodes are separable and
  // carry no force, so each half keeps its momentum exactly.
  BandedBlock b;
  auto half_momentum = [&]
  {
    double px = 0.0;
    for (std::size_t p = 0; p < b.P.size(); ++p)
      if (b.P.x[2 * p] > 3.0)
        px += b.P.mass[p] * b.P.v[2 * p];
    return px;
  };
  b.solver->advance(2);
  const double before = half_momentum();
  b.solver->advance(200);
  const ContactStats& s = *b.solver->contact_stats();
  EXPECT_GT(s.separable_total, 0);
  EXPECT_EQ(s.active, 0);
  EXPECT_NEAR(half_momentum(), before, 1e-13 * std::abs(before));
}

TEST(DamageFields, CollisionConservesMomentum)
{
  // Two disks of one contact group meet through their surface-flagged
  // fields: momentum is kept, forces are equal and opposite, C.1-C.4 hold.
  Grid<2> grid(2, {32, 24}, 0.25, {0.0, 0.0});
  Particles P = make_disks({{2.0, 2.0, 1.0, 0.5, 0.1}, {4.1, 2.6, 1.0, 0.0, 0.0}}, 0.125);
  DamageGradientOptions options;
  options.groups = {0, 0};
  StepConfig step(2e-3);
  step.friction = {0.3};
  step.partition = Partition::damage_gradient;
  step.damage = options;
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), step);
  solver.detect_surfaces({0.125, 0.125}, 0.99);
  const Energies before = solver.energies();
  const double scale = momentum_scale(P);
  for (int k = 0; k < 60; ++k)
  {
    solver.advance(25);
    const Energies e = solver.energies();
    EXPECT_NEAR(e.momentum[0], before.momentum[0], 1e-10 * scale);
    EXPECT_NEAR(e.momentum[1], before.momentum[1], 1e-10 * scale);
  }
  const ContactStats& s = *solver.contact_stats();
  EXPECT_GT(s.active, 0);
  EXPECT_GT(s.separable_total, 0);
  EXPECT_LT(s.friction_work, 0.0);
  for (int c = 0; c < 4; ++c)
    EXPECT_EQ(s.violations[c], 0) << "C." << c + 1;
}

TEST(DamageFields, GradientsAndMasksAwayFromOpenNodesAreZero)
{
  // Each build zeroes the gradients and masks that the one before set, and
  // after a restore (forget()) every particle's: where no node is open
  // within a particle's stencil, its gradient and mask are zero.
  BandedBlock b;
  b.solver->prepare();
  const std::vector<double>& grad = b.P.f64("damage_gradient");
  auto far_from = [&](double band, double margin)
  {
    int nonzero = 0, far = 0;
    for (std::size_t p = 0; p < b.P.size(); ++p)
      if (std::abs(b.P.x[2 * p] - band) > margin)
      {
        ++far;
        nonzero += grad[2 * p] != 0.0 || grad[2 * p + 1] != 0.0
                   || b.solver->damage_fields()->masks()[p] != 0u;
      }
    EXPECT_GT(far, 100);
    return nonzero;
  };
  auto near_count = [&](double band)
  {
    int n = 0;
    for (std::size_t p = 0; p < b.P.size(); ++p)
      n += std::abs(b.P.x[2 * p] - band) < 0.5 && (grad[2 * p] != 0.0 || grad[2 * p + 1] != 0.0);
    return n;
  };
  EXPECT_GT(near_count(3.0), 20);
  EXPECT_EQ(far_from(3.0, 1.0), 0);
  // The band moves to x = 2: nothing is left of the gradients at x = 3.
  std::vector<std::int32_t>& surface = b.P.i32("surface");
  for (std::size_t p = 0; p < b.P.size(); ++p)
    surface[p] = std::abs(b.P.x[2 * p] - 2.0) < 0.125 ? 1 : 0;
  b.solver->prepare();
  EXPECT_GT(near_count(2.0), 20);
  EXPECT_EQ(near_count(3.0), 0);
  EXPECT_EQ(far_from(2.0, 1.0), 0);
  // A restored state whose columns hold gradients everywhere.
  std::vector<double>& written = b.P.f64("damage_gradient");
  std::fill(written.begin(), written.end(), 1.0);
  b.solver->restore(b.solver->state());
  b.solver->prepare();
  EXPECT_GT(near_count(2.0), 20);
  EXPECT_EQ(far_from(2.0, 1.0), 0);
}

TEST(DamageFields, ThreadCountDoesNotChangeBits)
{
  // Bands one and three cells wide (the second with flat, fully damaged
  // particles, whose sides come from their neighbours).
  for (const double band : {0.125, 0.375})
  {
    auto run = [band](int threads)
    {
      omp_set_num_threads(threads);
      BandedBlock b(DamageGradientOptions{}, band);
      b.solver->advance(300);
      return std::make_pair(b.P, b.solver->contact_stats()->separable_total);
    };
    const int max_threads = omp_get_max_threads();
    const auto [p1, s1] = run(1);
    const auto [p3, s3] = run(3);
    omp_set_num_threads(max_threads);
    EXPECT_GT(s1, 0) << "band " << band;
    EXPECT_EQ(s1, s3) << "band " << band;
    EXPECT_TRUE(same_bits(p1.x, p3.x)) << "band " << band;
    EXPECT_TRUE(same_bits(p1.v, p3.v)) << "band " << band;
    EXPECT_TRUE(same_bits(p1.f64("damage_gradient"), p3.f64("damage_gradient"))) << "band " << band;
  }
}

TEST(DamageFields, RestoredRunContinuesBitwise)
{
  // The resumed run builds its neighbour lists afresh, the original keeps
  // older ones. The wider band adds flat, fully damaged particles, whose
  // sides come from their neighbours.
  for (const double band : {0.125, 0.375})
  {
    BandedBlock original(DamageGradientOptions{}, band);
    original.solver->advance(120);
    BandedBlock resumed(DamageGradientOptions{}, band);
    resumed.P = original.P; // the particle columns, surface flags included
    resumed.solver->restore(original.solver->state());
    original.solver->advance(150);
    resumed.solver->advance(150);
    EXPECT_TRUE(same_bits(original.P.x, resumed.P.x)) << "band " << band;
    EXPECT_TRUE(same_bits(original.P.v, resumed.P.v)) << "band " << band;
    EXPECT_TRUE(same_bits(original.P.stress, resumed.P.stress)) << "band " << band;
    EXPECT_EQ(original.solver->contact_stats()->separable_total,
              resumed.solver->contact_stats()->separable_total)
        << "band " << band;
  }
}

TEST(DamageFields, BadOptionsAreRefused)
{
  Grid<2> grid(2, {8, 8}, 1.0, {0.0, 0.0});
  Particles P(1);
  P.x = {4.0, 4.0};
  P.mass = {1.0};
  P.volume = {1.0};
  const auto m = elastic(1.0, 0.0, 1.0);
  auto make = [&](DamageGradientOptions o, std::vector<double> friction = {0.1})
  {
    StepConfig step(0.1);
    step.max_iterations = 10;
    step.friction = std::move(friction);
    step.partition = Partition::damage_gradient;
    step.damage = std::move(o);
    Solver(grid, P, m, step);
  };
  DamageGradientOptions o;
  EXPECT_NO_THROW(make(o));
  o.separability = 1.0;
  EXPECT_THROW(make(o), std::invalid_argument);
  o = {};
  o.kernel_radius = -1.0;
  EXPECT_THROW(make(o), std::invalid_argument);
  o = {};
  o.skin = 0.0;
  EXPECT_THROW(make(o), std::invalid_argument);
  o = {};
  o.groups = {1};
  EXPECT_THROW(make(o), std::invalid_argument); // group 1 of a 1 x 1 friction matrix
  EXPECT_THROW(make({}, {}), std::invalid_argument);
}

TEST(Coulomb, PairForcesAreExactlyOpposite)
{
  // B3: the Coulomb law gives the two fields of a pair forces that are exact
  // negatives (the reduced mass and the relative velocity), bit for bit.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 1000; ++k)
  {
    TrialField<2> f[2];
    for (TrialField<2>& t : f)
    {
      t.m = 1.0 + u(rng) * u(rng);
      for (int d = 0; d < 2; ++d)
      {
        t.vt[d] = u(rng);
        t.pt[d] = t.m * t.vt[d];
        t.g[d] = u(rng);
      }
      t.V = 1.0;
    }
    const bool live[2] = {true, true};
    const std::int32_t field[2] = {0, 1};
    const double friction[4] = {0.0, 0.4, 0.4, 0.0};
    double fn[2][2]{}, ft[2][2]{}, count[contact_counts]{}, impulse[2 * max_field_pairs]{};
    ContactPair<2> pairs[1];
    coulomb_forces(2, f, live, field, friction, 2, 1.0, 1e-2, fn, ft, pairs, count, impulse);
    for (int d = 0; d < 2; ++d)
    {
      EXPECT_EQ(fn[0][d] + ft[0][d], -(fn[1][d] + ft[1][d]));
      // The pair's impulse is the force on field 0 times dt.
      EXPECT_NEAR(impulse[d], 1e-2 * (fn[0][d] + ft[0][d]),
                  1e-16 * (std::abs(fn[0][d]) + std::abs(ft[0][d])));
    }
    EXPECT_EQ(count[count_c2], 0.0);
  }
}
