/// @file linear_elastic.cpp
/// @brief Linear elasticity: moduli, parameters and its registration.
#include "pfmpm/materials/linear_elastic.h"

#include <Eigen/Dense>

#include <algorithm>
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

namespace
{
/// The unit direction n of the principal value `l` of the symmetric `a`:
/// the largest cross product of two rows of a - l I, which n is orthogonal
/// to. Its error, round-off over the gap between l and the other principal
/// values, multiplies l in l n n: where the gap is small, so is l's share,
/// for a lone principal value of its sign. Zero where a - l I vanishes
/// (three equal principal values, l's share then being l I / 3 ~ 0 here).
void principal_direction(const Eigen::Matrix3d& a, double l, double (&n)[3])
{
  const Eigen::Matrix3d m = a - l * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d c[3] = {m.row(0).cross(m.row(1)), m.row(0).cross(m.row(2)),
                                m.row(1).cross(m.row(2))};
  int best = 0;
  for (int k = 1; k < 3; ++k)
    if (c[k].squaredNorm() > c[best].squaredNorm())
      best = k;
  const double norm = c[best].norm();
  for (int i = 0; i < 3; ++i)
    n[i] = norm > 0.0 ? c[best][i] / norm : 0.0;
}
} // namespace

void LinearElastic::degraded3(const double* eps, double g, double* sig, double& psi_plus,
                              double& psi_minus) const
{
  const double tr = eps[0] + eps[1] + eps[3];
  const double trp = std::max(tr, 0.0), trn = tr - trp;
  if (_split == Split::spectral)
  {
    // K&T eq. 14 on the principal strains l_i with directions n_i (Miehe et
    // al. 2010): sigma = lambda (g <tr>+ + <tr>-) I + 2 mu (g eps+ + eps-),
    // eps+ = sum_i <l_i>+ n_i n_i and eps- = eps - eps+.
    Eigen::Matrix3d strain;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        strain(i, j) = eps[symmetric_entry(i, j)];
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
    eigen.computeDirect(strain, Eigen::EigenvaluesOnly); // ascending
    const Eigen::Vector3d& l = eigen.eigenvalues();
    double plus = 0.5 * _lambda3 * trp * trp, minus = 0.5 * _lambda3 * trn * trn;
    for (int k = 0; k < 3; ++k)
    {
      const double lp = std::max(l[k], 0.0), ln = l[k] - lp;
      plus += _mu * lp * lp;
      minus += _mu * ln * ln;
    }
    psi_plus = plus;
    psi_minus = minus;
    // eps+ needs one direction at most: the lone positive principal strain's
    // (eps+ = l n n) or the lone negative one's (eps+ = eps - l n n).
    const int positive = (l[0] > 0.0) + (l[1] > 0.0) + (l[2] > 0.0);
    double eps_plus[6] = {};
    if (positive == 3)
      std::copy_n(eps, 6, eps_plus);
    else if (positive == 1 || positive == 2)
    {
      const double lone = positive == 1 ? l[2] : l[0];
      double n[3];
      principal_direction(strain, lone, n);
      for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j)
        {
          const int e = symmetric_entry(i, j);
          eps_plus[e] = positive == 1 ? lone * n[i] * n[j] : eps[e] - lone * n[i] * n[j];
        }
    }
    const double vol = _lambda3 * (g * trp + trn);
    for (int e = 0; e < 6; ++e)
      sig[e] = 2.0 * _mu * (g * eps_plus[e] + (eps[e] - eps_plus[e]));
    sig[0] += vol;
    sig[1] += vol;
    sig[3] += vol;
    return;
  }
  if (_split == Split::volumetric_deviatoric)
  {
    // Amor et al. 2009: the bulk part of a compression stays whole.
    const double mean = tr / 3.0;
    double dd = 0.0;
    for (int k = 0; k < 6; ++k)
    {
      const double e = k == 0 || k == 1 || k == 3 ? eps[k] - mean : eps[k];
      dd += (k == 0 || k == 1 || k == 3 ? 1.0 : 2.0) * e * e;
      sig[k] = 2.0 * _mu * g * e;
    }
    psi_plus = 0.5 * _bulk * trp * trp + _mu * dd;
    psi_minus = 0.5 * _bulk * trn * trn;
    const double vol = _bulk * (g * trp + trn);
    sig[0] += vol;
    sig[1] += vol;
    sig[3] += vol;
    return;
  }
  // No split: the whole energy degrades.
  psi_plus = 0.5 * _lambda3 * tr * tr;
  for (int k = 0; k < 6; ++k)
  {
    const bool diagonal = k == 0 || k == 1 || k == 3;
    psi_plus += _mu * (diagonal ? 1.0 : 2.0) * eps[k] * eps[k];
    sig[k] = g * (2.0 * _mu * eps[k] + (diagonal ? _lambda3 * tr : 0.0));
  }
  psi_minus = 0.0;
}

} // namespace pfmpm
