/// @file bindings.h
/// @brief The pfmpm._core module's parts, one per folder of the C++ library.
#pragma once

#include "pfmpm/common/parameters.h"

#include <pybind11/pybind11.h>

#include <vector>

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

/// A parameter's declaration as a dict: name, kind (number, integer, word),
/// unit, doc, lower, upper (None where unbounded), lower_open, upper_open,
/// choices, default (None: required, unless optional), optional, set_by.
pybind11::dict parameter_dict(const ParameterSpec& p);
/// Declarations as a list of parameter_dict()s.
pybind11::list parameter_list(const std::vector<ParameterSpec>& specs);
/// A dict of numbers and words (a scene's table) as Parameters, unchecked.
Parameters parameters_of(const pybind11::dict& values);

} // namespace pfmpm::bindings
