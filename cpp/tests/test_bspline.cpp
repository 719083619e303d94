/// @file test_bspline.cpp
/// @brief B-spline basis on open knot vectors: partition of unity, zero-sum derivatives, exact
/// reproduction of linear fields (Greville abscissae), and agreement with a direct Cox-de Boor
/// evaluation, on boundary and interior cells.
#include "pfmpm/grid/bspline.h"
#include "pfmpm/grid/grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using pfmpm::BSpline1D;

namespace
{
constexpr double tol = 1e-13;

/// Open knot vector in absolute coordinates.
std::vector<double> knots(int p, int cells, double h, double origin)
{
  std::vector<double> t;
  for (int j = 0; j < cells + 2 * p + 1; ++j)
    t.push_back(origin + h * std::clamp(j - p, 0, cells));
  return t;
}

/// Textbook recursive Cox-de Boor value of N_{i,p}(x), half-open spans, with
/// the last span closed so x = end is covered.
double cox_de_boor(const std::vector<double>& t, int i, int p, double x)
{
  if (p == 0)
  {
    const bool last = t[i + 1] == t.back() && t[i] < t[i + 1];
    return (t[i] <= x && (x < t[i + 1] || (last && x <= t[i + 1]))) ? 1.0 : 0.0;
  }
  double r = 0.0;
  if (t[i + p] > t[i])
    r += (x - t[i]) / (t[i + p] - t[i]) * cox_de_boor(t, i, p - 1, x);
  if (t[i + p + 1] > t[i + 1])
    r += (t[i + p + 1] - x) / (t[i + p + 1] - t[i + 1]) * cox_de_boor(t, i + 1, p - 1, x);
  return r;
}

/// Sample points: every cell, including its left end, plus the cell interiors.
std::vector<double> samples(const BSpline1D& b)
{
  std::vector<double> xs;
  for (int c = 0; c < b.cells(); ++c)
    for (double f : {0.0, 0.013, 0.25, 0.5, 0.77, 0.999})
      xs.push_back(b.origin() + (c + f) * b.h());
  return xs;
}

class BSplineDegree : public ::testing::TestWithParam<int>
{
};
} // namespace

TEST_P(BSplineDegree, PartitionOfUnityAndZeroSumDerivatives)
{
  const int p = GetParam();
  const BSpline1D b(p, 7, 0.3, -1.2);
  double N[4], dN[4], d2N[4];
  for (double x : samples(b))
  {
    const int c = b.cell(x);
    ASSERT_GE(c, 0);
    b.evaluate(c, x, N, dN, d2N);
    double s = 0, ds = 0, d2s = 0;
    for (int k = 0; k <= p; ++k)
    {
      EXPECT_GE(N[k], -tol);
      s += N[k];
      ds += dN[k];
      d2s += d2N[k];
    }
    EXPECT_NEAR(s, 1.0, tol) << "x = " << x;
    EXPECT_NEAR(ds, 0.0, tol / b.h()) << "x = " << x;
    EXPECT_NEAR(d2s, 0.0, 1e-11 / (b.h() * b.h())) << "x = " << x;
  }
}

TEST_P(BSplineDegree, ReproducesLinearFieldsExactly)
{
  // sum_i N_i(x) g_i = x with the Greville abscissae g_i = mean(t_{i+1..i+p}).
  const int p = GetParam();
  const int cells = 6;
  const BSpline1D b(p, cells, 0.5, 2.0);
  const auto t = knots(p, cells, 0.5, 2.0);
  std::vector<double> g(b.size());
  for (int i = 0; i < b.size(); ++i)
  {
    for (int j = 1; j <= p; ++j)
      g[i] += t[i + j];
    g[i] /= p;
    EXPECT_NEAR(b.greville(i), g[i], 1e-15) << i; // BSpline1D's own
  }
  double N[4], dN[4], d2N[4];
  for (double x : samples(b))
  {
    const int c = b.cell(x);
    b.evaluate(c, x, N, dN, d2N);
    double u = 0, du = 0, d2u = 0;
    for (int k = 0; k <= p; ++k)
    {
      const double f = 3.0 - 2.0 * g[c + k]; // u(x) = 3 - 2x
      u += N[k] * f;
      du += dN[k] * f;
      d2u += d2N[k] * f;
    }
    EXPECT_NEAR(u, 3.0 - 2.0 * x, 1e-12) << "x = " << x << " cell " << c;
    EXPECT_NEAR(du, -2.0, 1e-11) << "x = " << x << " cell " << c;
    EXPECT_NEAR(d2u, 0.0, 1e-10) << "x = " << x << " cell " << c;
  }
}

