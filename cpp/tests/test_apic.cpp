/// @file test_apic.cpp
/// @brief The pieces of the APIC transfer (transfer/apic.h): the node offsets are the
/// Greville abscissae's with a zero first moment, D_p is h^2/4 I and h^2/3 I away from
/// the grid's ends for quadratic and cubic B-splines and diag(xi (1 - xi)) h^2 for
/// linear ones (in 2D and 3D), whose affine weights are the gradients; CPDI's D_p is the corners' mean
/// plus the domain's r_1 r_1^T + r_2 r_2^T; and a solver step carries an affine field
/// unchanged and keeps angular momentum.
#include "helpers.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/solver/solver.h"
#include "pfmpm/transfer/apic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// The frame of affine_frame on a grid of 12 cells a side, h = 0.5, from
/// (-1, ..), along a diagonal through every cell, the p cells at each end
/// included, in Dim directions.
template <int Dim, int P>
void expect_bspline_frame()
{
  using S = BSplineStencil<Dim, P>;
  const double h = 0.5;
  std::array<int, Dim> cells;
  std::array<double, Dim> origin;
  cells.fill(12);
  origin.fill(-1.0);
  const Grid<Dim> grid(P, cells, h, origin);
  const std::array<const BSpline1D*, Dim> basis = grid.bases();
  for (int k = 0; k < 12 * 37; ++k)
  {
    double x[Dim];
    std::array<int, Dim> cell;
    for (int d = 0; d < Dim; ++d)
    {
      x[d] = -1.0 + 6.0 * (k + 0.5 - 0.2 * d) / (12 * 37);
      cell[d] = basis[d]->cell(x[d]);
    }
    S s;
    s.evaluate(basis, cell.data(), x);
    const AffineFrame<S> f = affine_frame<true>(s, BlockPoints<S>(grid, Cell<Dim>{cell, 0, 0, 0}));
    for (int d = 0; d < Dim; ++d)
    {
      double first = 0.0;
      for (int a = 0; a <= P; ++a)
      {
        // The offsets are the Greville abscissae's, up to round-off.
        EXPECT_NEAR(f.r[d][a], basis[d]->greville(cell[d] + a) - x[d], 1e-14);
        first += s.n[d][a] * f.r[d][a];
      }
      EXPECT_NEAR(first, 0.0, 4e-16); // sum_i N_i (x_i - x_p) = 0, to a few ulp of h
      const double xi = basis[d]->coordinate(x[d]) - cell[d], Dd = f.D[d];
      if (P == 1)
        EXPECT_NEAR(Dd, xi * (1.0 - xi) * h * h, 1e-16);
      else if (cell[d] >= P && cell[d] < 12 - P) // the uniform B-splines' h^2 / 4, h^2 / 3
        EXPECT_NEAR(Dd, (P == 2 ? 0.25 : 1.0 / 3.0) * h * h, 1e-15) << "degree " << P;
      else
        EXPECT_GT(Dd, 0.0);
    }
  }
}
} // namespace

TEST(Apic, BSplineInertiaIsAQuarterOrAThirdOfHSquaredAwayFromTheEnds)
{
  expect_bspline_frame<2, 1>();
  expect_bspline_frame<2, 2>();
  expect_bspline_frame<2, 3>();
  expect_bspline_frame<3, 1>();
  expect_bspline_frame<3, 2>();
  expect_bspline_frame<3, 3>();
}

