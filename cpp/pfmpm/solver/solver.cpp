/// @file solver.cpp
/// @brief The explicit step: orchestration of sort, phase fields, P2G, grid
/// update and G2P (Kakouris & Triantafyllou 2019, Algorithm 1).
#include "pfmpm/solver/solver.h"
#include "pfmpm/common/reduce.h"
#include "pfmpm/common/stopwatch.h"
#include "pfmpm/shape/stencil.h"
#include "pfmpm/solver/momentum.h"
#include "pfmpm/transfer/transfer.h"

#include <algorithm>
#include <cmath>
#include <omp.h>
#include <sstream>
#include <type_traits>

namespace pfmpm
{

namespace
{
/// Fracture parameters per material: `fracture` itself, or all none when empty.
std::vector<std::optional<Fracture>> per_material(std::vector<std::optional<Fracture>> fracture,
                                                  std::size_t materials)
{
  if (fracture.empty())
    fracture.resize(materials);
  if (fracture.size() != materials)
    throw std::invalid_argument("fracture: " + std::to_string(fracture.size())
                                + " entries for " + std::to_string(materials) + " materials");
  return fracture;
}

/// The state's array of the grid update's sums per slab (Solver::slab_sums), all slabs.
const std::string slab_key = "grid/slab_sums";

std::string phase_key(std::size_t k, const char* name)
{
  return "phase_field/" + std::to_string(k) + "/" + name;
}

/// The name of direction d, and "/" before it.
std::string component(int d)
{
  static const char* const names[3] = {"/x", "/y", "/z"};
  return names[d];
}

std::string wall_impulse_key(int side, int d)
{
  return std::string("wall_impulse/") + side_name(side) + component(d);
}

/// The squared length of a vector of Dim components.
template <int Dim>
double squared_length(const double* v)
{
  double sum = v[0] * v[0];
  for (int d = 1; d < Dim; ++d)
    sum += v[d] * v[d];
  return sum;
}

std::string region_key(int k, const std::string& name)
{
  return "region/" + std::to_string(k) + "/" + name;
}
} // namespace

namespace
{
/// The columns of Solver::tile_sums: kinetic, elastic, mass, fracture,
/// momentum (Dim), angular momentum (its z component in 2D, 3 in 3D); then
/// one per column of dissipated work, then one per body's fracture energy.
template <int Dim>
struct TileColumns
{
  static constexpr int first_axis = Dim == 2 ? 2 : 0; // of the angular momentum's components
  static constexpr int kinetic = 0, elastic = 1, mass = 2, fracture = 3, momentum = 4;
  static constexpr int angular = momentum + Dim - first_axis; // + axis a (first_axis <= a < 3)
  static constexpr int core = angular + 3;
};

/// The works and impulses of the grid update: each the sum of its slabs'
/// sums (Solver::slab_sums) in slab order.
template <int Dim>
struct GridTotals
{
  std::array<double, GridUpdate<Dim>::size> total{};
  explicit GridTotals(const std::vector<double>& slabs)
  {
    for (std::size_t s = 0; s < slabs.size(); s += GridUpdate<Dim>::size)
      for (int k = 0; k < GridUpdate<Dim>::size; ++k)
        total[k] += slabs[s + k];
  }
  /// Into the fields of the same names of `t` (an Energies).
  template <class Target>
  void into(Target& t, double& friction_work) const
  {
    using U = GridUpdate<Dim>;
    constexpr int sides = num_sides(Dim);
    t.external_work = total[U::external_work];
    t.wall_work = total[U::wall_work];
    friction_work = total[U::friction_work];
    for (int side = 0; side < sides; ++side)
      std::copy_n(&total[U::hold_impulse + Dim * side], Dim, t.wall_impulse[side].begin());
    for (int k = 0; k < max_regions; ++k)
    {
      t.region_work[k] = total[U::region_work + k];
      std::copy_n(&total[U::hold_impulse + Dim * (sides + k)], Dim, t.region_impulse[k].begin());
    }
    for (int q = 0; q < max_field_pairs; ++q)
      std::copy_n(&total[U::pair_impulse + Dim * q], Dim, t.pair_impulse[q].begin());
  }
};
} // namespace

template <int Dim>
Solver<Dim>::Solver(Grid<Dim>& grid, Particles& particles,
               std::vector<std::shared_ptr<const Material>> materials, StepConfig step)
    : _grid(grid), _particles(particles), _materials(std::move(materials)), _dt(step.dt),
      _transfer(step.transfer)
{
  // The configuration's fields by name, in StepConfig's order.
  auto& [dt, fracture, tol, max_iterations, partition, friction, damage, shape, scaling, transfer] = step;
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("dt = " + std::to_string(dt) + ": must be > 0");
  if (particles.dim() != Dim)
    throw std::invalid_argument("particles in " + std::to_string(particles.dim())
                                + " directions on a grid of " + std::to_string(Dim));
  if (_materials.empty())
    throw std::invalid_argument("materials: at least one material is needed");
  for (const auto& m : _materials)
    if (!m)
      throw std::invalid_argument("materials: a material is missing");
  _fracture = per_material(std::move(fracture), _materials.size());
  // Orders within a cell and tie-breaks go by the index: by the id, in this order.
  particles.check_order();

  const auto nmat = static_cast<std::int32_t>(_materials.size());
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.material[i] < 0 || particles.material[i] >= nmat)
      throw std::invalid_argument("particle " + std::to_string(i) + ": material index "
                                  + std::to_string(particles.material[i]) + " out of range");
  // The models' state, then the phase field's (only where something cracks).
  for (const auto& m : _materials)
    for (const ColumnSpec& c : m->columns(particles.dim()))
      particles.add(c);
  const bool cracks = std::any_of(_fracture.begin(), _fracture.end(),
                                  [](const auto& f) { return f.has_value(); });
  const bool fourth = std::any_of(_fracture.begin(), _fracture.end(),
                                  [](const auto& f) { return f && f->fourth_order(); });
  if (cracks)
    for (const ColumnSpec& c : PhaseFieldDeclarations::columns(fourth))
      particles.add(c);
  if (transfer == TransferScheme::apic)
    particles.add(affine_column(particles.dim()));
  if (grid.has_particle_regions())
    particles.add({"held_by", 1, DType::i32, {0.0},
                   "bit k set where the particle belongs to prescribed region k (a body, its face "
                   "or a set of particles), whose nodes it holds",
                   "", ""});

