/// @file bindings.cpp
/// @brief The pfmpm._core Python module: a thin layer over the C++ library.
///
/// Particle arrays are exposed as numpy views of the C++ storage (no copies);
/// each view keeps its Particles object alive.
#include "pfmpm/bspline.h"
#include "pfmpm/grid.h"
#include "pfmpm/material.h"
#include "pfmpm/particles.h"
#include "pfmpm/solver.h"

#include <omp.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

namespace py = pybind11;
using namespace pfmpm;

namespace
{
/// Zero-copy (rows) or (rows, cols) view of a vector, owned by `owner`.
template <class T>
py::array_t<T> view(std::vector<T>& data, std::size_t cols, py::handle owner)
{
  const auto rows = static_cast<py::ssize_t>(data.size() / cols);
  if (cols == 1)
    return py::array_t<T>({rows}, {py::ssize_t(sizeof(T))}, data.data(), owner);
  return py::array_t<T>({rows, py::ssize_t(cols)},
                        {py::ssize_t(cols * sizeof(T)), py::ssize_t(sizeof(T))}, data.data(),
                        owner);
}

template <class T>
void def_view(py::class_<Particles>& cls, const char* name, std::vector<T> Particles::*member,
              std::size_t cols, const char* doc)
{
  cls.def_property_readonly(
      name, [member, cols](py::object self)
      { return view(self.cast<Particles&>().*member, cols, self); },
      doc);
}
} // namespace

PYBIND11_MODULE(_core, m)
{
  m.doc() = "pfmpm C++ core: B-spline grid, particles and explicit MPM stepping";
  py::register_exception<SimulationError>(m, "SimulationError", PyExc_RuntimeError);
  m.def("num_threads", &omp_get_max_threads, "OpenMP threads the kernels use");

  py::class_<BSpline1D>(m, "BSpline1D", "B-spline basis on a uniform open knot vector")
      .def(py::init<int, int, double, double>(), py::arg("degree"), py::arg("cells"),
           py::arg("h"), py::arg("origin") = 0.0)
      .def_property_readonly("degree", &BSpline1D::degree)
      .def_property_readonly("size", &BSpline1D::size)
      .def(
          "evaluate",
          [](const BSpline1D& b, py::array_t<double, py::array::c_style | py::array::forcecast> xs)
          {
            const auto n = xs.size();
            const int k = b.degree() + 1;
            py::array_t<int> cells(n);
            py::array_t<double> N({n, py::ssize_t(k)}), dN({n, py::ssize_t(k)}),
                d2N({n, py::ssize_t(k)});
            const double* x = xs.data();
            for (py::ssize_t i = 0; i < n; ++i)
            {
              const int c = b.cell(x[i]);
              if (c < 0)
                throw py::value_error("x = " + std::to_string(x[i]) + " is outside the basis");
              cells.mutable_data()[i] = c;
              b.evaluate(c, x[i], N.mutable_data(i, 0), dN.mutable_data(i, 0),
                         d2N.mutable_data(i, 0));
            }
            return py::make_tuple(cells, N, dN, d2N);
          },
          py::arg("x"),
          "(cell, N, dN, d2N) at each x: N[i, k] is function cell[i] + k at x[i]");

  py::enum_<Side>(m, "Side")
      .value("left", Side::left)
      .value("right", Side::right)
      .value("bottom", Side::bottom)
      .value("top", Side::top);
  py::enum_<Wall>(m, "Wall").value("free", Wall::free).value("fixed", Wall::fixed).value("slip", Wall::slip);
  py::enum_<Plane>(m, "Plane").value("strain", Plane::strain).value("stress", Plane::stress);

  py::class_<Grid>(m, "Grid", "Uniform grid with a tensor-product B-spline basis")
      .def(py::init<int, std::array<int, 2>, double, std::array<double, 2>>(), py::arg("degree"),
           py::arg("cells"), py::arg("h"), py::arg("origin"))
      .def_property_readonly("degree", &Grid::degree)
      .def_property_readonly("cells", &Grid::cells)
      .def_property_readonly("nodes", &Grid::nodes)
      .def_property_readonly("num_active", &Grid::num_active, "active nodes in the last step")
      .def("set_wall", &Grid::set_wall, py::arg("side"), py::arg("wall"));

  py::class_<Particles> particles(m, "Particles", "Material points, struct of arrays");
  particles.def(py::init<std::size_t>(), py::arg("n"))
      .def("__len__", &Particles::size);
  def_view(particles, "x", &Particles::x, 2, "positions (N, 2)");
  def_view(particles, "v", &Particles::v, 2, "velocities (N, 2)");
  def_view(particles, "mass", &Particles::mass, 1, "masses (N,)");
  def_view(particles, "volume", &Particles::volume, 1, "volumes (N,)");
  def_view(particles, "strain", &Particles::strain, 3, "strains xx, yy, xy (N, 3)");
  def_view(particles, "stress", &Particles::stress, 4, "stresses xx, yy, xy, zz (N, 4)");
  def_view(particles, "fext", &Particles::fext, 2, "external forces (N, 2)");
  def_view(particles, "body", &Particles::body, 1, "body indices (N,)");
  def_view(particles, "material", &Particles::material, 1, "material indices (N,)");
  def_view(particles, "c", &Particles::c, 1, "phase field (N,)");
  def_view(particles, "history", &Particles::history, 1, "history field (N,)");
  def_view(particles, "phi", &Particles::phi, 1, "material orientation (N,)");

  py::class_<LinearElastic>(m, "LinearElastic", "Isotropic linear elasticity")
      .def(py::init<double, double, double, Plane>(), py::arg("E"), py::arg("nu"),
           py::arg("density"), py::arg("plane"))
      .def_property_readonly("wave_speed", &LinearElastic::wave_speed)
      .def_property_readonly("lame", [](const LinearElastic& e)
                             { return std::make_pair(e.lambda(), e.mu()); });

  py::class_<Solver>(m, "Solver", "Explicit MPM stepping (Algorithm 1)")
      .def(py::init<Grid&, Particles&, std::vector<LinearElastic>, double>(), py::arg("grid"),
           py::arg("particles"), py::arg("materials"), py::arg("dt"), py::keep_alive<1, 2>(),
           py::keep_alive<1, 3>())
      .def("advance", &Solver::advance, py::arg("steps"),
           py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("dt", &Solver::dt)
      .def_property_readonly("time", &Solver::time)
      .def_property_readonly("step_count", &Solver::step_count)
      .def("energies",
           [](const Solver& s)
           {
             const Energies e = s.energies();
             py::dict d;
             d["kinetic"] = e.kinetic;
             d["elastic"] = e.elastic;
             d["external_work"] = e.external_work;
             d["momentum_x"] = e.momentum[0];
             d["momentum_y"] = e.momentum[1];
             d["mass"] = e.mass;
             return d;
           })
      .def(
          "nodal_mass_momentum",
          [](Solver& s)
          {
            const auto rows = s.nodal_mass_momentum();
            py::array_t<double> out({py::ssize_t(rows.size()), py::ssize_t(4)});
            const auto* flat = reinterpret_cast<const double*>(rows.data());
            std::copy(flat, flat + 4 * rows.size(), out.mutable_data());
            return out;
          },
          "P2G of the current state: (node, mass, px, py) per active node (a copy)");
}
