/// @file linear_elastic.h
/// @brief Small-strain isotropic linear elasticity with the energy splits of
/// the phase field (Kakouris & Triantafyllou 2019, eqs. 14-16, 78).
#pragma once

#include "pfmpm/common/symmetric.h"
#include "pfmpm/materials/material.h"

#include <algorithm>
#include <cmath>

namespace pfmpm
{

/// 2D kinematic assumption.
enum class Plane : int
{
  strain = 0,
  stress = 1
};

/// How the strain energy splits into a part that cracking degrades and a part
/// it does not (K&T eq. 14).
enum class Split : int
{
  none = 0,                 ///< psi+ = psi: all energy degrades, also in compression
  spectral = 1,             ///< Miehe et al. 2010: principal strains, K&T eq. 14
  volumetric_deviatoric = 2 ///< Amor et al. 2009: compression of volume is kept
};

/// @brief Isotropic linear elasticity in plane strain or plane stress, with
/// the degraded energy psi = g psi+ + psi- of K&T eq. 14 and its stress (K&T eq. 16).
///
/// Undegraded, sigma = lambda* tr(eps) I + 2 mu eps with lambda* = lambda in
/// plane strain and 2 mu lambda / (lambda + 2 mu) in plane stress. In plane
/// strain the split uses the 3D strain (eps_zz = 0); in plane stress it acts
/// on the in-plane strain with lambda*, the usual 2D treatment.
///
/// Registered as "linear_elastic" with the parameters of parameters(). Its
/// state is the small strain (column `strain`: xx, yy, xy), advanced by K&T eq. 78.
class LinearElastic final : public MaterialModel<LinearElastic>
{
public:
  /// @param E Young's modulus (> 0).
  /// @param nu Poisson ratio (-1 < nu < 0.5).
  /// @param density Mass density (> 0).
  /// @param plane Plane strain or plane stress.
  /// @param split Energy split used when the material can crack.
  LinearElastic(double E, double nu, double density, Plane plane, Split split = Split::spectral);
  /// @brief From checked parameters (parameters()).
  explicit LinearElastic(const Parameters& p);

  static constexpr bool phase_field = true;
  /// In 3D too (undegraded: the phase field is 2D), with lambda and mu;
  /// plane stress is a 2D mode.
  static constexpr bool solid = true;
  static constexpr const char* description =
      "Isotropic linear elasticity, small strain, in plane strain or plane stress, with the "
      "energy splits of the phase field (K&T eqs. 14-16, 78).";
  /// E, nu, density; plane and split, which a scene sets from its plane and
  /// the material's fracture table.
  static std::vector<ParameterSpec> parameters();

  double E() const { return _E; }
  double nu() const { return _nu; }
  double density() const override { return _density; }
  Plane plane() const { return _plane; }
  Split split() const { return _split; }
  double lambda() const { return _lambda; } ///< in-plane lambda*
  double mu() const { return _mu; }

  /// Dilatational (P) wave speed sqrt((lambda* + 2 mu) / rho).
  double wave_speed() const override;
  double rayleigh_speed() const override { return isotropic_rayleigh_speed(_E, _nu, _density); }

  std::string model() const override { return "linear_elastic"; }
  std::vector<ColumnSpec> columns(int dim) const override;

