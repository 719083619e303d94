/// @file solver.h
/// @brief Explicit MPM time stepping (Kakouris & Triantafyllou 2019, Algorithm 1).
#pragma once

#include "pfmpm/common/error.h"
#include "pfmpm/contact/coulomb.h"
#include "pfmpm/fields/damage_fields.h"
#include "pfmpm/fields/fields.h"
#include "pfmpm/fracture/phasefield.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/materials/material.h"
#include "pfmpm/particles/cell_sort.h"
#include "pfmpm/particles/particles.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/solver/threads.h"
#include "pfmpm/transfer/apic.h"
#include "pfmpm/transfer/transfer.h"

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

namespace pfmpm
{

/// Global quantities of the particle state, with vectors of Dim components.
template <int Dim>
struct Energies
{
  /// The angular momentum: its z component in 2D, the vector in 3D.
  using Angular = std::conditional_t<Dim == 2, double, std::array<double, 3>>;

  double kinetic = 0.0;        ///< sum of M_p |v_p|^2 / 2
  double elastic = 0.0;        ///< sum of V_p psi_p (with a phase field g(c_p) psi+ + psi-: K&T eq. 14)
  double fracture = 0.0;       ///< sum of G_c V_p Z(c_p) (K&T eqs. 3-4)
  double external_work = 0.0;  ///< work of the external forces since t = 0
  double friction_work = 0.0;  ///< work of the friction (tangential contact) forces since t = 0 (<= 0)
  double wall_work = 0.0;      ///< work of the wall constraints since t = 0 (<= 0, see finish_slot)
  /// impulse of each side's wall on the bodies since t = 0, Dim components per Side
  std::array<std::array<double, Dim>, num_sides(Dim)> wall_impulse{};
  /// impulse and work of each prescribed-velocity region on the bodies since
  /// t = 0, and how far its nodes have moved along the components it holds
  std::array<std::array<double, Dim>, max_regions> region_impulse{};
  std::array<double, max_regions> region_work{};
  std::array<std::array<double, Dim>, max_regions> region_displacement{};
  /// contact impulse since t = 0 of field b on field a, per pair a < b
  /// (field_pair): bodies, or with damage-gradient fields contact groups
  std::array<std::array<double, Dim>, max_field_pairs> pair_impulse{};
  /// work the models dissipated since t = 0, by kind ("damage", "plastic":
  /// the columns declared with ColumnSpec::dissipation)
  std::map<std::string, double> dissipation;
  std::array<double, Dim> momentum{}; ///< sum of M_p v_p
  /// sum of M_p (x_p x v_p), about the origin; with APIC plus M_p eps_abc (B_p)_cb,
  /// the angular momentum of the particles' affine velocities (Jiang et al. 2015)
  Angular angular_momentum{};
  double mass = 0.0;           ///< sum of M_p
  std::vector<double> fracture_by_field; ///< with discrete fields: fracture energy per field
  /// With more than one body: each body's momentum, Dim values per body in body order.
  std::vector<double> momentum_by_body;

