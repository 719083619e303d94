/// @file drucker_prager.cpp
/// @brief Small-strain Drucker-Prager plasticity in plane strain, perfectly
/// plastic, with a non-associated flow rule: a pressure-dependent frictional
/// material (soil, rock, a ceramic's comminuted zone) for impact problems.
///
/// The whole model is this file and its CMake line: it declares its
/// parameters and its columns, and the registry, the scene reader and the
/// energy balance take everything else from those declarations.
#include "pfmpm/materials/material.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace pfmpm
{

namespace
{
constexpr double pi = 3.14159265358979323846;

/// 3 x / sqrt(9 + 12 tan^2(phi)) for the angle phi in degrees: with x =
/// tan(phi) the slope of the plane-strain fit of the cone to Mohr-Coulomb,
/// with x = c its shear strength.
double cone(double x, double degrees)
{
  const double t = std::tan(degrees * pi / 180.0);
  return 3.0 * x / std::sqrt(9.0 + 12.0 * t * t);
}

double slope(double degrees) { return cone(std::tan(degrees * pi / 180.0), degrees); }
} // namespace

/// @brief Drucker-Prager plasticity, plane strain, small strain.
///
/// Yield function f = sqrt(J2) + alpha p - k <= 0 with p = tr(sigma)/3
/// (tension positive) and J2 the second invariant of the deviatoric stress;
/// plastic potential g = sqrt(J2) + beta p. alpha, k (from the cohesion c and
/// friction angle phi) and beta (from the dilation angle psi) match
/// Mohr-Coulomb in plane strain: alpha = 3 tan phi / sqrt(9 + 12 tan^2 phi),
/// k = 3 c / sqrt(9 + 12 tan^2 phi), beta likewise with psi (psi = phi:
/// associated flow; psi = 0: no plastic volume change).
///
/// Stress update (backward Euler, the closed-form return of a perfectly
/// plastic cone, as in de Souza Neto, Peric & Owen 2008, chapter 8): the trial stress sigma* = C : (eps - eps_p) with the strain
/// advanced by K&T eq. 78; if f(sigma*) > 0, dgamma = f(sigma*) / (G + K alpha
/// beta) and s = s* (1 - G dgamma / sqrt(J2*)), p = p* - K beta dgamma,
/// which puts sigma on the cone (f = 0); where that would reverse s, the
/// return is to the apex p = k / alpha, s = 0. The plastic strain takes the
/// difference. The plastic work per step, V (sigma_n + sigma_{n+1}) : deps_p
/// / 2, is summed in `plastic_work`: with the stored energy
/// psi = (eps - eps_p) : C : (eps - eps_p) / 2, the work (sigma_n +
/// sigma_{n+1}) : deps / 2 of a step is dpsi plus it exactly.
class DruckerPrager final : public MaterialModel<DruckerPrager>
{
public:
  static constexpr bool phase_field = false;
  static constexpr const char* description =
      "Drucker-Prager plasticity in plane strain, small strain, perfectly plastic, matched to "
      "Mohr-Coulomb, with a non-associated flow rule (dilation angle <= friction angle).";

  static std::vector<ParameterSpec> parameters()
  {
    using P = ParameterSpec;
    return {P::number("E", "stress", "Young's modulus").above(0.0),
            P::number("nu", "1", "Poisson's ratio").above(-1.0).below(0.5),
            P::number("density", "density", "mass density").above(0.0),
            P::number("cohesion", "stress", "cohesion c of the matched Mohr-Coulomb surface")
                .above(0.0),
            P::number("friction_angle", "angle", "friction angle phi, degrees")
                .at_least(0.0)
                .below(90.0)
                .fallback(0.0),
            P::number("dilation_angle", "angle",
                      "dilation angle psi, degrees, at most the friction angle (psi = phi: "
                      "associated flow)")
                .at_least(0.0)
                .below(90.0)
                .fallback(0.0),
            P::word("plane", {"strain"}, "the 2D kinematic assumption: plane strain only")
                .fallback("strain")
                .from("plane")};
  }

  explicit DruckerPrager(const Parameters& p)
      : _E(p.number("E")), _nu(p.number("nu")), _density(p.number("density")),
        _alpha(slope(p.number("friction_angle"))), _beta(slope(p.number("dilation_angle"))),
        _k(cone(p.number("cohesion"), p.number("friction_angle")))
  {
    if (p.number("dilation_angle") > p.number("friction_angle"))
      throw std::invalid_argument(refusal("dilation_angle", p.number("dilation_angle"),
                                          "must be <= friction_angle = "
                                              + std::to_string(p.number("friction_angle"))));
    _mu = _E / (2.0 * (1.0 + _nu));
    _lambda = _E * _nu / ((1.0 + _nu) * (1.0 - 2.0 * _nu));
    _bulk = _lambda + 2.0 * _mu / 3.0;
  }

  std::string model() const override { return "drucker_prager"; }
  double density() const override { return _density; }
  double wave_speed() const override { return plane_strain_wave_speed(_E, _nu, _density); }
  double rayleigh_speed() const override { return isotropic_rayleigh_speed(_E, _nu, _density); }
  std::vector<ColumnSpec> columns(int dim) const override
  {
    if (dim != 2)
      throw std::invalid_argument("drucker_prager is two-dimensional (plane strain)");
    return {{"strain", 3, DType::f64, {0.0}, "small strain (K&T eq. 78)", "xx,yy,xy", "strain"},
            {"plastic_strain", 4, DType::f64, {0.0}, "plastic strain eps_p", "xx,yy,xy,zz",
             "plastic_strain"},
            {"plastic_work", 1, DType::f64, {0.0},
             "plastic work, the sum of V (sigma_n + sigma_{n+1}) : deps_p / 2 over the steps", "",
             "", "plastic"}};
  }

  /// @name Per-particle functions of MaterialModel
  /// @{
  struct View
  {
    double* strain;
    double* plastic;
    double* work;
    double* stress;
    const double* volume;
  };
  View view(Particles& P) const
  {
    return {P.f64("strain").data(), P.f64("plastic_strain").data(), P.f64("plastic_work").data(),
            P.stress.data(), P.volume.data()};
  }
  static constexpr bool constant_wave_speed = true;
  /// Plane strain alone.
  static constexpr bool solid = false;

  /// K&T eq. 78, then the return to the cone (class description).
  template <int Dim>
  void advance(const View& v, std::size_t p, const double* L, double dt) const
  {
    static_assert(Dim == 2, "plane strain");
    double* eps = &v.strain[3 * p];
    double* ep = &v.plastic[4 * p];
    double before[4];
    elastic(eps, ep, before);
    eps[0] += dt * L[0];
    eps[1] += dt * L[3];
    eps[2] += 0.5 * dt * (L[1] + L[2]);
    double sig[4];
    elastic(eps, ep, sig);
    const double mean = (sig[0] + sig[1] + sig[3]) / 3.0;
    double s[4] = {sig[0] - mean, sig[1] - mean, sig[2], sig[3] - mean};
    const double q = std::sqrt(0.5 * (s[0] * s[0] + s[1] * s[1] + s[3] * s[3]) + s[2] * s[2]);
    const double f = q + _alpha * mean - _k;
    if (f <= 0.0)
      return;
    double dgamma = f / (_mu + _bulk * _alpha * _beta);
    double scale = 1.0 - _mu * dgamma / q, mean_new = mean - _bulk * _beta * dgamma;
    if (scale < 0.0) // past the apex: all of s and the rest of the mean stress is plastic
    {
      scale = 0.0;
      mean_new = _k / _alpha;
    }
    // The plastic strain is the elastic strain the return takes away.
    const double dvol = (mean - mean_new) / (3.0 * _bulk);
    const double ddev = (1.0 - scale) / (2.0 * _mu);
    const double dep[4] = {ddev * s[0] + dvol, ddev * s[1] + dvol, ddev * s[2], ddev * s[3] + dvol};
    for (int i = 0; i < 4; ++i)
      ep[i] += dep[i];
    const double after[4] = {scale * s[0] + mean_new, scale * s[1] + mean_new, scale * s[2],
                             scale * s[3] + mean_new};
    double work = 0.0;
    for (int i = 0; i < 4; ++i)
      work += (before[i] + after[i]) * dep[i] * (i == 2 ? 2.0 : 1.0); // xy counts twice
    v.work[p] += 0.5 * v.volume[p] * work;
  }
  template <int Dim>
  void undegraded(const View& v, std::size_t p) const
  {
    static_assert(Dim == 2, "plane strain");
    elastic(&v.strain[3 * p], &v.plastic[4 * p], &v.stress[4 * p]);
  }
  template <int Dim>
  double degraded(const View& v, std::size_t p, double g) const
  {
    undegraded<Dim>(v, p);
    for (int i = 0; i < 4; ++i)
      v.stress[4 * p + i] *= g;
    return energy<2>(v, p);
  }
  template <int Dim>
  double energy(const View& v, std::size_t p) const
  {
    static_assert(Dim == 2, "plane strain");
    double sig[4];
    const double* eps = &v.strain[3 * p];
    const double* ep = &v.plastic[4 * p];
    elastic(eps, ep, sig);
    return 0.5 * (sig[0] * (eps[0] - ep[0]) + sig[1] * (eps[1] - ep[1])
                  + 2.0 * sig[2] * (eps[2] - ep[2]) - sig[3] * ep[3]);
  }
  template <int Dim>
  void split(const View& v, std::size_t p, double& plus, double& minus) const
  {
    plus = energy<Dim>(v, p);
    minus = 0.0;
  }
  /// @}

private:
  /// sigma = lambda tr(e) I + 2 mu e of the elastic strain e = eps - eps_p
  /// (eps_zz = 0): (xx, yy, xy, zz).
  void elastic(const double* eps, const double* ep, double* sig) const
  {
    const double exx = eps[0] - ep[0], eyy = eps[1] - ep[1], exy = eps[2] - ep[2], ezz = -ep[3];
    const double tr = exx + eyy + ezz;
    sig[0] = _lambda * tr + 2.0 * _mu * exx;
    sig[1] = _lambda * tr + 2.0 * _mu * eyy;
    sig[2] = 2.0 * _mu * exy;
    sig[3] = _lambda * tr + 2.0 * _mu * ezz;
  }

  double _E, _nu, _density;
  double _alpha, _beta, _k;
  double _mu = 0.0, _lambda = 0.0, _bulk = 0.0;
};

PFMPM_REGISTER_MATERIAL(DruckerPrager, "drucker_prager")

} // namespace pfmpm