  /// @name Per-particle functions of MaterialModel
  /// @{
  struct View
  {
    double* strain;
    double* stress;
  };
  View view(Particles& P) const { return {P.f64("strain").data(), P.stress.data()}; }
  static constexpr bool constant_wave_speed = true;
  /// Strain increment, K&T eq. 78: eps += dt sym(L) (in 2D xx, yy, xy; in
  /// 3D the symmetric layout of common/symmetric.h).
  template <int Dim>
  void advance(const View& v, std::size_t p, const double* L, double dt) const
  {
    if constexpr (Dim == 2)
    {
      double* eps = &v.strain[3 * p];
      eps[0] += dt * L[0];
      eps[1] += dt * L[3];
      eps[2] += 0.5 * dt * (L[1] + L[2]);
    }
    else
    {
      double* eps = &v.strain[6 * p];
#pragma GCC unroll 3
      for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
        for (int j = i; j < 3; ++j)
          eps[symmetric_entry(i, j)] += i == j ? dt * L[4 * i] : 0.5 * dt * (L[3 * i + j] + L[3 * j + i]);
    }
  }
  template <int Dim>
  void undegraded(const View& v, std::size_t p) const
  {
    if constexpr (Dim == 2)
      undegraded(&v.strain[3 * p], &v.stress[4 * p]); // K&T eq. 16, g = 1
    else
    {
      // sigma = lambda tr(eps) I + 2 mu eps
      const double* eps = &v.strain[6 * p];
      double* sig = &v.stress[6 * p];
      const double tr = eps[0] + eps[1] + eps[3];
#pragma GCC unroll 6
      for (int k = 0; k < 6; ++k)
        sig[k] = 2.0 * _mu * eps[k];
#pragma GCC unroll 3
      for (int d = 0; d < 3; ++d)
        sig[symmetric_entry(d, d)] += _lambda3 * tr;
    }
  }
  template <int Dim>
  double degraded(const View& v, std::size_t p, double g) const
  {
    double plus, minus;
    if constexpr (Dim == 2)
      degraded(&v.strain[3 * p], g, &v.stress[4 * p], plus, minus);
    else
      degraded3(&v.strain[6 * p], g, &v.stress[6 * p], plus, minus);
    return plus;
  }
  template <int Dim>
  double energy(const View& v, std::size_t p) const
  {
    if constexpr (Dim == 2)
      return energy_density(&v.strain[3 * p]);
    else
    {
      // psi = lambda/2 tr(eps)^2 + mu eps : eps
      const double* eps = &v.strain[6 * p];
      const double tr = eps[0] + eps[1] + eps[3];
      const double diagonal = eps[0] * eps[0] + eps[1] * eps[1] + eps[3] * eps[3];
      const double shear = eps[2] * eps[2] + eps[4] * eps[4] + eps[5] * eps[5];
      return 0.5 * _lambda3 * tr * tr + _mu * (diagonal + 2.0 * shear);
    }
  }
  template <int Dim>
  void split(const View& v, std::size_t p, double& plus, double& minus) const
  {
    double sig[Dim == 2 ? 4 : 6];
    if constexpr (Dim == 2)
      degraded(&v.strain[3 * p], 1.0, sig, plus, minus);
    else
      degraded3(&v.strain[6 * p], 1.0, sig, plus, minus);
  }
  /// @}

  /// @brief Undegraded stress from strain (K&T eq. 16 with g = 1).
  /// @param eps Strain (xx, yy, xy).
  /// @param[out] sig Stress (xx, yy, xy, zz).
  void undegraded(const double* eps, double* sig) const
  {
    const double tr = eps[0] + eps[1];
    sig[0] = _lambda * tr + 2.0 * _mu * eps[0];
    sig[1] = _lambda * tr + 2.0 * _mu * eps[1];
    sig[2] = 2.0 * _mu * eps[2];
    sig[3] = _zz * tr;
  }

  /// @brief Undegraded strain energy density psi = sigma : eps / 2.
  double energy_density(const double* eps) const
  {
    const double tr = eps[0] + eps[1];
    return 0.5 * _lambda * tr * tr
           + _mu * (eps[0] * eps[0] + eps[1] * eps[1] + 2.0 * eps[2] * eps[2]);
  }

  /// @brief Split energy (K&T eq. 14) and degraded stress
  /// sigma = d(g psi+ + psi-)/d eps (K&T eq. 16).
  /// @param eps Strain (xx, yy, xy).
  /// @param g Degradation g(c) (K&T eq. 15).
  /// @param[out] sig Stress (xx, yy, xy, zz).
  /// @param[out] psi_plus Tensile energy density psi+ (undegraded).
  /// @param[out] psi_minus Compressive energy density psi-.
  void degraded(const double* eps, double g, double* sig, double& psi_plus,
                double& psi_minus) const
  {
    if (_split == Split::spectral)
      spectral(eps, g, sig, psi_plus, psi_minus);
    else if (_split == Split::volumetric_deviatoric)
      volumetric_deviatoric(eps, g, sig, psi_plus, psi_minus);
    else
    {
      undegraded(eps, sig);
      for (int k = 0; k < 4; ++k)
        sig[k] *= g;
      psi_plus = energy_density(eps);
      psi_minus = 0.0;
    }
  }

