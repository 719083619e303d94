/// @file test_damage_fields3.cpp
/// @brief The damage-field-gradient partition (Homel & Herbold 2017) in 3D:
/// the kernel field's gradient vanishes for uniform damage and points at a
/// damaged plane, the cubic lattice's kernel sum, surface flags of a box
/// (a face on a wall is none), a slab of a banded block between slip walls
/// is the plane-strain run, a bar cut by a failed plane parts with no force
/// across it (B-splines and CPDI), and the partition repeats bitwise on 1 and 2 threads and
/// resumed.
#include "helpers.h"
#include "pfmpm/fields/damage_fields.h"
#include "pfmpm/fields/kernel.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <memory>
#include <vector>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// The step of a damage-gradient run with one group of crack-face friction 0.3.
StepConfig damage_step(double dt)
{
  StepConfig step(dt);
  step.friction = {0.3};
  step.partition = Partition::damage_gradient;
  step.damage = DamageGradientOptions{};
  return step;
}

/// The velocity of the banded block: its halves x < 3 and x > 3 pulled
/// apart and sheared past each other, with a wave along x.
void banded_velocity(const double* x, double* v)
{
  v[0] = x[0] < 3.0 ? -0.02 : 0.02;
  v[1] = 0.01 * std::sin(3.0 * x[0]) + (x[0] < 3.0 ? 0.01 : -0.01);
}

/// A bar [1, 5] x [1, 2] x [1, 2] (h = 0.25, 2 particles a cell a side)
/// cut by a failed plane, |x - 3| < 0.125 (surface-flagged), its halves
/// pulled apart along x and sheared along y and z, on free faces; on
/// quadratic B-splines, or with `cpdi` CPDI1 on the linear grid (each
/// domain its lattice cube).
struct FailedPlaneBar
{
  Grid<3> grid;
  Particles P = lattice<3>({1.0, 1.0, 1.0}, {5.0, 2.0, 2.0}, 0.125);
  std::unique_ptr<Solver<3>> solver;

  explicit FailedPlaneBar(bool cpdi = false) : grid(cpdi ? 1 : 2, {24, 12, 12}, 0.25, {0.0, 0.0, 0.0})
  {
    for (std::size_t p = 0; p < P.size(); ++p)
    {
      const double* x = &P.x[3 * p];
      const double s = x[0] < 3.0 ? 1.0 : -1.0;
      P.v[3 * p] = -0.02 * s;
      P.v[3 * p + 1] = 0.01 * s + 0.004 * std::sin(3.0 * x[0]);
      P.v[3 * p + 2] = -0.005 * s;
    }
    StepConfig step = damage_step(2e-3);
    if (cpdi)
      step.shape = ShapeFunctions::cpdi;
    solver = std::make_unique<Solver<3>>(grid, P, elastic(100.0, 0.3, 1.0), step);
    if (cpdi)
      lattice_domains<3>(P, 0.125);
    for (std::size_t p = 0; p < P.size(); ++p)
      if (std::abs(P.x[3 * p] - 3.0) < 0.125)
        P.i32("surface")[p] = 1;
  }
};
} // namespace

TEST(KernelField3, UniformDamageHasZeroGradient)
{
  // U1 in 3D: a ball, free surface included.
  const Grid<3> grid(2, {12, 12, 12}, 0.25, {0.0, 0.0, 0.0});
  const Particles P = lattice<3>({0.5, 0.5, 0.5}, {2.5, 2.5, 2.5}, 0.125, [](const double* x)
                                 { return std::hypot(x[0] - 1.5, x[1] - 1.5, x[2] - 1.5) < 0.9; });
  const double radius = std::sqrt(3.0) * 0.25;
  for (double d : {0.0, 0.37, 1.0})
  {
    const KernelField f = kernel_damage_field(grid, P.x, std::vector<double>(P.size(), d), radius);
    for (std::size_t p = 0; p < P.size(); ++p)
    {
      EXPECT_EQ(f.D[p], d);
      EXPECT_LT(std::hypot(f.grad[3 * p], f.grad[3 * p + 1], f.grad[3 * p + 2]), 1e-12 / radius);
    }
  }
}