  const double max_mass = particles.size() == 0
                              ? 0.0
                              : *std::max_element(particles.mass.begin(), particles.mass.end());
  // Nodes lighter than this carry no velocity: dividing by their mass would
  // amplify round-off (a particle at the edge of a node's support).
  _mass_tol = 1e-12 * max_mass;
  _bodies = particles.size() == 0 ? 0 : *std::max_element(particles.body.begin(), particles.body.end()) + 1;
  set_owned_slabs(0, num_slabs(grid.nodes()[0]));

  if (shape == ShapeFunctions::cpdi)
  {
    if (grid.degree() != 1)
      throw std::invalid_argument("CPDI runs on the degree-1 grid, not degree "
                                  + std::to_string(grid.degree()));
    const auto cells = grid.cells();
    if (*std::min_element(cells.begin(), cells.end()) < CpdiStencil<Dim>::width - 1)
      throw std::invalid_argument("CPDI needs at least 3 cells a side");
    if (!(scaling.c_failed >= 0.0 && scaling.c_failed < 1.0))
      throw std::invalid_argument("CPDI failed phase field c = " + std::to_string(scaling.c_failed)
                                  + ": must lie in [0, 1)");
    for (const ColumnSpec& c : ParticleDomains<Dim>::columns())
      particles.add(c);
    grid.set_block(NodeBlock{CpdiStencil<Dim>::lower, CpdiStencil<Dim>::width});
    _domains.emplace(grid.h(), scaling);
  }
  if (partition == Partition::single && !friction.empty())
    throw std::invalid_argument("friction: one velocity field has no contact to take it");
  if (partition != Partition::single && friction.empty())
    throw std::invalid_argument("friction: the contact of discrete fields needs the matrix between them");
  if (partition == Partition::bodies)
    _fields.template emplace<BodyFields<Dim>>(grid, particles, std::move(friction));
  if (partition == Partition::damage_gradient)
  {
    // Each material's damage: a damage model's column, else the phase field's.
    std::vector<DamageSource> source;
    for (std::size_t m = 0; m < _materials.size(); ++m)
    {
      const auto columns = _materials[m]->columns(particles.dim());
      const bool column = std::any_of(columns.begin(), columns.end(),
                                      [](const ColumnSpec& c) { return c.name == "damage"; });
      source.push_back(column          ? DamageSource::column
                       : _fracture[m] ? DamageSource::phase_field
                                      : DamageSource::none);
    }
    _fields.template emplace<DamageFields<Dim>>(grid, particles, std::move(friction),
                                                std::move(source), std::move(damage));
  }
  {
    if (!cracks)
      return;
    // The phase fields: one over all crackable particles, or with discrete
    // fields one per crackable body (K&T eq. 28), each from its own particles
    // (with damage-gradient fields, one per crackable contact group).
    const std::int32_t* field_of = phase_field_of();
    std::vector<char> crackable_body;
    bool all_crackable = true;
    for (std::size_t p = 0; p < particles.size(); ++p)
    {
      const bool c = _fracture[particles.material[p]].has_value();
      all_crackable = all_crackable && c;
      const std::size_t b = static_cast<std::size_t>(field_of[p]);
      if (c && b >= crackable_body.size())
        crackable_body.resize(b + 1, 0);
      if (c)
        crackable_body[b] = 1;
    }
    if (std::holds_alternative<SingleField>(_fields))
      _phase.push_back(PhaseFieldGroup{PhaseField<Dim>(grid, _fracture, tol, max_iterations), -1,
                                       !all_crackable, {}});
    else
      for (std::size_t b = 0; b < crackable_body.size(); ++b)
        if (crackable_body[b])
          _phase.push_back(PhaseFieldGroup{PhaseField<Dim>(grid, _fracture, tol, max_iterations),
                                           static_cast<std::int32_t>(b), true, {}});
  }
}

template <int Dim>
const std::int32_t* Solver<Dim>::phase_field_of() const
{
  if (const auto* d = damage_fields())
    return d->group().data();
  return _particles.body.data();
}

template <int Dim>
void Solver<Dim>::set_stability_length(double length)
{
  if (!(length >= 0.0) || !std::isfinite(length))
    throw std::invalid_argument("stability length = " + std::to_string(length)
                                + ": must be >= 0 and finite");
  _stability_length = length;
}

template <int Dim>
void Solver<Dim>::set_touch_fill(double fill)
{
  if (!(fill >= 0.0 && fill <= 1.0))
    throw std::invalid_argument("touch_fill = " + std::to_string(fill) + ": must lie in [0, 1]");
  _touch_fill = fill;
}

template <int Dim>
void Solver<Dim>::set_mass_tol(double tol)
{
  if (!(tol >= 0.0) || !std::isfinite(tol))
    throw std::invalid_argument("mass_tol = " + std::to_string(tol) + ": must be >= 0 and finite");
  _mass_tol = tol;
}

template <int Dim>
void Solver<Dim>::set_owned_slabs(std::int64_t first, std::int64_t last)
{
  const std::int64_t slabs = num_slabs(_grid.nodes()[0]);
  if (!(0 <= first && first <= last && last <= slabs))
    throw std::invalid_argument("owned slabs [" + std::to_string(first) + ", " + std::to_string(last)
                                + "): must lie in [0, " + std::to_string(slabs) + ")");
  _slab_first = first;
  _slab_last = last;
  _slab_sums.assign(GridUpdate<Dim>::size * (last - first), 0.0);
  total_slab_sums();
}

