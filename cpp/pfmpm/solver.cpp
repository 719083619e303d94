#include "solver.h"
#include "reduce.h"
#include "strips.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <type_traits>

namespace pfmpm
{

namespace
{
/// Call f(std::integral_constant<int, P>) for the run-time degree P.
template <class F>
void with_degree(int degree, F&& f)
{
  switch (degree)
  {
  case 1:
    f(std::integral_constant<int, 1>{});
    break;
  case 2:
    f(std::integral_constant<int, 2>{});
    break;
  default:
    f(std::integral_constant<int, 3>{});
  }
}
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
} // namespace

Solver::Solver(Grid& grid, Particles& particles, std::vector<LinearElastic> materials, double dt,
               std::vector<std::optional<Fracture>> fracture, double tol, int max_iterations,
               std::vector<double> friction)
    : _grid(grid), _particles(particles), _materials(std::move(materials)), _dt(dt),
      _phase_field(grid, per_material(std::move(fracture), _materials.size()), tol,
                   max_iterations),
      _cell(particles.size()), _order(particles.size()),
      _cell_start(static_cast<std::size_t>(grid.num_cells()) + 1)
{
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("dt = " + std::to_string(dt) + ": must be > 0");
  if (_materials.empty())
    throw std::invalid_argument("materials: at least one material is needed");

  const auto nmat = static_cast<std::int32_t>(_materials.size());
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.material[i] < 0 || particles.material[i] >= nmat)
      throw std::invalid_argument("particle " + std::to_string(i) + ": material index "
                                  + std::to_string(particles.material[i]) + " out of range");
  const double max_mass = particles.size() == 0
                              ? 0.0
                              : *std::max_element(particles.mass.begin(), particles.mass.end());
  for (const LinearElastic& m : _materials)
    _wave_speed.push_back(m.wave_speed());
  for (std::size_t i = 0; i < particles.size(); ++i)
    _fastest_wave = std::max(_fastest_wave, _wave_speed[particles.material[i]]);
  // Nodes lighter than this carry no velocity: dividing by their mass would
  // amplify round-off (a particle at the edge of a node's support).
  _mass_tol = 1e-12 * max_mass;
  if (!friction.empty())
  {
    std::vector<std::optional<Fracture>> per_mat(_materials.size());
    for (std::size_t m = 0; m < per_mat.size(); ++m)
      if (const Fracture* f = _phase_field.fracture(static_cast<std::int32_t>(m)))
        per_mat[m] = *f;
    _fields = std::make_unique<DiscreteFields>(grid, particles, std::move(friction), per_mat, tol,
                                               max_iterations);
  }
}

void Solver::set_stability_length(double length)
{
  if (!(length >= 0.0) || !std::isfinite(length))
    throw std::invalid_argument("stability length = " + std::to_string(length)
                                + ": must be >= 0 and finite");
  _stability_length = length;
}

SolverState Solver::state() const
{
  if (_fields)
    return SolverState{_time, _step, _external_work, _light_nodes, {}, _fields->state()};
  return SolverState{_time, _step, _external_work, _light_nodes, _phase_field.state(), {}};
}

void Solver::restore(SolverState state)
{
  if (state.fields.has_value() != static_cast<bool>(_fields))
    throw std::invalid_argument(std::string("solver state: ") + (_fields ? "without" : "with")
                                + " discrete fields, for a solver " + (_fields ? "with" : "without")
                                + " them (a scene with another [contact] table or bodies)");
  auto check_particles = [this](const PhaseFieldState& pf)
  {
    const std::size_t n = pf.fracture_energy.size();
    if (n != 0 && n != _particles.size())
      throw std::invalid_argument("solver state: fracture energy of " + std::to_string(n)
                                  + " particles for " + std::to_string(_particles.size()));
  };
  check_particles(state.phase_field);
  if (state.fields)
    for (const PhaseFieldState& pf : state.fields->phase_fields)
      check_particles(pf);
  if (!(state.time >= 0.0) || !std::isfinite(state.time) || state.step < 0)
    throw std::invalid_argument("solver state: step " + std::to_string(state.step) + " at t = "
                                + std::to_string(state.time));
  if (_fields)
    _fields->restore(std::move(*state.fields));
  else
    _phase_field.restore(std::move(state.phase_field));
  _time = state.time;
  _step = state.step;
  _external_work = state.external_work;
  _light_nodes = state.light_nodes;
}

