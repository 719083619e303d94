/// @file damage_fields.h
/// @brief The damage-field-gradient (DFG) partition of Homel & Herbold (2017),
/// sections 2.1-2.4: two velocity fields per contact group, chosen per
/// (particle, node) pair by the sign of the damage gradient.
#pragma once

#include "pfmpm/common/parameters.h"

#include "pfmpm/contact/coulomb.h"
#include "pfmpm/fields/fields.h"
#include "pfmpm/fields/neighbours.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/cell_sort.h"
#include "pfmpm/particles/particles.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/transfer/transfer.h"

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

namespace pfmpm
{

/// Where a material's particles take their damage D_p from.
enum class DamageSource : int
{
  none = 0,       ///< D_p = 0 (surface flags still count)
  column = 1,     ///< the `damage` column of a damage model, D_p in [0, 1]
  phase_field = 2 ///< D_p = 1 - c, clipped to [0, 1]
};

/// @brief Parameters of the damage-gradient partition.
struct DamageGradientOptions
{
  /// Contact group of each body (Particles::body); empty: every body its own group.
  std::vector<std::int32_t> groups;
  /// D-bar_min of the separability test (H&H eq. 21): both fields' mean damage must exceed it.
  double separability = 0.25;
  /// Kernel radius r_p of H&H eqs. 17-19; 0: the cell diagonal (the paper's choice).
  double kernel_radius = 0.0;
  /// Verlet skin delta over r_p: neighbours are listed within r_p + 2 delta
  /// and rebuilt once two particles may have closed the gap between them by
  /// more than 2 delta (NeighbourList::stale).
  double skin = 0.1;
  /// A damage model's particle is fully damaged at D_p >= this (the paper's D = 1).
  double full_damage = 1.0 - 1e-4;
  /// A phase-field particle is fully damaged at c <= this.
  double phase_field_threshold = 0.05;
  /// A group's fields may part at a node only where, besides H&H eq. 21, no
  /// particle of a damage model that maps there is still softening (its D
  /// grew in the last step, the column `softening`): the faces part once
  /// their band has stopped softening (docs/contact.md, "Parting"). False:
  /// H&H eq. 21 alone, as the paper.
  bool part_when_softened = true;