template <int Dim>
void Solver<Dim>::total_slab_sums()
{
  Energies<Dim> e;
  double friction_work = 0.0;
  GridTotals<Dim>(_slab_sums).into(e, friction_work);
  _external_work = e.external_work;
  _wall_work = e.wall_work;
  _wall_impulse = e.wall_impulse;
  _region_work = e.region_work;
  _region_impulse = e.region_impulse;
  _pair_impulse = e.pair_impulse;
  std::visit(
      [&](auto& fields)
      {
        if constexpr (std::decay_t<decltype(fields)>::discrete)
          fields.stats().friction_work = friction_work;
      },
      _fields);
}

template <int Dim>
template <class Self, class Visit>
void Solver<Dim>::each_scalar(Self& s, Visit&& visit)
{
  visit("time", s._time);
  visit("step", s._step);
  visit("external_work", s._external_work);
  visit("wall_work", s._wall_work);
  for (int side = 0; side < num_sides(Dim); ++side)
    for (int d = 0; d < Dim; ++d)
      visit(wall_impulse_key(side, d), s._wall_impulse[side][d]);
  for (int k = 0; k < max_regions; ++k)
  {
    visit(region_key(k, "work"), s._region_work[k]);
    for (int d = 0; d < Dim; ++d)
      visit(region_key(k, "impulse") + component(d), s._region_impulse[k][d]);
    for (int d = 0; d < Dim; ++d)
      visit(region_key(k, "displacement") + component(d), s._region_displacement[k][d]);
  }
  visit("light_nodes", s._light_nodes);
}

template <int Dim>
SolverState Solver<Dim>::state() const
{
  SolverState s;
  each_scalar(*this, [&](const std::string& key, const auto& value)
              { s.scalars[key] = static_cast<double>(value); });
  // Every slab's sums, zero where another process owns the slab.
  std::vector<double>& slabs = s.arrays[slab_key];
  slabs.assign(GridUpdate<Dim>::size * num_slabs(_grid.nodes()[0]), 0.0);
  std::copy(_slab_sums.begin(), _slab_sums.end(), slabs.begin() + GridUpdate<Dim>::size * _slab_first);
  for (std::size_t k = 0; k < _phase.size(); ++k)
  {
    PhaseFieldState pf = _phase[k].field.state();
    s.arrays[phase_key(k, "c")] = std::move(pf.c);
    s.arrays[phase_key(k, "c_previous")] = std::move(pf.c_previous);
    PhaseFieldStats::each([&](const char* name, PhaseFieldStats::Combine, const auto& value)
                          { s.scalars[phase_key(k, name)] = static_cast<double>(value); },
                          pf.stats);
  }
  if (const ContactStats* c = contact_stats())
  {
    ContactStats::each([&](const char* name, const auto& value)
                       { s.scalars[std::string("contact/") + name] = static_cast<double>(value); },
                       damage_fields() != nullptr, *c);
    std::vector<double>& impulse = s.arrays["contact/pair_impulse"];
    for (const auto& pair : _pair_impulse)
      impulse.insert(impulse.end(), pair.begin(), pair.end());
  }
  return s;
}

template <int Dim>
void Solver<Dim>::restore(const SolverState& state)
{
  // The particles restored beside this state: in ascending id order, as at construction.
  _particles.check_order();
  // What this solver's state has: the same keys, arrays of the same sizes.
  const SolverState mine = this->state();
  // Before the sums by slab (checkpoints before version 8) the works and
  // impulses were totals: they go into the first owned slab.
  const bool slabs = state.arrays.count(slab_key) > 0;
  for (const auto& [key, value] : state.scalars)
    if (!mine.scalars.count(key))
      throw std::invalid_argument("solver state: " + key + " is not part of this run's state"
                                  " (a scene with another [contact] table, bodies or fracture)");
  for (const auto& [key, value] : state.arrays)
    if (!mine.arrays.count(key))
      throw std::invalid_argument("solver state: " + key + " is not part of this run's state"
                                  " (a scene with another [contact] table, bodies or fracture)");
  for (const auto& [key, value] : mine.scalars)
    if (!state.scalars.count(key))
      throw std::invalid_argument("solver state: " + key + " is missing");
  for (const auto& [key, value] : mine.arrays)
  {
    const auto it = state.arrays.find(key);
    if (it == state.arrays.end() && key == slab_key)
      continue;
    if (it == state.arrays.end())
      throw std::invalid_argument("solver state: " + key + " is missing");
    if (it->second.size() != value.size())
      throw std::invalid_argument("solver state: " + key + " has " + std::to_string(it->second.size())
                                  + " values for a grid of " + std::to_string(value.size()));
  }
  const double time = state.scalars.at("time"), step = state.scalars.at("step");
  if (!(time >= 0.0) || !std::isfinite(time) || !(step >= 0.0))
    throw std::invalid_argument("solver state: step " + std::to_string(step) + " at t = "
                                + std::to_string(time));
  for (std::size_t k = 0; k < _phase.size(); ++k)
  {
    PhaseFieldStats stats;
    PhaseFieldStats::each(
        [&](const char* name, PhaseFieldStats::Combine, auto& value)
        { value = static_cast<std::decay_t<decltype(value)>>(state.scalars.at(phase_key(k, name))); },
        stats);
    _phase[k].field.restore(PhaseFieldState{state.arrays.at(phase_key(k, "c")),
                                            state.arrays.at(phase_key(k, "c_previous")), stats});
  }
  if (auto* fields = std::get_if<DamageFields<Dim>>(&_fields))
    fields->forget(); // the particles' gradients were restored beside this state
  if (const ContactStats* stats = contact_stats())
  {
    ContactStats& c = const_cast<ContactStats&>(*stats);
    ContactStats::each(
        [&](const char* name, auto& value)
        { value = static_cast<std::decay_t<decltype(value)>>(state.scalars.at(std::string("contact/") + name)); },
        damage_fields() != nullptr, c);
    const std::vector<double>& impulse = state.arrays.at("contact/pair_impulse");
    for (int q = 0; q < max_field_pairs; ++q)
      std::copy_n(&impulse[Dim * q], Dim, _pair_impulse[q].begin());
  }
  each_scalar(*this, [&](const std::string& key, auto& value)
              { value = static_cast<std::decay_t<decltype(value)>>(state.scalars.at(key)); });
  using U = GridUpdate<Dim>;
  if (slabs)
  {
    const std::vector<double>& all = state.arrays.at(slab_key);
    std::copy_n(all.begin() + U::size * _slab_first, _slab_sums.size(), _slab_sums.begin());
  }
  else if (!_slab_sums.empty())
  {
    std::fill(_slab_sums.begin(), _slab_sums.end(), 0.0);
    double* first = _slab_sums.data();
    first[U::external_work] = _external_work;
    first[U::wall_work] = _wall_work;
    constexpr int sides = Grid<Dim>::sides;
    for (int side = 0; side < sides; ++side)
      std::copy_n(_wall_impulse[side].begin(), Dim, &first[U::hold_impulse + Dim * side]);
    for (int k = 0; k < max_regions; ++k)
    {
      first[U::region_work + k] = _region_work[k];
      std::copy_n(_region_impulse[k].begin(), Dim, &first[U::hold_impulse + Dim * (sides + k)]);
    }
    for (int q = 0; q < max_field_pairs; ++q)
      std::copy_n(_pair_impulse[q].begin(), Dim, &first[U::pair_impulse + Dim * q]);
    if (const ContactStats* c = contact_stats())
      first[U::friction_work] = c->friction_work;
  }
  total_slab_sums();
  for (int k = 0; k < static_cast<int>(_grid.regions().size()); ++k)
    _grid.move_region(k, _region_displacement[k]);
}

