/// @file linear_elastic.cpp
/// @brief Linear elasticity: moduli, parameters and its registration.
#include "pfmpm/materials/linear_elastic.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace pfmpm
{

namespace
{
void require(bool ok, const char* name, double value, const char* rule)
{
  if (!ok)
  {
    std::ostringstream msg;
    msg << name << " = " << value << ": " << rule;
    throw std::invalid_argument(msg.str());
  }
}
} // namespace

LinearElastic::LinearElastic(double E, double nu, double density, Plane plane, Split split)
    : _E(E), _nu(nu), _density(density), _plane(plane), _split(split)
{
  require(std::isfinite(E) && E > 0.0, "E", E, "must be > 0");
  require(std::isfinite(nu) && nu > -1.0 && nu < 0.5, "nu", nu, "must lie in (-1, 0.5)");
  require(std::isfinite(density) && density > 0.0, "density", density, "must be > 0");
  _mu = E / (2.0 * (1.0 + nu));
  const double lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
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
Plane plane_of(const std::string& word)
{
  if (word == "strain")
    return Plane::strain;
  if (word == "stress")
    return Plane::stress;
  throw std::invalid_argument("plane = " + word + ": must be strain or stress");
}

Split split_of(const std::string& word)
{
  if (word == "none")
    return Split::none;
  if (word == "spectral")
    return Split::spectral;
  if (word == "volumetric_deviatoric")
    return Split::volumetric_deviatoric;
  throw std::invalid_argument("split = " + word
                              + ": must be none, spectral or volumetric_deviatoric");
}
} // namespace

LinearElastic::LinearElastic(const Parameters& p)
    : LinearElastic(p.number("E"), p.number("nu"), p.number("density"),
                    plane_of(p.word("plane", "strain")), split_of(p.word("split", "spectral")))
{
}

double LinearElastic::wave_speed() const { return std::sqrt((_lambda + 2.0 * _mu) / _density); }

std::vector<ColumnSpec> LinearElastic::columns() const
{
  return {{"strain", 3, DType::f64, {0.0}, "small strain (K&T eq. 78)", "xx,yy,xy", "strain"}};
}

PFMPM_REGISTER_MATERIAL(LinearElastic, "linear_elastic")

} // namespace pfmpm
