/// @file bindings.cpp
/// @brief The pfmpm._core Python module: a thin layer over the C++ library.
///
/// Particle arrays are exposed as numpy views of the C++ storage (no copies);
/// each view keeps its Particles object alive.
#include "pfmpm/bspline.h"
#include "pfmpm/grid.h"
#include "pfmpm/material.h"
#include "pfmpm/particles.h"
#include "pfmpm/phasefield.h"
#include "pfmpm/solver.h"

#include <omp.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

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

using Strains = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// A 1D numpy array that takes `data` over (no copy); it frees it when collected.
py::array_t<double> array_of(std::vector<double>&& data)
{
  auto owned = std::make_unique<std::vector<double>>(std::move(data));
  py::capsule owner(owned.get(), [](void* p) { delete static_cast<std::vector<double>*>(p); });
  const std::vector<double>* v = owned.release();
  return py::array_t<double>(static_cast<py::ssize_t>(v->size()), v->data(), owner);
}

/// A 1D float64 array as a vector (one copy, into the solver's storage).
std::vector<double> vector_of(const py::dict& d, const char* key)
{
  const auto a = d[key].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  if (a.ndim() != 1)
    throw py::value_error(std::string(key) + " must be one-dimensional");
  return std::vector<double>(a.data(), a.data() + a.size());
}

py::dict stats_dict(const PhaseFieldStats& st)
{
  py::dict d;
  d["solves"] = st.solves;
  d["iterations"] = st.iterations;
  d["last_iterations"] = st.last_iterations;
  d["start_residual"] = st.start_residual;
  d["last_residual"] = st.last_residual;
  d["unknowns"] = st.unknowns;
  return d;
}

PhaseFieldStats stats_of(const py::dict& d)
{
  PhaseFieldStats st;
  st.solves = d["solves"].cast<std::int64_t>();
  st.iterations = d["iterations"].cast<std::int64_t>();
  st.last_iterations = d["last_iterations"].cast<std::int32_t>();
  st.start_residual = d["start_residual"].cast<double>();
  st.last_residual = d["last_residual"].cast<double>();
  st.unknowns = d["unknowns"].cast<std::int32_t>();
  return st;
}

/// One phase field's state as a dict: nodal arrays `c`, `c_previous`, the
/// per-particle `fracture_energy` (taken over, no copies) and `stats`.
py::dict phase_field_dict(PhaseFieldState&& st)
{
  py::dict d;
  d["c"] = array_of(std::move(st.c));
  d["c_previous"] = array_of(std::move(st.c_previous));
  d["fracture_energy"] = array_of(std::move(st.fracture_energy));
  d["stats"] = stats_dict(st.stats);
  return d;
}

/// The inverse of phase_field_dict (one copy of each array, into the solver's storage).
PhaseFieldState phase_field_of(const py::dict& d)
{
  return PhaseFieldState{vector_of(d, "c"), vector_of(d, "c_previous"),
                         vector_of(d, "fracture_energy"),
                         stats_of(d["stats"].cast<py::dict>())};
}

/// The contact record as a dict (the keys of Solver.contact_stats()).
py::dict contact_dict(const ContactStats& st)
{
  py::dict d;
  d["nodes"] = st.nodes;
  d["pairs"] = st.pairs;
  d["active"] = st.active;
  d["sliding"] = st.sliding;
  d["C1"] = st.violations[0];
  d["C2"] = st.violations[1];
  d["C3"] = st.violations[2];
  d["C4"] = st.violations[3];
  d["friction_work"] = st.friction_work;
  return d;
}

/// The inverse of contact_dict.
ContactStats contact_of(const py::dict& d)
{
  ContactStats st;
  st.nodes = d["nodes"].cast<std::int32_t>();
  st.pairs = d["pairs"].cast<std::int64_t>();
  st.active = d["active"].cast<std::int64_t>();
  st.sliding = d["sliding"].cast<std::int64_t>();
  for (int c = 0; c < 4; ++c)
    st.violations[c] = d[("C" + std::to_string(c + 1)).c_str()].cast<std::int64_t>();
  st.friction_work = d["friction_work"].cast<double>();
  return st;
}