namespace
{
/// A type as a value, for dispatch.
template <class T>
struct Tag
{
  using type = T;
};
} // namespace

template <int Dim>
template <class F>
void Solver<Dim>::dispatch(F&& f)
{
  auto with_transfer = [&](auto shape, auto& fields)
  {
    if (_transfer == TransferScheme::apic)
      f(shape, fields, std::true_type{});
    else
      f(shape, fields, std::false_type{});
  };
  std::visit(
      [&](auto& fields)
      {
        if (_domains)
          return with_transfer(Tag<CpdiStencil<Dim>>{}, fields);
        switch (_grid.degree())
        {
        case 1:
          with_transfer(Tag<BSplineStencil<Dim, 1>>{}, fields);
          break;
        case 2:
          with_transfer(Tag<BSplineStencil<Dim, 2>>{}, fields);
          break;
        default:
          with_transfer(Tag<BSplineStencil<Dim, 3>>{}, fields);
        }
      },
      _fields);
}

template <int Dim>
Points Solver<Dim>::points() const
{
  if (_domains)
    return Points{_particles.x.data(), _domains->r(0), _domains->r(1),
                  Dim == 3 ? _domains->r(Dim - 1) : nullptr};
  return Points{_particles.x.data()};
}

template <int Dim>
void Solver<Dim>::advance(std::int64_t steps)
{
  // P2G skips the external force when there is none (fext only changes
  // between calls).
  _external = has_external_force();
  bind();
  // The user's thread count, restored on return (also when a step throws).
  struct Restore
  {
    int threads;
    ~Restore() { omp_set_num_threads(threads); }
  } restore{omp_get_max_threads()};
  // The calling thread's wait for a core so far: read once a step, its end
  // the next step's start.
  const RunQueueWait waits;
  double waited = _adaptive_threads ? waits.seconds() : 0.0;
  dispatch(
      [&](auto shape, auto& fields, auto affine)
      {
        for (std::int64_t k = 0; k < steps; ++k)
        {
          if (_adaptive_threads)
            omp_set_num_threads(_threads.next(restore.threads));
          const double start = omp_get_wtime();
          constexpr bool apic = decltype(affine)::value;
          step<typename decltype(shape)::type, apic>(fields, k + 1 == steps); // energy in the last
          if (_adaptive_threads)
          {
            const double now = waits.seconds();
            _threads.record(omp_get_wtime() - start, now - waited);
            waited = now;
          }
        }
      });
}

template <int Dim>
void Solver<Dim>::prepare()
{
  bind();
  dispatch([&](auto shape, auto& fields, auto)
           { prepare<typename decltype(shape)::type>(fields, true); });
}

template <int Dim>
void Solver<Dim>::bind()
{
  _bound.clear();
  for (const auto& m : _materials)
    _bound.push_back(m->bind(_particles));
  if (_domains)
    _domains->bind(_particles);
  _degradation_of.assign(_materials.size(), Degradation{});
  _degradation.assign(_materials.size(), nullptr);
  if (_phase.empty())
    return;
  const double* c = _particles.f64("c").data();
  double* history = _particles.f64("history").data();
  for (std::size_t m = 0; m < _materials.size(); ++m)
    if (_fracture[m])
    {
      _degradation_of[m] = Degradation{_fracture[m]->k_f, c, history};
      _degradation[m] = &_degradation_of[m];
    }
}

template <int Dim>
const std::vector<std::vector<std::int64_t>>& Solver<Dim>::region_cells()
{
  const auto& regions = _grid.regions();
  const std::vector<std::int64_t>& start = _sort.cell_start();
  const std::vector<std::int32_t>& order = _sort.order();
  const Column* column = _particles.find("held_by");
  if (!column)
    throw std::logic_error("particle regions need the particle column held_by");
  const std::int32_t* held_by = column->i32.data();
  _region_cells.resize(regions.size());
  for (std::size_t k = 0; k < regions.size(); ++k)
  {
    std::vector<std::int64_t>& offsets = _region_cells[k];
    if (!regions[k].particles)
    {
      offsets.clear();
      continue;
    }
    offsets.assign(start.size(), 0);
    for (std::size_t c = 0; c + 1 < start.size(); ++c)
    {
      std::int64_t members = 0;
      for (std::int64_t i = start[c]; i < start[c + 1]; ++i)
        members += (held_by[order[i]] >> k) & 1;
      offsets[c + 1] = offsets[c] + members;
    }
  }
  return _region_cells;
}

