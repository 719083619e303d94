/// @file damage.h
/// @brief The scalar damage models of Homel & Herbold (2017, §2.7): how the
/// damage D grows from the largest trial principal stress (H&H eqs. 23, 24), and
/// how it degrades the tensile principal stresses (H&H eqs. 26-27).
///
/// A damage model is a policy of a constitutive model (NeoHookean<Damage>),
/// chosen once per material: `grow(D, sigma_max, sigma_f, dt)` returns the
/// damage after a step whose largest trial principal stress is sigma_max, for
/// a particle of strength sigma_f (its own, with a Weibull field, H&H eq. 25).
#pragma once

#include "pfmpm/common/symmetric.h"
#include "pfmpm/materials/deformation.h"

#include <algorithm>

namespace pfmpm
{

/// @brief No damage: the elastic model alone.
struct NoDamage
{
};

/// @brief Rankine damage with linear strain softening (H&H eq. 23; Cervera &
/// Chiumenti): D = (1 + H_s)(1 - sigma_f / r), with the brittleness
/// H_s = Hbar l_ch / (1 - Hbar l_ch), Hbar = sigma_f^2 / (2 E G_f).
///
/// Irreversible as Cervera's model: r is the largest trial principal stress
/// seen so far (r^0 = sigma_f). Since D grows with r, keeping the largest D so
/// far is the same and needs no column for r: D^{n+1} = max(D^n, D(sigma_max))
/// while sigma_max > sigma_f, clipped to 1, which it reaches at the finite
/// trial stress sigma_f (1 + H_s) / H_s. In one dimension the stress then
/// falls linearly, (1 - D) sigma^E = sigma_f (1 + H_s) - H_s sigma^E, and a
/// particle dissipates G_f / l_ch per unit volume.
class RankineSoftening
{
public:
  /// @param E Young's modulus.
  /// @param Gf Fracture energy G_f (> 0).
  /// @param l_ch Characteristic length (> 0), the width of the damaged band.
  RankineSoftening(double E, double Gf, double l_ch) : _a(l_ch / (2.0 * E * Gf)) {}

  /// Hbar l_ch / sigma_f^2 = l_ch / (2 E G_f): softening needs a sigma_f^2 < 1.
  double a() const { return _a; }

  /// @brief H&H eq. 23 with the history of the largest trial stress; since
  /// 1 + H_s = 1 / (1 - a sigma_f^2), D = (1 - sigma_f / sigma_max) / (1 - a sigma_f^2).
  double grow(double D, double sigma_max, double sigma_f, double /*dt*/) const
  {
    if (!(sigma_max > sigma_f))
      return D;
    const double d = (1.0 - sigma_f / sigma_max) / (1.0 - _a * sigma_f * sigma_f);
    return std::max(D, std::min(d, 1.0));
  }

private:
  double _a;
};

/// @brief Time-to-failure damage (H&H eq. 24): D^{n+1} = min(1, D^n + dt / tau)
/// with tau = l / c_f, the time a crack running at c_f takes to cross the
/// length l (the cell diagonal). The paper prints tau = c_f / l, which is not
/// a time; we read it as its text does. D grows only in steps whose largest
/// trial principal stress exceeds sigma_f.
class TimeToFailure
{
public:
  /// @param c_f Crack speed (> 0).
  /// @param length l (> 0).
  TimeToFailure(double c_f, double length) : _rate(c_f / length) {}

  /// 1 / tau.
  double rate() const { return _rate; }

  /// H&H eq. 24.
  double grow(double D, double sigma_max, double sigma_f, double dt) const
  {
    return sigma_max > sigma_f ? std::min(1.0, D + dt * _rate) : D;
  }

private:
  double _rate;
};

/// @brief H&H eqs. 26-27: sigma = sum_i sigma_i^+ v_i (x) v_i with sigma_i^+ =
/// (1 - D) sigma_i where sigma_i > 0 and sigma_i otherwise, over the principal
/// values of the trial stress (in 2D the out-of-plane one, zz, among them).
///
/// In the plane, sum_i <sigma_i>+ v_i (x) v_i = (p1 + p2)/2 I + q (sigma - m I)
/// with p_i = <sigma_i>+ and the difference quotient q = (p1 - p2) / (sigma_1
/// - sigma_2), which stays bounded as the principal values meet (and the
/// deviator vanishes): equal principal values need no special case. In 3D
/// the principal values and directions come from Eigen's closed-form
/// eigensolver of a symmetric 3 x 3 matrix, and the degraded stress is
/// sigma - D sum_i <sigma_i>+ v_i (x) v_i, which a repeated value does not
/// disturb either (any basis of its eigenspace gives the same sum).
/// @param[in,out] sig Stress (symmetric layout, common/symmetric.h): the trial
///        stress in, the degraded one out.
/// @param D Damage in [0, 1].
template <int Dim>
void degrade_tensile(double* sig, double D)
{
  if constexpr (Dim == 2)
  {
    const Mohr s(sig[0], sig[1], sig[2]);
    const double p1 = std::max(s.max(), 0.0), p2 = std::max(s.min(), 0.0);
    const double q = s.r > 0.0 ? (p1 - p2) / (2.0 * s.r) : 0.0;
    const double iso = 0.5 * (p1 + p2), dev = 0.5 * (sig[0] - sig[1]);
    sig[0] -= D * (iso + q * dev);
    sig[1] -= D * (iso - q * dev);
    sig[2] -= D * q * sig[2];
    sig[3] -= D * std::max(sig[3], 0.0);
  }
  else
  {
    Eigen::Matrix3d S;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        S(i, j) = sig[symmetric_entry(i, j)];
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
    eigen.computeDirect(S);
    Eigen::Matrix3d tensile = Eigen::Matrix3d::Zero();
    for (int k = 0; k < 3; ++k)
      if (eigen.eigenvalues()(k) > 0.0)
        tensile += eigen.eigenvalues()(k) * eigen.eigenvectors().col(k) * eigen.eigenvectors().col(k).transpose();
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j)
        sig[symmetric_entry(i, j)] -= D * tensile(i, j);
  }
}

} // namespace pfmpm
