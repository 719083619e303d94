/// @file particles.cpp
/// @brief Particles in Python: every array by name, as a zero-copy numpy view.
#include "bindings.h"

#include "pfmpm/particles/particles.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>

namespace py = pybind11;
using namespace pfmpm;

namespace pfmpm::bindings
{

namespace
{
/// The numpy type of a column's values.
py::dtype dtype_of(DType t)
{
  switch (t)
  {
  case DType::f64:
    return py::dtype::of<double>();
  case DType::i32:
    return py::dtype::of<std::int32_t>();
  case DType::i64:
    return py::dtype::of<std::int64_t>();
  }
  throw std::logic_error("unknown particle column type");
}

/// Zero-copy (rows,) or (rows, cols) view of a column, owned by `owner`.
py::array view(const Particles::Entry& e, py::handle owner)
{
  const auto cols = static_cast<py::ssize_t>(e.spec->components);
  const auto rows = static_cast<py::ssize_t>(e.values) / cols;
  const py::dtype dtype = dtype_of(e.spec->dtype);
  const auto item = static_cast<py::ssize_t>(dtype.itemsize());
  if (cols == 1)
    return py::array(dtype, {rows}, {item}, e.data, owner);
  return py::array(dtype, {rows, cols}, {cols * item, item}, e.data, owner);
}

/// The entry of column `name`, or a Python AttributeError naming it.
Particles::Entry entry(Particles& P, const std::string& name)
{
  for (const Particles::Entry& e : P.columns())
    if (e.spec->name == name)
      return e;
  throw py::attribute_error("particles have no column " + name);
}
} // namespace

void bind_particles(py::module_& m)
{
  py::class_<Particles>(m, "Particles",
                        "Material points: core arrays and the named columns of a scene's models. "
                        "Every column is an attribute, a zero-copy numpy view (N,) or (N, k).")
      .def(py::init<std::size_t, int>(), py::arg("n"), py::arg("dim") = 2,
           "n particles at rest in dim (2 or 3) directions, with the ids 0 to n - 1 (the column id, "
           "int64, which must ascend: the solver checks it)")
      .def("__len__", &Particles::size)
      .def("resize", &Particles::resize, py::arg("n"),
           "n rows in every column: the first rows kept, new rows zero (ids included); views "
           "taken before do not survive it")
      .def_property_readonly("dim", &Particles::dim, "the directions: 2 or 3")
      .def("__getattr__", [](py::object self, const std::string& name)
           { return view(entry(self.cast<Particles&>(), name), self); })
      .def(
          "__dir__",
          [](py::object self)
          {
            py::list names = py::module_::import("builtins").attr("object").attr("__dir__")(self);
            for (const Particles::Entry& e : self.cast<Particles&>().columns())
              names.append(e.spec->name);
            return names;
          },
          "the methods and every column, so that dir() and completion list the columns")
      .def(
          "columns",
          [](Particles& P)
          {
            py::list out;
            for (const Particles::Entry& e : P.columns())
            {
              py::dict d;
              d["name"] = e.spec->name;
              d["components"] = e.spec->components;
              d["dtype"] = py::str(dtype_of(e.spec->dtype));
              d["doc"] = e.spec->doc;
              d["layout"] = e.spec->layout;
              d["output"] = e.spec->output;
              out.append(d);
            }
            return out;
          },
          "every column in order (core arrays first): dicts of name, components, dtype, doc, "
          "layout (component names) and output (its name in the VTU files, or empty)");
}

} // namespace pfmpm::bindings