template <int Dim>
template <class Shape, class Fields>
void Solver<Dim>::prepare(Fields& fields, bool energy)
{
  constexpr int P = Shape::degree;
  {
    Stopwatch clock{_timers.sort};
    if (const std::size_t outside = _sort.sort(_grid, _particles.x); outside < _particles.size())
      throw SimulationError(where(outside) + " is outside the grid");
    if (_grid.has_particle_regions())
      _grid.activate(_sort.cell_start(), region_cells());
    else
      _grid.activate(_sort.cell_start());
  }
  for (std::size_t k = 0; k < _phase.size(); ++k)
  {
    Stopwatch clock{_timers.phase_field};
    PhaseFieldGroup& g = _phase[k];
    if (g.select)
    {
      const std::int32_t* body = phase_field_of();
      const std::int32_t* material = _particles.material.data();
      g.sort.select(_sort, [&](std::size_t p)
                    { return _fracture[material[p]] && (g.body < 0 || body[p] == g.body); });
    }
    const CellSort& sort = g.select ? g.sort : _sort;
    const bool converged = g.field.template solve<P>(_particles, sort, energy);
    // The materials degrade their stresses with the new phase field (K&T eqs. 14-16).
    const std::int32_t* order = sort.order().data();
    const std::int64_t* start = sort.cell_start().data();
    const auto ncells = static_cast<std::ptrdiff_t>(sort.cell_start().size()) - 1;
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t c = 0; c < ncells; ++c)
      for_each_material_run(_particles.material.data(), order, start[c], start[c + 1],
                            [&](std::int32_t m, const Batch& b)
                            { _bound[m]->stress(b, *_degradation[m]); });
    if (!converged)
    {
      const PhaseFieldStats& s = g.field.stats();
      std::ostringstream msg;
      msg << "phase field" << (g.body >= 0 ? " of body " + std::to_string(g.body) : std::string());
      msg << (g.field.bounded() ? ": the bounded solve (MPRGP after the active-set passes)"
                                : ": conjugate gradients")
          << " stopped at relative residual " << s.last_residual << " > tol = " << g.field.tol()
          << " after " << s.last_iterations << " iterations";
      msg << ", at the start of the step after step " << _step << " (t = " << _time << ")";
      throw SimulationError(msg.str());
    }
  }
  // The integration domains, after the phase field (failed particles' are
  // scaled), before the velocity fields, whose partition may read them.
  if constexpr (Shape::domains)
    check_domains();
  // The velocity fields, after the phase field: damage-gradient fields read
  // the new c (Remark 4; H&H Algorithms 1 and 2).
  if constexpr (Fields::discrete)
  {
    Stopwatch clock{_timers.fields};
    if constexpr (Fields::per_pair)
      fields.build(_particles, _sort, points());
    else
      fields.build(_particles, _sort);
  }
}

template <int Dim>
void Solver<Dim>::check_domains() const
{
  const std::size_t n = _particles.size();
  if (_step == 0)
    if (const std::size_t p = _domains->oversized(n); p < n)
    {
      std::ostringstream msg;
      msg << "particle " << p << ": CPDI domain with half-edges " << _domains->describe(p)
          << " is wider than a cell (h = " << _grid.h() << ") or not positively oriented at t = 0";
      throw std::invalid_argument(msg.str());
    }
  // The integration domains of this step (failed particles scaled), each
  // within the cells next to its particle's.
  if (const std::size_t p = _domains->update(_grid, _particles.x.data(), n); p < n)
    throw SimulationError("the CPDI domain of " + where(p) + ", half-edges "
                          + _domains->describe(p) + ", reaches past the cells next to its own");
}

template <int Dim>
template <class Shape, bool Affine, class Fields>
void Solver<Dim>::step(Fields& fields, bool energy)
{
  prepare<Shape>(fields, energy);
  {
    Stopwatch clock{_timers.p2g};
    particle_to_grid<Shape, Affine>(fields);
  }
  using U = GridUpdate<Dim>;
  std::vector<std::array<double, U::size>> slabs;
  {
    Stopwatch clock{_timers.grid};
    slabs = update_grid(_grid, fields, _sums, _surface, _kinematics, _dt, _mass_tol, _touch_fill);
  }
  // The owned slabs' sums: each slab's over the steps (the works and
  // impulses total them in slab order), and the step's counts, which are
  // integers and so exact in any order.
  std::array<double, U::size> sums{};
  for (std::int64_t s = _slab_first; s < _slab_last; ++s)
    for (int k = 0; k < U::size; ++k)
    {
      _slab_sums[U::size * (s - _slab_first) + k] += slabs[s][k];
      sums[k] += slabs[s][k];
    }
  total_slab_sums();
  constexpr int sides = Grid<Dim>::sides;
  const std::vector<Region<Dim>>& regions = _grid.regions();
  for (std::size_t k = 0; k < regions.size(); ++k)
  {
    for (int d = 0; d < Dim; ++d)
      if (regions[k].components & (1 << d))
        _region_displacement[k][d] += _dt * _grid.holder_velocity()[sides + k][d];
    _grid.move_region(static_cast<int>(k), _region_displacement[k]);
  }
  _light_nodes += static_cast<std::int64_t>(sums[U::light]);
  if constexpr (Fields::discrete)
  {
    ContactStats& c = fields.stats();
    c.nodes = static_cast<std::int32_t>(sums[U::contact + count_nodes]);
    c.pairs += static_cast<std::int64_t>(sums[U::contact + count_pairs]);
    c.active += static_cast<std::int64_t>(sums[U::contact + count_active]);
    c.sliding += static_cast<std::int64_t>(sums[U::contact + count_sliding]);
    for (int i = 0; i < 4; ++i)
      c.violations[i] += static_cast<std::int64_t>(sums[U::contact + count_c1 + i]);
    c.split = static_cast<std::int32_t>(sums[U::contact + count_split]);
    c.separable = static_cast<std::int32_t>(sums[U::contact + count_separable]);
    c.separable_total += c.separable;
  }
  {
    Stopwatch clock{_timers.g2p};
    grid_to_particle<Shape, Affine>(fields, energy);
  }
  _time += _dt;
  ++_step;
}