  /// @brief The declarations of the partition's parameters, a scene's
  /// [contact] keys with partition = "damage_gradient": separability,
  /// kernel_radius, skin, phase_field_threshold and parting ("softened":
  /// part_when_softened, or "failed"). The defaults above are theirs.
  static std::vector<ParameterSpec> parameters();
  /// @brief The options of `groups` and `given` (the declared parameters,
  /// checked against parameters(), absent ones at their defaults).
  /// @throws std::invalid_argument naming a bad or unknown key.
  static DamageGradientOptions from(std::vector<std::int32_t> groups, const Parameters& given);
};

/// The normalised kernel damage field at every particle (H&H eqs. 17-19).
struct KernelField
{
  std::vector<double> S;    ///< kernel sum (H&H eq. 19)
  std::vector<double> D;    ///< D-bar
  std::vector<double> grad; ///< grad D-bar, N x Dim
};

/// @brief The kernel damage field and its gradient at every particle of
/// positions `x` (N x Dim) with damage `damage`, neighbours within `radius`
/// found through the cell sort of `grid` (for checks and figures).
template <int Dim>
KernelField kernel_damage_field(const Grid<Dim>& grid, const std::vector<double>& x,
                                const std::vector<double>& damage, double radius);

/// @brief Kernel sum (H&H eq. 19) at the interior of a square (Dim = 2) or
/// cubic (Dim = 3) lattice of `spacing`, kernel radius `radius`.
double lattice_kernel_sum(int dim, double spacing, double radius);

/// @brief A bit per node of a cell's block (Grid::block()): 16 nodes at
/// most in 2D, 64 in 3D (cubic B-splines, CPDI).
template <int Dim>
using NodeMask = std::conditional_t<Dim == 2, std::uint32_t, std::uint64_t>;

/// Per-block wall time of the partition, seconds since construction.
struct DamageTimers
{
  double damage = 0.0;     ///< the particle damage, the cells near full damage, the open nodes
  double neighbours = 0.0; ///< staleness check and rebuilds of the neighbour list
  double gradient = 0.0;   ///< the kernel field and its gradient (H&H eqs. 17-19)
  double partition = 0.0;  ///< Algorithm 1, Algorithm 2 and the slot layout
};

/// @brief Two velocity fields per contact group, split at every node by the
/// damage-field gradient (H&H Algorithms 1 and 2), coupled by frictional
/// contact where they are separable (H&H eq. 21, Algorithm 3).
///
/// build() computes, every step:
/// - the particle damage D~_p = max(s_p, D_p) with the surface flag s_p
///   (section 2.4) and whether the particle is fully damaged;
/// - the open nodes, where the fields may separate (below);
/// - at the particles whose stencil reaches an open node, the normalised
///   kernel field and its gradient grad D_p (H&H eqs. 17-19, `damage_gradient`),
///   neighbours from the Verlet list;
/// - per open node and group, the nodal gradient G_i: the particle gradient of
///   largest magnitude among the group's particles mapping to the node
///   (Algorithm 1), ties to the smaller particle index, which is the smaller
///   id (the particles are in ascending id order: Particles::id), so that the
///   result does not depend on the visiting order nor on the particles'
///   place in the arrays;
/// - per (particle, node) pair the side: field A if grad D_p . G_i >= 0,
///   else B (Algorithm 2), as a bit per node of the particle's cell's block
///   (Grid::block(): the B-spline's (degree + 1)^Dim nodes, CPDI's 4^Dim) in a
///   per-particle mask (NodeMask); a pair exists where the particle maps to the node
///   (with B-splines every node of the block, with CPDI those where its
///   averaged shape function exceeds cpdi_maps_to);
///   a particle with zero gradient (no damage variation within r_p, which a
///   B-spline stencil reaches past) is, if intact, on A when it lies behind
///   the particle p* that gave G_i, (x_p* - x_p) . G_i >= 0, else on B, and
///   if fully damaged on the side of its nearest neighbour within r_p of
///   the same body that has a gradient (A without one);
/// - the slots: per node, for each group in its support, A and (if some pair
///   chose it) B. Field index 2 group + side.
///
/// Exact shortcut: a group's fields at a node are separable only if a fully
/// damaged particle of the group maps to it (H&H eq. 21, condition i) and the
/// mass-weighted mean damage of both sides exceeds D-bar_min (condition
/// ii), which needs that of the two together to exceed it (a mean of the
/// two means); a non-separable node acts as one field (Algorithm 3). So
/// where either fails for the group's particles taken together (`open`
/// nodes pass both), G_i is taken as zero, every pair chooses A, and the
/// node has one slot: the single field's sums, without a split that would
/// be merged again. Only particles whose stencil reaches an open node need
/// their gradient, and the neighbours within r_p of the fully damaged ones
/// among them without one (whose side is such a neighbour's); all of them lie
/// in the cells near full damage, and only those cells' particles (and those
/// of the cells a margin around) are in the neighbour lists.
///
/// One source for Dim = 2 and 3 (explicitly instantiated): the kernel field
/// and the tests are the paper's in Dim directions, r_p the cell diagonal
/// sqrt(Dim) h, on B-splines or CPDI.
template <int Dim>
class DamageFields
{
public:
  using Mask = NodeMask<Dim>;
  static constexpr bool discrete = true;
  static constexpr bool per_pair = true;
  /// The most contact groups that may meet at a node (two fields each).
  static constexpr int max_groups = max_node_fields / 2;

  /// @param grid The background grid (kept by reference).
  /// @param particles Particles (kept by reference); gains the columns
  ///        `damage_gradient` and `surface`.
  /// @param friction Coulomb coefficient per pair of groups, row-major
  ///        groups x groups, symmetric, >= 0; the diagonal entry of a group
  ///        is that of its crack faces.
  /// @param source Per material, where its particles' damage comes from.
  DamageFields(const Grid<Dim>& grid, Particles& particles, std::vector<double> friction,
               std::vector<DamageSource> source, DamageGradientOptions options);

  /// Number of contact groups.
  int size() const { return _groups_n; }
  double friction(std::int32_t f, std::int32_t g) const { return _friction[f * _groups_n + g]; }
  const std::vector<double>& friction() const { return _friction; }
  const DamageGradientOptions& options() const { return _options; }
  /// The kernel radius r_p.
  double radius() const { return _radius; }
  /// Contact group of each particle.
  const std::vector<std::int32_t>& group() const { return _group; }

  /// @brief The partition of this step: damage, gradients, Algorithms 1 and
  /// 2, slots (see the class comment). `points` are the particle data the
  /// transfers' stencil reads: the centres, and with CPDI this step's
  /// domains, where a particle maps to the nodes its averaged shape function
  /// is positive at.
  void build(Particles& particles, const CellSort& sort, const Points& points);