  /// @brief Call `visit(name, member)` for every entry, by the names the
  /// bindings give them (momentum as momentum_x, momentum_y (, momentum_z);
  /// the angular momentum as angular_momentum in 2D and angular_momentum_x,
  /// _y, _z in 3D; the by-body fracture energies as fracture_by_body): the
  /// one list of them.
  template <class Visit, class Self>
  static void each(Visit&& visit, Self& e)
  {
    static const char* const momentum[3] = {"momentum_x", "momentum_y", "momentum_z"};
    visit("kinetic", e.kinetic);
    visit("elastic", e.elastic);
    visit("fracture", e.fracture);
    visit("external_work", e.external_work);
    visit("friction_work", e.friction_work);
    visit("wall_work", e.wall_work);
    visit("wall_impulse", e.wall_impulse);
    visit("region_impulse", e.region_impulse);
    visit("region_work", e.region_work);
    visit("region_displacement", e.region_displacement);
    visit("pair_impulse", e.pair_impulse);
    visit("dissipation", e.dissipation);
    visit("fracture_by_body", e.fracture_by_field);
    visit("momentum_by_body", e.momentum_by_body);
    for (int d = 0; d < Dim; ++d)
      visit(momentum[d], e.momentum[d]);
    if constexpr (Dim == 2)
      visit("angular_momentum", e.angular_momentum);
    else
    {
      static const char* const angular[3] = {"angular_momentum_x", "angular_momentum_y",
                                             "angular_momentum_z"};
      for (int d = 0; d < 3; ++d)
        visit(angular[d], e.angular_momentum[d]);
    }
    visit("mass", e.mass);
  }
};

/// @brief Everything besides the particle columns that a run carries from
/// one step to the next, by name: with the columns it is the complete state
/// of a run.
///
/// Scalars: `time`, `step`, `external_work`, `wall_work`, `wall_impulse/<side>/<x|y|z>`
/// (side: left, right, bottom, top, and in 3D back, front; z in 3D), `region/<k>/work`,
/// `region/<k>/impulse/<x|y|z>` and `region/<k>/displacement/<x|y|z>` (k < max_regions),
/// `light_nodes`; per phase field k
/// (the single field's is 0; with discrete fields, one per crackable body in
/// body order) `phase_field/k/solves`, `.../iterations`,
/// `.../last_iterations`, `.../start_residual`, `.../last_residual`,
/// `.../unknowns`, `.../passes`, `.../last_passes`, `.../at_bound`; with discrete fields `contact/nodes`, `contact/pairs`,
/// `contact/active`, `contact/sliding`, `contact/C1` .. `contact/C4`,
/// `contact/friction_work`; with damage-gradient fields also
/// `contact/split`, `contact/separable`, `contact/separable_total`. The
/// works, impulses and friction work are the totals of the array
/// `grid/slab_sums` (Solver::slab_sums, every slab of the grid, zero where
/// another process owns it), which a state without it (before checkpoint
/// version 8) takes from these scalars. Arrays: `phase_field/k/c` and
/// `phase_field/k/c_previous`, the nodal warm start; with discrete fields
/// `contact/pair_impulse` (x, y per field_pair, max_field_pairs of them).
struct SolverState
{
  std::map<std::string, double> scalars;
  std::map<std::string, std::vector<double>> arrays;
};

/// @brief Wall time of each stage of the steps, seconds summed since the
/// solver was made (for the cost per stage; not part of the state).
struct StageTimers
{
  double sort = 0.0;        ///< cell sort and active nodes
  double phase_field = 0.0; ///< phase-field solves and the degraded stresses
  double fields = 0.0;      ///< the partition's build (DamageFields::timers() splits the damage gradient's)
  double p2g = 0.0;         ///< P2G of mass, momentum and forces
  double grid = 0.0;        ///< grid update with walls and contact
  double g2p = 0.0;         ///< G2P and the materials' update
};

/// The velocity-field partition of a run, chosen once (StepConfig).
enum class Partition : int
{
  single = 0,         ///< one velocity field
  bodies = 1,         ///< every body its own field, frictional contact (K&T eqs. 63-77)
  damage_gradient = 2 ///< two fields per contact group by the damage gradient (H&H)
};

/// @brief What each step of a run does, chosen once: the time step, the
/// phase field's parameters, the velocity-field partition, the stencil and
/// the transfer. Every field but dt has a default.
struct StepConfig
{
  explicit StepConfig(double dt) : dt(dt) {}