namespace
{
/// Per particle, the field index a partition reads: the body, or with
/// damage-gradient fields the contact group.
template <class Fields>
const std::int32_t* field_of_particles(const Fields& fields, const Particles& particles)
{
  if constexpr (Fields::per_pair)
    return fields.group().data();
  else
    return particles.body.data();
}
} // namespace

template <int Dim>
template <class Shape, bool Affine, class Fields>
void Solver<Dim>::particle_to_grid(Fields& fields)
{
  std::size_t slots = static_cast<std::size_t>(_grid.num_active());
  if constexpr (Fields::discrete)
    slots = static_cast<std::size_t>(fields.num_slots());
  _sums.resize(slots);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(slots); ++a)
    _sums[a] = NodeSums<Dim>{};
  if constexpr (Fields::discrete)
    _surface.assign(slots, SurfaceSums<Dim>{});
  const Particles& P_ = _particles;
  P2GArrays arrays{P_.v.data(), P_.mass.data(), P_.volume.data(), P_.stress.data(),
                   P_.fext.data(), nullptr, nullptr};
  if constexpr (Fields::per_pair)
  {
    arrays.damage = fields.damage();
    arrays.full = fields.full();
  }
  if constexpr (Affine)
    arrays.affine = P_.f64("affine").data();
  auto run = [&](auto external)
  {
    constexpr bool External = decltype(external)::value;
    pfmpm::particle_to_grid<Shape>(
        _grid, _sort, points(),
        MomentumP2G<Shape, External, Fields, Affine>{
            _grid, fields, arrays, field_of_particles(fields, _particles), _sums.data(), _surface.data()});
  };
  if (_external)
    run(std::true_type{});
  else
    run(std::false_type{});
}

template <int Dim>
template <class Shape, bool Affine, class Fields>
void Solver<Dim>::grid_to_particle(Fields& fields, bool stress)
{
  const bool check_stability = _stability_length > 0.0;
  const ParticleDomains<Dim>* domains = _domains ? &*_domains : nullptr;
  KinematicsG2P<Shape, Fields, Affine> kernel{_grid,
                                              fields,
                                              _kinematics.data(),
                                              _particles,
                                              _bound,
                                              _degradation,
                                              domains,
                                              _dt,
                                              field_of_particles(fields, _particles),
                                              stress,
                                              Affine ? _particles.f64("affine").data() : nullptr,
                                              _particles.size()};
  pfmpm::grid_to_particle<Shape>(_grid, _sort, points(), kernel);
  if (kernel.bad < _particles.size())
    non_finite(kernel.bad);
  if constexpr (Fields::per_pair)
    fields.moved(_dt * std::sqrt(kernel.drift2)); // the neighbour lists' skin (H&H section 2.5)
  // max c_p + max |v_p| bounds max (c_p + |v_p|) without a square root per
  // particle; only a step whose bound exceeds the limit takes the exact maximum.
  if (check_stability && _dt * (kernel.wave + std::sqrt(kernel.speed2)) > stability_limit())
    check_stability_exactly();
}

template <int Dim>
std::string Solver<Dim>::where(std::size_t i) const
{
  std::ostringstream s;
  s << "particle " << i << " (id " << _particles.id[i] << ", body " << _particles.body[i] << ") at x = (";
  for (int d = 0; d < Dim; ++d)
    s << (d ? ", " : "") << _particles.x[Dim * i + d];
  s << ") during the step after step " << _step << " (t = " << _time << ")";
  return s.str();
}

template <int Dim>
void Solver<Dim>::non_finite(std::size_t p) const
{
  auto finite = [](const std::vector<double>& a, std::size_t begin, std::size_t k)
  { return std::all_of(&a[begin], &a[begin] + k, [](double u) { return std::isfinite(u); }); };
  const Particles& s = _particles;
  constexpr int T = symmetric_size(Dim);
  const char* what = !finite(s.v, Dim * p, Dim)      ? "velocity"
                     : !finite(s.x, Dim * p, Dim)    ? "position"
                     : !finite(s.stress, T * p, T) ? "stress"
                                                   : "material state (strain, history)";
  throw SimulationError(std::string(what) + " of " + where(p) + " is not finite");
}

template <int Dim>
double Solver<Dim>::signal_speed(std::size_t p) const
{
  return _bound[_particles.material[p]]->wave_speed(p)
         + std::sqrt(squared_length<Dim>(&_particles.v[Dim * p]));
}

template <int Dim>
double Solver<Dim>::max_signal_speed() const
{
  const auto n = static_cast<std::ptrdiff_t>(_particles.size());
  double fastest = 0.0;
#pragma omp parallel for schedule(static) reduction(max : fastest)
  for (std::ptrdiff_t p = 0; p < n; ++p)
    fastest = std::max(fastest, signal_speed(p));
  return fastest;
}

template <int Dim>
double Solver<Dim>::fastest_signal()
{
  bind();
  return max_signal_speed();
}

template <int Dim>
void Solver<Dim>::check_stability_exactly() const
{
  const double fastest = max_signal_speed();
  if (_dt * fastest <= stability_limit())
    return;
  std::size_t p = 0; // the first particle that fast
  while (p + 1 < _particles.size() && signal_speed(p) < fastest)
    ++p;
  const double speed = std::sqrt(squared_length<Dim>(&_particles.v[Dim * p]));
  std::ostringstream msg;
  msg << "time step dt = " << _dt << " became unstable: " << where(p)
      << " has P-wave speed " << fastest - speed << " and speed " << speed
      << ", so dt (c + |v|) = " << _dt * fastest << " exceeds the stability limit "
      << _stability_length << " (kappa h); lower time.cfl or time.dt";
  throw SimulationError(msg.str());
}

template <int Dim>
std::map<std::string, std::string> Solver<Dim>::dissipation_columns() const
{
  std::map<std::string, std::string> kept; // column -> kind
  for (const auto& m : _materials)
    for (const ColumnSpec& c : m->columns(_particles.dim()))
      if (!c.dissipation.empty())
        kept.emplace(c.name, c.dissipation);
  return kept;
}

template <int Dim>
int Solver<Dim>::TileLayout::width() const
{
  return TileColumns<Dim>::core + dissipated + bodies + moving;
}