TEST_P(BSplineDegree, MatchesRecursiveCoxDeBoor)
{
  const int p = GetParam();
  const int cells = 5;
  const BSpline1D b(p, cells, 1.7, 0.4);
  const auto t = knots(p, cells, 1.7, 0.4);
  double N[4], dN[4], d2N[4];
  const double eps = 1e-6;
  for (double x : samples(b))
  {
    const int c = b.cell(x);
    b.evaluate(c, x, N, dN, d2N);
    for (int i = 0; i < b.size(); ++i)
    {
      const double expected = cox_de_boor(t, i, p, x);
      const bool supported = i >= c && i <= c + p;
      EXPECT_NEAR(supported ? N[i - c] : 0.0, expected, tol) << "function " << i << " x " << x;
      // First derivative by central differences inside the cell.
      const double xi = (x - b.origin()) / b.h() - c;
      if (supported && xi > 0.01 && xi < 0.99)
      {
        const double fd = (cox_de_boor(t, i, p, x + eps) - cox_de_boor(t, i, p, x - eps)) / (2 * eps);
        EXPECT_NEAR(dN[i - c], fd, 1e-7);
      }
    }
  }
}

TEST_P(BSplineDegree, IntegralsMatchGaussQuadrature)
{
  // Each basis function is a polynomial of degree p on a cell: 3-point Gauss
  // integrates it exactly.
  const int p = GetParam();
  const BSpline1D b(p, 6, 1.7, 0.4);
  const double gx[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, gw[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
  std::vector<double> integral(b.size(), 0.0);
  double N[4], dN[4], d2N[4];
  for (int c = 0; c < b.cells(); ++c)
    for (int q = 0; q < 3; ++q)
    {
      b.evaluate(c, b.origin() + b.h() * (c + 0.5 + 0.5 * gx[q]), N, dN, d2N);
      for (int a = 0; a <= p; ++a)
        integral[c + a] += 0.5 * b.h() * gw[q] * N[a];
    }
  for (int i = 0; i < b.size(); ++i)
    EXPECT_NEAR(b.integral(i), integral[i], tol) << "function " << i;
  EXPECT_NEAR(b.integral(p + 1), b.h(), tol); // an interior function when cells > 2p
}

TEST_P(BSplineDegree, FastPathsMatchGeneralEvaluation)
{
  const int p = GetParam();
  const BSpline1D b(p, 9, 0.25, 0.0);
  double N[4], dN[4], d2N[4], Nf[4], dNf[4], Ns[4], dNs[4], d2Ns[4];
  for (double x : samples(b))
  {
    const int c = b.cell(x);
    b.evaluate(c, x, N, dN, d2N);
    switch (p)
    {
    case 1:
      b.evaluate<1>(c, x, Nf, dNf);
      b.evaluate<1>(c, x, Ns, dNs, d2Ns);
      break;
    case 2:
      b.evaluate<2>(c, x, Nf, dNf);
      b.evaluate<2>(c, x, Ns, dNs, d2Ns);
      break;
    default:
      b.evaluate<3>(c, x, Nf, dNf);
      b.evaluate<3>(c, x, Ns, dNs, d2Ns);
    }
    for (int k = 0; k <= p; ++k)
    {
      EXPECT_NEAR(Nf[k], N[k], tol);
      EXPECT_NEAR(dNf[k], dN[k], 1e-12);
      EXPECT_NEAR(Ns[k], N[k], tol);
      EXPECT_NEAR(dNs[k], dN[k], 1e-12);
      EXPECT_NEAR(d2Ns[k], d2N[k], 1e-10);
    }
  }
}

TEST_P(BSplineDegree, InterpolatesAtTheEnds)
{
  // Open knot vectors: only the first (last) function is nonzero at the ends.
  const int p = GetParam();
  const BSpline1D b(p, 4, 1.0, 0.0);
  double N[4], dN[4], d2N[4];
  b.evaluate(0, 0.0, N, dN, d2N);
  EXPECT_DOUBLE_EQ(N[0], 1.0);
  b.evaluate(3, 4.0, N, dN, d2N);
  EXPECT_NEAR(N[p], 1.0, tol);
}

INSTANTIATE_TEST_SUITE_P(Degrees, BSplineDegree, ::testing::Values(1, 2, 3));

TEST(BSpline, RejectsBadArguments)
{
  EXPECT_THROW(BSpline1D(0, 4, 1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(BSpline1D(4, 4, 1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(BSpline1D(2, 1, 1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(BSpline1D(2, 4, -1.0, 0.0), std::invalid_argument);
}

TEST(BSpline, CellLookup)
{
  const BSpline1D b(2, 10, 0.5, 1.0);
  EXPECT_EQ(b.cell(1.0), 0);
  EXPECT_EQ(b.cell(1.49), 0);
  EXPECT_EQ(b.cell(5.99), 9);
  EXPECT_EQ(b.cell(6.0), -1); // upper end is outside
  EXPECT_EQ(b.cell(0.99), -1);
  EXPECT_EQ(b.cell(std::nan("")), -1);
}
