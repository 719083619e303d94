/// @file solver.h
/// @brief Explicit MPM time stepping (Kakouris & Triantafyllou 2019, Algorithm 1).
#pragma once

#include "contact.h"
#include "grid.h"
#include "material.h"
#include "particles.h"
#include "phasefield.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pfmpm
{

/// @brief A run cannot continue: a particle left the grid or a value became
/// NaN or infinite. The message names the quantity, particle, step and time.
class SimulationError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Global quantities of the particle state.
struct Energies
{
  double kinetic = 0.0;        ///< sum of M_p |v_p|^2 / 2
  double elastic = 0.0;        ///< sum of V_p (g(c_p) psi+ + psi-) (eq. 14)
  double fracture = 0.0;       ///< sum of G_c V_p Z(c_p) (eqs. 3-4)
  double external_work = 0.0;  ///< work of the external forces since t = 0
  double friction_work = 0.0;  ///< work of the friction (tangential contact) forces since t = 0 (<= 0)
  std::array<double, 2> momentum{}; ///< sum of M_p v_p
  double mass = 0.0;           ///< sum of M_p
  std::vector<double> fracture_by_field; ///< with discrete fields: fracture energy per field
};

/// @brief Everything besides the particles that a run carries from one step
/// to the next; with the particle arrays it is the complete state of a run.
struct SolverState
{
  double time = 0.0;
  std::int64_t step = 0;
  double external_work = 0.0;    ///< work of the external forces since t = 0
  std::int64_t light_nodes = 0;  ///< see Solver::light_nodes
  /// The single field's phase field; empty nodal arrays when nothing can
  /// crack or with discrete fields (which have their own, in `fields`).
  PhaseFieldState phase_field;
  /// With discrete fields: their phase fields and contact record; else none.
  std::optional<DiscreteFieldsState> fields;
};

/// @brief Explicit update-stress-last MPM in the momentum formulation, with
/// a staggered phase-field solve for materials that can crack.
///
/// One step: sort particles by cell and activate the grid nodes they touch;
/// if some material can crack, solve the phase field with the current
/// history and degrade the stresses (eqs. 56, 14-16); map mass, momentum and
/// forces to the grid (P2G), integrate nodal momentum with wall conditions,
/// map velocity and acceleration back (G2P), update strain and stress, and
/// raise the history field to the new tensile energy (eq. 20). Every sum
/// over particles is taken in an order fixed by the particle positions alone,
/// so results do not depend on the thread count.
///
/// With discrete fields (a friction matrix given), the nodes two bodies share
/// are contact nodes: DiscreteFields keeps each body's quantities there and
/// applies frictional contact (eqs. 63-77); each crackable body has its own
/// phase field. Elsewhere the single-field steps above are unchanged.
///
/// With explicit time integration the internal force of a step comes from
/// the stresses fixed at its start, so the staggered loop of Algorithm 1
/// converges in one pass: the phase field solved at the start of step m+1
/// uses the history left by step m.
class Solver
{
public:
  /// @param grid Background grid (kept by reference; must outlive the solver).
  /// @param particles Particle state (kept by reference; must outlive the solver).
  /// @param materials Materials indexed by Particles::material.
  /// @param dt Time step (> 0); the caller checks it against the CFL limit.
  /// @param fracture Per material, its fracture parameters or none; empty: nothing cracks.
  /// @param tol Phase-field tolerance tol_c, relative to ||F|| (eq. 52).
  /// @param max_iterations Phase-field CG iteration limit per step.
  /// @param friction Empty: all particles form one velocity field. Otherwise
  ///        every body (Particles::body) is its own discrete field, coupled by
  ///        frictional contact with coefficient friction[a * n + b] between
  ///        bodies a and b (n x n, n >= 2; see DiscreteFields).
  Solver(Grid& grid, Particles& particles, std::vector<LinearElastic> materials, double dt,
         std::vector<std::optional<Fracture>> fracture = {}, double tol = 1e-6,
         int max_iterations = 1000, std::vector<double> friction = {});

  /// @brief Take `steps` explicit steps.
  /// @throws SimulationError when a particle leaves the grid or turns non-finite.
  void advance(std::int64_t steps);

  double dt() const { return _dt; }
  double time() const { return _time; }
  std::int64_t step_count() const { return _step; }

  /// @brief Sort the particles, activate the grid and, if something can
  /// crack, solve the phase field and degrade the stresses: the start of a
  /// step. Each step does this itself; call it to see the phase field of the
  /// initial state (an initial crack) before the first step.
  void prepare();

  /// @brief Check the time step against the stability limit every step.
  ///
  /// After each step's particle update, the largest c_p + |v_p| over the
  /// particles, with c_p the P-wave speed of the particle's material, must
  /// satisfy dt (c_p + |v_p|) <= `length` (up to round-off); otherwise the
  /// step throws SimulationError. `length` is the critical length kappa h of
  /// the scene's step rule (eqs. 83-84), which takes the initial body speeds;
  /// the check follows the speeds as they grow. (The small-strain model's
  /// stiffness does not change with deformation, and where strains grow large,
  /// in an opening crack, the phase field degrades it.) 0 switches the check
  /// off (the default).
  void set_stability_length(double length);

  /// @brief Nodes, summed over all steps so far, whose mass was positive but
  /// too small to divide by (below 1e-12 of the heaviest particle): they get
  /// zero velocity instead.
  std::int64_t light_nodes() const { return _light_nodes; }

  /// @brief A copy of the state besides the particles (time, step, external
  /// work, counters, phase-field warm start; with discrete fields, each
  /// field's phase field and the contact record), for a checkpoint.
  SolverState state() const;
  /// @brief Continue from `state`, saved by state() of a solver built on the
  /// same scene, with the particle arrays restored beside it.
  /// @throws std::invalid_argument if it does not fit this grid, particle
  ///         count or fields (a state with discrete fields for a solver
  ///         without, or the other way round).
  void restore(SolverState state);

  /// @brief Energies and momentum of the current particle state.
  Energies energies() const;

  /// Phase-field solver state (convergence statistics, per-particle fracture energy).
  const PhaseField& phase_field() const { return _phase_field; }
  /// Phase-field convergence record: of the single field, or summed over the discrete fields.
  PhaseFieldStats phase_field_stats() const;
  /// @brief The CG preconditioner of every phase field's solves from now on.
  void set_phase_field_preconditioner(Preconditioner preconditioner);
  /// The discrete fields and their contact record, or nullptr with one field.
  const DiscreteFields* fields() const { return _fields.get(); }

  /// @brief Map the current particle state to the grid (P2G only) and return,
  /// per active node, (node index, mass, momentum x, momentum y). For checks.
  std::vector<std::array<double, 4>> nodal_mass_momentum();

private:
  template <int P>
  void step();
  template <int P>
  void prepare();
  void sort_particles();
  template <int P>
  void particle_to_grid();
  template <int P, bool External>
  void particle_to_grid();
  void update_grid();
  template <int P>
  void grid_to_particle();
  std::string where(std::size_t particle) const;
  [[noreturn]] void non_finite(std::size_t particle) const;
  /// Throw SimulationError if some particle has dt (c_p + |v_p|) > the limit.
  void check_stability_exactly() const;
  /// The stability length with a relative slack that lets a run at the limit
  /// itself (cfl = 1) through round-off.
  double stability_limit() const { return (1.0 + 1e-9) * _stability_length; }
  /// c_p + |v_p|: P-wave speed of the particle's material plus its speed.
  double signal_speed(std::size_t particle) const
  {
    const std::size_t p = particle;
    const double vx = _particles.v[2 * p], vy = _particles.v[2 * p + 1];
    return _wave_speed[_particles.material[p]] + std::sqrt(vx * vx + vy * vy);
  }
  bool has_external_force() const;

  /// P2G accumulators of one active node.
  struct NodeSums
  {
    double m, px, py;   // mass (eq. 46) and momentum (eq. 61)
    double fx, fy;      // net force F^ext - F^int (eqs. 42, 62)
    double ex, ey;      // external force alone, for the work it does
  };
  /// Updated velocity and acceleration of one active node (eqs. 63-64).
  struct NodeKinematics
  {
    double vx, vy, ax, ay;
  };

  Grid& _grid;
  Particles& _particles;
  std::vector<LinearElastic> _materials;
  std::vector<double> _wave_speed; // per material: P-wave speed
  double _fastest_wave = 0.0;      // the largest over the particles' materials
  double _dt;
  double _time = 0.0;
  std::int64_t _step = 0;
  double _external_work = 0.0;
  double _mass_tol;
  std::int64_t _light_nodes = 0;
  double _stability_length = 0.0; // 0: no check
  bool _external = false; // some particle carries an external force
  PhaseField _phase_field;
  std::unique_ptr<DiscreteFields> _fields; // with contact: per-field data at contact nodes

  std::vector<std::int32_t> _cell;        // per particle: cell key
  std::vector<std::int32_t> _order;       // particles sorted by cell, stable
  std::vector<std::int64_t> _cell_start;  // offsets into _order, per cell
  std::vector<std::int64_t> _histogram;   // threads x cells, sort scratch
  std::vector<NodeSums> _sums;            // per active node
  std::vector<NodeKinematics> _kinematics; // per active node
};

} // namespace pfmpm
