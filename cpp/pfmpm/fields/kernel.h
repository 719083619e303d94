/// @file kernel.h
/// @brief The kernel damage field of Homel & Herbold (2017), eqs. 17-19: a
/// cubic kernel summed over a particle's neighbours, normalised by the kernel
/// sum, and its gradient at the particle.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace pfmpm
{

/// @brief The cubic kernel of eq. 18, omega(r) = 1 - 3 r^2 + 2 r^3 for
/// 0 <= r <= 1 and 0 beyond, with r the distance over the kernel radius.
inline double kernel_weight(double r) { return r < 1.0 ? 1.0 - r * r * (3.0 - 2.0 * r) : 0.0; }

/// @brief The normalised damage field at one particle and its gradient.
struct KernelValue
{
  double S;        ///< kernel sum (eq. 19), >= 1 (the particle's own term)
  double D;        ///< normalised damage D-bar = D / S (eqs. 17, 19)
  double grad[2];  ///< gradient of D-bar at the particle
};

/// @brief The normalised kernel damage field (eqs. 17-19) and its gradient
/// at particle p, from the neighbours `q[0, n)` (any superset of those within
/// `radius`, sorted by index so that the sums have an order fixed by the
/// positions alone).
///
/// With d_q = D_q - D_p, eq. 17 over eq. 19 is D-bar = D_p + sum_q d_q w_q / S
/// and its gradient (S sum_q d_q grad w_q - sum_q d_q w_q grad S) / S^2, where
/// grad w_q = 6 (r - 1)(x_p - x_q) / radius^2 is the kernel's gradient in x_p
/// and the particle's own term adds 1 to S and nothing to the gradients. Sums
/// of differences make a uniform damage give exactly zero gradient (check U1).
/// The sums are unweighted, as in the paper (GEOS weights them by V_q).
/// @param x Positions, N x 2.
/// @param damage D_p per particle (with surface flags, max(s_p, D_p)).
inline KernelValue kernel_field(std::size_t p, const std::int32_t* q, std::int64_t n,
                                const double* x, const double* damage, double radius)
{
  const double inv_r = 1.0 / radius, inv_r2 = inv_r * inv_r;
  const double xp = x[2 * p], yp = x[2 * p + 1], dp = damage[p];
  double S = 1.0, dS[2] = {0.0, 0.0}, Dw = 0.0, dD[2] = {0.0, 0.0};
  for (std::int64_t k = 0; k < n; ++k)
  {
    const std::size_t j = static_cast<std::size_t>(q[k]);
    const double rx = xp - x[2 * j], ry = yp - x[2 * j + 1];
    // r at most 1: a neighbour beyond the radius (the list's skin) adds
    // w = g = 0, exact zeros that leave the sums' bits as they are, without
    // a branch, which in a deformed body is mispredicted one time in three.
    // (The empty asm hides that r2 may be 1, so that the compiler does not
    // bring the branch back as a shortcut for that case.)
    double r2 = std::min((rx * rx + ry * ry) * inv_r2, 1.0);
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    asm("" : "+x"(r2));
#endif
    const double r = std::sqrt(r2);
    const double w = 1.0 - r * r * (3.0 - 2.0 * r); // kernel_weight(r)
    const double g = 6.0 * (r - 1.0) * inv_r2;       // grad w = g (x_p - x_q)
    const double d = damage[j] - dp;
    S += w;
    dS[0] += g * rx;
    dS[1] += g * ry;
    Dw += d * w;
    dD[0] += d * g * rx;
    dD[1] += d * g * ry;
  }
  const double inv_S = 1.0 / S;
  KernelValue out;
  out.S = S;
  out.D = dp + Dw * inv_S;
  out.grad[0] = (S * dD[0] - Dw * dS[0]) * inv_S * inv_S;
  out.grad[1] = (S * dD[1] - Dw * dS[1]) * inv_S * inv_S;
  return out;
}

} // namespace pfmpm