void Solver::advance(std::int64_t steps)
{
  // P2G skips the external force when there is none (fext only changes
  // between calls).
  _external = has_external_force();
  for (std::int64_t k = 0; k < steps; ++k)
    with_degree(_grid.degree(), [this](auto P) { step<decltype(P)::value>(); });
}

void Solver::prepare()
{
  with_degree(_grid.degree(), [this](auto P) { prepare<decltype(P)::value>(); });
}

template <int P>
void Solver::prepare()
{
  sort_particles();
  _grid.activate(_cell_start);
  if (_fields)
    _fields->detect(_particles, _order, _cell_start); // Remark 4
  if (!_phase_field.active())
    return;
  int failed = -1; // the field whose solve failed; 0 for the single field
  if (_fields)
    failed = _fields->template solve_phase_fields<P>(_particles, _order, _cell_start, _materials);
  else if (!_phase_field.template solve<P>(_particles, _order, _cell_start, _materials))
    failed = 0;
  if (failed >= 0)
  {
    const PhaseFieldStats s = phase_field_stats();
    std::ostringstream msg;
    msg << "phase field" << (_fields ? " of body " + std::to_string(failed) : std::string())
        << ": conjugate gradients stopped at relative residual " << s.last_residual
        << " > tol = " << _phase_field.tol() << " after " << s.last_iterations
        << " iterations, at the start of the step after step " << _step << " (t = " << _time
        << ")";
    throw SimulationError(msg.str());
  }
}

template <int P>
void Solver::step()
{
  prepare<P>();
  particle_to_grid<P>();
  update_grid();
  grid_to_particle<P>();
  _time += _dt;
  ++_step;
}

std::string Solver::where(std::size_t i) const
{
  std::ostringstream s;
  s << "particle " << i << " (body " << _particles.body[i] << ") at x = (" << _particles.x[2 * i]
    << ", " << _particles.x[2 * i + 1] << ") during the step after step " << _step
    << " (t = " << _time << ")";
  return s.str();
}

void Solver::sort_particles()
{
  const auto n = static_cast<std::ptrdiff_t>(_particles.size());
  const BSpline1D& bx = _grid.basis(0);
  const BSpline1D& by = _grid.basis(1);
  const int ncy = by.cells();
  const auto ncells = static_cast<std::size_t>(_grid.num_cells());
  const double* x = _particles.x.data();

  std::ptrdiff_t outside = n;
#pragma omp parallel for schedule(static) reduction(min : outside)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const int cx = bx.cell(x[2 * i]), cy = by.cell(x[2 * i + 1]);
    if (cx < 0 || cy < 0)
    {
      outside = std::min(outside, i);
      _cell[i] = 0;
    }
    else
      _cell[i] = cx * ncy + cy;
  }
  if (outside < n)
    throw SimulationError(where(outside) + " is outside the grid");

  // Stable counting sort by cell. Each thread counts a contiguous slice; the
  // offsets put slice t before slice t+1 inside every cell, which is the order
  // a serial stable sort gives, whatever the number of threads.
  _histogram.resize(static_cast<std::size_t>(omp_get_max_threads()) * ncells);
#pragma omp parallel
  {
    const std::ptrdiff_t nt = omp_get_num_threads(), t = omp_get_thread_num();
    const std::ptrdiff_t begin = n * t / nt, end = n * (t + 1) / nt;
    std::int64_t* count = &_histogram[t * ncells];
    std::fill(count, count + ncells, 0);
    for (std::ptrdiff_t i = begin; i < end; ++i)
      ++count[_cell[i]];
#pragma omp barrier
#pragma omp single
    {
      std::int64_t running = 0;
      for (std::size_t c = 0; c < ncells; ++c)
      {
        _cell_start[c] = running;
        for (std::ptrdiff_t s = 0; s < nt; ++s)
        {
          std::int64_t& slot = _histogram[s * ncells + c];
          const std::int64_t k = slot;
          slot = running;
          running += k;
        }
      }
      _cell_start[ncells] = running;
    }
    for (std::ptrdiff_t i = begin; i < end; ++i)
      _order[count[_cell[i]]++] = static_cast<std::int32_t>(i);
  }
}