TEST(Apic, LinearAffineWeightsAreTheShapeFunctionGradients)
{
  // N_i D_p^-1 (x_i - x_p): the affine velocity of B_p = I is D_p^-1.
  const Grid<2> grid(1, {10, 10}, 0.25, {0.0, 0.0});
  const std::array<const BSpline1D*, 2> basis{&grid.basis(0), &grid.basis(1)};
  using S = BSplineStencil<2, 1>;
  const double identity[4] = {1.0, 0.0, 0.0, 1.0};
  for (const double fx : {0.0, 0.1, 0.5, 0.93})
  {
    const double x[2] = {(4 + fx) * 0.25, (2 + 0.37) * 0.25};
    const int cell[2] = {4, 2};
    S s;
    s.evaluate(basis, cell, x);
    const AffineFrame<S> f = affine_frame<true>(s, BlockPoints<S>(grid, Cell<2>{{4, 2}, 42, 0, 0}));
    EXPECT_NEAR(f.D[0], fx * (1.0 - fx) * 0.0625, 1e-16);
    EXPECT_NEAR(f.D[1], 0.37 * 0.63 * 0.0625, 1e-16);
    double C[4];
    affine_velocity<S>(identity, f.D, C);
    for (int i = 0; i < S::size; ++i)
    {
      const double rx = f.r[0][S::offset(i, 0)], ry = f.r[1][S::offset(i, 1)];
      // On a grid line (fx = 0) the x weights are zero: all weight at distance 0.
      EXPECT_NEAR(s.N(i) * (C[0] * rx + C[1] * ry), fx == 0.0 ? 0.0 : s.dN(0, i), 1e-13) << i;
      EXPECT_NEAR(s.N(i) * (C[2] * rx + C[3] * ry), s.dN(1, i), 1e-13) << i;
    }
  }
}

TEST(Apic, CpdiInertiaIsTheCornersMeanPlusTheDomain)
{
  // A sheared domain across cell faces: D_p = 1/4 sum_c D_lin(x_c) + r1 r1^T + r2 r2^T,
  // D_lin(x) = diag(xi (1 - xi), eta (1 - eta)) h^2, and the offsets' first moment is zero.
  const double h = 0.25;
  const Grid<2> grid(1, {10, 10}, h, {0.0, 0.0});
  const std::array<const BSpline1D*, 2> basis{&grid.basis(0), &grid.basis(1)};
  const double x[2] = {1.07, 0.61}, r1[2] = {0.09, 0.03}, r2[2] = {-0.04, 0.1};
  const int cell[2] = {4, 2};
  CpdiStencil<2> s;
  s.evaluate(basis, cell, x, r1, r2);
  const AffineFrame<CpdiStencil<2>> f = affine_frame<true>(s, BlockPoints<CpdiStencil<2>>(grid, Cell<2>{{4, 2}, 42, 0, 0}));
  double expect[3] = {r1[0] * r1[0] + r2[0] * r2[0], r1[0] * r1[1] + r2[0] * r2[1],
                      r1[1] * r1[1] + r2[1] * r2[1]};
  for (int c = 0; c < 4; ++c)
  {
    const double xi = CpdiStencil<2>::corner(x, {r1, r2}, c, 0) / h,
                 eta = CpdiStencil<2>::corner(x, {r1, r2}, c, 1) / h;
    expect[0] += 0.25 * (xi - std::floor(xi)) * (1.0 - xi + std::floor(xi)) * h * h;
    expect[2] += 0.25 * (eta - std::floor(eta)) * (1.0 - eta + std::floor(eta)) * h * h;
  }
  double first[2] = {0.0, 0.0};
  for (int i = 0; i < CpdiStencil<2>::size; ++i)
  {
    const double rx = f.r[0][CpdiStencil<2>::offset(i, 0)], ry = f.r[1][CpdiStencil<2>::offset(i, 1)];
    // The block's first node is (3, 1) (a node before the cell's).
    EXPECT_NEAR(rx, (3 + CpdiStencil<2>::offset(i, 0)) * h - x[0], 1e-15);
    EXPECT_NEAR(ry, (1 + CpdiStencil<2>::offset(i, 1)) * h - x[1], 1e-15);
    first[0] += s.N(i) * rx;
    first[1] += s.N(i) * ry;
  }
  EXPECT_NEAR(first[0], 0.0, 1e-16);
  EXPECT_NEAR(first[1], 0.0, 1e-16);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(f.D[k], expect[k], 1e-16) << k;
  // The affine velocity of B_p = D_p is the identity.
  const double B[4] = {f.D[0], f.D[1], f.D[1], f.D[2]};
  double C[4];
  affine_velocity<CpdiStencil<2>>(B, f.D, C);
  EXPECT_NEAR(C[0], 1.0, 1e-14);
  EXPECT_NEAR(C[1], 0.0, 1e-14);
  EXPECT_NEAR(C[2], 0.0, 1e-14);
  EXPECT_NEAR(C[3], 1.0, 1e-14);
}