TEST(KernelField3, GradientPointsAtADamagedPlane)
{
  // U2 in 3D: a layer of D = 1 at z = 1.5625 in a block; within r_p of it
  // and away from the block's sides, the gradients point at it along its
  // normal. The kernel sum deep inside is the cubic lattice's.
  const Grid<3> grid(2, {16, 16, 12}, 0.25, {0.0, 0.0, 0.0});
  const Particles P = lattice<3>({0.5, 0.5, 0.5}, {3.5, 3.5, 2.5}, 0.125);
  const double radius = std::sqrt(3.0) * 0.25, plane = 1.5625;
  std::vector<double> damage(P.size(), 0.0);
  for (std::size_t p = 0; p < P.size(); ++p)
    damage[p] = std::abs(P.x[3 * p + 2] - plane) < 0.01 ? 1.0 : 0.0;
  const KernelField f = kernel_damage_field(grid, P.x, damage, radius);
  const double bulk = lattice_kernel_sum(3, 0.125, radius);
  int seen = 0, inside = 0;
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    const double* x = &P.x[3 * p];
    const double dz = x[2] - plane;
    const double edge = std::min({x[0] - 0.5, 3.5 - x[0], x[1] - 0.5, 3.5 - x[1], x[2] - 0.5, 2.5 - x[2]});
    if (edge > radius)
    {
      EXPECT_NEAR(f.S[p], bulk, 1e-12 * bulk);
      ++inside;
    }
    if (std::abs(dz) < 0.01 || std::abs(dz) >= radius || std::min({x[0] - 0.5, 3.5 - x[0], x[1] - 0.5, 3.5 - x[1]}) < radius)
      continue;
    const double* g = &f.grad[3 * p];
    EXPECT_LT(g[2] * dz, 0.0) << "towards the plane";
    EXPECT_LT(std::hypot(g[0], g[1]), 1e-12 * std::abs(g[2])) << "along its normal";
    ++seen;
  }
  EXPECT_GT(seen, 500);
  EXPECT_GT(inside, 500);
  // The cubic lattice's sum, shell by shell (|n|^2 = 1 .. 11 spacings^2;
  // r_p is sqrt(12) spacings).
  EXPECT_NEAR(bulk, 1.0 + 6.0 * kernel_weight(0.125 / radius) + 12.0 * kernel_weight(0.125 * std::sqrt(2.0) / radius)
                        + 8.0 * kernel_weight(0.125 * std::sqrt(3.0) / radius)
                        + 6.0 * kernel_weight(0.25 / radius) + 24.0 * kernel_weight(0.125 * std::sqrt(5.0) / radius)
                        + 24.0 * kernel_weight(0.125 * std::sqrt(6.0) / radius)
                        + 12.0 * kernel_weight(0.125 * std::sqrt(8.0) / radius)
                        + 30.0 * kernel_weight(0.125 * 3.0 / radius)
                        + 24.0 * kernel_weight(0.125 * std::sqrt(10.0) / radius)
                        + 24.0 * kernel_weight(0.125 * std::sqrt(11.0) / radius),
              1e-12);
}