  /// @brief degraded for a 3D strain and stress, symmetric layout
  /// (common/symmetric.h: xx, yy, xy, zz, yz, xz): the same splits on the
  /// 3 x 3 strain, the spectral one from its eigenvalues and eigenvectors.
  void degraded3(const double* eps, double g, double* sig, double& psi_plus,
                 double& psi_minus) const;

private:
  void spectral(const double* eps, double g, double* sig, double& psi_plus,
                double& psi_minus) const
  {
    // Principal strains l1 >= l2 of the in-plane strain; the out-of-plane
    // principal strain is zero and adds nothing to either part.
    const double m = 0.5 * (eps[0] + eps[1]), d = 0.5 * (eps[0] - eps[1]);
    const double r = std::sqrt(d * d + eps[2] * eps[2]); // strains are small: no overflow
    const double l1 = m + r, l2 = m - r;
    const double tr = eps[0] + eps[1];
    const double trp = std::max(tr, 0.0), trn = tr - trp;
    const double p1 = std::max(l1, 0.0), p2 = std::max(l2, 0.0);
    const double n1 = l1 - p1, n2 = l2 - p2;
    psi_plus = 0.5 * _lambda * trp * trp + _mu * (p1 * p1 + p2 * p2);
    psi_minus = 0.5 * _lambda * trn * trn + _mu * (n1 * n1 + n2 * n2);
    // sum_i f(l_i) n_i (x) n_i = (f(l1) + f(l2))/2 I + q (eps - m I) with the
    // difference quotient q = (f(l1) - f(l2)) / (l1 - l2); for the ramp
    // f = <.>+ it tends to the step H(m) as r -> 0, and q- = 1 - q+.
    const double qp = r > 0.0 ? (p1 - p2) / (2.0 * r) : (m > 0.0 ? 1.0 : 0.0);
    const double qn = 1.0 - qp;
    const double vol = _lambda * (g * trp + trn);
    const double iso = 2.0 * _mu * 0.5 * (g * (p1 + p2) + (n1 + n2));
    const double dev = 2.0 * _mu * (g * qp + qn);
    sig[0] = vol + iso + dev * d;
    sig[1] = vol + iso - dev * d;
    sig[2] = dev * eps[2];
    sig[3] = _zz * (g * trp + trn);
  }

  void volumetric_deviatoric(const double* eps, double g, double* sig, double& psi_plus,
                             double& psi_minus) const
  {
    const double tr = eps[0] + eps[1];
    const double trp = std::max(tr, 0.0), trn = tr - trp;
    // Deviator of the 3D strain (plane strain) or of the in-plane strain.
    const double mean = tr * _mean_fraction;
    const double dxx = eps[0] - mean, dyy = eps[1] - mean;
    const double dzz = _plane == Plane::strain ? -mean : 0.0;
    const double dd = dxx * dxx + dyy * dyy + dzz * dzz + 2.0 * eps[2] * eps[2];
    psi_plus = 0.5 * _bulk * trp * trp + _mu * dd;
    psi_minus = 0.5 * _bulk * trn * trn;
    const double vol = _bulk * (g * trp + trn);
    sig[0] = vol + 2.0 * _mu * g * dxx;
    sig[1] = vol + 2.0 * _mu * g * dyy;
    sig[2] = 2.0 * _mu * g * eps[2];
    sig[3] = _plane == Plane::strain ? vol + 2.0 * _mu * g * dzz : 0.0;
  }

  double _E, _nu, _density;
  Plane _plane;
  Split _split;
  double _lambda, _mu, _zz; // _zz: sigma_zz per unit in-plane trace
  double _lambda3;          // the 3D lambda, E nu / ((1 + nu)(1 - 2 nu))
  double _bulk;             // bulk modulus: 3D in plane strain, 2D in plane stress
  double _mean_fraction;    // 1/3 (3D trace) or 1/2 (2D trace)
};

} // namespace pfmpm