  /// @brief Surface flags at t = 0 (H&H section 2.4): s_p = 1 where the kernel
  /// sum of H&H eq. 19 over the particles of p's own body is below `threshold`
  /// times that of the body's lattice interior, S_bulk (reading of card
  /// section 9; per body, so that bodies that start in contact get their
  /// interface painted). The grid's walls are mirror planes: the sum adds
  /// the particles' images in them, so a face on a wall (a symmetry plane)
  /// is not a surface. Flags already set are kept.
  /// @param spacing Lattice spacing of each body (Particles::body).
  /// @return S / S_bulk per particle.
  std::vector<double> detect_surfaces(Particles& particles, const CellSort& sort,
                                      const std::vector<double>& spacing, double threshold);

  // -- what the transfers read ---------------------------------------------

  /// Slots of active node a: [slot_start()[a], slot_start()[a + 1]).
  const std::vector<std::int32_t>& slot_start() const { return _slot_start; }
  std::int32_t num_slots() const { return _slot_start.back(); }
  /// Field index of each slot: 2 group + side (0: A, 1: B).
  const std::vector<std::int32_t>& slot_field() const { return _slot_field; }
  /// @brief Slot of (group, side) at active node a, or -1 when that field
  /// has no particle there.
  /// (A node's slots lie in group order, each group's B right after its
  /// A: a scan of the node's few slots, without going through the groups.)
  std::int32_t slot(std::int32_t a, std::int32_t group, int side) const
  {
    const std::int32_t field = 2 * group;
    std::int32_t s = _slot_start[a];
    while (_slot_field[s] != field) // A is there: the group is in the node's support
      ++s;
    if (side == 0)
      return s;
    return s + 1 < _slot_start[a + 1] && _slot_field[s + 1] == field + 1 ? s + 1 : -1;
  }
  /// @brief The groups of occupied cell `key`, sorted, into out[0, n); returns n.
  int cell_groups(std::size_t key, std::int32_t* out) const
  {
    if (_groups)
      return _groups->cell_fields(key, out);
    out[0] = 0;
    return 1;
  }
  /// Whether a pair of cell `key` chose field B at some node.
  bool split(std::size_t key) const { return _split[key] != 0; }
  /// Whether cell `key` has a node with two or more slots.
  bool touches(std::size_t key) const { return _touches[key] != 0; }
  /// Per particle: bit i set when the pair with stencil node i chose field B.
  const Mask* mask() const { return _mask.data(); }
  /// Per particle: D~_p = max(s_p, D_p).
  const double* damage() const { return _damage.data(); }
  /// Per particle: 1 when fully damaged (or a surface particle), else 0.
  const double* full() const { return _full.data(); }
  /// Per particle: the masks of the last build.
  const std::vector<Mask>& masks() const { return _mask; }
  /// @brief The nodal gradients G_i of the last build (Algorithm 1): per
  /// active node and group in its support, (node, group, G_x, G_y[, G_z]),
  /// from the `damage_gradient` column of `particles` as that build left it.
  std::vector<std::array<double, 2 + Dim>> nodal_gradients(const Particles& particles) const;

