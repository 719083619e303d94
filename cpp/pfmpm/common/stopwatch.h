/// @file stopwatch.h
/// @brief Wall time of a block, added to a running total.
#pragma once

#include <omp.h>

namespace pfmpm
{

/// @brief Adds the seconds from its construction to its destruction to
/// `total` (omp_get_wtime, about 20 ns a call: cheap enough per stage and step).
struct Stopwatch
{
  double& total;
  double start = omp_get_wtime();
  ~Stopwatch() { total += omp_get_wtime() - start; }
};

} // namespace pfmpm
