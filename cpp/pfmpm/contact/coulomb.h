/// @file coulomb.h
/// @brief Coulomb frictional contact between the velocity fields at a grid
/// node (Kakouris & Triantafyllou 2019, eqs. 66-77 of sections 4.3.1-4.3.2) and
/// the checks C.1-C.4 of Algorithm 1.
#pragma once

#include <array>
#include <cstdint>

namespace pfmpm
{

/// Record of the contact nodes, forces and the checks C.1-C.4 since t = 0.
struct ContactStats
{
  std::int32_t nodes = 0;      ///< contact nodes in the last step (Remark 4)
  std::int64_t pairs = 0;      ///< (node, pair of fields) examined, all steps
  std::int64_t active = 0;     ///< of them, approaching (K&T eq. 77): a force acted
  std::int64_t sliding = 0;    ///< of the active ones, friction at the Coulomb cap (K&T eq. 75)
  /// Violations of C.1 (normals and tangents collinear, K&T eqs. 22a/23a), C.2
  /// (forces equal and opposite, K&T eqs. 22b/23b), C.3 (no approach after the
  /// correction and non-tension, K&T eqs. 22c-22e), C.4 (stick: no slip; slip:
  /// friction at the cap against the slip, K&T eqs. 23c-23e).
  std::array<std::int64_t, 4> violations{};
  double friction_work = 0.0; ///< work of the tangential (friction) contact forces since t = 0 (<= 0)
  /// With damage-gradient fields (H&H): nodes where a group has both sides,
  /// and of them the separable ones (H&H eq. 21), in the last step; and the
  /// separable (node, group)s summed over all steps.
  std::int32_t split = 0;
  std::int32_t separable = 0;
  std::int64_t separable_total = 0;

  /// @brief Call `visit(name, s.member)` for every statistic of `s`, the last
  /// three only with damage-gradient fields (`damage`): the one list that the
  /// solver's state, its restore and the bindings iterate.
  template <class Visit, class Stats>
  static void each(Visit&& visit, bool damage, Stats& s)
  {
    visit("nodes", s.nodes);
    visit("pairs", s.pairs);
    visit("active", s.active);
    visit("sliding", s.sliding);
    visit("C1", s.violations[0]);
    visit("C2", s.violations[1]);
    visit("C3", s.violations[2]);
    visit("C4", s.violations[3]);
    visit("friction_work", s.friction_work);
    if (damage)
    {
      visit("split", s.split);
      visit("separable", s.separable);
      visit("separable_total", s.separable_total);
    }
  }
};

/// Fields (bodies; with damage-gradient fields, contact groups) whose
/// contact impulses are kept per pair: those numbered below this.
constexpr int max_pair_fields = 16;
/// Pairs of such fields.
constexpr int max_field_pairs = max_pair_fields * (max_pair_fields - 1) / 2;
/// The index of the pair of fields a < b < max_pair_fields.
constexpr int field_pair(int a, int b) { return b * (b - 1) / 2 + a; }

/// A field at a contact node after its trial update, as the contact law
/// sees it, in Dim directions.
template <int Dim>
struct TrialField
{
  double m;       ///< mass at the node (K&T eq. 46)
  double pt[Dim]; ///< trial momentum p + dt (F^ext - F^int) (K&T eq. 63)
  double vt[Dim]; ///< trial velocity (K&T eq. 64)
  double g[Dim];  ///< mass gradient (K&T eq. 70)
  double V;       ///< volume sum_p N_I V_p
};

/// A pair of fields a contact force acted on, kept for the checks C.3 and C.4.
template <int Dim>
struct ContactPair
{
  int i, j;
  /// Normal and tangent of field i: in 2D the normal turned a quarter
  /// counter-clockwise; in 3D the direction of the other field's tangential
  /// velocity relative to field i's, along which friction acts (the tangent plane).
  double n[Dim], s[Dim];
  double fn, ft;     ///< normal force (K&T eq. 72) and friction (K&T eq. 75) on field i
  double fts;        ///< the stick force (K&T eq. 74) on field i
  double mu;         ///< friction coefficient
  double scale;      ///< velocity scale of the round-off tolerance
};

/// Counters of the contact at one node, summed over the nodes in a fixed order.
enum ContactCount : int
{
  count_pairs = 0, ///< pairs of live fields examined
  count_active,    ///< of them, approaching: a force acted
  count_sliding,   ///< of those, friction at the Coulomb cap
  count_c1,        ///< violations of C.1
  count_c2,        ///< violations of C.2
  count_c3,        ///< violations of C.3
  count_c4,        ///< violations of C.4
  count_split,     ///< (node, group)s with both damage-gradient sides
  count_separable, ///< of them, separable (H&H eq. 21)
  count_nodes,     ///< contact nodes: nodes with two or more fields
  contact_counts
};

/// @brief Contact forces among the n fields at one node (K&T eqs. 66-77).
///
/// Fields meet in pairs (K&T eq. 66 with the pair's centre of mass). A pair can
/// act only where the two touch (their volumes at the node add up to at
/// least `touch_volume`) and have a normal. With one such pair this is the
/// paper's algorithm: a force where the pair approaches (K&T eq. 77). With two
/// or more (three or more fields), projected Gauss-Seidel sweeps over the
/// pairs: each pair's force is the pair law applied to the velocities the
/// other pairs' forces leave, until no pair approaches, none pulls, none
/// pushes while parting and none slips against Coulomb (C.3, C.4). In 3D
/// the stick force and friction lie in the tangent plane, along the pair's
/// tangential relative velocity, and Coulomb caps their length. Each
/// side's force is computed and the two are checked to be equal and
/// opposite (C.2), so momentum is conserved to round-off.
/// @param n Fields at the node; live[i] false for one too light to act.
/// @param field Field index of each, into `friction` (nfields x nfields).
/// @param touch_volume The volume two fields fill between them where they
///        touch: a touch fraction of the node's volume (default_touch_fill).
/// @param[out] fn, ft Normal and friction force on each field (added to).
/// @param[out] pairs The pairs to check: with one pair, it if it pushed;
///             with more, all of them. Returns how many.
/// @param[in,out] count Counters, indexed by ContactCount.
/// @param[in,out] impulse Per pair of fields a < b (field_pair), the impulse
///        dt F of b's contact force on a, Dim components, added to; pairs of a
///        field with itself or numbered from max_pair_fields on are not kept.
template <int Dim>
int coulomb_forces(int n, const TrialField<Dim>* f, const bool* live, const std::int32_t* field,
                   const double* friction, int nfields, double touch_volume, double dt,
                   double (*fn)[Dim], double (*ft)[Dim], ContactPair<Dim>* pairs, double* count,
                   double* impulse);

/// @brief C.3 and C.4 on the corrected velocities vn of the fields.
template <int Dim>
void check_contact(int active, const ContactPair<Dim>* pairs, const double (*vn)[Dim],
                   double* count);

/// Two fields touch at a node when their volumes there, sum_p N_I V_p, add up
/// to at least a fraction of the node's volume (the integral of N_I), by
/// default this one (`contact.touch_fill` of a scene); bodies with a gap
/// between them fill less. Without this check (a fraction of 0: the
/// paper's contact) the approach condition (K&T eq. 77) alone acts between
/// bodies up to three cells apart. Of 0.9, 0.95 and 0.97, 0.9 is the largest
/// that kept colliding disks apart by half a particle spacing
/// (docs/contact.md, "Touching").
inline constexpr double default_touch_fill = 0.9;

} // namespace pfmpm
