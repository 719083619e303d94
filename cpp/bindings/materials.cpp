/// @file materials.cpp
/// @brief Materials in Python: the registry by name, and the vectorised
/// stress and energy of linear elasticity (used by the finite-element reference).
#include "bindings.h"

#include "pfmpm/materials/linear_elastic.h"
#include "pfmpm/materials/material.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <map>
#include <string>

namespace py = pybind11;
using namespace pfmpm;

namespace pfmpm::bindings
{

namespace
{
using Strains = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// Number of rows of an (N, 3) (2D: xx, yy, xy) or (N, 6) (3D: xx, yy, xy,
/// zz, yz, xz) strain array; throws on another shape.
py::ssize_t strain_rows(const Strains& strain)
{
  if (strain.ndim() != 2 || (strain.shape(1) != 3 && strain.shape(1) != 6))
    throw py::value_error("strain must have shape (N, 3) or (N, 6)");
  return strain.shape(0);
}

/// LinearElastic::degraded for a 2D (3 entries) or 3D (6 entries) strain.
void degrade(const LinearElastic& e, bool three, const double* eps, double g, double* sig,
             double& plus, double& minus)
{
  if (three)
    e.degraded3(eps, g, sig, plus, minus);
  else
    e.degraded(eps, g, sig, plus, minus);
}
} // namespace

py::dict parameter_dict(const ParameterSpec& p)
{
  const char* kinds[] = {"number", "integer", "word"};
  auto bound = [](double x) { return std::isfinite(x) ? py::object(py::float_(x)) : py::object(py::none()); };
  py::object fallback = py::none();
  if (p.number_default)
    fallback = p.kind == ParameterKind::integer ? py::object(py::int_(static_cast<long>(*p.number_default)))
                                                : py::object(py::float_(*p.number_default));
  else if (p.word_default)
    fallback = py::str(*p.word_default);
  py::dict d;
  d["name"] = p.name;
  d["kind"] = kinds[static_cast<int>(p.kind)];
  d["unit"] = p.unit;
  d["doc"] = p.doc;
  d["lower"] = bound(p.lower);
  d["upper"] = bound(p.upper);
  d["lower_open"] = p.lower_open;
  d["upper_open"] = p.upper_open;
  d["choices"] = p.choices;
  d["default"] = fallback;
  d["optional"] = p.optional;
  d["set_by"] = p.set_by;
  return d;
}

py::list parameter_list(const std::vector<ParameterSpec>& specs)
{
  py::list out;
  for (const ParameterSpec& p : specs)
    out.append(parameter_dict(p));
  return out;
}

Parameters parameters_of(const py::dict& values)
{
  std::map<std::string, double> numbers;
  std::map<std::string, std::string> words;
  for (const auto& [key, value] : values)
  {
    if (py::isinstance<py::str>(value))
      words[key.cast<std::string>()] = value.cast<std::string>();
    else
      numbers[key.cast<std::string>()] = value.cast<double>();
  }
  return Parameters(numbers, words);
}

void bind_materials(py::module_& m)
{
  py::enum_<Plane>(m, "Plane").value("strain", Plane::strain).value("stress", Plane::stress);
  py::enum_<Split>(m, "Split")
      .value("none", Split::none)
      .value("spectral", Split::spectral)
      .value("volumetric_deviatoric", Split::volumetric_deviatoric);

  py::class_<Material, std::shared_ptr<Material>>(m, "Material", "A constitutive model")
      .def_property_readonly("model", &Material::model)
      .def_property_readonly("density", &Material::density)
      .def_property_readonly("wave_speed", py::overload_cast<>(&Material::wave_speed, py::const_),
                             "P-wave speed of the undeformed material")
      .def_property_readonly("rayleigh_speed", &Material::rayleigh_speed,
                             "Rayleigh wave speed of the undeformed material")
      .def_property_readonly("solid", &Material::solid,
                             "whether the model runs in 3D too (else in plane strain or stress alone)")
      .def_property_readonly(
          "dissipation",
          [](const Material& mat)
          {
            py::dict out;
            for (const ColumnSpec& c : mat.columns(2)) // the same names in 2D and 3D
              if (!c.dissipation.empty())
                out[py::str(c.dissipation)] = c.name;
            return out;
          },
          "the kinds of work the model dissipates, each with the column that sums it per particle")
      .def_property_readonly(
          "columns",
          [](const Material& mat)
          {
            py::list out;
            for (const ColumnSpec& c : mat.columns(2)) // the same names in 2D and 3D
              out.append(c.name);
            return out;
          },
          "names of the particle columns the model keeps");

  m.def(
      "material",
      [](const std::string& model, const py::dict& parameters)
      { return MaterialRegistry::make(model, parameters_of(parameters)); },
      py::arg("model"), py::arg("parameters"),
      "build the registered model `model` from a dict of numbers and words; a bad, missing or "
      "unknown key raises ValueError naming it");
  m.def(
      "material_models",
      []()
      {
        py::dict out;
        for (const std::string& name : MaterialRegistry::models())
        {
          const MaterialDeclaration& d = MaterialRegistry::declaration(name);
          out[py::str(name)] = py::dict(py::arg("doc") = d.doc, py::arg("phase_field") = d.phase_field,
                                        py::arg("parameters") = parameter_list(d.parameters));
        }
        return out;
      },
      "the registered material models by name, each with its description (`doc`), whether a "
      "phase field can crack it (`phase_field`) and its declared `parameters`: dicts of name, kind (number, integer, word), unit, doc, "
      "lower, upper, lower_open, upper_open (bounds, None where unbounded), choices, "
      "default (None: required, unless optional), optional and set_by (empty: the "
      "material's table; else the scene entry that sets it)");

  py::class_<LinearElastic, Material, std::shared_ptr<LinearElastic>>(
      m, "LinearElastic", "Isotropic linear elasticity (registered as linear_elastic)")
      .def(py::init<double, double, double, Plane, Split>(), py::arg("E"), py::arg("nu"),
           py::arg("density"), py::arg("plane"), py::arg("split") = Split::spectral)
      .def(
          "split_energies",
          [](const LinearElastic& e, const Strains& strain)
          {
            const py::ssize_t n = strain_rows(strain);
            const bool three = strain.shape(1) == 6;
            py::array_t<double> plus(n), minus(n);
            for (py::ssize_t i = 0; i < n; ++i)
            {
              double sig[6];
              degrade(e, three, strain.data(i, 0), 1.0, sig, plus.mutable_data()[i],
                      minus.mutable_data()[i]);
            }
            return py::make_tuple(plus, minus);
          },
          py::arg("strain"),
          "(psi+, psi-) of K&T eq. 14 for strains (N, 3): xx, yy, xy, or (N, 6): xx, yy, xy, zz, yz, xz")
      .def(
          "stresses",
          [](const LinearElastic& e, const Strains& strain,
             py::array_t<double, py::array::c_style | py::array::forcecast> g)
          {
            const py::ssize_t n = strain_rows(strain);
            const bool three = strain.shape(1) == 6;
            if (g.ndim() != 1 || g.shape(0) != n)
              throw py::value_error("g must have shape (N,) matching strain");
            py::array_t<double> sig({n, py::ssize_t(three ? 6 : 4)});
            for (py::ssize_t i = 0; i < n; ++i)
            {
              double plus, minus;
              degrade(e, three, strain.data(i, 0), g.data()[i], sig.mutable_data(i, 0), plus, minus);
            }
            return sig;
          },
          py::arg("strain"), py::arg("g"),
          "stresses of g psi+ + psi- (K&T eqs. 14, 16): (N, 4) xx, yy, xy, zz for 2D strains, (N, 6) "
          "xx, yy, xy, zz, yz, xz for 3D ones")
      .def_property_readonly("lame", [](const LinearElastic& e)
                             { return std::make_pair(e.lambda(), e.mu()); });
}

} // namespace pfmpm::bindings