template <int P>
void Solver::particle_to_grid()
{
  if (_external)
  {
    particle_to_grid<P, true>();
    if (_fields)
      _fields->template particle_to_grid<P, true>(_particles, _order, _cell_start);
  }
  else
  {
    particle_to_grid<P, false>();
    if (_fields)
      _fields->template particle_to_grid<P, false>(_particles, _order, _cell_start);
  }
}

template <int P, bool External>
void Solver::particle_to_grid()
{
  constexpr int K = (P + 1) * (P + 1); // nodes touched by one cell
  const BSpline1D& bx = _grid.basis(0);
  const BSpline1D& by = _grid.basis(1);
  const int ncx = bx.cells(), ncy = by.cells();
  const double* x = _particles.x.data();
  const double* v = _particles.v.data();
  const double* mass = _particles.mass.data();
  const double* volume = _particles.volume.data();
  const double* stress = _particles.stress.data();
  const double* fext = _particles.fext.data();

  _sums.resize(static_cast<std::size_t>(_grid.num_active()));
  _kinematics.resize(_sums.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(_sums.size()); ++a)
    _sums[a] = NodeSums{};

  // Each cell's particles are summed in sorted order into a local K-node
  // block, which is then added to the nodes (see for_each_cell_by_strips).
  auto scatter = [&](int cx, int cy, std::int64_t begin, std::int64_t end)
  {
    double m[K]{}, px[K]{}, py[K]{}, fx[K]{}, fy[K]{}, ex[K]{}, ey[K]{};
    for (std::int64_t k = begin; k < end; ++k)
    {
      const std::size_t p = _order[k];
      double Nx[P + 1], dNx[P + 1], Ny[P + 1], dNy[P + 1];
      bx.evaluate<P>(cx, x[2 * p], Nx, dNx);
      by.evaluate<P>(cy, x[2 * p + 1], Ny, dNy);
      const double mp = mass[p];
      const double mvx = mp * v[2 * p], mvy = mp * v[2 * p + 1];
      const double V = volume[p];
      const double sxx = V * stress[4 * p], syy = V * stress[4 * p + 1],
                   sxy = V * stress[4 * p + 2];
      for (int a = 0; a <= P; ++a)
        for (int b = 0; b <= P; ++b)
        {
          const int i = a * (P + 1) + b;
          const double w = Nx[a] * Ny[b];
          const double gx = dNx[a] * Ny[b], gy = Nx[a] * dNy[b];
          m[i] += w * mp;    // eq. 46
          px[i] += w * mvx;  // eq. 61
          py[i] += w * mvy;
          fx[i] -= sxx * gx + sxy * gy; // eq. 62
          fy[i] -= sxy * gx + syy * gy;
          if constexpr (External)
          {
            ex[i] += w * fext[2 * p]; // eq. 42
            ey[i] += w * fext[2 * p + 1];
          }
        }
    }
    for (int a = 0; a <= P; ++a)
    {
      NodeSums* node = &_sums[_grid.active_index(cx + a, cy)];
      for (int b = 0; b <= P; ++b)
      {
        const int i = a * (P + 1) + b;
        NodeSums& n = node[b];
        n.m += m[i];
        n.px += px[i];
        n.py += py[i];
        n.fx += fx[i] + ex[i];
        n.fy += fy[i] + ey[i];
        n.ex += ex[i];
        n.ey += ey[i];
      }
    }
  };
  for_each_cell_by_strips(ncx, ncy, _cell_start, scatter);
}

