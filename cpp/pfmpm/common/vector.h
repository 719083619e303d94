/// @file vector.h
/// @brief Small vectors of Dim entries: the dot product and the length, one
/// summation order for every caller.
#pragma once

#include <cmath>

namespace pfmpm
{

/// a . b, summed from the first entry.
template <int Dim>
double dot(const double* a, const double* b)
{
  double sum = a[0] * b[0];
  for (int d = 1; d < Dim; ++d)
    sum += a[d] * b[d];
  return sum;
}

/// |a|: std::hypot in 2D, the root of a . a in 3D.
template <int Dim>
double length(const double* a)
{
  if constexpr (Dim == 2)
    return std::hypot(a[0], a[1]);
  else
    return std::sqrt(dot<Dim>(a, a));
}

} // namespace pfmpm
