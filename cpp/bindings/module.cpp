/// @file module.cpp
/// @brief The pfmpm._core Python module: a thin layer over the C++ library.
///
/// Particle columns are numpy views of the C++ storage (no copies); each
/// view keeps its Particles object alive.
#include "bindings.h"

#include "pfmpm/common/error.h"
#include "pfmpm/grid/bspline.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/solver/threads.h"

#include <omp.h>
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
/// The grid of Dim directions as the Python class `name`.
template <int Dim>
void bind_grid_class(py::module_& m, const char* name)
{
  py::class_<Grid<Dim>>(m, name, "Uniform grid with a tensor-product B-spline basis")
      .def(py::init<int, std::array<int, Dim>, double, std::array<double, Dim>>(), py::arg("degree"),
           py::arg("cells"), py::arg("h"), py::arg("origin"))
      .def_property_readonly("degree", &Grid<Dim>::degree)
      .def_property_readonly("cells", &Grid<Dim>::cells)
      .def_property_readonly("nodes", &Grid<Dim>::nodes)
      .def_property_readonly("num_active", &Grid<Dim>::num_active, "active nodes in the last step")
      .def_property_readonly(
          "reach", [](const Grid<Dim>& g) { return g.block().reach(); },
          "the farthest apart, in cells, two cells whose particles reach a common node (NodeBlock::reach): "
          "the degree for B-splines, up to 5 for CPDI")
      .def("set_wall", &Grid<Dim>::set_wall, py::arg("side"), py::arg("wall"))
      .def("add_region", &Grid<Dim>::add_region, py::arg("min"), py::arg("max"), py::arg("components"),
           py::arg("moves") = false,
           "a box of nodes whose velocity components (bit d: direction d) are prescribed; with "
           "moves, the box follows the region's displacement; its index")
      .def("add_particle_region", &Grid<Dim>::add_particle_region, py::arg("components"),
           "a region of the nodes its particles reach (those whose column held_by has the bit of "
           "its index), followed as they move; its index")
      .def("set_region_velocity", &Grid<Dim>::set_region_velocity, py::arg("k"), py::arg("velocity"),
           "the velocity region k prescribes from the next step on");
}
} // namespace

void bind_grid(py::module_& m)
{
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
      .value("top", Side::top)
      .value("back", Side::back)
      .value("front", Side::front);
  py::enum_<Wall>(m, "Wall").value("free", Wall::free).value("fixed", Wall::fixed).value("slip", Wall::slip);

  bind_grid_class<2>(m, "Grid");
  bind_grid_class<3>(m, "Grid3");
}

} // namespace pfmpm::bindings

PYBIND11_MODULE(_core, m)
{
  m.doc() = "pfmpm C++ core: B-spline grid, particles, materials and explicit MPM stepping";
  py::register_exception<SimulationError>(m, "SimulationError", PyExc_RuntimeError);
  m.def("num_threads", &omp_get_max_threads, "OpenMP threads the kernels use");
  m.def(
      "set_num_threads",
      [](int n)
      {
        if (n < 1)
          throw std::invalid_argument("threads = " + std::to_string(n) + ": must be >= 1");
        omp_set_num_threads(n);
      },
      py::arg("n"), "use n OpenMP threads from now on (as OMP_NUM_THREADS=n at the start)");
  m.attr("thread_warmup_steps") = pfmpm::ThreadGovernor::warmup();
  pfmpm::bindings::bind_grid(m);
  pfmpm::bindings::bind_particles(m);
  pfmpm::bindings::bind_materials(m);
  pfmpm::bindings::bind_fields(m);
  pfmpm::bindings::bind_solver(m);
}