template <int Dim>
typename Solver<Dim>::TileLayout Solver<Dim>::tile_layout() const
{
  TileLayout layout;
  layout.dissipated = static_cast<int>(dissipation_columns().size());
  // The fracture energy per body, with contact; the momentum per body, with more than one.
  layout.bodies = contact_stats() && _particles.find("fracture_energy") ? _bodies : 0;
  layout.moving = _bodies > 1 ? Dim * _bodies : 0;
  return layout;
}

template <int Dim>
TileSums Solver<Dim>::tile_sums() const
{
  using C = TileColumns<Dim>;
  const auto n = _particles.size();
  const Particles& P = _particles;
  const Column* fracture = P.find("fracture_energy");
  const double* fe = fracture ? fracture->f64.data() : nullptr;
  std::vector<std::unique_ptr<Material::Bound>> bound;
  for (const auto& m : _materials)
    bound.push_back(m->bind(const_cast<Particles&>(P))); // read only
  std::vector<Degradation> degradation(_materials.size());
  std::vector<const Degradation*> by_material(_materials.size(), nullptr);
  if (!_phase.empty())
    for (std::size_t m = 0; m < _materials.size(); ++m)
      if (_fracture[m])
      {
        degradation[m] = Degradation{_fracture[m]->k_f, P.f64("c").data(), nullptr};
        by_material[m] = &degradation[m];
      }
  // With APIC, the angular momentum of each particle's affine velocity.
  const Column* affine = P.find("affine");
  const double* B = affine ? affine->f64.data() : nullptr;
  std::vector<const double*> dissipated;
  for (const auto& [column, kind] : dissipation_columns())
    dissipated.push_back(P.f64(column).data());
  const TileLayout layout = tile_layout();
  const int ndissipated = layout.dissipated, bodies = layout.bodies, moving = layout.moving;
  const int by_body = C::core + ndissipated + bodies; // the first momentum per body
  const std::int32_t* body = P.body.data();
  // Every sum runs by tile of cells, so that a process holding some whole
  // tiles adds its particles as one holding all of them would.
  CellSort tiles;
  if (const std::size_t outside = tiles.sort<Dim, tile_cells>(_grid, P.x); outside < n)
    throw SimulationError(where(outside) + " is outside the grid");
  return pfmpm::tile_sums(
      tiles, layout.width(),
      [&](const std::int32_t* order, std::int64_t begin, std::int64_t end, double* acc)
      {
        for (std::int64_t k = begin; k < end; ++k)
        {
          const auto p = static_cast<std::size_t>(order[k]);
          const double m = P.mass[p];
          const double* x = &P.x[Dim * p];
          const double* v = &P.v[Dim * p];
          acc[C::kinetic] += 0.5 * m * squared_length<Dim>(v);
          acc[C::mass] += m;
          if (fe)
            acc[C::fracture] += fe[p];
          for (int d = 0; d < Dim; ++d)
            acc[C::momentum + d] += m * v[d];
          // (x_p x v_p)_a, and with APIC eps_abc (B_p)_cb
          for (int a = C::first_axis; a < 3; ++a)
          {
            const int b = (a + 1) % 3, c = (a + 2) % 3;
            acc[C::angular + a] += m * (x[b] * v[c] - x[c] * v[b]);
            if (B)
              acc[C::angular + a] += m * (B[Dim * (Dim * p + c) + b] - B[Dim * (Dim * p + b) + c]);
          }
          for (int w = 0; w < ndissipated; ++w)
            acc[C::core + w] += dissipated[w][p];
          if (bodies)
            acc[C::core + ndissipated + body[p]] += fe[p];
          if (moving)
            for (int d = 0; d < Dim; ++d)
              acc[by_body + Dim * body[p] + d] += m * v[d];
        }
        // The elastic energy of each run of one material in the tile's (id) order.
        for_each_material_run(P.material.data(), order, begin, end,
                              [&](std::int32_t mat, const Batch& batch)
                              { bound[mat]->add_energy(batch, by_material[mat], acc[C::elastic]); });
      });
}

template <int Dim>
Energies<Dim> Solver<Dim>::energies() const
{
  return energies_of(tile_sums(), _slab_sums);
}

template <int Dim>
Energies<Dim> Solver<Dim>::energies_of(const TileSums& tiles, const std::vector<double>& slabs) const
{
  using C = TileColumns<Dim>;
  const std::vector<double> sums = fold_tiles(tiles);
  const std::map<std::string, std::string> kept = dissipation_columns();
  const TileLayout layout = tile_layout();
  const int bodies = layout.bodies, moving = layout.moving;
  if (tiles.width != layout.width())
    throw std::invalid_argument("tile sums: " + std::to_string(tiles.width) + " per tile for "
                                + std::to_string(C::core) + " sums, " + std::to_string(kept.size())
                                + " dissipation columns and " + std::to_string(_bodies) + " bodies");
  if (slabs.size() % GridUpdate<Dim>::size != 0)
    throw std::invalid_argument("slab sums: " + std::to_string(slabs.size()) + " values, not a multiple of "
                                + std::to_string(GridUpdate<Dim>::size));
  Energies<Dim> e;
  e.kinetic = sums[C::kinetic];
  e.elastic = sums[C::elastic];
  e.fracture = sums[C::fracture];
  // The work the models dissipated, summed per kind over the columns that
  // keep it per particle (ColumnSpec::dissipation), each column once.
  int w = C::core;
  for (const auto& [column, kind] : kept)
    e.dissipation[kind] += sums[w++];
  double friction_work = 0.0;
  GridTotals<Dim>(slabs).into(e, friction_work);
  e.region_displacement = _region_displacement;
  std::copy_n(&sums[C::momentum], Dim, e.momentum.begin());
  if constexpr (Dim == 2)
    e.angular_momentum = sums[C::angular + 2];
  else
    std::copy_n(&sums[C::angular], 3, e.angular_momentum.begin());
  e.mass = sums[C::mass];
  if (contact_stats())
  {
    // Fracture energy per body (with damage-gradient fields too).
    e.friction_work = friction_work;
    e.fracture_by_field.assign(_bodies, 0.0);
    std::copy_n(&sums[w], bodies, e.fracture_by_field.begin());
    e.fracture = 0.0;
    for (double f : e.fracture_by_field)
      e.fracture += f;
  }
  e.momentum_by_body.assign(sums.begin() + w + bodies, sums.begin() + w + bodies + moving);
  return e;
}

