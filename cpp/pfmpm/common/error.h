/// @file error.h
/// @brief The error a run stops with.
#pragma once

#include <stdexcept>

namespace pfmpm
{

/// @brief A run cannot continue: a particle left the grid, a value became
/// NaN or infinite, or the time step became unstable. The message names the
/// quantity, particle, step and time.
class SimulationError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

} // namespace pfmpm
