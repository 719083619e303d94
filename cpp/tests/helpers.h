/// @file helpers.h
/// @brief Helpers of the C++ tests: materials, model columns, lattices of
/// particles and bitwise comparison.
#pragma once

#include "pfmpm/fracture/phasefield.h"
#include "pfmpm/materials/linear_elastic.h"
#include "pfmpm/particles/particles.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace pfmpm::test
{

/// `count` linear elastic materials in plane strain (spectral split).
inline std::vector<std::shared_ptr<const Material>> elastic(double E, double nu, double density,
                                                            int count = 1)
{
  std::vector<std::shared_ptr<const Material>> out;
  for (int i = 0; i < count; ++i)
    out.push_back(std::make_shared<LinearElastic>(E, nu, density, Plane::strain));
  return out;
}

/// Add the linear elastic strain and, with `phase_field`, the phase field's
/// columns, so that a test can set their initial values before the solver
/// (which adds them too) is built.
inline void add_model_columns(Particles& P, bool phase_field)
{
  for (const ColumnSpec& c : LinearElastic(1.0, 0.0, 1.0, Plane::strain).columns(2))
    P.add(c);
  if (phase_field)
    for (const ColumnSpec& c : PhaseFieldDeclarations::columns(/*fourth_order=*/true)) // with phi, which some tests set
      P.add(c);
}

/// Particles on the lattice of spacing `d` whose cells' centres lie in the
/// box [lo, hi] and in `inside` (true everywhere if null), density 1,
/// in lexicographic order (the last direction fastest).
template <int Dim>
Particles lattice(const std::array<double, Dim>& lo, const std::array<double, Dim>& hi, double d,
                  const std::function<bool(const double*)>& inside = nullptr)
{
  std::array<int, Dim> n;
  for (int k = 0; k < Dim; ++k)
    n[k] = static_cast<int>(std::lround((hi[k] - lo[k]) / d));
  std::vector<double> points;
  std::array<int, Dim> i{};
  for (;;)
  {
    double x[Dim];
    for (int k = 0; k < Dim; ++k)
      x[k] = lo[k] + (i[k] + 0.5) * d;
    if (!inside || inside(x))
      points.insert(points.end(), x, x + Dim);
    int k = Dim - 1;
    for (; k >= 0 && ++i[k] == n[k]; --k)
      i[k] = 0;
    if (k < 0)
      break;
  }
  Particles P(points.size() / Dim, Dim);
  P.x = points;
  const double volume = std::pow(d, Dim);
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    P.volume[p] = volume;
    P.mass[p] = volume;
  }
  return P;
}

/// CPDI: every particle's domain the lattice's cube of side `spacing` (half-edges spacing / 2
/// along the axes), convected and integration domain alike. The solver adds the columns.
template <int Dim>
void lattice_domains(Particles& P, double spacing)
{
  for (int k = 0; k < Dim; ++k)
    for (const std::string name : {"convected_r", "domain_r"})
    {
      std::vector<double>& r = P.f64(name + std::to_string(k + 1));
      for (std::size_t p = 0; p < P.size(); ++p)
        for (int d = 0; d < Dim; ++d)
          r[Dim * p + d] = d == k ? 0.5 * spacing : 0.0;
    }
}

/// @brief The largest relative gap between a plane run's energies `a` and
/// its slab's `b` per unit thickness t: the kinetic and elastic energy and
/// the friction work over `energy`, the momentum along x and y over
/// `momentum`, the mass over itself.
inline double slab_gap(const Energies<2>& a, const Energies<3>& b, double t, double energy,
                       double momentum)
{
  auto gap = [](double x, double y, double scale) { return std::abs(x - y) / scale; };
  double worst = 0.0;
  for (double g : {gap(a.kinetic, b.kinetic / t, energy), gap(a.elastic, b.elastic / t, energy),
                   gap(a.friction_work, b.friction_work / t, energy),
                   gap(a.momentum[0], b.momentum[0] / t, momentum),
                   gap(a.momentum[1], b.momentum[1] / t, momentum), gap(a.mass, b.mass / t, a.mass)})
    worst = std::max(worst, g);
  return worst;
}

/// @brief Step a plane run and its slab of thickness t side by side for
/// `steps` steps: each step the slab's energies per unit thickness must be
/// the plane's to 1e-10 (slab_gap, and the angular momentum about z over
/// `angular`), its z momentum zero to 1e-12 of `momentum` t and its in-plane
/// angular momentum that of its mid-plane z = t/2 to 1e-12 of `angular` t.
/// Returns the largest gap; stops at the first step beyond 1e-10.
inline double step_alongside(Solver<2>& plane, Solver<3>& slab, double t, int steps, double energy,
                             double momentum, double angular)
{
  double worst = 0.0;
  for (int step = 0; step < steps; ++step)
  {
    plane.advance(1);
    slab.advance(1);
    const Energies<2> a = plane.energies();
    const Energies<3> b = slab.energies();
    worst = std::max({worst, slab_gap(a, b, t, energy, momentum),
                      std::abs(a.angular_momentum - b.angular_momentum[2] / t) / angular});
    if (!(worst < 1e-10))
    {
      ADD_FAILURE() << "the slab left the plane run at step " << step + 1 << ": gap " << worst;
      return worst;
    }
    EXPECT_LT(std::abs(b.momentum[2]), 1e-12 * momentum * t) << "step " << step + 1;
    EXPECT_LT(std::abs(b.angular_momentum[0] + 0.5 * t * b.momentum[1])
                  + std::abs(b.angular_momentum[1] - 0.5 * t * b.momentum[0]),
              1e-12 * angular * t)
        << "step " << step + 1;
  }
  return worst;
}

inline bool same_bits(const std::vector<double>& a, const std::vector<double>& b)
{
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

} // namespace pfmpm::test
