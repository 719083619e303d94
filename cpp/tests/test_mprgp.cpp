/// @file test_mprgp.cpp
/// @brief MPRGP (mprgp.h) on box-constrained systems stored as phase-field
/// stencils: the minimiser that projected Gauss-Seidel converges to, on
/// matrices that are not M-matrices, semi-definite ones among them.
#include "pfmpm/fracture/mprgp.h"

#include "helpers.h"

#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

using namespace pfmpm;

namespace
{
constexpr int P = 2;
constexpr int H = SymmetricStencil<2, P>::size;

/// A system on an n x n block of grid nodes, padded by P on each side: K is
/// a sum of rank-one "particle" blocks w N N^T over 3 x 3 nodes (N > 0, as
/// B-spline values, so K's off-diagonal entries are positive: not an
/// M-matrix) and `diffusion` times a 5-point Laplacian (semi-definite alone).
struct BoxSystem
{
  int n, ny;
  std::vector<double> rows; // SymmetricStencil rows, padded layout
  std::vector<std::size_t> position;
  std::vector<double> diagonal, rhs;

  BoxSystem(int n_, int particles, double diffusion, unsigned seed)
      : n(n_), ny(n_ + 2 * P), rows(static_cast<std::size_t>(n_ + 2 * P) * (n_ + 2 * P) * H, 0.0)
  {
    for (int x = 0; x < n; ++x)
      for (int y = 0; y < n; ++y)
        position.push_back(padded(x, y));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int p = 0; p < particles; ++p)
    {
      const int cx = static_cast<int>(u(rng) * (n - 2)), cy = static_cast<int>(u(rng) * (n - 2));
      // A weight over six orders of magnitude, as histories are.
      const double w = std::pow(10.0, 6.0 * u(rng) - 2.0);
      double v[9];
      for (double& x : v)
        x = 0.05 + u(rng);
      for (int a = 0; a < 9; ++a)
        for (int b = 0; b < 9; ++b)
          add(cx + a / 3, cy + a % 3, cx + b / 3, cy + b % 3, w * v[a] * v[b]);
    }
    for (int x = 0; x < n; ++x)
      for (int y = 0; y + 1 < n; ++y)
        for (const auto& [ax, ay, bx, by] : {std::array{x, y, x, y + 1}, std::array{y, x, y + 1, x}})
        {
          add(ax, ay, ax, ay, diffusion);
          add(bx, by, bx, by, diffusion);
          add(ax, ay, bx, by, -diffusion);
        }
    // Untouched nodes: identity rows, as the phase field's.
    for (std::size_t a : position)
    {
      if (rows[a * H] == 0.0)
        rows[a * H] = 1.0;
      diagonal.push_back(rows[a * H]);
    }
    // F = K c* + lambda: c* partly outside the box, and multipliers that push
    // some nodes onto each bound.
    std::vector<double> star(rows.size() / H, 0.0);
    for (std::size_t a : position)
      star[a] = 1.6 * u(rng) - 0.3;
    const StencilSystem<2, P> K = system();
    for (std::size_t a = 0; a < position.size(); ++a)
      rhs.push_back(K.product(a, star.data()) + diagonal[a] * (u(rng) - 0.5));
  }
  std::size_t padded(int ix, int iy) const
  {
    return static_cast<std::size_t>(ix + P) * ny + (iy + P);
  }
  /// K_ij += v for nodes i = (ix, iy), j = (jx, jy) (and K_ji, the same entry).
  void add(int ix, int iy, int jx, int jy, double v)
  {
    const int k = SymmetricStencil<2, P>::slot(jx - ix, jy - iy);
    if (k >= 0)
      rows[padded(ix, iy) * H + k] += v;
    else if (ix != jx || iy != jy)
      return; // the pair (j, i) adds it
  }
  StencilSystem<2, P> system() const
  {
    return {SymmetricStencil<2, P>(static_cast<std::size_t>(ny)), rows.data(), position.data(),
            diagonal.data(), rhs.data(), position.size()};
  }
  /// The minimiser by projected Gauss-Seidel, which converges for any K
  /// positive semi-definite with positive diagonal (each sweep lowers the energy).
  std::vector<double> reference() const
  {
    const StencilSystem<2, P> K = system();
    std::vector<double> c(rows.size() / H, 0.0);
    for (std::size_t a : position)
      c[a] = 0.5;
    for (int sweep = 0; sweep < 200000; ++sweep)
    {
      double change = 0.0;
      for (std::size_t a = 0; a < position.size(); ++a)
      {
        double& x = c[position[a]];
        const double next = std::clamp(x + (rhs[a] - K.product(a, c.data())) / diagonal[a], 0.0, 1.0);
        change = std::max(change, std::abs(next - x));
        x = next;
      }
      if (change < 1e-15)
        break;
    }
    std::vector<double> out;
    for (std::size_t a : position)
      out.push_back(c[a]);
    return out;
  }
};

