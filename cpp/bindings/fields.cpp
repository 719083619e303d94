/// @file fields.cpp
/// @brief The damage-gradient partition's parameters and the kernel damage
/// field (H&H eqs. 17-19) in Python.
#include "bindings.h"

#include "pfmpm/fields/damage_fields.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <limits>
#include <vector>

namespace py = pybind11;
using namespace pfmpm;

namespace pfmpm::bindings
{

void bind_fields(py::module_& m)
{
  m.attr("max_pair_fields") = max_pair_fields;
  m.attr("max_field_pairs") = max_field_pairs;
  m.def("field_pair", &field_pair, py::arg("a"), py::arg("b"),
        "the index of the pair of fields a < b in Energies' pair_impulse");
  m.def(
      "damage_gradient_parameters",
      []() { return parameter_list(DamageGradientOptions::parameters()); },
      "the declared parameters of the damage-gradient partition (dicts as material_models' "
      "parameters)");
  py::class_<DamageGradientOptions>(
      m, "DamageGradient",
      "Parameters of the damage-field-gradient partition (Homel & Herbold 2017)")
      .def(py::init(
               [](std::vector<std::int32_t> groups, const py::dict& parameters)
               { return DamageGradientOptions::from(std::move(groups), parameters_of(parameters)); }),
           py::arg("groups") = std::vector<std::int32_t>{}, py::arg("parameters") = py::dict(),
           "groups: contact group of each body (empty: each body its own); parameters: the "
           "declared ones (damage_gradient_parameters()), absent ones at their defaults; a bad "
           "or unknown key raises ValueError naming it")
      .def_readonly("groups", &DamageGradientOptions::groups)
      .def_readonly("separability", &DamageGradientOptions::separability)
      .def_readonly("kernel_radius", &DamageGradientOptions::kernel_radius)
      .def_readonly("skin", &DamageGradientOptions::skin)
      .def_readonly("full_damage", &DamageGradientOptions::full_damage)
      .def_readonly("phase_field_threshold", &DamageGradientOptions::phase_field_threshold)
      .def_readonly("part_when_softened", &DamageGradientOptions::part_when_softened);

  // The kernel field on a grid of either dimension: x is (N, Dim).
  auto kernel = [](const auto& grid, py::array_t<double, py::array::c_style | py::array::forcecast> x,
                   py::array_t<double, py::array::c_style | py::array::forcecast> damage,
                   double radius)
  {
    constexpr int Dim = std::decay_t<decltype(grid)>::dim;
    if (x.ndim() != 2 || x.shape(1) != Dim)
      throw py::value_error("x must have shape (N, " + std::to_string(Dim) + ")");
    std::vector<double> xs(x.data(), x.data() + x.size());
    std::vector<double> ds(damage.data(), damage.data() + damage.size());
    KernelField f = kernel_damage_field(grid, xs, ds, radius);
    const auto n = static_cast<py::ssize_t>(f.S.size());
    py::array_t<double> S(n), D(n), grad({n, py::ssize_t(Dim)});
    std::copy(f.S.begin(), f.S.end(), S.mutable_data());
    std::copy(f.D.begin(), f.D.end(), D.mutable_data());
    std::copy(f.grad.begin(), f.grad.end(), grad.mutable_data());
    return py::make_tuple(S, D, grad);
  };
  const char* kernel_doc =
      "(S, D-bar, grad D-bar) at every particle: the kernel sum (H&H eq. 19), the normalised "
      "kernel damage field (H&H eqs. 17-19) and its gradient, neighbours within radius";
  m.def(
      "kernel_damage_field",
      [=](const Grid<2>& grid, py::array_t<double, py::array::c_style | py::array::forcecast> x,
          py::array_t<double, py::array::c_style | py::array::forcecast> damage, double radius)
      { return kernel(grid, x, damage, radius); },
      py::arg("grid"), py::arg("x"), py::arg("damage"), py::arg("radius"), kernel_doc);
  m.def(
      "kernel_damage_field",
      [=](const Grid<3>& grid, py::array_t<double, py::array::c_style | py::array::forcecast> x,
          py::array_t<double, py::array::c_style | py::array::forcecast> damage, double radius)
      { return kernel(grid, x, damage, radius); },
      py::arg("grid"), py::arg("x"), py::arg("damage"), py::arg("radius"), kernel_doc);
  m.def("lattice_kernel_sum", &lattice_kernel_sum, py::arg("dim"), py::arg("spacing"),
        py::arg("radius"),
        "kernel sum (H&H eq. 19) at the interior of a square (dim 2) or cubic (dim 3) lattice");
}

} // namespace pfmpm::bindings
