/// @file kernel.h
/// @brief The kernel damage field of Homel & Herbold 2017, eqs. 17-19: a
/// cubic kernel summed over a particle's neighbours, normalised by the kernel
/// sum, and its gradient at the particle.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace pfmpm
{

/// @brief The cubic kernel of H&H eq. 18, omega(r) = 1 - 3 r^2 + 2 r^3 for
/// 0 <= r <= 1 and 0 beyond, with r the distance over the kernel radius.
inline double kernel_weight(double r) { return r < 1.0 ? 1.0 - r * r * (3.0 - 2.0 * r) : 0.0; }

/// @brief The normalised damage field at one particle and its gradient, in
/// Dim directions.
template <int Dim>
struct KernelValue
{
  double S;         ///< kernel sum (H&H eq. 19), >= 1 (the particle's own term)
  double D;         ///< normalised damage D-bar = D / S (H&H eqs. 17, 19)
  double grad[Dim]; ///< gradient of D-bar at the particle
};

/// @brief The normalised kernel damage field (H&H eqs. 17-19) and its gradient
/// at particle p, from the neighbours `q[0, n)` (any superset of those within
/// `radius`, sorted by index, which is id order, so that the sums have an
/// order fixed by the positions and ids alone), in Dim directions.
///
/// With d_q = D_q - D_p, the ratio of H&H eqs. 17 and 19 is D-bar = D_p + sum_q d_q w_q / S
/// and its gradient (S sum_q d_q grad w_q - sum_q d_q w_q grad S) / S^2, where
/// grad w_q = 6 (r - 1)(x_p - x_q) / radius^2 is the kernel's gradient in x_p
/// and the particle's own term adds 1 to S and nothing to the gradients. Sums
/// of differences make a uniform damage give exactly zero gradient (check U1).
/// The sums are unweighted, as in the paper (GEOS weights them by V_q).
/// @param x Positions, N x Dim.
/// @param damage D_p per particle (with surface flags, max(s_p, D_p)).
template <int Dim>
KernelValue<Dim> kernel_field(std::size_t p, const std::int32_t* q, std::int64_t n, const double* x,
                              const double* damage, double radius)
{
  const double inv_r = 1.0 / radius, inv_r2 = inv_r * inv_r;
  const double* const xp = &x[Dim * p];
  const double dp = damage[p];
  double S = 1.0, dS[Dim] = {}, Dw = 0.0, dD[Dim] = {};
  // A chunk of the list at a time: first the neighbours within the radius,
  // in list order, found without a branch (one in three is beyond it, in
  // the list's skin, and would be mispredicted); then their terms. Those
  // beyond add nothing (w = g = 0), so the sums stay a function of the
  // positions alone, whenever the list was built.
  constexpr int chunk = 64;
  double e[Dim][chunk], r2[chunk];
  std::int32_t j[chunk];
  for (std::int64_t k0 = 0; k0 < n; k0 += chunk)
  {
    const int m = static_cast<int>(std::min<std::int64_t>(chunk, n - k0));
    int within = 0;
    for (int k = 0; k < m; ++k)
    {
      const std::size_t i = static_cast<std::size_t>(q[k0 + k]);
      double ed[Dim];
#pragma GCC unroll 3
      for (int d = 0; d < Dim; ++d)
        ed[d] = xp[d] - x[Dim * i + d];
      double s2 = ed[0] * ed[0];
#pragma GCC unroll 3
      for (int d = 1; d < Dim; ++d)
        s2 += ed[d] * ed[d];
      s2 *= inv_r2;
#pragma GCC unroll 3
      for (int d = 0; d < Dim; ++d)
        e[d][within] = ed[d];
      r2[within] = s2;
      j[within] = q[k0 + k];
      within += s2 < 1.0;
    }
    for (int k = 0; k < within; ++k)
    {
      const double r = std::sqrt(r2[k]);
      const double w = 1.0 - r * r * (3.0 - 2.0 * r); // kernel_weight(r)
      const double g = 6.0 * (r - 1.0) * inv_r2;       // grad w = g (x_p - x_q)
      const double d = damage[j[k]] - dp;
      S += w;
#pragma GCC unroll 3
      for (int c = 0; c < Dim; ++c)
        dS[c] += g * e[c][k];
      Dw += d * w;
#pragma GCC unroll 3
      for (int c = 0; c < Dim; ++c)
        dD[c] += d * g * e[c][k];
    }
  }
  const double inv_S = 1.0 / S;
  KernelValue<Dim> out;
  out.S = S;
  out.D = dp + Dw * inv_S;
  for (int c = 0; c < Dim; ++c)
    out.grad[c] = (S * dD[c] - Dw * dS[c]) * inv_S * inv_S;
  return out;
}

} // namespace pfmpm