  /// Time step (> 0); the caller checks it against the CFL limit.
  double dt;
  /// Per material, its fracture parameters or none; empty: nothing cracks.
  std::vector<std::optional<Fracture>> fracture;
  /// Phase-field tolerance tol_c, relative to ||F|| (K&T eq. 52).
  double tol = PhaseFieldDeclarations::default_tol;
  /// Phase-field CG iteration limit per step.
  int max_iterations = PhaseFieldDeclarations::default_max_iterations;
  /// The velocity-field partition: one field (SingleField); every body
  /// (Particles::body) its own discrete field (BodyFields); or two fields per
  /// contact group chosen by the damage gradient (DamageFields).
  Partition partition = Partition::single;
  /// With bodies or damage_gradient, the Coulomb coefficients of the
  /// frictional contact, friction[a * n + b] between fields a and b: bodies
  /// (n x n, n >= 2) or contact groups (n >= 1). Empty with one field.
  std::vector<double> friction;
  /// With damage_gradient, its parameters. A material's damage is its
  /// `damage` column if it has one, else 1 - c if it cracks by the phase
  /// field, else 0.
  DamageGradientOptions damage;
  /// The shape functions of the momentum transfers: B-splines, or CPDI1 on
  /// the degree-1 grid (with any partition), which adds the domain columns
  /// (ParticleDomains) and sets the grid's node block. The phase field is
  /// assembled with B-splines either way.
  ShapeFunctions shape = ShapeFunctions::bspline;
  /// With CPDI: which particles are failed, and whether their domains are scaled.
  DomainScaling scaling;
  /// The particle-grid transfer: FLIP (K&T eq. 80), or APIC (transfer/apic.h,
  /// with any stencil and partition), which adds the column `affine` (B_p,
  /// zero: set_velocity_gradients sets it).
  TransferScheme transfer = TransferScheme::flip;
};

/// @brief The velocity-field partitions a run in Dim directions may take.
template <int Dim>
struct Partitions
{
  using type = std::variant<SingleField, BodyFields<Dim>, DamageFields<Dim>>;
};

/// @brief Explicit update-stress-last MPM in the momentum formulation, with
/// a staggered phase-field solve for materials that can crack, in Dim = 2 or
/// 3 directions (explicitly instantiated for both in solver.cpp).
///
/// One step (step()): sort the particles by cell and activate the grid nodes
/// they touch; lay out the velocity fields' slots; if some material can crack,
/// solve each phase field with the current history and let the materials
/// degrade their stresses (K&T eqs. 56, 14-16); P2G of mass, momentum and forces;
/// the grid update with walls and contact; G2P of velocity, position and
/// velocity gradient, and the materials' update of their state and stress,
/// which raises the history field (K&T eq. 20). Every sum over particles is
/// taken in an order fixed by the particle positions alone, so results do
/// not depend on the thread count.
///
/// The velocity-field partition is chosen once, at construction
/// (StepConfig::partition): one field; every body its own discrete field
/// coupled by frictional contact (K&T eqs. 63-77), each crackable body with its
/// own phase field; or two fields per contact group chosen per (particle,
/// node) by the damage gradient (Homel & Herbold 2017, DamageFields), each
/// crackable group with its own phase field.
///
/// With explicit time integration the internal force of a step comes from
/// the stresses fixed at its start, so the staggered loop of Algorithm 1
/// converges in one pass: the phase field solved at the start of step m+1
/// uses the history left by step m.
///
/// In 3D a run has one velocity field or every body its own, B-spline shape
/// functions (FLIP or APIC) and no phase field yet; the constructor refuses
/// the rest.
template <int Dim>
class Solver
{
public:
  /// @param grid Background grid (kept by reference; must outlive the solver).
  /// @param particles Particle state (kept by reference; must outlive the
  ///        solver), in ascending id order (Particles::check_order). The
  ///        materials' and the phase field's columns are added.
  /// @param materials Materials indexed by Particles::material.
  /// @param step What each step does (StepConfig).
  /// @throws std::invalid_argument for a bad configuration, or in 3D for one
  ///         that is two-dimensional yet (the damage-gradient partition,
  ///         CPDI, a phase field).
  Solver(Grid<Dim>& grid, Particles& particles, std::vector<std::shared_ptr<const Material>> materials,
         StepConfig step);

  /// @brief Take `steps` explicit steps, each on the OpenMP thread count
  /// that ThreadGovernor chooses (at most omp_get_max_threads(), which is
  /// as it was on return), unless set_adaptive_threads(false).
  /// @throws SimulationError when a particle leaves the grid, a value turns
  ///         non-finite or the step becomes unstable.
  void advance(std::int64_t steps);

