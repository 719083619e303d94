/// @file contact.h
/// @brief Discrete fields and Coulomb frictional contact at shared grid nodes
/// (Kakouris & Triantafyllou 2019, sections 3.1.1 and 4.3.1-4.3.2, eqs. 63-77,
/// Remark 4, checks C.1-C.4 of Algorithm 1).
#pragma once

#include "grid.h"
#include "material.h"
#include "particles.h"
#include "phasefield.h"

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace pfmpm
{

/// Record of the contact nodes, forces and the checks C.1-C.4 since t = 0.
struct ContactStats
{
  std::int32_t nodes = 0;      ///< contact nodes in the last step (Remark 4)
  std::int64_t pairs = 0;      ///< (node, pair of fields) examined, all steps
  std::int64_t active = 0;     ///< of them, approaching (eq. 77): a force acted
  std::int64_t sliding = 0;    ///< of the active ones, friction at the Coulomb cap (eq. 75)
  /// Violations of C.1 (normals and tangents collinear, eqs. 22a/23a), C.2
  /// (forces equal and opposite, eqs. 22b/23b), C.3 (no approach after the
  /// correction and non-tension, eqs. 22c-22e), C.4 (stick: no slip; slip:
  /// friction at the cap against the slip, eqs. 23c-23e).
  std::array<std::int64_t, 4> violations{};
  double friction_work = 0.0; ///< work of the tangential (friction) contact forces since t = 0 (<= 0)
};

/// @brief What discrete fields carry from one step to the next: each
/// crackable field's phase-field state (its CG warm start, statistics and
/// per-particle fracture energy) and the contact record. The contact nodes,
/// their per-field sums and the per-field particle order are rebuilt every step.
struct DiscreteFieldsState
{
  std::vector<PhaseFieldState> phase_fields; ///< per crackable field, in field order
  ContactStats stats;
};

/// @brief Every body its own discrete field on the shared grid (eq. 28),
/// coupled only by frictional contact at the nodes two fields share.
///
/// The solver's single-field P2G and grid update stay as they are: at a
/// node that one field alone touches they are that field's. This class keeps
/// the per-field quantities at the contact nodes only: mass, momentum,
/// forces and mass gradient, the predictor-corrector of eqs. 63-77 there,
/// and the per-field velocities particles of each field read back. It also
/// owns one phase field per field that can crack, each assembled from that
/// field's particles alone.
///
/// Fields meeting at a node interact in pairs (eq. 66 with the pair's centre
/// of mass); for two fields this is the paper's algorithm. Each pair's force
/// is computed from both sides and the two are checked to be equal and
/// opposite (C.2), so linear momentum is conserved to round-off. All sums
/// have a fixed order: results do not depend on the thread count.
class DiscreteFields
{
public:
  /// @param grid The background grid (kept by reference).
  /// @param particles Particles; Particles::body is the field index, in [0, fields).
  /// @param friction Coulomb coefficient mu_f per pair of fields, row-major
  ///        fields x fields, symmetric, >= 0.
  /// @param fracture Per material: fracture parameters or none.
  /// @param tol, max_iterations Phase-field solver settings (see PhaseField).
  DiscreteFields(const Grid& grid, const Particles& particles, std::vector<double> friction,
                 const std::vector<std::optional<Fracture>>& fracture, double tol,
                 int max_iterations);

  /// Number of fields.
  int size() const { return _fields; }

  /// @brief Find the contact nodes (Remark 4): active nodes in the support
  /// of particles of two or more fields. Needs the cell sort and the active
  /// nodes of this step.
  void detect(const Particles& particles, const std::vector<std::int32_t>& order,
              const std::vector<std::int64_t>& cell_start);

  /// @brief Solve each crackable field's phase field (eqs. 56, 57) with its
  /// own particles and degrade their stresses.
  /// @return -1 when all converged, else the first field that did not.
  template <int P>
  int solve_phase_fields(Particles& particles, const std::vector<std::int32_t>& order,
                         const std::vector<std::int64_t>& cell_start,
                         const std::vector<LinearElastic>& materials);

  /// @brief Per-field P2G at the contact nodes: mass (eq. 46), momentum
  /// (eq. 61), net force (eqs. 42, 62) and mass gradient (eq. 70).
  template <int P, bool External>
  void particle_to_grid(const Particles& particles, const std::vector<std::int32_t>& order,
                        const std::vector<std::int64_t>& cell_start);

  /// @brief Predictor-corrector at the contact nodes (eqs. 63-77), walls,
  /// checks C.1-C.4, and the work of the friction and external forces.
  /// @param dt Time step.
  /// @param mass_tol Nodes (per field) lighter than this carry no velocity.
  /// @return Work of the external forces at the contact nodes over the step.
  double update(double dt, double mass_tol);

  /// Whether active node `a` is a contact node (the solver skips it).
  bool is_contact(std::int32_t a) const { return _contact[a] >= 0; }
  /// Per active node: its contact-node index or -1.
  const std::vector<std::int32_t>& contact_index() const { return _contact; }
  /// Whether a cell has a contact node among its nodes.
  bool touches(std::size_t cell) const { return _touches[cell] != 0; }

  /// @brief Replace the velocities and accelerations of a cell's contact
  /// nodes (arrays of (P+1)^2, node (a, b) at a * (P+1) + b) by those of
  /// `field` there.
  template <int P>
  void field_kinematics(int cx, int cy, std::int32_t field, double* vx, double* vy, double* ax,
                        double* ay) const;

  /// Sum of G_c V Z over the particles of each field (zero where it cannot crack).
  std::vector<double> fracture_energies() const;
  /// Phase-field statistics summed over the fields' solves.
  PhaseFieldStats phase_field_stats() const;
  /// @brief The CG preconditioner of every field's phase-field solves.
  void set_phase_field_preconditioner(Preconditioner preconditioner);
  const ContactStats& stats() const { return _stats; }

  /// @brief A copy of the state carried between steps, for a checkpoint.
  DiscreteFieldsState state() const;
  /// @brief Replace the state carried between steps by `state`.
  /// @throws std::invalid_argument, with nothing replaced, if it does not
  ///         hold one phase field per crackable field, each fitting the grid.
  void restore(DiscreteFieldsState state);

private:
  /// Per-field sums at one contact node.
  struct Sums
  {
    double m, px, py;  // mass (eq. 46), momentum (eq. 61)
    double fx, fy;     // net force F^ext - F^int (eqs. 42, 62)
    double ex, ey;     // external force alone
    double gx, gy;     // mass gradient (eq. 70)
    double V;          // volume sum_p N_I V_p (the touch check)
  };
  struct Kinematics
  {
    double vx, vy, ax, ay;
  };
  /// Slot of `field` at contact node k (the field touches that node).
  std::int32_t slot(std::int32_t k, std::int32_t field) const
  {
    std::int32_t s = _slot_start[k];
    while (_slot_field[s] != field)
      ++s;
    return s;
  }
  /// Distinct fields of the cells in node (ix, iy)'s support, sorted, into
  /// `out` (capacity max_fields_per_node); returns how many.
  int node_fields(int ix, int iy, std::int32_t* out) const;
  void split_by_field(const Particles& particles, const std::vector<std::int32_t>& order,
                      const std::vector<std::int64_t>& cell_start);

  static constexpr int max_fields_per_node = 16;
  /// Two fields touch at a node when their volumes there, sum_p N_I V_p,
  /// add up to at least this fraction of the node's volume (the integral of
  /// N_I); bodies with a gap between them fill less. Without this check the
  /// approach condition (eq. 77) alone acts between bodies up to three cells
  /// apart. Of 0.9, 0.95 and 0.97, 0.9 is the largest that kept colliding
  /// disks apart by half a particle spacing (docs/contact.md, "Touching").
  static constexpr double touch_fill = 0.9;

  const Grid& _grid;
  int _fields;
  std::vector<double> _friction;           // fields x fields
  std::vector<std::int32_t> _crackable;    // per field: index into _phase, or -1
  std::vector<PhaseField> _phase;          // per crackable field
  std::vector<std::int32_t> _phase_field_of; // per crackable field: its field
  std::vector<std::vector<std::int32_t>> _field_order;      // per crackable field
  std::vector<std::vector<std::int64_t>> _field_cell_start; // per crackable field

  std::vector<std::int32_t> _cell_field;  // per cell: -1 empty, field, or -2 - mixed index
  std::vector<std::int32_t> _mixed_start; // CSR of the fields of mixed cells
  std::vector<std::int32_t> _mixed_fields;
  std::vector<std::uint8_t> _touches;     // per cell
  std::vector<std::int32_t> _contact;     // per active node: contact index or -1
  std::vector<std::int32_t> _contact_node; // per contact node: active index
  std::vector<std::int32_t> _slot_start;  // per contact node + 1: first slot
  std::vector<std::int32_t> _slot_field;  // per slot: field
  std::vector<Sums> _sums;                // per slot
  std::vector<Kinematics> _kinematics;    // per slot
  std::vector<std::int32_t> _count;       // per active node, detection scratch
  ContactStats _stats;
};

} // namespace pfmpm