void Solver::update_grid()
{
  const std::vector<std::uint8_t>& constrained = _grid.constraints();
  const bool walls = !constrained.empty();
  const double dt = _dt;
  // Contact nodes are updated per field by DiscreteFields::update.
  const std::int32_t* contact = _fields ? _fields->contact_index().data() : nullptr;
  const auto sums = deterministic_sum<2>(
      _sums.size(),
      [&](std::size_t i, std::array<double, 2>& acc)
      {
        const NodeSums& s = _sums[i];
        NodeKinematics& k = _kinematics[i];
        if (contact && contact[i] >= 0)
        {
          k = NodeKinematics{};
          return;
        }
        if (s.m <= _mass_tol)
        {
          k = NodeKinematics{};
          if (s.m > 0.0)
            acc[1] += 1.0; // a light node, counted
          return;
        }
        // Trial momentum (eq. 63) and velocity (eq. 64); with a single field
        // there is no contact force, so these are final (eq. 65).
        const double vo[2] = {s.px / s.m, s.py / s.m};
        double vn[2] = {vo[0] + dt * s.fx / s.m, vo[1] + dt * s.fy / s.m};
        // A wall sets the new velocity; the acceleration keeps the unconstrained
        // old velocity so that the particle update (eq. 80) feels the reaction.
        double vw[2] = {vo[0], vo[1]}; // old velocity as the wall allows it
        if (walls && constrained[i])
          for (int d = 0; d < 2; ++d)
            if (constrained[i] & (1 << d))
              vn[d] = vw[d] = 0.0;
        k = NodeKinematics{vn[0], vn[1], (vn[0] - vo[0]) / dt, (vn[1] - vo[1]) / dt};
        // Work of the nodal external force over the step (trapezoidal velocity).
        acc[0] += 0.5 * dt * (s.ex * (vw[0] + vn[0]) + s.ey * (vw[1] + vn[1]));
      });
  _external_work += sums[0];
  _light_nodes += static_cast<std::int64_t>(sums[1]);
  if (_fields)
    _external_work += _fields->update(_dt, _mass_tol); // eqs. 63-77 at contact nodes
}