  double dt() const { return _dt; }
  /// The particle-grid transfer of the run.
  TransferScheme transfer() const { return _transfer; }
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
  /// particles, with c_p the P-wave speed of the particle's material in its
  /// state, must satisfy dt (c_p + |v_p|) <= `length` (up to round-off);
  /// otherwise the step throws SimulationError. `length` is the critical
  /// length kappa h of the scene's step rule (K&T eqs. 83-84), which takes the
  /// initial body speeds; the check follows the speeds as they grow. 0
  /// switches the check off (the default).
  void set_stability_length(double length);
  /// @brief With contact, two fields touch at a node, and may push or rub,
  /// where their volumes there add up to at least `fill` of the node's
  /// volume (coulomb_forces): default_touch_fill unless set; 0 is the
  /// paper's contact, on approach alone.
  /// @throws std::invalid_argument unless 0 <= fill <= 1.
  void set_touch_fill(double fill);

  /// @brief The largest c_p + |v_p| over the particles in their present
  /// state: the signal speed the stability check compares with
  /// length / dt (so dt times it over kappa h is the step's Courant number).
  double fastest_signal();

  /// @brief Slot-steps, summed over all steps so far, whose mass was positive
  /// but too small to divide by (below 1e-12 of the heaviest particle): they
  /// get zero velocity instead.
  std::int64_t light_nodes() const { return _light_nodes; }

  /// @brief The mass at or below which a slot is too light to divide by:
  /// 1e-12 of the heaviest particle's at construction.
  double mass_tol() const { return _mass_tol; }
  /// @brief Set mass_tol(): a rank holding part of the particles sets that
  /// of all of them.
  /// @throws std::invalid_argument unless it is >= 0 and finite.
  void set_mass_tol(double tol);

  /// @brief The slabs of nodes (slab_sum) whose sums this solver keeps:
  /// the works, impulses and counts of the grid update over all steps are
  /// those of the nodes of slabs [first, last). All of them by default; a
  /// rank owning the cells of whole tiles along x keeps its own.
  /// @throws std::invalid_argument unless 0 <= first <= last <= the grid's slabs.
  void set_owned_slabs(std::int64_t first, std::int64_t last);
  /// The owned slabs, [first, last).
  std::array<std::int64_t, 2> owned_slabs() const { return {_slab_first, _slab_last}; }
  /// @brief The grid update's sums over all steps so far per owned slab
  /// (GridUpdate's entries, its `size` per slab, slab by slab): every work
  /// and impulse is the sum of its slabs' in slab order.
  const std::vector<double>& slab_sums() const { return _slab_sums; }

  /// @brief The state besides the particle columns, for a checkpoint.
  SolverState state() const;
  /// @brief Continue from `state`, saved by state() of a solver built on the
  /// same scene, with the particle columns restored beside it.
  /// @throws std::invalid_argument naming the entry if a key is missing or
  ///         unknown, or an array does not fit this grid; naming the
  ///         particle if the restored particles are not in ascending id order.
  void restore(const SolverState& state);

  /// @brief Energies and momentum of the current particle state:
  /// energies_of(tile_sums(), slab_sums()).
  Energies<Dim> energies() const;
  /// @brief The particle sums of energies() per tile of cells (TileSums):
  /// kinetic, elastic, mass and fracture energy, momentum, angular momentum
  /// (its z component in 2D, three in 3D), the work kept by each column of
  /// dissipated work (in the order of their names), with contact each
  /// body's fracture energy, and with more than one body each body's
  /// momentum (Dim per body).
  TileSums tile_sums() const;
  /// @brief The energies from the tile sums of all particles (the tiles
  /// of every process, keys ascending) and the grid update's sums of all
  /// slabs (slab_sums() of every process, in slab order); with one
  /// process, energies().
  /// @throws std::invalid_argument if the tiles' width or the slab sums'
  ///         size does not fit this run.
  Energies<Dim> energies_of(const TileSums& tiles, const std::vector<double>& slabs) const;

