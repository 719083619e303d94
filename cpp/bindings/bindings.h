/// @file bindings.h
/// @brief The pfmpm._core module's parts, one per folder of the C++ library.
#pragma once

#include <pybind11/pybind11.h>

namespace pfmpm::bindings
{

/// B-splines, the grid and its walls.
void bind_grid(pybind11::module_& m);
/// Particles: core arrays and named columns as zero-copy numpy views.
void bind_particles(pybind11::module_& m);
/// Materials: the registry, and linear elasticity's vectorised helpers.
void bind_materials(pybind11::module_& m);
/// The damage-gradient partition's parameters and the kernel damage field.
void bind_fields(pybind11::module_& m);
/// Fracture parameters and the solver.
void bind_solver(pybind11::module_& m);

} // namespace pfmpm::bindings
