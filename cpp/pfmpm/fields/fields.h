/// @file fields.h
/// @brief Velocity-field partitions: the grid slot that each (particle, node)
/// pair maps to, chosen once per run.
///
/// Every P2G sum and every G2P read goes to a slot. With one velocity field
/// (SingleField) a node has one slot and every particle maps to it. With
/// discrete fields (BodyFields, K&T eq. 28 of section 3.1.1) every body is its
/// own field: a node has one slot per body in its support, and a particle maps
/// to its body's slot; nodes with two or more are contact nodes (Remark 4),
/// where the contact law couples the slots. A partition that chooses the slot
/// per (particle, node) pair (the damage-field gradient of Homel & Herbold
/// 2017, Algorithm 2: DamageFields, damage_fields.h) takes the same place:
/// its choice depends on the node (`per_pair`).
#pragma once

#include "pfmpm/contact/coulomb.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/cell_sort.h"
#include "pfmpm/particles/particles.h"

#include <cstdint>
#include <vector>

namespace pfmpm
{

/// P2G sums of one slot, in Dim directions.
template <int Dim>
struct NodeSums
{
  double m;      ///< mass (K&T eq. 46)
  double p[Dim]; ///< momentum (K&T eq. 61)
  double f[Dim]; ///< net force F^ext - F^int (K&T eqs. 42, 62)
  double e[Dim]; ///< external force alone, for the work it does
};

/// Surface sums of one slot at a contact node, in Dim directions.
template <int Dim>
struct SurfaceSums
{
  double g[Dim]; ///< mass gradient sum_p grad N_I M_p (K&T eq. 70, before normalisation)
  double V;      ///< volume sum_p N_I V_p (the touch check, docs/contact.md)
  /// With damage fields only: sum_p N_I M_p D_p, the numerator of the mean
  /// damage (H&H eq. 21), and whether a fully damaged particle maps here (1 or 0).
  double md, full;
};

/// The most fields (bodies, or damage-gradient sides) that may meet in one cell or at one node.
constexpr int max_node_fields = 16;

/// Velocity and acceleration of one slot after the grid update (K&T eqs. 63-65).
template <int Dim>
struct NodeKinematics
{
  double v[Dim], a[Dim];
};

/// @brief The number n of fields of a row-major n x n friction matrix.
/// @throws std::invalid_argument unless it is square with n >= `at_least`
///         fields and finite, >= 0 and symmetric entries.
int friction_fields(const std::vector<double>& friction, int at_least);

/// @brief Set the entries of `cells` (per cell of `grid`) of the occupied
/// cells of `sort` whose block holds active node a (NodeBlock::holders),
/// given `only`, of those where it is not 0: from a node, which is cheaper
/// than from every cell to its nodes where such nodes are few.
template <int Dim>
void mark_holders(const Grid<Dim>& grid, const CellSort& sort, std::int32_t a,
                  const std::uint8_t* only, std::uint8_t* cells);

/// @brief Per cell of `sort`, whether a node of its block has two or more
/// slots (a contact node), where P2G sums the surface quantities: into
/// `touches`, 0 for every cell when there are no `contact_nodes`, and for
/// the empty cells and, given `only`, the cells where it is 0.
/// @param slot_start Slots of active node a: [slot_start[a], slot_start[a + 1]).
template <int Dim>
void mark_contact_cells(const Grid<Dim>& grid, const CellSort& sort,
                        const std::vector<std::int32_t>& slot_start, std::int32_t contact_nodes,
                        const std::uint8_t* only, std::vector<std::uint8_t>& touches);

/// @brief One velocity field: node a's only slot is a.
struct SingleField
{
  static constexpr bool discrete = false;
  static constexpr bool per_pair = false;
};

/// @brief Every body its own velocity field on the shared grid (K&T eq. 28),
/// coupled by frictional contact where two meet.
///
/// build() tags each occupied cell with the bodies of its particles and gives
/// each active node one slot per body in its support, in body order; a node
/// with two or more is a contact node. A cell touches contact when one of its
/// nodes is one: only there does P2G sum the surface quantities.
template <int Dim>
class BodyFields
{
public:
  static constexpr bool discrete = true;
  static constexpr bool per_pair = false;
  /// The most bodies that may meet in one cell or at one node.
  static constexpr int max_fields = max_node_fields;

  /// @param grid The background grid (kept by reference).
  /// @param particles Particles; Particles::body is the field index, in [0, fields).
  /// @param friction Coulomb coefficient mu_f per pair of fields, row-major
  ///        fields x fields, symmetric, >= 0, at least 2 x 2.
  /// @param field The field index of each particle instead of
  ///        Particles::body (the contact groups of DamageFields; kept by pointer).
  BodyFields(const Grid<Dim>& grid, const Particles& particles, std::vector<double> friction,
             const std::int32_t* field = nullptr);

  /// Number of fields.
  int size() const { return _fields; }
  /// Friction coefficient between fields f and g.
  double friction(std::int32_t f, std::int32_t g) const { return _friction[f * _fields + g]; }
  const std::vector<double>& friction() const { return _friction; }

  /// @brief Tag the cells and lay out the slots for this step's sort and
  /// active nodes (Remark 4). Without `mark_touches`, touches() is left as
  /// it was (DamageFields, which splits these slots, marks its own cells).
  void build(const Particles& particles, const CellSort& sort, bool mark_touches = true);

  /// Slots of active node a: [slot_start()[a], slot_start()[a + 1]).
  const std::vector<std::int32_t>& slot_start() const { return _slot_start; }
  std::int32_t num_slots() const { return _slot_start.back(); }
  /// The field of slot s.
  std::int32_t field(std::int32_t s) const { return _slot_field[s]; }
  const std::vector<std::int32_t>& slot_field() const { return _slot_field; }
  /// Slot of `field` at active node a (the field is in the node's support).
  std::int32_t slot(std::int32_t a, std::int32_t field) const
  {
    std::int32_t s = _slot_start[a];
    while (_slot_field[s] != field)
      ++s;
    return s;
  }
  /// @brief The bodies of occupied cell `key`, sorted, into out[0, n); returns n.
  int cell_fields(std::size_t key, std::int32_t* out) const;
  /// Whether cell `key` has a contact node among its nodes.
  bool touches(std::size_t key) const { return _touches[key] != 0; }

  ContactStats& stats() { return _stats; }
  const ContactStats& stats() const { return _stats; }

private:
  /// Distinct fields of the cells whose block holds node `node` (its
  /// support: NodeBlock::holders, with CPDI the cells whose 4 x 4 blocks hold it), sorted, into
  /// `out` (capacity max_fields); returns how many, or -1 past capacity.
  int node_fields(std::int32_t node, std::int32_t* out) const;

  const Grid<Dim>& _grid;
  const std::int32_t* _field;             // per particle, or null: Particles::body
  int _fields;
  std::vector<double> _friction;          // fields x fields
  std::vector<std::int32_t> _cell_field;  // per cell: -1 empty, field, or -2 - mixed index
  std::vector<std::int32_t> _mixed_start; // CSR of the fields of mixed cells
  std::vector<std::int32_t> _mixed_fields;
  std::vector<std::uint8_t> _touches;     // per cell
  std::vector<std::int32_t> _slot_start;  // per active node + 1
  std::vector<std::int32_t> _slot_field;  // per slot
  std::vector<std::int32_t> _lone_field;  // per active node: its field, when it has one (build scratch)
  ContactStats _stats;
};

} // namespace pfmpm