  /// @brief With APIC: set each particle's affine matrix to that of the
  /// velocity field v_p + G_p (x - x_p) about it, B_p = G_p D_p, D_p at its
  /// present position (transfer/apic.h): a body seeded with a velocity
  /// gradient starts with it.
  /// @param G The gradients G_p, Dim x Dim row-major per particle, G_ij = dv_i/dx_j.
  /// @throws std::logic_error without APIC; std::invalid_argument for a
  ///         wrong size; SimulationError for a particle outside the grid.
  void set_velocity_gradients(const std::vector<double>& G);

  /// Whether some material can crack.
  bool cracks() const { return !_phase.empty(); }
  /// Whether some material has the fourth-order phase-field term.
  bool fourth_order() const;
  /// Whether the phase field is solved with the bound 0 <= c <= 1.
  bool bounded() const;
  /// Phase-field convergence record, summed over the phase fields.
  PhaseFieldStats phase_field_stats() const;
  /// The contact record, or nullptr with one velocity field.
  const ContactStats* contact_stats() const;
  /// @brief The CG preconditioner of every phase field's solves from now on.
  void set_phase_field_preconditioner(Preconditioner preconditioner);
  /// The preconditioner the phase-field CG uses (automatic resolved).
  Preconditioner phase_field_preconditioner() const;
  /// @brief The last system K c = F of the (single) phase field, for the record.
  /// @throws std::logic_error without a phase field or with several.
  PhaseFieldSystem phase_field_system() const;
  /// The damage-gradient partition, or nullptr.
  const DamageFields<Dim>* damage_fields() const { return std::get_if<DamageFields<Dim>>(&_fields); }
  /// The particles the solver advances.
  const Particles& particles() const { return _particles; }
  /// Wall time per stage so far.
  const StageTimers& timers() const { return _timers; }
  /// @brief Whether advance() adapts the thread count to the machine
  /// (ThreadGovernor; the default), or runs every step on all threads.
  void set_adaptive_threads(bool adaptive) { _adaptive_threads = adaptive; }
  bool adaptive_threads() const { return _adaptive_threads; }
  /// Steps run on fewer threads than the user's count so far.
  std::int64_t reduced_thread_steps() const { return _threads.reduced_steps(); }

  /// @brief Surface flags at t = 0 by the kernel sum over each body's own
  /// particles (DamageFields::detect_surfaces), into the `surface` column.
  /// @param spacing Lattice spacing of each body.
  /// @param threshold s_p = 1 where S < threshold S_bulk.
  /// @return S / S_bulk per particle.
  /// @throws std::logic_error without the damage-gradient partition.
  std::vector<double> detect_surfaces(const std::vector<double>& spacing, double threshold);

  /// @brief Map the current particle state to the grid (P2G only) and return,
  /// per active node, (node index, mass, momentum in Dim directions), summed over
  /// the node's fields. For checks.
  std::vector<std::array<double, 2 + Dim>> nodal_mass_momentum();

private:
  /// One step; `energy`: the particles' fracture energy and the cracking
  /// particles' stress too (the last step of an advance(), whose state
  /// energies and output read).
  template <class Shape, bool Affine, class Fields>
  void step(Fields& fields, bool energy);
  template <class Shape, class Fields>
  void prepare(Fields& fields, bool energy);
  template <class Shape, bool Affine, class Fields>
  void particle_to_grid(Fields& fields);
  template <class Shape, bool Affine, class Fields>
  void grid_to_particle(Fields& fields, bool stress);
  /// @brief Call `visit(key, member)` for every scalar of the run's state
  /// besides the phase fields' and the contact's (SolverState): the one
  /// list that state() and restore() iterate.
  template <class Self, class Visit>
  static void each_scalar(Self& s, Visit&& visit);
  /// Per region, the offsets of each cell's particles of a particle region
  /// (Region::particles, the column `held_by`) in the cell sort; empty for a
  /// box. Kept in _region_cells from step to step.
  const std::vector<std::vector<std::int64_t>>& region_cells();
  /// With CPDI: at t = 0, that no domain is wider than a cell; then set the
  /// step's integration domains and check that each fits its stencil.
  void check_domains() const;
  /// The particle data the stencil of the run reads.
  Points points() const;
  /// f(shape, fields, affine) with the stencil type as shape's `type`
  /// (B-splines of the grid's degree, or CPDI), the partition's type and
  /// the transfer as std::bool_constant (true: APIC).
  template <class F>
  void dispatch(F&& f);
  /// Attach the materials to the particles, and the degradation of each
  /// crackable material to the phase field's columns (once per advance()).
  void bind();
  std::string where(std::size_t particle) const;
  [[noreturn]] void non_finite(std::size_t particle) const;
  /// Throw SimulationError if some particle has dt (c_p + |v_p|) > the limit.
  void check_stability_exactly() const;
  /// The stability length with a relative slack that lets a run at the limit
  /// itself (cfl = 1) through round-off.
  double stability_limit() const { return (1.0 + 1e-9) * _stability_length; }
  /// c_p + |v_p|: P-wave speed of the particle plus its speed.
  double signal_speed(std::size_t particle) const;
  /// The largest signal_speed() over the particles (materials bound).
  double max_signal_speed() const;
  bool has_external_force() const;

