/// @file linear_elastic.cpp
/// @brief Linear elasticity: moduli, parameters and its registration.
#include "pfmpm/materials/linear_elastic.h"

#include <cmath>

namespace pfmpm
{

std::vector<ParameterSpec> LinearElastic::parameters()
{
  using P = ParameterSpec;
  return {P::number("E", "stress", "Young's modulus").above(0.0),
          P::number("nu", "1", "Poisson's ratio").above(-1.0).below(0.5),
          P::number("density", "density", "mass density").above(0.0),
          P::word("plane", {"strain", "stress"}, "the 2D kinematic assumption")
              .fallback("strain")
              .from("plane"),
          P::word("split", {"spectral", "volumetric_deviatoric", "none"},
                  "which strain energy cracking degrades (K&T eq. 14)")
              .fallback("spectral")
              .from("fracture.split")};
}

LinearElastic::LinearElastic(double E, double nu, double density, Plane plane, Split split)
    : _E(E), _nu(nu), _density(density), _plane(plane), _split(split)
{
  const auto specs = parameters();
  declared(specs, "E").check(E);
  declared(specs, "nu").check(nu);
  declared(specs, "density").check(density);
  _mu = E / (2.0 * (1.0 + nu));
  const double lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  _lambda3 = lambda;
  if (plane == Plane::strain)
  {
    _lambda = lambda;
    _zz = lambda;
    _bulk = lambda + 2.0 * _mu / 3.0;
    _mean_fraction = 1.0 / 3.0;
  }
  else
  {
    _lambda = 2.0 * _mu * lambda / (lambda + 2.0 * _mu);
    _zz = 0.0;
    _bulk = _lambda + _mu;
    _mean_fraction = 0.5;
  }
}

namespace
{
// The words are checked against parameters() before they get here.
Plane plane_of(const std::string& word) { return word == "stress" ? Plane::stress : Plane::strain; }

Split split_of(const std::string& word)
{
  if (word == "none")
    return Split::none;
  return word == "spectral" ? Split::spectral : Split::volumetric_deviatoric;
}
} // namespace

LinearElastic::LinearElastic(const Parameters& p)
    : LinearElastic(p.number("E"), p.number("nu"), p.number("density"),
                    plane_of(p.word("plane")), split_of(p.word("split")))
{
}

double LinearElastic::wave_speed() const
{
  return _plane == Plane::strain ? plane_strain_wave_speed(_E, _nu, _density)
                                 : plane_stress_wave_speed(_E, _nu, _density);
}

std::vector<ColumnSpec> LinearElastic::columns(int dim) const
{
  if (dim == 3)
  {
    if (_plane == Plane::stress)
      throw std::invalid_argument("linear_elastic: plane stress is a 2D mode, not a 3D one");
    return {{"strain", 6, DType::f64, {0.0}, "small strain (K&T eq. 78)", "xx,yy,xy,zz,yz,xz",
             "strain"}};
  }
  return {{"strain", 3, DType::f64, {0.0}, "small strain (K&T eq. 78)", "xx,yy,xy", "strain"}};
}

PFMPM_REGISTER_MATERIAL(LinearElastic, "linear_elastic")

} // namespace pfmpm