template <int P>
void Solver::grid_to_particle()
{
  constexpr int K = (P + 1) * (P + 1);
  const BSpline1D& bx = _grid.basis(0);
  const BSpline1D& by = _grid.basis(1);
  const int ncx = bx.cells(), ncy = by.cells();
  const auto n = static_cast<std::ptrdiff_t>(_particles.size());
  const double dt = _dt;
  double* x = _particles.x.data();
  double* v = _particles.v.data();
  double* volume = _particles.volume.data();
  double* strain = _particles.strain.data();
  double* stress = _particles.stress.data();
  double* history = _particles.history.data();
  const double* c = _particles.c.data();
  const std::int32_t* material = _particles.material.data();
  const std::int32_t* body = _particles.body.data();
  const DiscreteFields* fields = _fields.get();

  const bool check_stability = _stability_length > 0.0;

  // Cell by cell: the K nodes of a cell are read once for all its particles.
  std::ptrdiff_t bad = n;
  double speed2 = 0.0; // largest |v_p|^2
#pragma omp parallel for schedule(static) reduction(min : bad) reduction(max : speed2)
  for (int cx = 0; cx < ncx; ++cx)
    for (int cy = 0; cy < ncy; ++cy)
    {
      const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
      const std::int64_t begin = _cell_start[cell], end = _cell_start[cell + 1];
      if (begin == end)
        continue;
      double nvx[K], nvy[K], nax[K], nay[K];
      for (int a = 0; a <= P; ++a)
      {
        const NodeKinematics* node = &_kinematics[_grid.active_index(cx + a, cy)];
        for (int b = 0; b <= P; ++b)
        {
          const int i = a * (P + 1) + b;
          nvx[i] = node[b].vx;
          nvy[i] = node[b].vy;
          nax[i] = node[b].ax;
          nay[i] = node[b].ay;
        }
      }
      // The cell's particles; near a contact node (Contact) each reads its
      // own field's values there. Two instances, so that the common path
      // reads the cell's arrays directly: through a pointer switched per
      // particle it took 38 more instructions per particle
      // (docs/performance.md).
      auto particles = [&](auto contact)
      {
        constexpr bool Contact = decltype(contact)::value;
        [[maybe_unused]] double fvx[K], fvy[K], fax[K], fay[K];
        [[maybe_unused]] std::int32_t loaded = -1;
        const double *kvx = Contact ? fvx : nvx, *kvy = Contact ? fvy : nvy,
                     *kax = Contact ? fax : nax, *kay = Contact ? fay : nay;
        for (std::int64_t k = begin; k < end; ++k)
        {
          const std::size_t p = _order[k];
          if constexpr (Contact)
            if (body[p] != loaded)
            {
              std::copy(nvx, nvx + K, fvx);
              std::copy(nvy, nvy + K, fvy);
              std::copy(nax, nax + K, fax);
              std::copy(nay, nay + K, fay);
              fields->template field_kinematics<P>(cx, cy, body[p], fvx, fvy, fax, fay);
              loaded = body[p];
            }
          double Nx[P + 1], dNx[P + 1], Ny[P + 1], dNy[P + 1];
          bx.evaluate<P>(cx, x[2 * p], Nx, dNx);
          by.evaluate<P>(cy, x[2 * p + 1], Ny, dNy);
          double vx = 0, vy = 0, ax = 0, ay = 0, Lxx = 0, Lxy = 0, Lyx = 0, Lyy = 0;
          for (int a = 0; a <= P; ++a)
            for (int b = 0; b <= P; ++b)
            {
              const int i = a * (P + 1) + b;
              const double w = Nx[a] * Ny[b];
              const double gx = dNx[a] * Ny[b], gy = Nx[a] * dNy[b];
              vx += w * kvx[i];
              vy += w * kvy[i];
              ax += w * kax[i];
              ay += w * kay[i];
              Lxx += kvx[i] * gx; // velocity gradient, L_ij = dv_i/dx_j
              Lxy += kvx[i] * gy;
              Lyx += kvy[i] * gx;
              Lyy += kvy[i] * gy;
            }
          v[2 * p] += dt * ax; // eq. 80
          v[2 * p + 1] += dt * ay;
          x[2 * p] += dt * vx; // eq. 82
          x[2 * p + 1] += dt * vy;
          // Strain increment, eq. 78; volume follows det(I + dt L).
          double* eps = &strain[3 * p];
          eps[0] += dt * Lxx;
          eps[1] += dt * Lyy;
          eps[2] += 0.5 * dt * (Lxy + Lyx);
          volume[p] *= (1.0 + dt * Lxx) * (1.0 + dt * Lyy) - dt * dt * Lxy * Lyx;
          const LinearElastic& mat = _materials[material[p]];
          if (const Fracture* f = _phase_field.fracture(material[p]))
          {
            // eqs. 14-16 with this step's phase field; the history takes the
            // largest tensile energy so far (eq. 20, Kuhn-Tucker conditions).
            double plus, minus;
            mat.degraded(eps, f->degradation(c[p]), &stress[4 * p], plus, minus);
            history[p] = std::max(history[p], plus);
          }
          else
            mat.stress(eps, &stress[4 * p]); // eq. 16, g = 1
          const double* sig = &stress[4 * p];
          if (!std::isfinite(x[2 * p] + x[2 * p + 1] + v[2 * p] + v[2 * p + 1] + sig[0] + sig[1]
                             + sig[2] + sig[3] + history[p]))
            bad = std::min(bad, static_cast<std::ptrdiff_t>(p));
          if (check_stability)
            speed2 = std::max(speed2, v[2 * p] * v[2 * p] + v[2 * p + 1] * v[2 * p + 1]);
        }
      };
      if (fields && fields->touches(cell))
        particles(std::true_type{});
      else
        particles(std::false_type{});
    }
  if (bad < n)
    non_finite(bad);
  // max c_p + max |v_p| bounds max (c_p + |v_p|) without a square root per
  // particle; only a step whose bound exceeds the limit takes the exact maximum.
  if (check_stability && dt * (_fastest_wave + std::sqrt(speed2)) > stability_limit())
    check_stability_exactly();
}

void Solver::non_finite(std::size_t p) const
{
  auto finite = [](const std::vector<double>& a, std::size_t begin, std::size_t k)
  { return std::all_of(&a[begin], &a[begin] + k, [](double u) { return std::isfinite(u); }); };
  const Particles& s = _particles;
  const char* what = !finite(s.v, 2 * p, 2)        ? "velocity"
                     : !finite(s.x, 2 * p, 2)      ? "position"
                     : !finite(s.stress, 4 * p, 4) ? "stress"
                                                   : "history";
  throw SimulationError(std::string(what) + " of " + where(p) + " is not finite");
}

