/// @file test_cpdi.cpp
/// @brief CPDI1: the averaged shape functions are a partition of unity and reproduce linear
/// fields and their gradients to round-off for sheared, stretched and rotated domains (also at
/// the grid's ends, where the node block moves inwards, and past them), in 2D and 3D; P2G
/// conserves mass and momentum; the domains of failed particles are scaled to half-diagonals of
/// at most h / 2 (2D and 3D); bad input is refused.
#include "helpers.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/shape/stencil.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
constexpr double h = 0.5;

/// Half-edge pairs (r1x, r1y, r2x, r2y) of undeformed, stretched, sheared and rotated domains,
/// each at most a cell wide.
const double domains[][4] = {
    {h / 4, 0.0, 0.0, h / 4},              // the initial lattice, 2 particles per cell
    {0.45 * h, 0.0, 0.0, 0.1 * h},         // stretched in x, compressed in y
    {0.2 * h, 0.05 * h, 0.15 * h, 0.25 * h}, // sheared
    {0.3 * h * std::cos(0.7), 0.3 * h * std::sin(0.7), -0.12 * h * std::sin(0.7),
     0.12 * h * std::cos(0.7)}, // stretched and rotated
};

/// Particle centres over the grid: interior ones, ones in the first and last cells, and one
/// whose domains reach past the grid's corner (origin (-0.25, 0)).
const double centres[][2] = {{2.37, 1.81}, {2.5, 2.0}, {0.26, 0.3}, {4.7, 4.74}, {0.3, 4.6},
                             {1.01, 3.49}, {0.05, 0.1}};
} // namespace

TEST(Cpdi, PartitionOfUnityAndLinearFields)
{
  const Grid<2> grid(1, {10, 10}, h, {-0.25, 0.0});
  const std::array<const BSpline1D*, 2> basis{&grid.basis(0), &grid.basis(1)};
  const auto nodes = grid.nodes();
  for (const auto& r : domains)
    for (const auto& c : centres)
    {
      const double x[2] = {c[0] - 0.25, c[1]};
      const int cell[2] = {grid.basis(0).cell(x[0]), grid.basis(1).cell(x[1])};
      CpdiStencil<2> s;
      s.evaluate(basis, cell, x, &r[0], &r[2]);
      // sum_i Sbar_i = 1, sum_i grad Sbar_i = 0, sum_i x_i Sbar_i = x_p and
      // sum_i x_i (x) grad Sbar_i = I: the nodes of degree 1 sit at the knots.
      double sum = 0, grad[2] = {}, first[2] = {}, second[2][2] = {};
      const int x0 = CpdiStencil<2>::first(cell[0], nodes[0]);
      const int y0 = CpdiStencil<2>::first(cell[1], nodes[1]);
      for (int i = 0; i < CpdiStencil<2>::size; ++i)
      {
        const double xi[2] = {-0.25 + h * (x0 + CpdiStencil<2>::offset(i, 0)),
                              h * (y0 + CpdiStencil<2>::offset(i, 1))};
        sum += s.N(i);
        for (int a = 0; a < 2; ++a)
        {
          grad[a] += s.dN(a, i);
          first[a] += xi[a] * s.N(i);
          for (int b = 0; b < 2; ++b)
            second[a][b] += xi[a] * s.dN(b, i);
        }
      }
      EXPECT_NEAR(sum, 1.0, 4e-16);
      for (int a = 0; a < 2; ++a)
      {
        EXPECT_NEAR(grad[a], 0.0, 1e-14 / h);
        EXPECT_NEAR(first[a], x[a], 4e-15);
        for (int b = 0; b < 2; ++b)
          EXPECT_NEAR(second[a][b], a == b ? 1.0 : 0.0, 2e-14);
      }
    }
}

