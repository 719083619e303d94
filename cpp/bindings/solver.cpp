/// @file solver.cpp
/// @brief Fracture parameters and the solver in Python; the solver's state
/// as named arrays and scalars.
#include "bindings.h"

#include "pfmpm/fracture/phasefield.h"
#include "pfmpm/solver/solver.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

namespace py = pybind11;
using namespace pfmpm;

namespace pfmpm::bindings
{

namespace
{
/// A 1D numpy array that takes `data` over (no copy); it frees it when collected.
py::array_t<double> array_of(std::vector<double>&& data)
{
  auto owned = std::make_unique<std::vector<double>>(std::move(data));
  py::capsule owner(owned.get(), [](void* p) { delete static_cast<std::vector<double>*>(p); });
  const std::vector<double>* v = owned.release();
  return py::array_t<double>(static_cast<py::ssize_t>(v->size()), v->data(), owner);
}

py::dict stats_dict(const PhaseFieldStats& st)
{
  py::dict d;
  PhaseFieldStats::each([&](const char* name, PhaseFieldStats::Combine, const auto& value) { d[name] = value; },
                        st);
  return d;
}

/// The contact record as a dict.
py::dict contact_dict(const ContactStats& st, bool damage)
{
  py::dict d;
  ContactStats::each([&](const char* name, const auto& value) { d[name] = value; }, damage, st);
  return d;
}

/// A solver state as a dict of `scalars` and `arrays` (taken over, no copy).
py::dict dict_of(SolverState st)
{
  py::dict scalars, arrays;
  for (const auto& [key, value] : st.scalars)
    scalars[py::str(key)] = value;
  for (auto& [key, value] : st.arrays)
    arrays[py::str(key)] = array_of(std::move(value));
  py::dict d;
  d["scalars"] = scalars;
  d["arrays"] = arrays;
  return d;
}

/// Energies as a dict of their fields.
template <int Dim>
py::dict energies_dict(const Energies<Dim>& e)
{
  py::dict d;
  Energies<Dim>::each([&](const char* name, const auto& value) { d[name] = value; }, e);
  return d;
}

/// The solver state of a dict made by dict_of.
SolverState state_of(const py::dict& d)
{
  SolverState st;
  for (const auto& [key, value] : d["scalars"].cast<py::dict>())
    st.scalars[key.cast<std::string>()] = value.cast<double>();
  for (const auto& [key, value] : d["arrays"].cast<py::dict>())
  {
    const auto a = value.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
    if (a.ndim() != 1)
      throw py::value_error("solver state: " + key.cast<std::string>() + " must be one-dimensional");
    st.arrays[key.cast<std::string>()] = std::vector<double>(a.data(), a.data() + a.size());
  }
  return st;
}

/// A copy of `data` as a numpy array.
template <class T>
py::array_t<T> copy_of(const std::vector<T>& data)
{
  py::array_t<T> out(static_cast<py::ssize_t>(data.size()));
  std::copy(data.begin(), data.end(), out.mutable_data());
  return out;
}

/// The solver of Dim directions as the Python class `name`.
template <int Dim>
void bind_solver_class(py::module_& m, const char* name)
{
  py::class_<Solver<Dim>>(m, name, Dim == 2 ? "Explicit MPM stepping with a staggered phase field (Algorithm 1)"
                                          : "Explicit MPM stepping in 3D (one velocity field, B-splines)")
      .def(py::init(
               [](Grid<Dim>& grid, Particles& particles,
                  const std::vector<std::shared_ptr<Material>>& materials, double dt,
                  std::vector<std::optional<Fracture>> fracture, double tol, int max_iterations,
                  Partition partition, std::vector<double> friction, DamageGradientOptions damage,
                  ShapeFunctions shape, bool scale_failed, double failed_c, TransferScheme transfer)
               {
                 StepConfig step(dt);
                 step.fracture = std::move(fracture);
                 step.tol = tol;
                 step.max_iterations = max_iterations;
                 step.partition = partition;
                 step.friction = std::move(friction);
                 step.damage = std::move(damage);
                 step.shape = shape;
                 step.scaling = DomainScaling{scale_failed, failed_c};
                 step.transfer = transfer;
                 return std::make_unique<Solver<Dim>>(
                     grid, particles,
                     std::vector<std::shared_ptr<const Material>>(materials.begin(), materials.end()),
                     std::move(step));
               }),
           py::arg("grid"), py::arg("particles"), py::arg("materials"), py::arg("dt"),
           py::arg("fracture") = std::vector<std::optional<Fracture>>{}, py::arg("tol") = PhaseFieldDeclarations::default_tol,
           py::arg("max_iterations") = PhaseFieldDeclarations::default_max_iterations, py::arg("partition") = Partition::single,
           py::arg("friction") = std::vector<double>{}, py::arg("damage") = DamageGradientOptions{}, py::arg("shape") = ShapeFunctions::bspline,
           py::arg("scale_failed") = true, py::arg("failed_c") = 0.0,
           py::arg("transfer") = TransferScheme::flip, py::keep_alive<1, 2>(),
           py::keep_alive<1, 3>(),
           "materials: pfmpm._core.Material per material index (see pfmpm._core.material); "
           "partition: the velocity-field partition (Partition: single, bodies, "
           "damage_gradient); friction: with discrete fields the n x n (row-major) Coulomb "
           "coefficients between them (bodies, or contact groups), empty with one field; damage: "
           "with damage_gradient its pfmpm._core.DamageGradient; shape: the shape functions (CPDI adds the "
           "domain columns, to be set before the first step); scale_failed, failed_c: with CPDI, "
           "scale the domains of failed particles (damage D = 1, or phase field c < failed_c) to "
           "a diagonal of at most a cell; transfer: FLIP or APIC (which adds the column "
           "`affine`, B_p). Adds the models' particle columns.")
      .def("advance", &Solver<Dim>::advance, py::arg("steps"),
           py::call_guard<py::gil_scoped_release>(),
           "take `steps` steps, each on the thread count the solver's ThreadGovernor chooses "
           "(at most num_threads(), restored on return) unless adaptive_threads is False")
      .def_property("adaptive_threads", &Solver<Dim>::adaptive_threads, &Solver<Dim>::set_adaptive_threads,
                    "whether advance adapts the thread count to the machine's load (default True)")
      .def_property_readonly("reduced_thread_steps", &Solver<Dim>::reduced_thread_steps,
                             "steps run on fewer threads than num_threads() so far")
      .def("prepare", [](Solver<Dim>& s) { s.prepare(); }, py::call_guard<py::gil_scoped_release>(),
           "sort, activate and solve the phase field for the current state")
      .def("phase_field_stats",
           [](const Solver<Dim>& s)
           {
             py::dict d = stats_dict(s.phase_field_stats());
             d["fourth_order"] = s.fourth_order();
             d["bounded"] = s.bounded();
             return d;
           })
      .def(
          "phase_field_system",
          [](const Solver<Dim>& s)
          {
            const PhaseFieldSystem k = s.phase_field_system();
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
      .def("set_phase_field_preconditioner", &Solver<Dim>::set_phase_field_preconditioner,
           py::arg("preconditioner"),
           "the phase-field CG preconditioner from the next solve on (automatic: ssor for "
           "the second-order model, multigrid for the fourth-order one)")
      .def("set_stability_length", &Solver<Dim>::set_stability_length, py::arg("length"),
           "check dt (c_p + |v_p|) <= length after every step (0: no check)")
      .def("set_touch_fill", &Solver<Dim>::set_touch_fill, py::arg("fill"),
           "with contact, fields touch at a node where their volumes fill this fraction of "
           "its volume (0: on approach alone)")
      .def("fastest_signal", &Solver<Dim>::fastest_signal,
           "the largest c_p + |v_p| over the particles now (c_p the P-wave speed in the "
           "particle's state): the speed the stability check holds dt to")
      .def_property_readonly("light_nodes", &Solver<Dim>::light_nodes,
                             "slot-steps so far too light to divide by (given zero velocity)")
      .def_property_readonly("mass_tol", &Solver<Dim>::mass_tol,
                             "the mass at or below which a node slot is too light to divide by "
                             "(1e-12 of the heaviest particle's)")
      .def(
          "state",
          [](const Solver<Dim>& s) { return dict_of(s.state()); },
          "the state besides the particle columns, for a checkpoint: a dict of `scalars` "
          "(name: float) and `arrays` (name: 1D array, a copy)")
      .def(
          "restore",
          [](Solver<Dim>& s, const py::dict& d) { s.restore(state_of(d)); },
          py::arg("state"), "continue from a state() dict; restore the particle columns beside it")
      .def_property_readonly("dt", &Solver<Dim>::dt)
      .def_property_readonly("transfer", &Solver<Dim>::transfer)
      .def(
          "set_velocity_gradients",
          [](Solver<Dim>& s, const py::array_t<double, py::array::c_style | py::array::forcecast>& G)
          {
            if (G.ndim() != 3 || G.shape(1) != Dim || G.shape(2) != Dim)
              throw py::value_error("velocity gradients: an (n, " + std::to_string(Dim) + ", "
                                    + std::to_string(Dim) + ") array is needed");
            const std::vector<double> g(G.data(), G.data() + G.size());
            s.set_velocity_gradients(g);
          },
          py::arg("G"),
          "with APIC: each particle's affine matrix B_p = G_p D_p for the velocity field "
          "v_p + G_p (x - x_p) about it (G: (n, dim, dim), G[p, i, j] = dv_i/dx_j)")
      .def_property_readonly("time", &Solver<Dim>::time)
      .def_property_readonly("step_count", &Solver<Dim>::step_count)
      .def("energies", [](const Solver<Dim>& s) { return energies_dict(s.energies()); },
           "energies and momentum now: a dict of the Energies fields")
      .def(
          "tile_sums",
          [](const Solver<Dim>& s)
          {
            TileSums t = s.tile_sums();
            const auto rows = static_cast<py::ssize_t>(t.keys.size());
            py::array_t<std::int64_t> keys(rows, t.keys.data());
            py::array_t<double> sums = array_of(std::move(t.sums)).reshape({rows, py::ssize_t{t.width}});
            return py::make_tuple(keys, sums);
          },
          "the particle sums of energies() per non-empty tile of 8 cells a side: (keys, sums), "
          "sums one row per tile (Solver::tile_sums)")
      .def(
          "energies_of",
          [](const Solver<Dim>& s, const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>& keys,
             const py::array_t<double, py::array::c_style | py::array::forcecast>& sums,
             const py::array_t<double, py::array::c_style | py::array::forcecast>& slabs)
          {
            if (sums.ndim() != 2 || sums.shape(0) != keys.size())
              throw py::value_error("tile sums: one row per tile key is needed");
            TileSums t{static_cast<int>(sums.shape(1)), std::vector<std::int64_t>(keys.data(), keys.data() + keys.size()),
                       std::vector<double>(sums.data(), sums.data() + sums.size())};
            return energies_dict(s.energies_of(t, std::vector<double>(slabs.data(), slabs.data() + slabs.size())));
          },
          py::arg("keys"), py::arg("sums"), py::arg("slabs"),
          "energies() from the tile sums of every process (keys ascending) and the slab sums of "
          "every slab in order")
      .def_property_readonly(
          "slab_sums", [](const Solver<Dim>& s) { return array_of(std::vector<double>(s.slab_sums())); },
          "the grid update's sums over the steps per owned slab of 8 node columns along x, "
          "slab after slab (a copy)")
      .def("set_owned_slabs", &Solver<Dim>::set_owned_slabs, py::arg("first"), py::arg("last"),
           "keep the grid sums of the slabs [first, last) only: a rank's own")
      .def_property_readonly("owned_slabs", &Solver<Dim>::owned_slabs)
      .def("set_mass_tol", &Solver<Dim>::set_mass_tol, py::arg("tol"),
           "the mass at or below which a node slot is too light to divide by: a rank sets that "
           "of all particles")
      .def(
          "contact_stats",
          [](const Solver<Dim>& s) -> py::object
          {
            const ContactStats* c = s.contact_stats();
            if (!c)
              return py::none();
            return contact_dict(*c, s.damage_fields() != nullptr);
          },
          "contact record (None with one field): contact nodes in the last step, node-pairs "
          "examined, active (K&T eq. 77) and sliding (K&T eq. 75) ones, violations of "
          "C.1-C.4, work of the friction forces since t = 0; with damage-gradient fields also "
          "the nodes where a group has both sides (split) and of them the separable ones "
          "(H&H eq. 21) in the last step, and the separable ones summed over the steps "
          "(separable_total)")
      .def(
          "detect_surfaces",
          [](Solver<Dim>& s, const std::vector<double>& spacing, double threshold)
          { return copy_of(s.detect_surfaces(spacing, threshold)); },
          py::arg("spacing"), py::arg("threshold") = 0.99,
          "surface flags at t = 0 (H&H section 2.4) into the `surface` column: S < threshold "
          "S_bulk over each body's own particles, S_bulk from the body's lattice spacing; "
          "returns S / S_bulk per particle")
      .def(
          "stage_seconds",
          [](const Solver<Dim>& s)
          {
            const StageTimers& t = s.timers();
            return py::dict(py::arg("sort") = t.sort, py::arg("phase_field") = t.phase_field,
                            py::arg("fields") = t.fields, py::arg("p2g") = t.p2g,
                            py::arg("grid") = t.grid, py::arg("g2p") = t.g2p);
          },
          "wall seconds per stage of the steps so far: cell sort and active nodes, phase field, "
          "the partition's build (fields; damage_partition()['seconds'] splits the damage "
          "gradient's), P2G, grid update with contact, G2P with the materials' update")
      .def(
          "damage_partition",
          [](const Solver<Dim>& s) -> py::object
          {
            const DamageFields<Dim>* d = s.damage_fields();
            if (!d)
              return py::none();
            py::dict out;
            out["mask"] = copy_of(d->masks());
            const auto rows = d->nodal_gradients(s.particles());
            constexpr int width = 2 + Dim;
            py::array_t<double> G({py::ssize_t(rows.size()), py::ssize_t(width)});
            const auto* flat = reinterpret_cast<const double*>(rows.data());
            std::copy(flat, flat + width * rows.size(), G.mutable_data());
            out["nodal_gradient"] = G;
            out["radius"] = d->radius();
            out["neighbour_builds"] = d->neighbour_builds();
            out["kernel_evaluations"] = d->kernel_evaluations();
            const DamageTimers& t = d->timers();
            out["seconds"] = py::dict(py::arg("damage") = t.damage,
                                      py::arg("neighbours") = t.neighbours,
                                      py::arg("gradient") = t.gradient,
                                      py::arg("partition") = t.partition);
            return out;
          },
          "the damage-gradient partition of the last step (None without it): per particle the "
          "mask of its stencil nodes where it chose field B (bit i: stencil node i, the last "
          "direction fastest), per (active node, group) the nodal gradient (node, group, G_x, "
          "G_y[, G_z]) of Algorithm 1, "
          "the kernel radius, the neighbour-list builds and kernel-field evaluations so far and the "
          "seconds spent per block")
      .def(
          "nodal_mass_momentum",
          [](Solver<Dim>& s)
          {
            const auto rows = s.nodal_mass_momentum();
            constexpr int width = 2 + Dim;
            py::array_t<double> out({py::ssize_t(rows.size()), py::ssize_t(width)});
            const auto* flat = reinterpret_cast<const double*>(rows.data());
            std::copy(flat, flat + width * rows.size(), out.mutable_data());
            return out;
          },
          "P2G of the current state: (node, mass, momentum per direction) per active node (a copy)");;
}
} // namespace

void bind_solver(py::module_& m)
{
  using Matrix3 = std::array<std::array<double, 3>, 3>;
  auto matrix = [](const Voigt& v)
  {
    Matrix3 out;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        out[i][j] = v[3 * i + j];
    return out;
  };
  py::enum_<Model>(m, "Model", "the phase-field model: w(d) = d^2 (AT2) or d (AT1)")
      .value("AT2", Model::AT2)
      .value("AT1", Model::AT1);
  m.def(
      "fracture_parameters",
      []() { return parameter_list(Fracture::parameters()); },
      "the declared parameters of a material's fracture table (dicts as material_models' "
      "parameters)");
  m.def(
      "phase_field_parameters",
      []() { return parameter_list(PhaseFieldDeclarations::solver_parameters()); },
      "the declared parameters of the phase-field solve (a scene's [phase_field] keys)");
  py::class_<Fracture>(m, "Fracture", "Fracture parameters of a material that can crack")
      .def(py::init(
               [](double Gc, double l0, double k_f, const Matrix3& gamma, Model model, bool bound)
               {
                 Fracture f{Gc, l0, k_f};
                 for (int i = 0; i < 3; ++i)
                   for (int j = 0; j < 3; ++j)
                     f.gamma[3 * i + j] = gamma[i][j];
                 f.model = model;
                 f.bound = bound;
                 return f;
               }),
           py::arg("Gc"), py::arg("l0"), py::arg("k_f") = 0.0, py::arg("gamma") = Matrix3{},
           py::arg("model") = Model::AT2, py::arg("bound") = true,
           "gamma: the 3 x 3 Voigt anisotropy tensor of K&T eq. 6 in the material frame")
      .def_readonly("Gc", &Fracture::Gc)
      .def_readonly("l0", &Fracture::l0)
      .def_readonly("k_f", &Fracture::k_f)
      .def_readonly("model", &Fracture::model)
      .def_readonly("bound", &Fracture::bound)
      .def("reaction", &Fracture::reaction, py::arg("H"),
           "coefficient of N_I N_J V_p in K at history H (K&T eq. 49; AT1: "
           "16 l0 (1 - k_f) H / (3 G_c))")
      .def("source", &Fracture::source,
           "coefficient of N_I V_p in F (K&T eq. 52): 1 (AT2), 1/2 (AT1)")
      .def("crack_density", &Fracture::crack_density, py::arg("c"), py::arg("grad2"),
           "crack density Z at c with |grad c|^2 = grad2 (K&T eq. 4, gamma = 0)")
      .def_property_readonly("gamma", [matrix](const Fracture& f) { return matrix(f.gamma); })
      .def_property_readonly("fourth_order", &Fracture::fourth_order)
      .def("rotated", [matrix](const Fracture& f, double phi) { return matrix(f.rotated(phi)); },
           py::arg("phi"), "gamma in the global frame for axes turned phi radians clockwise");

  py::enum_<Preconditioner>(m, "Preconditioner", "preconditioner of the phase-field CG")
      .value("automatic", Preconditioner::automatic)
      .value("jacobi", Preconditioner::jacobi)
      .value("ssor", Preconditioner::ssor)
      .value("multigrid", Preconditioner::multigrid);

  py::enum_<Partition>(m, "Partition", "the velocity-field partition of a run")
      .value("single", Partition::single)
      .value("bodies", Partition::bodies)
      .value("damage_gradient", Partition::damage_gradient);
  py::enum_<ShapeFunctions>(m, "ShapeFunctions",
                            "shape functions of the momentum transfers: B-splines, or CPDI1 "
                            "averages over the particle domains (degree-1 grid)")
      .value("bspline", ShapeFunctions::bspline)
      .value("cpdi", ShapeFunctions::cpdi);

  py::enum_<TransferScheme>(m, "TransferScheme",
                            "the particle-grid transfer: FLIP (v_p += dt sum N_i a_i) or APIC "
                            "(v_p = sum N_i v_i with the affine matrix B_p, Jiang et al. 2015)")
      .value("flip", TransferScheme::flip)
      .value("apic", TransferScheme::apic);

  bind_solver_class<2>(m, "Solver");
  bind_solver_class<3>(m, "Solver3");
}

} // namespace pfmpm::bindings