  /// Per particle, the field index its phase field is chosen by: the body
  /// with discrete fields, the contact group with damage-gradient fields.
  const std::int32_t* phase_field_of() const;

  /// A phase field and the particles that assemble it.
  struct PhaseFieldGroup
  {
    PhaseField<Dim> field;
    std::int32_t body; ///< its body (contact group), or -1 for all crackable particles of the single field
    bool select;       ///< whether its particles are a selection of the sort
    CellSort sort;     ///< the selection, when select
  };

  Grid<Dim>& _grid;
  Particles& _particles;
  std::vector<std::shared_ptr<const Material>> _materials;
  std::vector<std::unique_ptr<Material::Bound>> _bound; // per material, on _particles
  std::vector<std::optional<Fracture>> _fracture; // per material
  std::vector<Degradation> _degradation_of;      // per material, with a phase field
  std::vector<const Degradation*> _degradation;  // per material: of _degradation_of, or null
  double _dt;
  double _time = 0.0;
  std::int64_t _step = 0;
  double _external_work = 0.0;
  double _wall_work = 0.0;
  std::array<std::array<double, Dim>, num_sides(Dim)> _wall_impulse{};
  std::array<std::array<double, Dim>, max_regions> _region_impulse{};
  std::array<double, max_regions> _region_work{};
  std::array<std::array<double, Dim>, max_regions> _region_displacement{};
  std::array<std::array<double, Dim>, max_field_pairs> _pair_impulse{};
  double _mass_tol;
  std::int64_t _light_nodes = 0;
  std::int32_t _bodies = 0;                      // bodies: the largest body index + 1
  std::map<std::string, std::string> dissipation_columns() const; // column -> kind of dissipation
  /// The columns of tile_sums() after the core sums (TileColumns): one per
  /// dissipation column, one per body's fracture energy, Dim per body's momentum.
  struct TileLayout
  {
    int dissipated = 0, bodies = 0, moving = 0;
    int width() const;
  };
  TileLayout tile_layout() const;
  std::int64_t _slab_first = 0, _slab_last = 0; // owned slabs (set_owned_slabs)
  std::vector<double> _slab_sums;                // per owned slab: GridUpdate's sums over the steps
  void total_slab_sums();
  double _stability_length = 0.0; // 0: no check
  double _touch_fill = default_touch_fill;
  bool _external = false; // some particle carries an external force
  typename Partitions<Dim>::type _fields;
  TransferScheme _transfer;
  std::optional<ParticleDomains<Dim>> _domains; // with CPDI
  std::vector<PhaseFieldGroup> _phase;

  CellSort _sort;
  std::vector<NodeSums<Dim>> _sums;          // per slot
  std::vector<SurfaceSums<Dim>> _surface;    // per slot, at contact cells
  std::vector<NodeKinematics<Dim>> _kinematics; // per slot
  std::vector<std::vector<std::int64_t>> _region_cells; // per region (region_cells)
  StageTimers _timers;
  bool _adaptive_threads = true;
  ThreadGovernor _threads;
};

} // namespace pfmpm
