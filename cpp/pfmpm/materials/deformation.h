/// @file deformation.h
/// @brief Kinematics of finite-strain models: the deformation gradient F,
/// advanced with the velocity gradient (Homel & Herbold 2017, eq. 8), and the
/// principal values of a plane symmetric tensor.
#pragma once

#include <cmath>

namespace pfmpm
{

/// @brief det F of a plane deformation gradient (xx, xy, yx, yy); F_33 = 1.
inline double determinant(const double* F) { return F[0] * F[3] - F[1] * F[2]; }

/// @brief F <- (I + dt/n L)^n F: H&H eq. 8, F^{n+1} = F^n + dt L F^n, taken in n
/// equal sub-steps with the step's velocity gradient (n = 1 is H&H eq. 8 itself).
/// @param[in,out] F Deformation gradient, row-major (xx, xy, yx, yy).
/// @param L Velocity gradient L_ij = dv_i/dx_j, row-major.
/// @param dt Time step.
/// @param substeps n >= 1.
inline void advance_deformation(double* F, const double* L, double dt, int substeps)
{
  const double h = dt / substeps;
  const double A[4] = {1.0 + h * L[0], h * L[1], h * L[2], 1.0 + h * L[3]};
  for (int k = 0; k < substeps; ++k)
  {
    const double G[4] = {A[0] * F[0] + A[1] * F[2], A[0] * F[1] + A[1] * F[3],
                         A[2] * F[0] + A[3] * F[2], A[2] * F[1] + A[3] * F[3]};
    F[0] = G[0];
    F[1] = G[1];
    F[2] = G[2];
    F[3] = G[3];
  }
}

/// @brief F <- exp(dt L) F: H&H eq. 8 integrated exactly for a velocity gradient
/// constant over the step (the higher-order integration its footnote
/// allows). A rigid spin L = W gives an exact rotation, so the update is
/// objective: a rotated body keeps its stretches to round-off.
///
/// For A = dt L with mean trace t and deviator M = A - t I, M^2 = s^2 I with
/// s^2 = -det M, so exp(A) = e^t (cosh(s) I + sinh(s)/s M) (cos and sin of
/// sqrt(-s^2) when s^2 < 0; their Taylor series near 0).
/// @param[in,out] F Deformation gradient, row-major (xx, xy, yx, yy).
/// @param L Velocity gradient, row-major.
/// @param dt Time step.
inline void exponential_deformation(double* F, const double* L, double dt)
{
  const double t = 0.5 * dt * (L[0] + L[3]);
  const double m00 = 0.5 * dt * (L[0] - L[3]), m01 = dt * L[1], m10 = dt * L[2];
  const double s2 = m00 * m00 + m01 * m10;
  double c, k;
  if (std::abs(s2) < 1e-4) // truncation s2^3/720 < 2e-15
  {
    c = 1.0 + s2 * (0.5 + s2 / 24.0);
    k = 1.0 + s2 * (1.0 / 6.0 + s2 / 120.0);
  }
  else if (s2 > 0.0)
  {
    const double s = std::sqrt(s2);
    c = std::cosh(s);
    k = std::sinh(s) / s;
  }
  else
  {
    const double w = std::sqrt(-s2);
    c = std::cos(w);
    k = std::sin(w) / w;
  }
  const double e = std::exp(t);
  const double A[4] = {e * (c + k * m00), e * k * m01, e * k * m10, e * (c - k * m00)};
  const double G[4] = {A[0] * F[0] + A[1] * F[2], A[0] * F[1] + A[1] * F[3],
                       A[2] * F[0] + A[3] * F[2], A[2] * F[1] + A[3] * F[3]};
  F[0] = G[0];
  F[1] = G[1];
  F[2] = G[2];
  F[3] = G[3];
}

/// @brief How a model advances its deformation gradient with L: H&H eq. 8 in
/// `substeps` sub-steps, or the exponential.
struct DeformationUpdate
{
  bool exponential = false; ///< exp(dt L) (exponential_deformation) instead of H&H eq. 8
  int substeps = 1;         ///< sub-steps of H&H eq. 8 (advance_deformation)

  void operator()(double* F, const double* L, double dt) const
  {
    if (exponential)
      exponential_deformation(F, L, dt);
    else
      advance_deformation(F, L, dt, substeps);
  }
  /// Whether det F changes by det(I + dt L), the factor G2P applies to the
  /// particle volume: H&H eq. 8 in one step.
  bool scales_volume_as_g2p() const { return !exponential && substeps == 1; }
};

/// @brief Principal values of a plane symmetric tensor (xx, yy, xy): the mean
/// m and the radius r of its Mohr circle, so that the values are m + r >= m - r.
struct Mohr
{
  double m, r;
  explicit Mohr(double xx, double yy, double xy)
      : m(0.5 * (xx + yy)), r(std::sqrt(0.25 * (xx - yy) * (xx - yy) + xy * xy))
  {
  }
  double max() const { return m + r; }
  double min() const { return m - r; }
};

} // namespace pfmpm