/// The padded vector with `start` at every active node.
std::vector<double> padded_fill(const BoxSystem& s, double start)
{
  std::vector<double> c(static_cast<std::size_t>(s.n + 2 * P) * s.ny, 0.0);
  for (std::size_t a : s.position)
    c[a] = start;
  return c;
}
} // namespace

TEST(Mprgp, FindsTheBoxMinimiserOfSystemsThatAreNotMMatrices)
{
  int expansions = 0, proportionings = 0, at_zero = 0, at_one = 0, free = 0;
  for (unsigned seed = 1; seed <= 6; ++seed)
  {
    const BoxSystem s(10, 30, seed % 2 ? 1e-3 : 0.0, seed);
    const std::vector<double> expected = s.reference();
    double norm_f = 0.0;
    for (double f : s.rhs)
      norm_f += f * f;
    norm_f = std::sqrt(norm_f);
    // From all held at c = 1 (the phase field of an intact body), which
    // only proportioning steps leave, and from the middle of the box.
    for (double start : {1.0, 0.5})
    {
      std::vector<double> c = padded_fill(s, start), p = padded_fill(s, 0.0), g, q;
      const MprgpResult r = mprgp<2, P>(s.system(), c.data(), p.data(), g, q, 1e-13 * norm_f, 1e-13, 100000);
      ASSERT_TRUE(r.converged) << "seed " << seed << ", start " << start;
      for (std::size_t a = 0; a < s.position.size(); ++a)
      {
        EXPECT_NEAR(c[s.position[a]], expected[a], 1e-8) << "seed " << seed << ", node " << a;
        const double x = c[s.position[a]];
        (x == 0.0 ? at_zero : x == 1.0 ? at_one : free) += 1;
      }
      for (std::size_t a = 0; a < p.size(); ++a)
        if (std::find(s.position.begin(), s.position.end(), a) == s.position.end())
          ASSERT_EQ(p[a], 0.0); // the work vector stays zero off the active nodes
      expansions += r.expansions;
      proportionings += r.proportionings;
    }
  }
  // The cases exercise every kind of step, and both bounds hold nodes.
  EXPECT_GT(expansions, 0);
  EXPECT_GT(proportionings, 0);
  EXPECT_GT(at_zero, 50);
  EXPECT_GT(at_one, 50);
  EXPECT_GT(free, 50);
}

TEST(Mprgp, SemiDefiniteSystemWithoutReactionSettlesOnTheBound)
{
  // Diffusion alone (AT1 where no history has reached) with F > 0: K 1 = 0,
  // so the energy falls without bound along c = t 1 until c = 1 everywhere.
  BoxSystem s(8, 0, 1.0, 3);
  for (double& f : s.rhs)
    f = 0.25;
  std::vector<double> c = padded_fill(s, 0.3), p = padded_fill(s, 0.0), g, q;
  const MprgpResult r = mprgp<2, P>(s.system(), c.data(), p.data(), g, q, 1e-12, 1e-12, 1000);
  ASSERT_TRUE(r.converged);
  for (std::size_t a : s.position)
    EXPECT_EQ(c[a], 1.0);
}

TEST(Mprgp, ThreadCountDoesNotChangeBits)
{
  const BoxSystem s(80, 2000, 1e-3, 11); // 6400 nodes: two blocks of deterministic_sum
  std::vector<std::vector<double>> out;
  for (int threads : {1, 3})
  {
    omp_set_num_threads(threads);
    std::vector<double> c = padded_fill(s, 1.0), p = padded_fill(s, 0.0), g, q;
    mprgp<2, P>(s.system(), c.data(), p.data(), g, q, 1e-10, 1e-10, 100000);
    out.push_back(c);
  }
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_TRUE(test::same_bits(out[0], out[1]));
}