template <int Dim>
bool Solver<Dim>::fourth_order() const
{
  return !_phase.empty() && _phase.front().field.fourth_order();
}

template <int Dim>
void Solver<Dim>::set_phase_field_preconditioner(Preconditioner preconditioner)
{
  for (PhaseFieldGroup& g : _phase)
    g.field.set_preconditioner(preconditioner);
}

template <int Dim>
Preconditioner Solver<Dim>::phase_field_preconditioner() const
{
  return _phase.empty() ? Preconditioner::automatic : _phase.front().field.preconditioner();
}

template <int Dim>
PhaseFieldSystem Solver<Dim>::phase_field_system() const
{
  if (_phase.size() != 1)
    throw std::logic_error("phase_field_system: the run has " + std::to_string(_phase.size())
                           + " phase fields, not one");
  return _phase.front().field.system();
}

template <int Dim>
bool Solver<Dim>::bounded() const
{
  return !_phase.empty() && _phase.front().field.bounded();
}

template <int Dim>
PhaseFieldStats Solver<Dim>::phase_field_stats() const
{
  PhaseFieldStats total;
  for (const PhaseFieldGroup& g : _phase)
  {
    PhaseFieldStats::each(
        [](const char*, PhaseFieldStats::Combine how, auto& sum, const auto& value)
        { sum = how == PhaseFieldStats::Combine::sum ? sum + value : std::max(sum, value); },
        total, g.field.stats());
  }
  return total;
}

template <int Dim>
const ContactStats* Solver<Dim>::contact_stats() const
{
  if (const auto* fields = std::get_if<BodyFields<Dim>>(&_fields))
    return &fields->stats();
  if (const auto* fields = std::get_if<DamageFields<Dim>>(&_fields))
    return &fields->stats();
  return nullptr;
}

template <int Dim>
std::vector<double> Solver<Dim>::detect_surfaces(const std::vector<double>& spacing, double threshold)
{
  if (auto* fields = std::get_if<DamageFields<Dim>>(&_fields))
  {
    if (const std::size_t outside = _sort.sort(_grid, _particles.x); outside < _particles.size())
      throw SimulationError(where(outside) + " is outside the grid");
    return fields->detect_surfaces(_particles, _sort, spacing, threshold);
  }
  throw std::logic_error("surface detection needs the damage-gradient partition");
}

template <int Dim>
bool Solver<Dim>::has_external_force() const
{
  return std::any_of(_particles.fext.begin(), _particles.fext.end(),
                     [](double f) { return f != 0.0; });
}

template <int Dim>
void Solver<Dim>::set_velocity_gradients(const std::vector<double>& G)
{
  if (_transfer != TransferScheme::apic)
    throw std::logic_error("velocity gradients set the affine matrices of APIC, not of this run");
  const std::size_t n = _particles.size();
  constexpr int LL = Dim * Dim;
  if (G.size() != LL * n)
    throw std::invalid_argument("velocity gradients: " + std::to_string(G.size())
                                + " values for " + std::to_string(n) + " particles ("
                                + std::to_string(LL) + " each)");
  if (const std::size_t outside = _sort.sort(_grid, _particles.x); outside < n)
    throw SimulationError(where(outside) + " is outside the grid");
  if (_domains)
  {
    _domains->bind(_particles);
    check_domains();
  }
  double* B = _particles.f64("affine").data();
  dispatch(
      [&](auto shape, auto&, auto)
      {
        using Shape = typename decltype(shape)::type;
        pfmpm::grid_to_particle<Shape>(
            _grid, _sort, points(),
            unreduced(
                [&](const Cell<Dim>& cell, const detail::EachParticle<Shape>& each)
                {
                  const BlockPoints<Shape> X(_grid, cell);
                  each(
                      [&](std::size_t p, const Shape& s)
                      {
                        // B_p = G_p D_p (Jiang et al. 2015, eq. 10 for a linear field)
                        const auto D = inertia_matrix(affine_frame<true>(s, X));
                        const double* g = &G[LL * p];
                        for (int i = 0; i < Dim; ++i)
                          for (int j = 0; j < Dim; ++j)
                          {
                            double b = g[Dim * i] * D[j];
                            for (int k = 1; k < Dim; ++k)
                              b += g[Dim * i + k] * D[Dim * k + j];
                            B[LL * p + Dim * i + j] = b;
                          }
                      });
                }));
      });
}

template <int Dim>
std::vector<std::array<double, 2 + Dim>> Solver<Dim>::nodal_mass_momentum()
{
  _external = has_external_force();
  std::vector<std::array<double, 2 + Dim>> out;
  dispatch(
      [&](auto shape, auto& fields, auto affine)
      {
        using Fields = std::decay_t<decltype(fields)>;
        using Shape = typename decltype(shape)::type;
        bind();
        prepare<Shape>(fields, true);
        particle_to_grid<Shape, decltype(affine)::value>(fields);
        const auto na = static_cast<std::size_t>(_grid.num_active());
        out.assign(na, {});
        for (std::size_t a = 0; a < na; ++a)
        {
          std::int32_t s0 = static_cast<std::int32_t>(a), s1 = s0 + 1;
          if constexpr (Fields::discrete)
          {
            s0 = fields.slot_start()[a];
            s1 = fields.slot_start()[a + 1];
          }
          out[a][0] = static_cast<double>(_grid.active_nodes()[a]);
          for (std::int32_t s = s0; s < s1; ++s)
          {
            out[a][1] += _sums[s].m;
            for (int d = 0; d < Dim; ++d)
              out[a][2 + d] += _sums[s].p[d];
          }
        }
      });
  return out;
}

template class Solver<2>;
template class Solver<3>;

} // namespace pfmpm
