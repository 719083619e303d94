/// @file helpers.h
/// @brief Helpers of the C++ tests: materials, model columns and bitwise comparison.
#pragma once

#include "pfmpm/fracture/phasefield.h"
#include "pfmpm/materials/linear_elastic.h"
#include "pfmpm/particles/particles.h"

#include <cstring>
#include <memory>
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
    for (const ColumnSpec& c : PhaseField::columns(/*fourth_order=*/true)) // with phi, which some tests set
      P.add(c);
}

inline bool same_bits(const std::vector<double>& a, const std::vector<double>& b)
{
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

} // namespace pfmpm::test