void Solver::check_stability_exactly() const
{
  const auto n = static_cast<std::ptrdiff_t>(_particles.size());
  double fastest = 0.0;
#pragma omp parallel for schedule(static) reduction(max : fastest)
  for (std::ptrdiff_t p = 0; p < n; ++p)
    fastest = std::max(fastest, signal_speed(p));
  if (_dt * fastest <= stability_limit())
    return;
  std::size_t p = 0; // the first particle that fast
  while (p + 1 < _particles.size() && signal_speed(p) < fastest)
    ++p;
  const double vx = _particles.v[2 * p], vy = _particles.v[2 * p + 1];
  const double speed = std::sqrt(vx * vx + vy * vy);
  std::ostringstream msg;
  msg << "time step dt = " << _dt << " became unstable: " << where(p)
      << " has P-wave speed " << fastest - speed << " and speed " << speed
      << ", so dt (c + |v|) = " << _dt * fastest << " exceeds the stability limit "
      << _stability_length << " (kappa h); lower time.cfl or time.dt";
  throw SimulationError(msg.str());
}

Energies Solver::energies() const
{
  const auto n = _particles.size();
  const Particles& P = _particles;
  const std::vector<double>& fracture = _phase_field.fracture_energy();
  const bool cracks = fracture.size() == n;
  const auto sums = deterministic_sum<6>(
      n,
      [&](std::size_t p, std::array<double, 6>& acc)
      {
        const double m = P.mass[p], vx = P.v[2 * p], vy = P.v[2 * p + 1];
        acc[0] += 0.5 * m * (vx * vx + vy * vy);
        const LinearElastic& mat = _materials[P.material[p]];
        const double* eps = &P.strain[3 * p];
        if (const Fracture* f = _phase_field.fracture(P.material[p]))
        {
          double sig[4], plus, minus;
          mat.degraded(eps, f->degradation(P.c[p]), sig, plus, minus);
          acc[1] += P.volume[p] * (f->degradation(P.c[p]) * plus + minus); // eq. 14
        }
        else
          acc[1] += P.volume[p] * mat.energy_density(eps);
        acc[2] += m * vx;
        acc[3] += m * vy;
        acc[4] += m;
        if (cracks)
          acc[5] += fracture[p];
      });
  Energies e;
  e.kinetic = sums[0];
  e.elastic = sums[1];
  e.fracture = sums[5];
  e.external_work = _external_work;
  e.momentum = {sums[2], sums[3]};
  e.mass = sums[4];
  if (_fields)
  {
    e.friction_work = _fields->stats().friction_work;
    e.fracture_by_field = _fields->fracture_energies();
    e.fracture = 0.0;
    for (double f : e.fracture_by_field)
      e.fracture += f;
  }
  return e;
}

void Solver::set_phase_field_preconditioner(Preconditioner preconditioner)
{
  _phase_field.set_preconditioner(preconditioner);
  if (_fields)
    _fields->set_phase_field_preconditioner(preconditioner);
}

PhaseFieldStats Solver::phase_field_stats() const
{
  return _fields ? _fields->phase_field_stats() : _phase_field.stats();
}

bool Solver::has_external_force() const
{
  return std::any_of(_particles.fext.begin(), _particles.fext.end(),
                     [](double f) { return f != 0.0; });
}

std::vector<std::array<double, 4>> Solver::nodal_mass_momentum()
{
  _external = has_external_force();
  with_degree(_grid.degree(),
              [this](auto P)
              {
                prepare<decltype(P)::value>();
                particle_to_grid<decltype(P)::value>();
              });
  std::vector<std::array<double, 4>> out(_sums.size());
  for (std::size_t a = 0; a < _sums.size(); ++a)
    out[a] = {static_cast<double>(_grid.active_nodes()[a]), _sums[a].m, _sums[a].px, _sums[a].py};
  return out;
}

} // namespace pfmpm
