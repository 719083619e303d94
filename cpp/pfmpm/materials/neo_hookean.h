/// @file neo_hookean.h
/// @brief Compressible neo-Hookean elasticity in plane strain (Homel & Herbold
/// 2017, eq. 22) on the deformation gradient (H&H eq. 8), with an optional scalar
/// damage model (H&H eqs. 23-27).
#pragma once

#include "pfmpm/materials/damage.h"
#include "pfmpm/materials/deformation.h"
#include "pfmpm/materials/material.h"
#include "pfmpm/common/symmetric.h"

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace pfmpm
{

/// @brief Compressible neo-Hookean elasticity, plane strain (F_33 = 1), with
/// the damage model `Damage` (NoDamage, RankineSoftening or TimeToFailure).
///
/// Trial stress (H&H eq. 22): sigma^E = mu/J (B - I) + lambda ln J / J I with
/// B = F F^T, so sigma_zz = lambda ln J / J; stored energy per unit reference
/// volume W = mu/2 (tr C - 3) - mu ln J + lambda/2 (ln J)^2, whose Kirchhoff
/// stress J sigma^E this is.
///
/// State (particle columns): `F` (xx, xy, yx, yy), advanced by H&H eq. 8 (in
/// sub-steps, or by its exponential: DeformationUpdate), and `J` = det F. With damage also
/// `damage` (D: 0 intact, 1 failed), `sigma_f` (the tensile strength, filled
/// with the material's; a Weibull field (H&H eq. 25) is drawn into it at set-up)
/// and `dissipated`, the work dissipated by damage. The current volume is
/// J V_0: G2P multiplies it by det(I + dt L) each step, which for H&H eq. 8 in
/// one step is det F^{n+1} / det F^n; otherwise the model rescales it to
/// keep V / J fixed.
///
/// Damage: after F, the largest trial principal stress (in-plane or zz)
/// grows D (Damage::grow), and the stress is the trial stress with its
/// tensile principal values scaled by 1 - D (H&H eqs. 26-27). The stored energy
/// is W - D W+, with W+ = sum over the tensile principal directions of
/// mu/2 (lambda_i^2 - 1 - ln lambda_i^2), plus lambda/2 (ln J)^2 when J > 1: the
/// part of W that damage releases. A step that raises D by dD dissipates
/// V_0 W+ dD (the energy release rate -dpsi/dD; W+ the mean of its values at
/// the start and the end of the step), summed in `dissipated`. In
/// one dimension (nu = 0) the degraded stress is exactly d(W - D W+)/dF, so
/// the energy balance closes; where a tensile principal stress meets a
/// compressed volume (or the reverse), W+ is not a potential of the
/// degraded tensile stresses and it closes only approximately.
///
/// Registered (neo_hookean.cpp) as "neo_hookean" with the damage model chosen
/// by the word `damage`; the parameters are declared there.
///
/// The phase field (MaterialModel's `degraded`) multiplies the whole stress
/// by g(c) and takes psi+ = the stored energy (no split); scenes do not
/// combine it with this model yet.
///
/// In 3D the same equations hold on the 3 x 3 F (`F` row-major xx, xy, xz,
/// yx, .., zz) and B: sigma = mu/J (B - I) + lambda ln J / J I, W = mu/2
/// (tr C - 3) - mu ln J + lambda/2 (ln J)^2; the principal values are the
/// three eigenvalues of B (of the in-plane B and b_zz = 1 in 2D).
template <class Damage>
class NeoHookean final : public MaterialModel<NeoHookean<Damage>>
{
public:
  /// Whether the model carries damage.
  static constexpr bool damages = !std::is_same_v<Damage, NoDamage>;
  /// In 3D too, with or without damage.
  static constexpr bool solid = true;

  /// @param E Young's modulus (> 0).
  /// @param nu Poisson ratio (-1 < nu < 0.5).
  /// @param density Reference mass density (> 0).
  /// @param update How F follows L (substeps >= 1).
  /// @param damage The damage model.
  /// @param sigma_f Tensile strength (> 0), the fill of the `sigma_f` column;
  ///        unused without damage.
  NeoHookean(double E, double nu, double density, DeformationUpdate update, Damage damage,
             double sigma_f);

  double E() const { return _E; }
  double nu() const { return _nu; }
  double lambda() const { return _lambda; }
  double mu() const { return _mu; }
  double density() const override { return _density; }
  const DeformationUpdate& update() const { return _update; }
  const Damage& damage() const { return _damage; }
  /// P-wave speed of the undeformed material sqrt((lambda + 2 mu) / rho_0).
  double wave_speed() const override { return plane_strain_wave_speed(_E, _nu, _density); }
  /// Rayleigh wave speed of the undeformed material.
  double rayleigh_speed() const override { return isotropic_rayleigh_speed(_E, _nu, _density); }
  std::string model() const override { return "neo_hookean"; }
  std::vector<ColumnSpec> columns(int dim) const override;

  /// @name Per-particle functions of MaterialModel
  /// @{
  struct View
  {
    double* F;
    double* J;
    double* stress;
    double* volume;
    double* damage;      ///< with damage only
    const double* sigma_f;
    double* dissipated;
    std::int32_t* softening; ///< with damage only: 1 where D grew in the last step
  };
  View view(Particles& P) const;
  static constexpr bool constant_wave_speed = false;

  /// H&H eq. 8 (DeformationUpdate), J, and with damage the growth of D (H&H eqs. 23-24).
  template <int Dim>
  void advance(const View& v, std::size_t p, const double* L, double dt) const
  {
    constexpr int FF = Dim * Dim;
    double* F = &v.F[FF * p];
    [[maybe_unused]] double before[FF + 1]; // F and J at the start of the step
    if constexpr (damages)
    {
      std::copy(F, F + FF, before);
      before[FF] = v.J[p];
    }
    _update.template apply<Dim>(F, L, dt);
    const double J = determinant<Dim>(F);
    if (!_volume_as_g2p)
      v.volume[p] *= J / (v.J[p] * volume_ratio<Dim>(L, dt));
    v.J[p] = J;
    if constexpr (damages)
    {
      const Principal s = Principal::template of<Dim>(*this, F, J);
      const double D0 = v.damage[p];
      const double D = _damage.grow(D0, s.max_stress(), v.sigma_f[p], dt);
      v.softening[p] = D > D0 ? 1 : 0;
      if (D > D0)
      {
        // int W+ dD over the step by the trapezoidal rule, W+ at F^n and F^{n+1}.
        const double released = tensile_energy<Dim>(Principal::template of<Dim>(*this, before, before[FF]));
        v.dissipated[p] += v.volume[p] / J * (D - D0) * 0.5 * (released + tensile_energy<Dim>(s));
        v.damage[p] = D;
      }
    }
  }
  /// The stress of the current state: H&H eq. 22, with damage H&H eqs. 26-27.
  template <int Dim>
  void undegraded(const View& v, std::size_t p) const
  {
    double* sig = &v.stress[symmetric_size(Dim) * p];
    trial_stress<Dim>(&v.F[Dim * Dim * p], v.J[p], sig);
    if constexpr (damages)
      if (v.damage[p] > 0.0)
        degrade_tensile<Dim>(sig, v.damage[p]);
  }
  template <int Dim>
  double degraded(const View& v, std::size_t p, double g) const
  {
    constexpr int T = symmetric_size(Dim);
    undegraded<Dim>(v, p);
    for (int k = 0; k < T; ++k)
      v.stress[T * p + k] *= g;
    return energy<Dim>(v, p);
  }
  /// Stored energy per unit current volume, (W - D W+) / J.
  template <int Dim>
  double energy(const View& v, std::size_t p) const
  {
    const double* F = &v.F[Dim * Dim * p];
    const double J = v.J[p];
    double psi = stored_energy<Dim>(F, J);
    if constexpr (damages)
      if (v.damage[p] > 0.0)
        psi -= v.damage[p] * tensile_energy<Dim>(Principal::template of<Dim>(*this, F, J));
    return psi / J;
  }
  template <int Dim>
  void split(const View& v, std::size_t p, double& plus, double& minus) const
  {
    plus = energy<Dim>(v, p);
    minus = 0.0;
  }
  /// @brief P-wave speed in the current state, for the stability check: the
  /// largest longitudinal speed of the tangent of H&H eq. 22, along the larger
  /// principal stretch, is c^2 = (mu b_max + lambda + mu - lambda ln J) /
  /// rho_0, with b_max the largest eigenvalue of B (in 2D the in-plane one,
  /// as the plane carries no wave along z); we take its
  /// bound with -ln J <= max(1/J - 1, 0), equal at J = 1 and within a few
  /// per cent for |ln J| < 0.1, which saves a logarithm per particle and
  /// step. With damage, H&H eqs. 26-27 scale the stress along each tensile
  /// principal direction by 1 - D and keep it along a compressive one, so
  /// the longitudinal stiffness along each principal direction i is (1 - D)
  /// (mu b_i + ...) where sigma_i > 0 and mu b_i + ... where not; the speed is
  /// that of the stiffer. (A failed particle drawn out between two fragments,
  /// b_1 ~ 1e9 with sigma_1 > 0 > sigma_2, has no stiffness along its
  /// stretch: the speed is the compressive direction's, not mu b_1's.)
  template <int Dim>
  double state_wave_speed(const View& v, std::size_t p) const
  {
    const double* F = &v.F[Dim * Dim * p];
    const double J = v.J[p];
    const double compression = _lambda * std::max(1.0 / J - 1.0, 0.0);
    if constexpr (damages)
      if (v.damage[p] > 0.0)
      {
        // Along each principal direction (the in-plane ones in 2D).
        const Principal s = Principal::template of<Dim>(*this, F, J);
        const double kept = 1.0 - v.damage[p];
        double c = 0.0;
        for (int i = 0; i < Dim; ++i)
          c = std::max(c, (_mu * s.b[i] + _lambda + _mu + compression) * (s.sigma[i] > 0.0 ? kept : 1.0));
        return std::sqrt(c / _density);
      }
    if constexpr (Dim == 3)
    {
      double b[3];
      squared_stretches<3>(F, b);
      return std::sqrt((_mu * b[0] + _lambda + _mu + compression) / _density);
    }
    const Mohr b(F[0] * F[0] + F[1] * F[1], F[2] * F[2] + F[3] * F[3], F[0] * F[2] + F[1] * F[3]);
    return std::sqrt((_mu * b.max() + _lambda + _mu + compression) / _density);
  }
  /// @}

  /// @brief B = F F^T of a Dim x Dim F.
  template <int Dim>
  static void left_cauchy_green(const double* F, double (&B)[Dim][Dim])
  {
    for (int i = 0; i < Dim; ++i)
      for (int j = 0; j < Dim; ++j)
      {
        double b = F[Dim * i] * F[Dim * j];
        for (int k = 1; k < Dim; ++k)
          b += F[Dim * i + k] * F[Dim * j + k];
        B[i][j] = b;
      }
  }

  /// @brief The trial stress of H&H eq. 22.
  /// @param F Deformation gradient, row-major Dim x Dim.
  /// @param J det F.
  /// @param[out] sig Cauchy stress (xx, yy, xy, zz[, yz, xz]; plane strain in 2D).
  template <int Dim>
  void trial_stress(const double* F, double J, double* sig) const
  {
    const double iJ = 1.0 / J, lnJ = std::log(J);
    double B[Dim][Dim];
    left_cauchy_green<Dim>(F, B);
    const double vol = _lambda * lnJ;
    for (int i = 0; i < Dim; ++i)
      for (int j = i; j < Dim; ++j)
        sig[symmetric_entry(i, j)] = i == j ? (_mu * (B[i][i] - 1.0) + vol) * iJ : _mu * B[i][j] * iJ;
    if constexpr (Dim == 2)
      sig[3] = vol * iJ; // F_33 = 1: B_zz - 1 = 0
  }

  /// @brief W = mu/2 (tr C - 3) - mu ln J + lambda/2 (ln J)^2 per unit
  /// reference volume (tr C = |F|^2, + 1 in plane strain).
  template <int Dim>
  double stored_energy(const double* F, double J) const
  {
    const double lnJ = std::log(J);
    double FF = F[0] * F[0];
    for (int k = 1; k < Dim * Dim; ++k)
      FF += F[k] * F[k];
    return 0.5 * _mu * (FF - (Dim == 2 ? 2.0 : 3.0)) - _mu * lnJ + 0.5 * _lambda * lnJ * lnJ;
  }

private:
  /// @brief The principal values of a state: the eigenvalues b_1 >= b_2 >=
  /// b_3 of B (the squared principal stretches; in 2D the in-plane two and
  /// b_zz = 1), ln J, and the trial principal stresses sigma_i = (mu (b_i -
  /// 1) + lambda ln J) / J (in 2D sigma_zz = lambda ln J / J).
  struct Principal
  {
    double b[3], sigma[3], lnJ;
    template <int Dim>
    static Principal of(const NeoHookean& m, const double* F, double J)
    {
      Principal s;
      squared_stretches<Dim>(F, s.b);
      s.lnJ = std::log(J);
      const double iJ = 1.0 / J, vol = m._lambda * s.lnJ;
      for (int i = 0; i < Dim; ++i)
        s.sigma[i] = (m._mu * (s.b[i] - 1.0) + vol) * iJ;
      if constexpr (Dim == 2)
        s.sigma[2] = vol * iJ;
      return s;
    }
    /// The largest trial principal stress (in 2D the zz one included).
    double max_stress() const { return std::max(std::max(sigma[0], sigma[1]), sigma[2]); }
  };

  /// @brief The eigenvalues b_1 >= b_2 >= b_3 of B = F F^T (in 2D the
  /// in-plane two, by the Mohr circle, and b_zz = 1; in 3D by Eigen's
  /// closed-form symmetric eigensolver).
  template <int Dim>
  static void squared_stretches(const double* F, double (&b)[3])
  {
    if constexpr (Dim == 2)
    {
      const Mohr m(F[0] * F[0] + F[1] * F[1], F[2] * F[2] + F[3] * F[3], F[0] * F[2] + F[1] * F[3]);
      b[0] = m.max();
      b[1] = m.min();
      b[2] = 1.0;
    }
    else
    {
      double B[3][3];
      left_cauchy_green<3>(F, B);
      Eigen::Matrix3d matrix;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          matrix(i, j) = B[i][j];
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
      eigen.computeDirect(matrix, Eigen::EigenvaluesOnly); // ascending
      for (int i = 0; i < 3; ++i)
        b[i] = eigen.eigenvalues()(2 - i);
    }
  }

  /// @brief W+ per unit reference volume: the part of W that damage
  /// releases (see the class description); in 2D ln b_2 = 2 ln J - ln b_1,
  /// and b_zz = 1 releases nothing.
  template <int Dim>
  double tensile_energy(const Principal& s) const
  {
    double ln[3];
    ln[0] = std::log(s.b[0]);
    if constexpr (Dim == 2)
      ln[1] = 2.0 * s.lnJ - ln[0];
    else
    {
      ln[1] = std::log(s.b[1]);
      ln[2] = std::log(s.b[2]);
    }
    double w = s.lnJ > 0.0 ? 0.5 * _lambda * s.lnJ * s.lnJ : 0.0;
    for (int i = 0; i < Dim; ++i)
      if (s.sigma[i] > 0.0)
        w += 0.5 * _mu * (s.b[i] - 1.0 - ln[i]);
    return w;
  }

  double _E, _nu, _density;
  DeformationUpdate _update;
  bool _volume_as_g2p;
  Damage _damage;
  double _sigma_f;
  double _lambda, _mu;
};

} // namespace pfmpm
