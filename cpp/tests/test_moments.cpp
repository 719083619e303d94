/// @file test_moments.cpp
/// @brief A cell's phase-field block from its particles' moments (moments.h)
/// against the sum over the particles of eq. 57's integrand, formed from the
/// B-spline stencil's values and derivatives, on the cells next to the ends
/// of the open knot vector and in the interior.
#include "pfmpm/fracture/moments.h"
#include "pfmpm/shape/stencil.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

using namespace pfmpm;

namespace
{
template <int P, bool Fourth>
void check_cells()
{
  constexpr int W = P + 1, K = W * W;
  using Moments = CellMoments<2, P, Fourth>;
  const int cells = 9;
  const BSpline1D bx(P, cells, 0.5, -1.0), by(P, cells, 0.25, 2.0);
  const std::array<const BSpline1D*, 2> basis{&bx, &by};
  const CellProducts tx(bx), ty(by);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0), weight(0.5, 2.0);
  // A symmetric gamma (Voigt, kappa = xx, yy, xy).
  const double g[9] = {1.0, 0.3, -0.2, 0.3, 74.0, 0.5, -0.2, 0.5, 2.0};
  for (const int cx : {0, 1, P, cells / 2, cells - 2, cells - 1})
    for (const int cy : {0, cells / 2, cells - 1})
    {
      Moments moments;
      double direct[K][K] = {}, direct_f[K] = {};
      for (int k = 0; k < 7; ++k)
      {
        const double x[2] = {bx.origin() + (cx + unit(random)) * bx.h(),
                             by.origin() + (cy + unit(random)) * by.h()};
        const int cell[2] = {cx, cy};
        double w[Moments::weights];
        for (double& v : w)
          v = weight(random);
        const double e = Fourth ? weight(random) : 0.0, src = weight(random);
        if constexpr (Fourth)
        {
          const int pair[6] = {0, 4, 8, 1, 2, 5}; // moments' order of gamma's components
          for (int q = 0; q < 6; ++q)
            w[2 + q] = e * g[pair[q]];
        }
        CellPowers<2, P> powers;
        powers.evaluate(basis, cell, x);
        moments.add(powers, w, src);
        BSplineStencil<2, P, Fourth ? 2 : 1> s;
        s.evaluate(basis, cell, x);
        for (int i = 0; i < K; ++i)
        {
          direct_f[i] += src * s.N(i);
          for (int j = 0; j < K; ++j)
          {
            double v = w[0] * s.N(i) * s.N(j)
                       + w[1] * (s.dN(0, i) * s.dN(0, j) + s.dN(1, i) * s.dN(1, j));
            if constexpr (Fourth)
              for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                  v += e * s.d2N(c, i) * g[3 * r + c] * s.d2N(r, j);
            direct[i][j] += v;
          }
        }
      }
      double block[K][CellProducts::row(P)], f[K];
      moments.block(tx.products(cx), ty.products(cy), nullptr, block);
      moments.rhs(tx.values(cx), ty.values(cy), nullptr, f);
      double scale = 0.0;
      for (const auto& row : direct)
        for (double v : row)
          scale = std::max(scale, std::abs(v));
      for (int i = 0; i < K; ++i)
      {
        const int a = i / W, b = i % W;
        EXPECT_NEAR(f[i], direct_f[i], 1e-13) << "cell " << cx << ", " << cy << " node " << i;
        for (int j = 0; j < K; ++j)
          if (j / W >= a)
            EXPECT_NEAR(block[a * W + j / W][b * W + j % W], direct[i][j], 2e-13 * scale)
                << "cell " << cx << ", " << cy << " entry " << i << ", " << j;
      }
    }
}

/// check_cells in 3D (second order): the block's entries for i = (a, b, c)
/// and j = (a', b', c') with a' >= a, and F.
template <int P>
void check_cells3()
{
  constexpr int W = P + 1, K = W * W * W;
  using Moments = CellMoments<3, P, false>;
  const int cells = 8;
  const BSpline1D bx(P, cells, 0.5, -1.0), by(P, cells, 0.5, 2.0), bz(P, cells, 0.5, 0.25);
  const std::array<const BSpline1D*, 3> basis{&bx, &by, &bz};
  const CellProducts tx(bx), ty(by), tz(bz);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0), weight(0.5, 2.0);
  for (const int cx : {0, P, cells - 1})
    for (const int cy : {0, cells / 2})
      for (const int cz : {1, cells - 1})
      {
        Moments moments;
        std::vector<double> direct(K * K, 0.0), direct_f(K, 0.0);
        for (int k = 0; k < 9; ++k)
        {
          const double x[3] = {bx.origin() + (cx + unit(random)) * bx.h(),
                               by.origin() + (cy + unit(random)) * by.h(),
                               bz.origin() + (cz + unit(random)) * bz.h()};
          const int cell[3] = {cx, cy, cz};
          double w[Moments::weights];
          for (double& v : w)
            v = weight(random);
          const double src = weight(random);
          CellPowers<3, P> powers;
          powers.evaluate(basis, cell, x);
          moments.add(powers, w, src);
          BSplineStencil<3, P> s;
          s.evaluate(basis, cell, x);
          for (int i = 0; i < K; ++i)
          {
            direct_f[i] += src * s.N(i);
            for (int j = 0; j < K; ++j)
              direct[i * K + j] += w[0] * s.N(i) * s.N(j)
                                   + w[1] * (s.dN(0, i) * s.dN(0, j) + s.dN(1, i) * s.dN(1, j)
                                             + s.dN(2, i) * s.dN(2, j));
          }
        }
        static typename Moments::Block block;
        double f[K];
        moments.block(tx.products(cx), ty.products(cy), tz.products(cz), block);
        moments.rhs(tx.values(cx), ty.values(cy), tz.values(cz), f);
        const double scale = *std::max_element(direct.begin(), direct.end());
        for (int i = 0; i < K; ++i)
        {
          const int a = i / (W * W), b = i / W % W, c = i % W;
          EXPECT_NEAR(f[i], direct_f[i], 1e-13) << "cell " << cx << ", " << cy << ", " << cz;
          for (int j = 0; j < K; ++j)
          {
            const int aa = j / (W * W), bb = j / W % W, cc = j % W;
            if (aa >= a)
              // The third axis's products add round-off: up to 5.6e-13 of the scale.
              EXPECT_NEAR(block[a * W + aa][b * W + bb][c * W + cc], direct[i * K + j], 1e-12 * scale)
                  << "cell " << cx << ", " << cy << ", " << cz << " entry " << i << ", " << j;
          }
        }
      }
}
} // namespace

TEST(Moments, SecondOrderBlockIn3DIsTheSumOverTheParticles)
{
  check_cells3<1>();
  check_cells3<2>();
  check_cells3<3>();
}

TEST(Moments, SecondOrderBlockIsTheSumOverTheParticles)
{
  check_cells<1, false>();
  check_cells<2, false>();
  check_cells<3, false>();
}

TEST(Moments, FourthOrderBlockIsTheSumOverTheParticles)
{
  check_cells<2, true>();
  check_cells<3, true>();
}