TEST(Apic, Cpdi3InertiaIsTheCornersMeanPlusTheDomain)
{
  // The 3D parallelepiped across cell faces: D_p = 1/8 sum_c D_lin(x_c) + sum_k r_k r_k^T,
  // D_lin(x) = diag(xi (1 - xi), eta (1 - eta), zeta (1 - zeta)) h^2; the offsets' first
  // moment is zero; the affine velocity of B_p = D_p is the identity (the 3 x 3 inverse).
  using S = CpdiStencil<3>;
  const double h = 0.25;
  const Grid<3> grid(1, {10, 10, 10}, h, {0.0, 0.0, 0.0});
  const double x[3] = {1.07, 0.61, 1.38}, r1[3] = {0.09, 0.03, -0.02}, r2[3] = {-0.04, 0.1, 0.01},
               r3[3] = {0.02, -0.03, 0.08};
  const int cell[3] = {4, 2, 5};
  S s;
  s.evaluate(grid.bases(), cell, x, r1, r2, r3);
  const AffineFrame<S> f = affine_frame<true>(s, BlockPoints<S>(grid, Cell<3>{{4, 2, 5}, 0, 0, 0}));
  const double* r[3] = {r1, r2, r3};
  double expect[6] = {};
  int k = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b, ++k)
      for (const double* e : r)
        expect[k] += e[a] * e[b];
  for (int c = 0; c < 8; ++c)
  {
    const int diagonal[3] = {0, 3, 5}; // xx, yy, zz
    for (int d = 0; d < 3; ++d)
    {
      const double u = S::corner(x, r, c, d) / h;
      expect[diagonal[d]] += 0.125 * (u - std::floor(u)) * (1.0 - u + std::floor(u)) * h * h;
    }
  }
  double first[3] = {};
  for (int i = 0; i < S::size; ++i)
    for (int d = 0; d < 3; ++d)
    {
      const double rd = f.r[d][S::offset(i, d)];
      // The block's first node is one before the cell's.
      EXPECT_NEAR(rd, (cell[d] - 1 + S::offset(i, d)) * h - x[d], 1e-15);
      first[d] += s.N(i) * rd;
    }
  for (int d = 0; d < 3; ++d)
    EXPECT_NEAR(first[d], 0.0, 1e-16);
  for (k = 0; k < 6; ++k)
    EXPECT_NEAR(f.D[k], expect[k], 1e-16) << k;
  const std::array<double, 9> B = inertia_matrix(f);
  double C[9];
  affine_velocity<S>(B.data(), f.D, C);
  for (int i = 0; i < 9; ++i)
    EXPECT_NEAR(C[i], i % 4 == 0 ? 1.0 : 0.0, 1e-13) << i;
}

class ApicDegree : public ::testing::TestWithParam<int>
{
};