  ContactStats& stats() { return _stats; }
  const ContactStats& stats() const { return _stats; }
  const DamageTimers& timers() const { return _timers; }
  /// Neighbour-list builds so far.
  std::int64_t neighbour_builds() const { return _neighbours.builds(); }
  /// Kernel fields evaluated so far (particles whose stencil reaches an open
  /// node, and their neighbours that give a side, whose neighbours' damage
  /// differs from theirs), summed over the builds.
  std::int64_t kernel_evaluations() const { return _evaluated; }
  /// @brief Note that no particle moved more than `distance` in the step
  /// (for the neighbour lists' skin).
  void moved(double distance) { _neighbours.moved(distance); }
  /// @brief Note that the particles' columns were replaced (a restored
  /// state): the next build clears every gradient and mask, not only those
  /// it set itself.
  void forget() { _clear_all = true; }

private:
  /// Group slots: with two or more groups their BodyFields slots, else one
  /// per active node (its index).
  std::size_t num_group_slots() const
  {
    return _groups ? static_cast<std::size_t>(_groups->num_slots())
                   : static_cast<std::size_t>(_grid.num_active());
  }
  /// The group slots of active node a: [first, second).
  std::pair<std::int32_t, std::int32_t> group_slots(std::int32_t a) const
  {
    if (_groups)
      return {_groups->slot_start()[a], _groups->slot_start()[a + 1]};
    return {a, a + 1};
  }
  /// D~_p, the fully damaged flags and the cells holding a fully damaged
  /// particle; returns whether some particle is.
  bool particle_damage(const Particles& particles, const CellSort& sort);
  /// The cells near full damage, then the open nodes and cells.
  void open_cells(const Particles& particles, const CellSort& sort, const Points& points);
  /// The open nodes and cells (class comment; H&H eq. 21 for the two sides
  /// together): per group slot the sums of N_ip m_p and N_ip m_p D~_p over
  /// the cells near full damage, with the shape functions of `Stencil`, the
  /// transfers' own.
  template <class Stencil>
  void open_nodes(const Particles& particles, const CellSort& sort, const Points& points);
  /// The kernel-field gradient at the particles whose stencil reaches an
  /// open node and at their neighbours. The other particles get zero
  /// gradient, and every particle all pairs A (sides() sets the masks of
  /// the open cells).
  void gradients(Particles& particles, const CellSort& sort);
  /// Zero the gradients and masks that the last build set (all of them
  /// after forget()).
  void clear(Particles& particles);
  /// G_i of group slot s: the gradient (in `grad`) of the particle that
  /// Algorithm 1 chose, zero where the node is not open (there the fields
  /// cannot be separable: one field) or no particle there has a gradient.
  std::array<double, Dim> nodal_gradient(std::int32_t s, const double* grad) const
  {
    std::array<double, Dim> G{};
    const std::int32_t q = _best[s];
    if (_open_slot[s] && q >= 0)
      std::copy(&grad[Dim * q], &grad[Dim * q] + Dim, G.begin());
    return G;
  }
  /// Algorithms 1 and 2 from the particle gradients `grad`: nodal
  /// gradients, the pairs' sides, the split cells.
  void sides(const Particles& particles, const CellSort& sort, const Points& points,
             const double* grad);
  /// Slots from the group slots and their sides; the cells next to a node
  /// with two or more.
  void layout(const CellSort& sort, bool any_split);

  const Grid<Dim>& _grid;
  int _groups_n;
  std::vector<double> _friction;
  std::vector<DamageSource> _source;
  DamageGradientOptions _options;
  double _radius;
  std::vector<std::int32_t> _group;   // per particle
  std::optional<BodyFields<Dim>> _groups;  // with two or more groups: their slots
  NeighbourList<Dim> _neighbours;

  std::vector<double> _damage;        // per particle: D~_p
  std::vector<double> _full;          // per particle: 0 or 1
  std::vector<std::uint8_t> _softening; // per particle: a damage model's D grew in the last step
  std::vector<Mask> _mask;            // per particle
  std::vector<std::uint8_t> _full_cell; // per cell: it holds a fully damaged particle
  std::vector<std::uint8_t> _dilated; // per cell: _full_cell dilated along some directions (scratch)
  std::vector<std::uint8_t> _near;    // per cell: a fully damaged particle within reach() cells
  std::vector<std::uint8_t> _open;    // per cell: its block holds an open node
  std::vector<std::int32_t> _near_cells, _open_cells; // the cells of each, in key order
  std::vector<std::uint8_t> _listed_cells; // per cell: the neighbour lists hold its particles
  bool _unlisted = true;              // a particle of a near cell is not in the lists (open_nodes())
  std::vector<std::uint8_t> _proxy;   // per particle: its gradient gives a side (gradients())
  std::vector<std::uint8_t> _set;     // per particle: its gradient or mask may be non-zero
  bool _clear_all = true;             // clear() zeroes every particle's (first build, forget())
  std::vector<std::uint8_t> _split;   // per cell
  std::vector<std::uint8_t> _touches; // per cell
  bool _dirty = false;                // the nodal gradients are this build's (_best is set)

  // Per group slot: the sums of N_ip m_p and N_ip m_p D~_p over the group's
  // particles, whether a fully damaged one maps there, whether a softening
  // one does, whether the node is
  // open; Algorithm 1's best particle (|grad|^2, index; nodal_gradient()),
  // whether some pair chose B.
  std::vector<double> _mass, _mass_damage;
  std::vector<std::uint8_t> _group_full;
  std::vector<std::uint8_t> _group_softening;
  std::vector<std::uint8_t> _open_slot;
  std::vector<double> _best_norm;
  std::vector<std::int32_t> _best;
  std::vector<std::uint8_t> _has_b;

  std::vector<std::int32_t> _slot_start; // per active node + 1
  std::vector<std::int32_t> _slot_field; // per slot
  ContactStats _stats;
  DamageTimers _timers;
  std::int64_t _evaluated = 0;
};

extern template class DamageFields<2>;
extern template class DamageFields<3>;

} // namespace pfmpm