TEST(DamageFields3, SurfaceFlagsOfABoxOnAWall)
{
  // U4 in 3D: with S < 0.99 S_bulk, the outer particle layer of a box is
  // flagged and its interior (beyond r_p of a free face) is not, nor its
  // face on the bottom wall z = 0, a mirror plane.
  Grid<3> grid(2, {14, 14, 10}, 0.25, {0.0, 0.0, 0.0});
  grid.set_wall(Side::back, Wall::slip);
  Particles P = lattice<3>({1.0, 1.0, 0.0}, {2.5, 2.5, 1.5}, 0.125);
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), damage_step(1e-3));
  const std::vector<double> ratio = solver.detect_surfaces({0.125}, 0.99);
  const std::vector<std::int32_t>& flag = P.i32("surface");
  int flagged = 0;
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    const double* x = &P.x[3 * p];
    const double edge = std::min({x[0] - 1.0, 2.5 - x[0], x[1] - 1.0, 2.5 - x[1], 1.5 - x[2]});
    const double r = std::sqrt(3.0) * 0.25;
    if (edge > r)
    {
      EXPECT_NEAR(ratio[p], 1.0, 1e-12) << "interior " << x[0] << ", " << x[1] << ", " << x[2];
      EXPECT_EQ(flag[p], 0);
    }
    if (edge < 0.125)
      EXPECT_EQ(flag[p], 1) << x[0] << ", " << x[1] << ", " << x[2];
    flagged += flag[p];
  }
  EXPECT_GT(flagged, 0);
  // The wall mirrors the box: a particle of its vertical edge next to the
  // wall sees what one at mid-height sees (an edge, r_p from any other
  // face), and one at the top corner, of three free faces, less.
  auto at = [&](double x, double y, double z)
  {
    for (std::size_t p = 0; p < P.size(); ++p)
      if (std::hypot(P.x[3 * p] - x, P.x[3 * p + 1] - y, P.x[3 * p + 2] - z) < 1e-9)
        return ratio[p];
    ADD_FAILURE() << "no particle at " << x << ", " << y << ", " << z;
    return 0.0;
  };
  const double bottom = at(1.0625, 1.0625, 0.0625), middle = at(1.0625, 1.0625, 0.6875);
  EXPECT_NEAR(bottom, middle, 1e-12);
  EXPECT_LT(at(1.0625, 1.0625, 1.4375), 0.9 * middle);
}

TEST(DamageFields3, SlabOfABandedBlockIsThePlaneStrainRun)
{
  // The 2D block of the 2D tests (a fully damaged band one cell wide, its
  // halves pulled apart and sheared) and its 3D slab two cells thick
  // between slip walls, each with its own dimension's defaults (r_p the
  // cell diagonal, sqrt(2) h and sqrt(3) h): the band splits the same nodes
  // into the same sides, the faces part, and every energy per unit thickness
  // is the plane run's to round-off.
  Grid<2> grid2(2, {24, 16}, 0.25, {0.0, 0.0});
  Particles P = lattice<2>({1.0, 1.0}, {5.0, 3.0}, 0.125);
  for (std::size_t p = 0; p < P.size(); ++p)
    banded_velocity(&P.x[2 * p], &P.v[2 * p]);
  const double t = 0.5;
  Grid<3> grid3(2, {24, 16, 2}, 0.25, {0.0, 0.0, 0.0});
  grid3.set_wall(Side::back, Wall::slip);
  grid3.set_wall(Side::front, Wall::slip);
  Particles Q = lattice<3>({1.0, 1.0, 0.0}, {5.0, 3.0, t}, 0.125);
  for (std::size_t q = 0; q < Q.size(); ++q)
    banded_velocity(&Q.x[3 * q], &Q.v[3 * q]);
  Solver plane(grid2, P, elastic(100.0, 0.3, 1.0), damage_step(2e-3));
  Solver slab(grid3, Q, elastic(100.0, 0.3, 1.0), damage_step(2e-3));
  for (std::size_t p = 0; p < P.size(); ++p)
    P.i32("surface")[p] = std::abs(P.x[2 * p] - 3.0) < 0.125 ? 1 : 0;
  for (std::size_t q = 0; q < Q.size(); ++q)
    Q.i32("surface")[q] = std::abs(Q.x[3 * q] - 3.0) < 0.125 ? 1 : 0;
  const Energies<2> start = plane.energies();
  const double energy = start.kinetic, momentum = start.mass * 0.03, angular = 5.0 * momentum;
  const double worst = step_alongside(plane, slab, t, 200, energy, momentum, angular);
  const ContactStats& c2 = *plane.contact_stats();
  const ContactStats& c3 = *slab.contact_stats();
  EXPECT_GT(c2.separable_total, 0);
  // Each 2D node is a line of 4 nodes across the slab (2 cells, degree 2).
  EXPECT_EQ(c3.separable_total, 4 * c2.separable_total);
  EXPECT_GT(plane.energies().elastic, 0.01 * energy) << "the block should have deformed";
  std::cout << "banded slab against plane strain, 200 steps: largest relative gap " << worst << "\n";
}