TEST(Cpdi, UndeformedDomainAveragesTheHatFunctions)
{
  // A domain inside one cell: Sbar_i is the exact mean of the bilinear hat
  // over the domain, which for a hat linear in each direction is its value
  // at the centre; grad Sbar_i is then grad S_i at the centre.
  const Grid<2> grid(1, {10, 10}, h, {0.0, 0.0});
  const std::array<const BSpline1D*, 2> basis{&grid.basis(0), &grid.basis(1)};
  const double x[2] = {2.3, 1.2}, r1[2] = {0.06, 0.0}, r2[2] = {0.0, 0.09};
  const int cell[2] = {4, 2};
  CpdiStencil<2> s;
  s.evaluate(basis, cell, x, r1, r2);
  using B = BSplineStencil<2, 1>;
  B b;
  b.evaluate(basis, cell, x);
  // The B-spline block of cell c is nodes c, c+1: CPDI offsets 1, 2.
  for (int i = 0; i < 4; ++i)
  {
    const int j = (1 + B::offset(i, 0)) * 4 + 1 + B::offset(i, 1);
    EXPECT_NEAR(s.N(j), b.N(i), 1e-15);
    EXPECT_NEAR(s.dN(0, j), b.dN(0, i), 1e-14);
    EXPECT_NEAR(s.dN(1, j), b.dN(1, i), 1e-14);
  }
}

