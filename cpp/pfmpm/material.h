/// @file material.h
/// @brief Constitutive models.
#pragma once

#include <string>

namespace pfmpm
{

/// 2D kinematic assumption.
enum class Plane : int
{
  strain = 0,
  stress = 1
};

/// @brief Isotropic linear elasticity in plane strain or plane stress.
///
/// sigma = lambda* tr(eps) I + 2 mu eps (eq. 16 with g(c) = 1), with
/// lambda* = lambda in plane strain and 2 mu lambda / (lambda + 2 mu) in
/// plane stress.
class LinearElastic
{
public:
  /// @param E Young's modulus (> 0).
  /// @param nu Poisson ratio (-1 < nu < 0.5).
  /// @param density Mass density (> 0).
  /// @param plane Plane strain or plane stress.
  LinearElastic(double E, double nu, double density, Plane plane);

  double E() const { return _E; }
  double nu() const { return _nu; }
  double density() const { return _density; }
  Plane plane() const { return _plane; }
  double lambda() const { return _lambda; } ///< in-plane lambda*
  double mu() const { return _mu; }

  /// Dilatational (P) wave speed sqrt((lambda* + 2 mu) / rho).
  double wave_speed() const;

  /// @brief Stress from strain.
  /// @param eps Strain (xx, yy, xy).
  /// @param[out] sig Stress (xx, yy, xy, zz).
  void stress(const double* eps, double* sig) const
  {
    const double tr = eps[0] + eps[1];
    sig[0] = _lambda * tr + 2.0 * _mu * eps[0];
    sig[1] = _lambda * tr + 2.0 * _mu * eps[1];
    sig[2] = 2.0 * _mu * eps[2];
    sig[3] = _zz * tr;
  }

  /// @brief Strain energy density psi = sigma : eps / 2.
  double energy_density(const double* eps) const
  {
    const double tr = eps[0] + eps[1];
    return 0.5 * _lambda * tr * tr
           + _mu * (eps[0] * eps[0] + eps[1] * eps[1] + 2.0 * eps[2] * eps[2]);
  }

private:
  double _E, _nu, _density;
  Plane _plane;
  double _lambda, _mu, _zz; // _zz: sigma_zz per unit in-plane trace
};

} // namespace pfmpm