/// B-splines (false) or CPDI (true).
class FailedPlaneOf : public ::testing::TestWithParam<bool>
{
};

TEST_P(FailedPlaneOf, BarParts)
{
  // The two halves of a 3D bar on either side of a failed plane are pulled
  // apart and sheared: the plane's nodes are separable and carry no force,
  // so each half keeps its momentum, and the gap between them opens at
  // their relative speed.
  FailedPlaneBar b(GetParam());
  auto half = [&](bool right)
  {
    // The momentum of the half, the failed layer's particles on its side
    // included, then its intact particles' extreme x facing the plane.
    std::array<double, 4> out{};
    out[3] = right ? 1e9 : -1e9;
    for (std::size_t p = 0; p < b.P.size(); ++p)
    {
      const double* x = &b.P.x[3 * p];
      if ((x[0] > 3.0) != right)
        continue;
      for (int d = 0; d < 3; ++d)
        out[d] += b.P.mass[p] * b.P.v[3 * p + d];
      if (!b.P.i32("surface")[p])
        out[3] = right ? std::min(out[3], x[0]) : std::max(out[3], x[0]);
    }
    return out;
  };
  b.solver->advance(2);
  const auto left0 = half(false), right0 = half(true);
  const double opening0 = right0[3] - left0[3];
  b.solver->advance(300);
  const auto left1 = half(false), right1 = half(true);
  const ContactStats& s = *b.solver->contact_stats();
  EXPECT_GT(s.separable_total, 0);
  EXPECT_EQ(s.active, 0);
  const double scale = std::abs(left0[0]);
  for (int d = 0; d < 3; ++d)
  {
    EXPECT_NEAR(left1[d], left0[d], 1e-13 * scale) << "left half, direction " << d;
    EXPECT_NEAR(right1[d], right0[d], 1e-13 * scale) << "right half, direction " << d;
  }
  // 300 steps of 2e-3 at a relative speed of 0.04: 0.024, less the halves'
  // elastic recoil at their faces.
  EXPECT_NEAR(right1[3] - left1[3] - opening0, 0.024, 0.1 * 0.024);
}

INSTANTIATE_TEST_SUITE_P(DamageFields3, FailedPlaneOf, ::testing::Values(false, true));

TEST(DamageFields3, RepeatsBitwiseOnOneOrTwoThreadsAndResumed)
{
  auto run = [](int threads)
  {
    omp_set_num_threads(threads);
    FailedPlaneBar b;
    b.solver->advance(150);
    return std::make_pair(b.P, b.solver->contact_stats()->separable_total);
  };
  const int max_threads = omp_get_max_threads();
  const auto [p1, s1] = run(1);
  const auto [p2, s2] = run(2);
  omp_set_num_threads(max_threads);
  EXPECT_GT(s1, 0);
  EXPECT_EQ(s1, s2);
  EXPECT_TRUE(same_bits(p1.x, p2.x));
  EXPECT_TRUE(same_bits(p1.v, p2.v));
  EXPECT_TRUE(same_bits(p1.f64("damage_gradient"), p2.f64("damage_gradient")));

  FailedPlaneBar original;
  original.solver->advance(70);
  FailedPlaneBar resumed;
  resumed.P = original.P; // the particle columns, surface flags included
  resumed.solver->restore(original.solver->state());
  original.solver->advance(80);
  resumed.solver->advance(80);
  EXPECT_TRUE(same_bits(original.P.x, resumed.P.x));
  EXPECT_TRUE(same_bits(original.P.v, resumed.P.v));
  EXPECT_TRUE(same_bits(original.P.stress, resumed.P.stress));
  EXPECT_TRUE(same_bits(original.P.x, p1.x));
}