/// Number of rows of an (N, 3) strain array; throws on another shape.
py::ssize_t strain_rows(const Strains& strain)
{
  if (strain.ndim() != 2 || strain.shape(1) != 3)
    throw py::value_error("strain must have shape (N, 3)");
  return strain.shape(0);
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
  py::enum_<Split>(m, "Split")
      .value("none", Split::none)
      .value("spectral", Split::spectral)
      .value("volumetric_deviatoric", Split::volumetric_deviatoric);

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
      .def(py::init<double, double, double, Plane, Split>(), py::arg("E"), py::arg("nu"),
           py::arg("density"), py::arg("plane"), py::arg("split") = Split::spectral)
      .def_property_readonly("wave_speed", &LinearElastic::wave_speed)
      .def(
          "split_energies",
          [](const LinearElastic& e, const Strains& strain)
          {
            const py::ssize_t n = strain_rows(strain);
            py::array_t<double> plus(n), minus(n);
            for (py::ssize_t i = 0; i < n; ++i)
            {
              double sig[4];
              e.degraded(strain.data(i, 0), 1.0, sig, plus.mutable_data()[i],
                         minus.mutable_data()[i]);
            }
            return py::make_tuple(plus, minus);
          },
          py::arg("strain"), "(psi+, psi-) of eq. 14 for strains (N, 3): xx, yy, xy")
      .def(
          "stresses",
          [](const LinearElastic& e, const Strains& strain,
             py::array_t<double, py::array::c_style | py::array::forcecast> g)
          {
            const py::ssize_t n = strain_rows(strain);
            if (g.ndim() != 1 || g.shape(0) != n)
              throw py::value_error("g must have shape (N,) matching strain");
            py::array_t<double> sig({n, py::ssize_t(4)});
            for (py::ssize_t i = 0; i < n; ++i)
            {
              double plus, minus;
              e.degraded(strain.data(i, 0), g.data()[i], sig.mutable_data(i, 0), plus, minus);
            }
            return sig;
          },
          py::arg("strain"), py::arg("g"),
          "stresses (N, 4): xx, yy, xy, zz of g psi+ + psi- (eqs. 14, 16)")
      .def_property_readonly("lame", [](const LinearElastic& e)
                             { return std::make_pair(e.lambda(), e.mu()); });

  using Matrix3 = std::array<std::array<double, 3>, 3>;
  auto matrix = [](const Voigt& v)
  {
    Matrix3 out;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        out[i][j] = v[3 * i + j];
    return out;
  };
  py::class_<Fracture>(m, "Fracture", "Fracture parameters of a material that can crack")
      .def(py::init(
               [](double Gc, double l0, double k_f, const Matrix3& gamma)
               {
                 Fracture f{Gc, l0, k_f};
                 for (int i = 0; i < 3; ++i)
                   for (int j = 0; j < 3; ++j)
                     f.gamma[3 * i + j] = gamma[i][j];
                 return f;
               }),
           py::arg("Gc"), py::arg("l0"), py::arg("k_f") = 0.0, py::arg("gamma") = Matrix3{},
           "gamma: the 3 x 3 Voigt anisotropy tensor of eq. 6 in the material frame")
      .def_readonly("Gc", &Fracture::Gc)
      .def_readonly("l0", &Fracture::l0)
      .def_readonly("k_f", &Fracture::k_f)
      .def_property_readonly("gamma", [matrix](const Fracture& f) { return matrix(f.gamma); })
      .def_property_readonly("fourth_order", &Fracture::fourth_order)
      .def("rotated", [matrix](const Fracture& f, double phi) { return matrix(f.rotated(phi)); },
           py::arg("phi"), "gamma in the global frame for axes turned phi radians clockwise");

  py::enum_<Preconditioner>(m, "Preconditioner", "preconditioner of the phase-field CG")
      .value("automatic", Preconditioner::automatic)
      .value("jacobi", Preconditioner::jacobi)
      .value("ssor", Preconditioner::ssor)
      .value("multigrid", Preconditioner::multigrid);

  py::class_<Solver>(m, "Solver", "Explicit MPM stepping with a staggered phase field (Algorithm 1)")
      .def(py::init<Grid&, Particles&, std::vector<LinearElastic>, double,
                    std::vector<std::optional<Fracture>>, double, int, std::vector<double>>(),
           py::arg("grid"), py::arg("particles"), py::arg("materials"), py::arg("dt"),
           py::arg("fracture") = std::vector<std::optional<Fracture>>{}, py::arg("tol") = 1e-6,
           py::arg("max_iterations") = 1000, py::arg("friction") = std::vector<double>{},
           py::keep_alive<1, 2>(), py::keep_alive<1, 3>(),
           "friction: empty for one velocity field, else the n x n (row-major) Coulomb "
           "coefficients between bodies, each body its own discrete field")
      .def("advance", &Solver::advance, py::arg("steps"),
           py::call_guard<py::gil_scoped_release>())
      .def("prepare", [](Solver& s) { s.prepare(); }, py::call_guard<py::gil_scoped_release>(),
           "sort, activate and solve the phase field for the current state")
      .def("phase_field_stats",
           [](const Solver& s)
           {
             py::dict d = stats_dict(s.phase_field_stats());
             d["fourth_order"] = s.phase_field().fourth_order();
             return d;
           })
      .def(
          "phase_field_system",
          [](const Solver& s)
          {
            const PhaseFieldSystem k = s.phase_field().system();
            auto copy = [](const auto& v)
            {
              using T = typename std::decay_t<decltype(v)>::value_type;
              return py::array_t<T>(static_cast<py::ssize_t>(v.size()), v.data());
            };
            py::dict d;
            d["nodes"] = copy(k.nodes);
            d["row_start"] = copy(k.row_start);
            d["column"] = copy(k.column);
            d["value"] = copy(k.value);
            d["rhs"] = copy(k.rhs);
            d["solution"] = copy(k.solution);
            return d;
          },
          "the last phase-field system K c = F in compressed rows over the active nodes "
          "(nodes, row_start, column, value, rhs) and its solution (one velocity field only)")
      .def("set_phase_field_preconditioner", &Solver::set_phase_field_preconditioner,
           py::arg("preconditioner"),
           "the phase-field CG preconditioner from the next solve on (automatic: jacobi for "
           "the second-order model, ssor for the fourth-order one)")
      .def("set_stability_length", &Solver::set_stability_length, py::arg("length"),
           "check dt (c_p + |v_p|) <= length after every step (0: no check)")
      .def_property_readonly("light_nodes", &Solver::light_nodes,
                             "nodes so far too light to divide by (given zero velocity)")
      .def(
          "state",
          [](const Solver& s)
          {
            SolverState st = s.state();
            py::dict d;
            d["time"] = st.time;
            d["step"] = st.step;
            d["external_work"] = st.external_work;
            d["light_nodes"] = st.light_nodes;
            d["phase_field_c"] = array_of(std::move(st.phase_field.c));
            d["phase_field_c_previous"] = array_of(std::move(st.phase_field.c_previous));
            d["fracture_energy"] = array_of(std::move(st.phase_field.fracture_energy));
            d["phase_field_stats"] = stats_dict(st.phase_field.stats);
            py::object fields = py::none();
            if (st.fields)
            {
              py::list phase_fields;
              for (PhaseFieldState& pf : st.fields->phase_fields)
                phase_fields.append(phase_field_dict(std::move(pf)));
              py::dict f;
              f["phase_fields"] = phase_fields;
              f["contact"] = contact_dict(st.fields->stats);
              fields = f;
            }
            d["fields"] = fields;
            return d;
          },
          "the state besides the particles, for a checkpoint (a dict owning one copy); "
          "`fields`: None, or with discrete fields `phase_fields` (per crackable body: dicts of "
          "`c`, `c_previous`, `fracture_energy`, `stats`) and `contact` (as contact_stats())")
      .def(
          "restore",
          [](Solver& s, const py::dict& d)
          {
            SolverState st;
            st.time = d["time"].cast<double>();
            st.step = d["step"].cast<std::int64_t>();
            st.external_work = d["external_work"].cast<double>();
            st.light_nodes = d["light_nodes"].cast<std::int64_t>();
            st.phase_field.c = vector_of(d, "phase_field_c");
            st.phase_field.c_previous = vector_of(d, "phase_field_c_previous");
            st.phase_field.fracture_energy = vector_of(d, "fracture_energy");
            st.phase_field.stats = stats_of(d["phase_field_stats"].cast<py::dict>());
            if (const py::object fields = d["fields"]; !fields.is_none())
            {
              DiscreteFieldsState f;
              for (const py::handle pf : fields["phase_fields"])
                f.phase_fields.push_back(phase_field_of(pf.cast<py::dict>()));
              f.stats = contact_of(fields["contact"].cast<py::dict>());
              st.fields = std::move(f);
            }
            s.restore(std::move(st));
          },
          py::arg("state"), "continue from a state() dict; restore the particle arrays beside it")
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
             d["fracture"] = e.fracture;
             d["external_work"] = e.external_work;
             d["friction_work"] = e.friction_work;
             d["fracture_by_body"] = e.fracture_by_field;
             d["momentum_x"] = e.momentum[0];
             d["momentum_y"] = e.momentum[1];
             d["mass"] = e.mass;
             return d;
           })
      .def(
          "contact_stats",
          [](const Solver& s) -> py::object
          {
            const DiscreteFields* f = s.fields();
            if (!f)
              return py::none();
            return contact_dict(f->stats());
          },
          "contact record (None with one field): contact nodes in the last step, node-pairs "
          "examined, active (eq. 77) and sliding (eq. 75) ones, violations of C.1-C.4, work of "
          "the friction forces since t = 0")
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