namespace
{
/// Half-edge triples (r1, r2, r3) of undeformed, stretched, sheared and rotated parallelepipeds,
/// each at most a cell wide in every direction and positively oriented.
std::vector<std::array<std::array<double, 3>, 3>> parallelepipeds()
{
  std::vector<std::array<std::array<double, 3>, 3>> out = {
      {{{h / 4, 0, 0}, {0, h / 4, 0}, {0, 0, h / 4}}},                       // the initial lattice
      {{{0.45 * h, 0, 0}, {0, 0.1 * h, 0}, {0, 0, 0.2 * h}}},                 // stretched in x
      {{{0.2 * h, 0.05 * h, -0.03 * h}, {0.12 * h, 0.2 * h, 0.04 * h},
        {-0.05 * h, 0.08 * h, 0.18 * h}}}, // sheared
  };
  // The sheared one, stretched along x and turned by 0.7 about the axis (1, 2, 2) / 3.
  const double a = 0.7, c = std::cos(a), s = std::sin(a), n[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3};
  double Q[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
    {
      // Rodrigues: Q = c I + s [n]x + (1 - c) n n^T.
      const double cross = i == j ? 0.0 : ((j - i + 3) % 3 == 1 ? -1.0 : 1.0) * n[3 - i - j];
      Q[i][j] = (i == j ? c : 0.0) + s * cross + (1.0 - c) * n[i] * n[j];
    }
  std::array<std::array<double, 3>, 3> turned{};
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        turned[k][i] += Q[i][j] * out[2][k][j] * (j == 0 ? 1.3 : 1.0);
  out.push_back(turned);
  return out;
}

/// Particle centres over the 3D grid (origin (-0.25, 0, 0)): interior ones, ones in the first
/// and last cells, and one whose domains reach past the grid's corner.
const double centres3[][3] = {{2.37, 1.81, 2.02}, {2.5, 2.0, 1.5},   {0.26, 0.3, 3.7},
                              {3.7, 3.74, 0.28},  {1.01, 3.49, 2.2}, {0.05, 0.1, 0.12}};
} // namespace

TEST(Cpdi3, PartitionOfUnityAndLinearFields)
{
  // The 3D averages (H&H eqs. 1-4, 2^3 corners): sum_i Sbar_i = 1, sum_i grad Sbar_i = 0,
  // sum_i x_i Sbar_i = x_p and sum_i x_i (x) grad Sbar_i = I, for each parallelepiped at each
  // centre: a linear field and its gradient reproduced to round-off.
  const Grid<3> grid(1, {8, 8, 8}, h, {-0.25, 0.0, 0.0});
  const std::array<const BSpline1D*, 3> basis = grid.bases();
  const auto nodes = grid.nodes();
  using S = CpdiStencil<3>;
  int checked = 0;
  for (const auto& r : parallelepipeds())
  {
    ASSERT_GT(S::determinant({r[0].data(), r[1].data(), r[2].data()}), 0.0);
    for (const auto& c : centres3)
    {
      const double x[3] = {c[0] - 0.25, c[1], c[2]};
      int cell[3], first[3];
      for (int d = 0; d < 3; ++d)
      {
        cell[d] = grid.basis(d).cell(x[d]);
        first[d] = S::first(cell[d], nodes[d]);
      }
      S s;
      s.evaluate(basis, cell, x, r[0].data(), r[1].data(), r[2].data());
      double sum = 0, grad[3] = {}, moment[3] = {}, jacobian[3][3] = {};
      for (int i = 0; i < S::size; ++i)
      {
        double xi[3];
        for (int d = 0; d < 3; ++d)
          xi[d] = (d == 0 ? -0.25 : 0.0) + h * (first[d] + S::offset(i, d));
        sum += s.N(i);
        for (int a = 0; a < 3; ++a)
        {
          grad[a] += s.dN(a, i);
          moment[a] += xi[a] * s.N(i);
          for (int b = 0; b < 3; ++b)
            jacobian[a][b] += xi[a] * s.dN(b, i);
        }
      }
      EXPECT_NEAR(sum, 1.0, 1e-15);
      for (int a = 0; a < 3; ++a)
      {
        EXPECT_NEAR(grad[a], 0.0, 1e-14 / h);
        EXPECT_NEAR(moment[a], x[a], 4e-15);
        for (int b = 0; b < 3; ++b)
          EXPECT_NEAR(jacobian[a][b], a == b ? 1.0 : 0.0, 2e-14) << a << b;
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, 24);
}

TEST(Cpdi3, SmallDomainAveragesTheTrilinearHats)
{
  // A box inside one cell, its edges along the axes: the mean of a trilinear hat over it is
  // its value at the centre, and its gradient's mean the gradient there (the means of
  // products of independent coordinates).
  const Grid<3> grid(1, {8, 8, 8}, h, {0.0, 0.0, 0.0});
  const std::array<const BSpline1D*, 3> basis = grid.bases();
  const double x[3] = {2.3, 1.2, 0.61}, r1[3] = {0.06, 0.0, 0.0}, r2[3] = {0.0, 0.09, 0.0},
               r3[3] = {0.0, 0.0, 0.05};
  const int cell[3] = {4, 2, 1};
  CpdiStencil<3> s;
  s.evaluate(basis, cell, x, r1, r2, r3);
  using B = BSplineStencil<3, 1>;
  B b;
  b.evaluate(basis, cell, x);
  // The B-spline block of cell c is nodes c, c+1: CPDI offsets 1, 2 (cells 1 .. 4 are away
  // from the grid's ends, where the block would move).
  double total = 0.0;
  for (int i = 0; i < B::size; ++i)
  {
    const int j = ((1 + B::offset(i, 0)) * 4 + 1 + B::offset(i, 1)) * 4 + 1 + B::offset(i, 2);
    EXPECT_NEAR(s.N(j), b.N(i), 1e-15);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(s.dN(k, j), b.dN(k, i), 1e-14);
    total += s.N(j);
  }
  EXPECT_NEAR(total, 1.0, 1e-15); // no weight outside the cell's 8 nodes
}

TEST(Cpdi3, FailedDomainsAreScaledToACell)
{
  // Per particle: the convected half-edges and its damage.
  const double hh = 0.5 * h;
  struct Case
  {
    double r[3][3];
    double damage;
  };
  const Case cases[] = {
      // Stretched and sheared, intact: the convected domain.
      {{{0.3, 0.05, 0.02}, {0.04, 0.1, 0.0}, {0.0, 0.03, 0.08}}, 0.99},
      // The same, failed: the four half-diagonals shortened to h / 2, the edges rebuilt
      // (method card §1.3).
      {{{0.3, 0.05, 0.02}, {0.04, 0.1, 0.0}, {0.0, 0.03, 0.08}}, 1.0},
      // Stretched along the axes, failed: its half-diagonals are equally long, all shortened by
      // one factor, and the rebuilt domain is the convected one scaled by it.
      {{{0.3, 0.0, 0.0}, {0.0, 0.1, 0.0}, {0.0, 0.0, 0.08}}, 1.0},
      // Failed but small: no half-diagonal longer than h / 2, the convected domain.
      {{{0.1, 0.02, 0.0}, {0.0, 0.1, 0.03}, {0.02, 0.0, 0.1}}, 1.0},
  };
  const std::size_t n = std::size(cases);
  Particles P(n, 3);
  for (const ColumnSpec& c : ParticleDomains<3>::columns())
    P.add(c);
  P.add({"damage", 1, DType::f64, {0.0}, "", "", ""});
  for (std::size_t p = 0; p < n; ++p)
  {
    for (int k = 0; k < 3; ++k)
    {
      std::vector<double>& r = P.f64("convected_r" + std::to_string(k + 1));
      std::copy(cases[p].r[k], cases[p].r[k] + 3, &r[3 * p]);
    }
    P.f64("damage")[p] = cases[p].damage;
    P.x[3 * p] = 1.0 + p;
    P.x[3 * p + 1] = P.x[3 * p + 2] = 2.0;
  }
  const Grid<3> grid(1, {10, 10, 10}, h, {0.0, 0.0, 0.0});
  ParticleDomains<3> domains(h, DomainScaling{true, 0.0});
  domains.bind(P);
  EXPECT_EQ(domains.update(grid, P.x.data(), n), n);
  auto edge = [&](std::size_t p, int k, int d) { return domains.r(k)[3 * p + d]; };
  // Damaged but not failed: the convected domain; failed but small: that, up to the
  // rebuild's round-off.
  for (int k = 0; k < 3; ++k)
    for (int d = 0; d < 3; ++d)
    {
      EXPECT_EQ(edge(0, k, d), cases[0].r[k][d]);
      EXPECT_NEAR(edge(3, k, d), cases[3].r[k][d], 1e-17);
    }
  // Particle 1, by hand: l_a = r1 + r2 + r3, l_b = r1 - r2 + r3, l_c = -r1 + r2 + r3,
  // l_d = -r1 - r2 + r3, each longer than h / 2 here.
  const double(&r)[3][3] = cases[1].r;
  const double sign[4][3] = {{1, 1, 1}, {1, -1, 1}, {-1, 1, 1}, {-1, -1, 1}};
  double l[4][3];
  for (int m = 0; m < 4; ++m)
  {
    double length = 0.0;
    for (int d = 0; d < 3; ++d)
    {
      l[m][d] = sign[m][0] * r[0][d] + sign[m][1] * r[1][d] + sign[m][2] * r[2][d];
      length += l[m][d] * l[m][d];
    }
    length = std::sqrt(length);
    ASSERT_GT(length, hh) << m;
    for (double& v : l[m])
      v *= hh / length;
  }
  // r_1 = (l_a + l_b - l_c - l_d) / 4, r_2 = (l_a - l_b + l_c - l_d) / 4,
  // r_3 = (l_a + l_b + l_c + l_d) / 4.
  for (int d = 0; d < 3; ++d)
  {
    EXPECT_NEAR(edge(1, 0, d), 0.25 * (l[0][d] + l[1][d] - l[2][d] - l[3][d]), 1e-16);
    EXPECT_NEAR(edge(1, 1, d), 0.25 * (l[0][d] - l[1][d] + l[2][d] - l[3][d]), 1e-16);
    EXPECT_NEAR(edge(1, 2, d), 0.25 * (l[0][d] + l[1][d] + l[2][d] + l[3][d]), 1e-16);
  }
  // The scaled domain is within its particle's cells, narrower than the convected one, and
  // still positively oriented.
  const double* d1[3] = {&domains.r(0)[3], &domains.r(1)[3], &domains.r(2)[3]};
  EXPECT_GT(CpdiStencil<3>::determinant(d1), 0.0);
  EXPECT_LT(std::abs(edge(1, 0, 0)) + std::abs(edge(1, 1, 0)) + std::abs(edge(1, 2, 0)), hh);
  // Particle 2: one factor hh / |l| for all four; every half-diagonal of the rebuilt domain
  // is h / 2 long.
  const double factor = hh / std::sqrt(0.3 * 0.3 + 0.1 * 0.1 + 0.08 * 0.08);
  for (int k = 0; k < 3; ++k)
    for (int d = 0; d < 3; ++d)
      EXPECT_NEAR(edge(2, k, d), factor * cases[2].r[k][d], 1e-16);
  for (int m = 0; m < 4; ++m)
  {
    double length = 0.0;
    for (int d = 0; d < 3; ++d)
    {
      const double v =
          sign[m][0] * edge(2, 0, d) + sign[m][1] * edge(2, 1, d) + sign[m][2] * edge(2, 2, d);
      length += v * v;
    }
    EXPECT_NEAR(std::sqrt(length), hh, 1e-15);
  }
  // Particle 0 is 2 (0.3 + 0.04) = 0.68 wide in x, wider than a cell: oversized names it (a
  // run refuses it at t = 0). Stretched to r1 = (0.8, .., ..), its corners reach past the
  // cells next to its own: the step's check names it.
  EXPECT_EQ(domains.oversized(n), 0u);
  P.f64("convected_r1")[0] = 0.8;
  EXPECT_EQ(domains.update(grid, P.x.data(), n), 0u);
}

namespace
{
/// A disk of particles with a swirling velocity, a non-uniform stress and sheared domains that
/// vary from particle to particle, on a degree-1 CPDI solver.
struct Disk
{
  Grid<2> grid{1, {40, 40}, 0.25, {-1.0, -2.0}};
  Particles P{0};
  std::unique_ptr<Solver<2>> solver;

  Disk() : P(count())
  {
    add_model_columns(P, false);
    StepConfig step(1e-3);
    step.shape = ShapeFunctions::cpdi;
    solver = std::make_unique<Solver<2>>(grid, P, elastic(100.0, 0.3, 1.0), step);
    const double d = 4.0 / 60;
    std::size_t k = 0;
    std::vector<double>& strain = P.f64("strain");
    for (int i = 0; i < 60; ++i)
      for (int j = 0; j < 60; ++j)
      {
        const double x = -2.0 + (i + 0.5) * d, y = -2.0 + (j + 0.5) * d;
        if (x * x + y * y >= 4.0)
          continue;
        P.x[2 * k] = x + 3.0;
        P.x[2 * k + 1] = y + 2.5;
        P.v[2 * k] = 0.3 - 0.2 * y + 0.05 * std::sin(3 * x);
        P.v[2 * k + 1] = -0.1 + 0.2 * x;
        P.volume[k] = d * d;
        P.mass[k] = d * d * (1.0 + 0.1 * std::cos(x));
        strain[3 * k] = 1e-3 * std::sin(y);
        strain[3 * k + 2] = 5e-4 * x;
        const double shear = 0.3 * std::sin(2 * x + y), stretch = 1.0 + 0.5 * std::cos(x * y);
        const double r1[2] = {0.5 * d * stretch, 0.0}, r2[2] = {0.5 * d * shear, 0.5 * d / stretch};
        for (const char* name : {"convected_r1", "domain_r1"})
          std::copy(r1, r1 + 2, &P.f64(name)[2 * k]);
        for (const char* name : {"convected_r2", "domain_r2"})
          std::copy(r2, r2 + 2, &P.f64(name)[2 * k]);
        ++k;
      }
  }
  static std::size_t count()
  {
    std::size_t n = 0;
    const double d = 4.0 / 60;
    for (int i = 0; i < 60; ++i)
      for (int j = 0; j < 60; ++j)
      {
        const double x = -2.0 + (i + 0.5) * d, y = -2.0 + (j + 0.5) * d;
        n += x * x + y * y < 4.0;
      }
    return n;
  }
};
} // namespace

TEST(Cpdi, P2GConservesMassAndMomentum)
{
  Disk disk;
  const Energies e = disk.solver->energies();
  double m = 0, px = 0, py = 0;
  for (const auto& row : disk.solver->nodal_mass_momentum())
  {
    m += row[1];
    px += row[2];
    py += row[3];
  }
  EXPECT_NEAR(m, e.mass, 1e-13 * e.mass);
  EXPECT_NEAR(px, e.momentum[0], 1e-13 * e.mass);
  EXPECT_NEAR(py, e.momentum[1], 1e-13 * e.mass);
}

TEST(Cpdi, FreeMotionConservesMomentumAndConvectsDomains)
{
  Disk disk;
  const Energies e0 = disk.solver->energies();
  const std::vector<double> r0 = disk.P.f64("convected_r1");
  disk.solver->advance(5);
  const Energies e = disk.solver->energies();
  EXPECT_NEAR(e.momentum[0], e0.momentum[0], 1e-13 * e0.mass);
  EXPECT_NEAR(e.momentum[1], e0.momentum[1], 1e-13 * e0.mass);
  // The swirl turns the domains: the half-edges changed, and at the start
  // of the next step the integration domains of the intact particles are
  // the convected ones.
  EXPECT_FALSE(same_bits(disk.P.f64("convected_r1"), r0));
  disk.solver->prepare();
  EXPECT_TRUE(same_bits(disk.P.f64("convected_r1"), disk.P.f64("domain_r1")));
}

TEST(Cpdi, FailedDomainsAreScaledToACell)
{
  Particles P(3);
  for (const ColumnSpec& c : ParticleDomains<2>::columns())
    P.add(c);
  P.add({"damage", 1, DType::f64, {0.0}, "", "", ""});
  // Stretched 3x along x and sheared: a diagonal of about 1.6 cells.
  const double r1[2] = {0.375, 0.05}, r2[2] = {0.1, 0.125};
  for (std::size_t p = 0; p < 3; ++p)
  {
    std::copy(r1, r1 + 2, &P.f64("convected_r1")[2 * p]);
    std::copy(r2, r2 + 2, &P.f64("convected_r2")[2 * p]);
    P.x[2 * p] = 2.0 + p;
    P.x[2 * p + 1] = 2.0;
  }
  P.f64("damage")[1] = 1.0;
  P.f64("damage")[2] = 0.99;
  const Grid<2> grid(1, {10, 10}, h, {0.0, 0.0});
  ParticleDomains<2> domains(h, DomainScaling{true, 0.0});
  domains.bind(P);
  EXPECT_EQ(domains.update(grid, P.x.data(), 3), 3u);
  const double* d1 = domains.r(0);
  const double* d2 = domains.r(1);
  // Intact and damaged but not failed: the convected domain.
  for (std::size_t p : {0u, 2u})
    for (int a = 0; a < 2; ++a)
    {
      EXPECT_EQ(d1[2 * p + a], r1[a]);
      EXPECT_EQ(d2[2 * p + a], r2[a]);
    }
  // Failed: l_a = (0.475, 0.175) and l_b = (0.275, -0.075) are shortened to
  // h / 2 = 0.25 along themselves.
  const double la = std::hypot(0.475, 0.175), lb = std::hypot(0.275, -0.075);
  const double sa = 0.25 / la, sb = 0.25 / lb;
  EXPECT_NEAR(d1[2], 0.5 * (0.475 * sa + 0.275 * sb), 1e-15);
  EXPECT_NEAR(d1[3], 0.5 * (0.175 * sa - 0.075 * sb), 1e-15);
  EXPECT_NEAR(d2[2], 0.5 * (0.475 * sa - 0.275 * sb), 1e-15);
  EXPECT_NEAR(d2[3], 0.5 * (0.175 * sa + 0.075 * sb), 1e-15);
  EXPECT_NEAR(std::hypot(d1[2] + d2[2], d1[3] + d2[3]), 0.25, 1e-15);
  EXPECT_NEAR(std::hypot(d1[2] - d2[2], d1[3] - d2[3]), 0.25, 1e-15);
}

TEST(Cpdi, BadInputIsRefused)
{
  Disk disk;
  // Degree 2.
  Grid<2> quadratic(2, {10, 10}, 0.5, {0.0, 0.0});
  Particles P(1);
  StepConfig cpdi(1e-3);
  cpdi.shape = ShapeFunctions::cpdi;
  EXPECT_THROW(Solver(quadratic, P, elastic(1.0, 0.3, 1.0), cpdi), std::invalid_argument);
  // A domain wider than a cell at t = 0.
  disk.P.f64("convected_r1")[0] = disk.P.f64("domain_r1")[0] = 0.2;
  EXPECT_THROW(disk.solver->advance(1), std::invalid_argument);
}

// The cells whose block holds a node (the node's support, NodeBlock::holders)
// and the farthest apart two cells whose blocks share a node
// (NodeBlock::reach), against every pair of cell and node, for the
// B-splines' blocks and CPDI's on lines of 3 to 9 cells.
TEST(Cpdi, NodeBlockHoldersAndReach)
{
  for (int degree = 1; degree <= 3; ++degree)
    for (const bool cpdi : {false, true})
    {
      if (cpdi && degree != 1)
        continue;
      const NodeBlock block = cpdi ? NodeBlock{CpdiStencil<2>::lower, CpdiStencil<2>::width}
                                   : NodeBlock{0, degree + 1};
      int farthest = 0;
      for (int cells = 3; cells <= 9; ++cells)
      {
        const int nodes = cells + degree;
        auto holds = [&](int c, int i)
        { return block.first(c, nodes) <= i && i < block.first(c, nodes) + block.width; };
        for (int i = 0; i < nodes; ++i)
        {
          int c0, c1;
          block.holders(i, cells, nodes, c0, c1);
          for (int c = 0; c < cells; ++c)
          {
            EXPECT_EQ(holds(c, i), c0 <= c && c <= c1)
                << "degree " << degree << (cpdi ? " CPDI" : "") << ", " << cells << " cells, node "
                << i << ", cell " << c;
            for (int d = 0; d < cells; ++d)
              if (holds(c, i) && holds(d, i))
                farthest = std::max(farthest, std::abs(c - d));
          }
        }
      }
      EXPECT_EQ(farthest, block.reach()) << "degree " << degree << (cpdi ? " CPDI" : "");
    }
}