TEST_P(ApicDegree, AStepCarriesAnAffineFieldAndKeepsAngularMomentum)
{
  // A block reaching the degree cells next to the grid's lower-left corner
  // (where D_p varies), with v = a + G x and B_p = G D_p, from zero stress:
  // after a step the nodal velocities are a + G x_i at the Greville points,
  // and each particle keeps v_p and B_p. Then 100 steps with the stresses
  // that the stretching builds: the angular momentum (the affine part
  // included) and the momentum stay to round-off.
  const int degree = GetParam();
  Grid<2> grid(degree, {16, 16}, 0.25, {0.0, 0.0});
  std::vector<double> xs;
  for (double x = 0.0625; x < 2.0; x += 0.125)
    for (double y = 0.0625; y < 1.5; y += 0.125)
      xs.insert(xs.end(), {x, y});
  const std::size_t n = xs.size() / 2;
  Particles P(n);
  const double a[2] = {0.3, -0.2}, G[4] = {0.1, -0.4, 0.35, -0.05};
  for (std::size_t p = 0; p < n; ++p)
  {
    P.x[2 * p] = xs[2 * p];
    P.x[2 * p + 1] = xs[2 * p + 1];
    P.v[2 * p] = a[0] + G[0] * xs[2 * p] + G[1] * xs[2 * p + 1];
    P.v[2 * p + 1] = a[1] + G[2] * xs[2 * p] + G[3] * xs[2 * p + 1];
    P.mass[p] = 0.015625 * (1.0 + 0.2 * std::sin(7.0 * p));
    P.volume[p] = 0.015625;
  }
  StepConfig step(2e-3);
  step.transfer = TransferScheme::apic;
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), step);
  EXPECT_EQ(solver.transfer(), TransferScheme::apic);
  std::vector<double> gradients(4 * n);
  for (std::size_t p = 0; p < n; ++p)
    std::copy(G, G + 4, &gradients[4 * p]);
  solver.set_velocity_gradients(gradients);
  const std::vector<double> v0 = P.v, B0 = P.f64("affine");
  const Energies e0 = solver.energies();

  const int ny = grid.basis(1).size();
  int checked = 0;
  for (const auto& row : solver.nodal_mass_momentum())
  {
    const int id = static_cast<int>(row[0]);
    const double xi = grid.basis(0).greville(id / ny), yi = grid.basis(1).greville(id % ny);
    EXPECT_NEAR(row[2] / row[1], a[0] + G[0] * xi + G[1] * yi, 1e-13) << id;
    EXPECT_NEAR(row[3] / row[1], a[1] + G[2] * xi + G[3] * yi, 1e-13) << id;
    ++checked;
  }
  EXPECT_GE(checked, 63); // the 9 x 7 nodes of degree 1, more for 2 and 3
  solver.advance(1);
  for (std::size_t k = 0; k < 2 * n; ++k)
    EXPECT_NEAR(P.v[k], v0[k], 1e-14) << k;
  const std::vector<double>& B = P.f64("affine");
  for (std::size_t k = 0; k < 4 * n; ++k)
    EXPECT_NEAR(B[k], B0[k], 1e-15) << k;

  solver.advance(100);
  const Energies e = solver.energies();
  // The scales of round-off: sum_p m_p |x_p| |v_p| and sum_p m_p |v_p|.
  double angular = 0.0, linear = 0.0, heaviest = 0.0, fastest = 0.0, farthest = 0.0;
  for (std::size_t p = 0; p < n; ++p)
  {
    const double r = std::hypot(P.x[2 * p], P.x[2 * p + 1]), v = std::hypot(v0[2 * p], v0[2 * p + 1]);
    angular += P.mass[p] * r * v;
    linear += P.mass[p] * v;
    heaviest = std::max(heaviest, P.mass[p]);
    fastest = std::max(fastest, v);
    farthest = std::max(farthest, r);
  }
  // A light node (below 1e-12 of the heaviest mass: zero velocity) takes its
  // momentum, that of a node within 2 h of the particles moving at a few times
  // their speed at most; the cubic run has one.
  const double light = static_cast<double>(solver.light_nodes()) * 1e-12 * heaviest * 4.0 * fastest;
  EXPECT_LE(solver.light_nodes(), degree == 3 ? 1 : 0);
  EXPECT_GT(e.elastic, 0.0);
  EXPECT_NEAR(e.angular_momentum, e0.angular_momentum, 1e-14 * angular + light * (farthest + 0.5));
  EXPECT_NEAR(e.momentum[0], e0.momentum[0], 1e-14 * linear + light);
  EXPECT_NEAR(e.momentum[1], e0.momentum[1], 1e-14 * linear + light);
}

INSTANTIATE_TEST_SUITE_P(Degrees, ApicDegree, ::testing::Values(1, 2, 3));
