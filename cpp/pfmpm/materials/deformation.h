/// @file deformation.h
/// @brief Kinematics of finite-strain models in 2 and 3 directions: the
/// deformation gradient F, advanced with the velocity gradient (Homel &
/// Herbold 2017, eq. 8), the volume ratio of a step, and the principal values
/// of a plane symmetric tensor. Tensors are row-major Dim x Dim (xx, xy, yx,
/// yy in 2D, where F_33 = 1).
#pragma once

#include <Eigen/Dense>
#include <unsupported/Eigen/MatrixFunctions>

#include <cmath>

namespace pfmpm
{

/// @brief det F of a deformation gradient.
template <int Dim>
double determinant(const double* F)
{
  if constexpr (Dim == 2)
    return F[0] * F[3] - F[1] * F[2];
  else
    return F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6])
           + F[2] * (F[3] * F[7] - F[4] * F[6]);
}

/// @brief det(I + dt L) of a velocity gradient L: the volume ratio over a
/// step of H&H eq. 8 (G2P scales the particle volume by it).
template <int Dim>
double volume_ratio(const double* L, double dt)
{
  if constexpr (Dim == 2)
    return (1.0 + dt * L[0]) * (1.0 + dt * L[3]) - dt * dt * L[1] * L[2];
  else
  {
    const double A[9] = {1.0 + dt * L[0], dt * L[1], dt * L[2], dt * L[3], 1.0 + dt * L[4],
                         dt * L[5], dt * L[6], dt * L[7], 1.0 + dt * L[8]};
    return determinant<3>(A);
  }
}

/// F <- A F for row-major Dim x Dim matrices.
template <int Dim>
void premultiply(const double* A, double* F)
{
  double G[Dim * Dim];
  for (int i = 0; i < Dim; ++i)
    for (int j = 0; j < Dim; ++j)
    {
      double g = A[Dim * i] * F[j];
      for (int k = 1; k < Dim; ++k)
        g += A[Dim * i + k] * F[Dim * k + j];
      G[Dim * i + j] = g;
    }
  for (int k = 0; k < Dim * Dim; ++k)
    F[k] = G[k];
}

/// @brief F <- (I + dt/n L)^n F: H&H eq. 8, F^{n+1} = F^n + dt L F^n, taken in n
/// equal sub-steps with the step's velocity gradient (n = 1 is H&H eq. 8 itself).
/// @param[in,out] F Deformation gradient.
/// @param L Velocity gradient L_ij = dv_i/dx_j.
/// @param dt Time step.
/// @param substeps n >= 1.
template <int Dim>
void advance_deformation(double* F, const double* L, double dt, int substeps)
{
  const double h = dt / substeps;
  double A[Dim * Dim];
  for (int k = 0; k < Dim * Dim; ++k)
    A[k] = h * L[k];
  for (int d = 0; d < Dim; ++d)
    A[(Dim + 1) * d] += 1.0;
  for (int k = 0; k < substeps; ++k)
    premultiply<Dim>(A, F);
}

/// @brief F <- exp(dt L) F: H&H eq. 8 integrated exactly for a velocity gradient
/// constant over the step (the higher-order integration its footnote
/// allows). A rigid spin L = W gives an exact rotation, so the update is
/// objective: a rotated body keeps its stretches to round-off.
///
/// In 2D, for A = dt L with mean trace t and deviator M = A - t I, M^2 = s^2 I
/// with s^2 = -det M, so exp(A) = e^t (cosh(s) I + sinh(s)/s M) (cos and sin
/// of sqrt(-s^2) when s^2 < 0; their Taylor series near 0). In 3D by Eigen's
/// matrix exponential (scaling and squaring with a Pade approximant).
/// @param[in,out] F Deformation gradient.
/// @param L Velocity gradient.
/// @param dt Time step.
template <int Dim>
void exponential_deformation(double* F, const double* L, double dt)
{
  if constexpr (Dim == 3)
  {
    using Matrix = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    const Matrix A = (dt * Eigen::Map<const Matrix>(L)).exp();
    premultiply<3>(A.data(), F);
    return;
  }
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
  premultiply<2>(A, F);
}

/// @brief How a model advances its deformation gradient with L: H&H eq. 8 in
/// `substeps` sub-steps, or the exponential.
struct DeformationUpdate
{
  bool exponential = false; ///< exp(dt L) (exponential_deformation) instead of H&H eq. 8
  int substeps = 1;         ///< sub-steps of H&H eq. 8 (advance_deformation)

  template <int Dim>
  void apply(double* F, const double* L, double dt) const
  {
    if (exponential)
      exponential_deformation<Dim>(F, L, dt);
    else
      advance_deformation<Dim>(F, L, dt, substeps);
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
