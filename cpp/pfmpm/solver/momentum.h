/// @file momentum.h
/// @brief The momentum stages of the explicit step on a velocity-field
/// partition (Kakouris & Triantafyllou 2019, Algorithm 1): P2G of mass,
/// momentum and forces, the grid update with walls and contact, and G2P of
/// velocity, position and velocity gradient followed by the materials' update.
#pragma once

#include "pfmpm/common/reduce.h"
#include "pfmpm/common/symmetric.h"
#include "pfmpm/contact/coulomb.h"
#include "pfmpm/fields/fields.h"
#include "pfmpm/materials/deformation.h"
#include "pfmpm/materials/material.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/transfer/apic.h"
#include "pfmpm/transfer/transfer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

namespace pfmpm
{

/// @brief The active indices of a cell's stencil nodes.
///
/// A stencil row (the nodes with the same offsets but the last) is a run of
/// consecutive active nodes (Grid::activate), so one look-up per row gives
/// them: width rows in 2D, width^2 in 3D.
template <class Shape>
class CellNodes
{
public:
  static constexpr int Dim = Shape::dim;
  static constexpr int rows = Shape::size / Shape::width;

  CellNodes(const Grid<Dim>& grid, const Cell<Dim>& cell)
  {
    const std::array<int, Dim> nodes = grid.nodes();
    std::array<int, Dim> first;
    for (int d = 0; d < Dim; ++d)
      first[d] = Shape::first(cell.index[d], nodes[d]);
    for (int r = 0; r < rows; ++r)
    {
      std::array<int, Dim> node = first;
      for (int d = 0; d + 1 < Dim; ++d)
        node[d] += Shape::offset(r * Shape::width, d);
      _row[r] = grid.active().index(node);
    }
  }
  /// Active index of stencil node i.
  std::int32_t operator[](int i) const
  {
    return _row[i / Shape::width] + Shape::offset(i, Dim - 1);
  }

private:
  std::int32_t _row[rows];
};

/// The fields of a cell: the local field f of the block is `field[f]` (with
/// damage fields, the local fields 2 f and 2 f + 1 are the sides of group `field[f]`).
struct CellFields
{
  int n = 1;                                      ///< local fields (groups)
  std::int32_t field[max_node_fields] = {}; ///< their field (group) indices
  /// Local field of a particle of field `body`.
  int local(std::int32_t body) const
  {
    int f = 0;
    while (field[f] != body)
      ++f;
    return f;
  }
};

/// @brief The local field of a cell's (particle, node) pairs when the cell
/// has one: every pair maps to it.
struct OneField
{
  struct Particle
  {
  };
  Particle particle(std::size_t) const { return {}; }
  static int at(Particle, int) { return 0; }
};

/// @brief Discrete fields (K&T eq. 28): a particle maps to its body's local
/// field at every node.
struct ByBody
{
  const std::int32_t* body;
  const CellFields& local;
  int particle(std::size_t p) const { return local.local(body[p]); }
  static int at(int f, int) { return f; }
};

/// @brief Damage-gradient fields (H&H Algorithm 2): the pair (p, i) maps to
/// the local field 2 g + side, g the local index of p's group and side the
/// bit i of p's mask (A if grad D_p . G_i >= 0, B otherwise).
template <class Mask>
struct BySide
{
  const std::int32_t* group;
  const Mask* mask;
  const CellFields& local;
  struct Particle
  {
    int base;
    Mask mask;
  };
  Particle particle(std::size_t p) const { return {2 * local.local(group[p]), mask[p]}; }
  static int at(const Particle& f, int i) { return f.base + static_cast<int>((f.mask >> i) & 1u); }
};

/// The particle arrays that P2G reads (vectors Dim per particle, the stress
/// symmetric_size(Dim)).
struct P2GArrays
{
  const double *v, *mass, *volume, *stress, *fext;
  const double *damage, *full; ///< with damage fields: D~_p and the fully damaged flag
  const double* affine = nullptr; ///< with APIC: B_p
};

/// @brief The P2G sums of one cell: per local field and stencil node, the
/// sums of NodeSums (internal and external force apart), with Surface those
/// of SurfaceSums, and with Damage its damage sums.
template <int Dim, int F, int K, bool Surface, bool Damage>
struct P2GBlock
{
  double m[F][K], p[Dim][F][K], f[Dim][F][K], e[Dim][F][K];
  double g[Dim][Surface ? F : 1][K], V[Surface ? F : 1][K];
  double md[Damage ? F : 1][K], full[Damage ? F : 1][K];
};

/// @brief Sum a cell's particles, in sorted order, into its block: mass
/// (K&T eq. 46), momentum (K&T eq. 61), internal and external force (K&T eqs. 62,
/// 42), with Surface the mass gradient (K&T eq. 70, H&H eq. 11) and volume, and
/// with Damage the mass-weighted damage and the fully damaged flag of H&H
/// eq. 21. `select` gives each (particle, node) pair its local field.
///
/// Not inlined, on purpose: every partition runs this same compiled
/// arithmetic (the compiler may fuse multiply-adds differently where it
/// inlines), so a body alone in its cells, or a damage field with no
/// split, gets the bits one field gets.
template <class Shape, bool External, int F, bool Surface, bool Damage, class Select>
[[gnu::noinline]] void sum_cell(const detail::EachParticle<Shape>& each, const P2GArrays& a,
                                const Select& select,
                                P2GBlock<Shape::dim, F, Shape::size, Surface, Damage>& block)
{
  constexpr int Dim = Shape::dim;
  constexpr int K = Shape::size;
  constexpr int S = Surface ? F : 1;
  constexpr int D = Damage ? F : 1;
  constexpr int T = symmetric_size(Dim);
  const double *v = a.v, *mass = a.mass, *volume = a.volume, *stress = a.stress, *fext = a.fext;
  // Local arrays, which the compiler keeps apart from the particle arrays.
  // One block per direction, each aligned for the vector units (a
  // [Dim][F][K] array would start its second direction mid-vector).
  struct alignas(32) Block
  {
    double v[F][K];
  };
  double m[F][K]{};
  Block mv[Dim]{}, fi[Dim]{}, ext[Dim]{};
  struct alignas(32) SurfaceBlock
  {
    double v[S][K];
  };
  [[maybe_unused]] SurfaceBlock mg[Dim]{};
  [[maybe_unused]] double V[S][K]{};
  [[maybe_unused]] double md[D][K]{}, full[D][K]{};
  each(
      [&](std::size_t p, const Shape& s)
      {
        const auto fp = select.particle(p);
        const double mp = mass[p];
        double mvp[Dim];
#pragma GCC unroll 3
        for (int d = 0; d < Dim; ++d)
          mvp[d] = mp * v[Dim * p + d];
        const double Vp = volume[p];
        // V_p sigma_p, the entries the force reads (zz in 2D is out of plane).
        double Vs[Dim][Dim];
#pragma GCC unroll 3
        for (int d = 0; d < Dim; ++d)
#pragma GCC unroll 3
          for (int k = 0; k < Dim; ++k)
            Vs[d][k] = Vp * stress[T * p + symmetric_entry(d, k)];
        if constexpr (Dim == 3 && F == 1 && !Surface && !Damage)
        {
          // One field in 3D: the same sums, node by node in a loop the
          // compiler vectorises, from the shape functions laid out in node
          // order (2D's nine nodes run fewer instructions through each_node,
          // and summing the 27 by lines along z runs more).
          alignas(32) double w[K], g[Dim][K];
          node_weights(s, w, g);
#pragma omp simd
          for (int i = 0; i < K; ++i)
          {
            m[0][i] += w[i] * mp; // K&T eq. 46
#pragma GCC unroll 3
            for (int d = 0; d < Dim; ++d)
              mv[d].v[0][i] += w[i] * mvp[d]; // K&T eq. 61
#pragma GCC unroll 3
            for (int d = 0; d < Dim; ++d)
            {
              double t = Vs[d][0] * g[0][i]; // K&T eq. 62
#pragma GCC unroll 3
              for (int k = 1; k < Dim; ++k)
                t += Vs[d][k] * g[k][i];
              fi[d].v[0][i] -= t;
            }
          }
        }
        else
        s.each_node(
            [&](int i, double w, const double* g)
            {
              const int f = Select::at(fp, i);
              m[f][i] += w * mp; // K&T eq. 46
#pragma GCC unroll 3
              for (int d = 0; d < Dim; ++d)
                mv[d].v[f][i] += w * mvp[d]; // K&T eq. 61
#pragma GCC unroll 3
              for (int d = 0; d < Dim; ++d)
              {
                double t = Vs[d][0] * g[0]; // K&T eq. 62
#pragma GCC unroll 3
                for (int k = 1; k < Dim; ++k)
                  t += Vs[d][k] * g[k];
                fi[d].v[f][i] -= t;
              }
              if constexpr (Surface)
              {
#pragma GCC unroll 3
                for (int d = 0; d < Dim; ++d)
                  mg[d].v[f][i] += g[d] * mp; // K&T eq. 70, before normalisation
                V[f][i] += w * Vp; // for the touch check
              }
              if constexpr (Damage)
              {
                md[f][i] += w * mp * a.damage[p]; // H&H eq. 21, numerator
                // A fully damaged particle maps to the node where its shape
                // function is positive: every node of the cell's with
                // B-splines, part of the 4 x 4 block with CPDI (above
                // round-off, cpdi_maps_to).
                if constexpr (Shape::domains)
                  full[f][i] = w > cpdi_maps_to ? std::max(full[f][i], a.full[p]) : full[f][i];
                else
                  full[f][i] = std::max(full[f][i], a.full[p]);
              }
            });
        // K&T eq. 42, from the loaded particles alone (few: a load on an edge):
        // a zero force adds zeros, which leave the sums as they are.
        if constexpr (External)
        {
          bool loaded = false;
          for (int d = 0; d < Dim; ++d)
            loaded = loaded || fext[Dim * p + d] != 0.0;
          if (loaded)
            s.each_node(
                [&](int i, double w, const double*)
                {
                  const int f = Select::at(fp, i);
                  for (int d = 0; d < Dim; ++d)
                    ext[d].v[f][i] += w * fext[Dim * p + d];
                });
        }
      });
  std::memcpy(block.m, m, sizeof m);
  for (int d = 0; d < Dim; ++d)
  {
    std::memcpy(block.p[d], mv[d].v, sizeof mv[d].v);
    std::memcpy(block.f[d], fi[d].v, sizeof fi[d].v);
    std::memcpy(block.e[d], ext[d].v, sizeof ext[d].v);
  }
  if constexpr (Surface)
  {
    for (int d = 0; d < Dim; ++d)
      std::memcpy(block.g[d], mg[d].v, sizeof mg[d].v);
    std::memcpy(block.V, V, sizeof V);
  }
  if constexpr (Damage)
  {
    std::memcpy(block.md, md, sizeof md);
    std::memcpy(block.full, full, sizeof full);
  }
}

/// @brief APIC: add to a cell's momentum sums `momentum` (of sum_cell) the
/// affine part of each particle's momentum, m_p N_i C_p (x_i - x_p) with
/// C_p = B_p D_p^-1 (Jiang et al. 2015, eq. 8; apic.h), D_p at the particle's
/// position (`points`: the Greville abscissae of the cell's nodes), each
/// (particle, node) pair's in its own local field (`select`). A pass of its
/// own, so that sum_cell, which every transfer runs, stays as it is.
template <class Shape, int F, class Select>
[[gnu::noinline]] void sum_affine(const detail::EachParticle<Shape>& each, const double* mass,
                                  const double* affine, const Select& select,
                                  const BlockPoints<Shape>& points,
                                  double (&momentum)[Shape::dim][F][Shape::size])
{
  constexpr int Dim = Shape::dim;
  constexpr int K = Shape::size;
  // One aligned block per direction, as in sum_cell.
  struct alignas(32) Block
  {
    double v[F][K];
  };
  Block a[Dim]{};
  each(
      [&](std::size_t p, const Shape& s)
      {
        const auto fp = select.particle(p);
        const AffineFrame<Shape> frame = affine_frame<true>(s, points);
        double c[Dim * Dim];
        affine_velocity<Shape>(&affine[Dim * Dim * p], frame.D, c);
        for (double& ck : c)
          ck *= mass[p];
        s.each_node(
            [&](int i, double w, const double*)
            {
              const int f = Select::at(fp, i);
              double r[Dim];
              frame.node(i, r);
#pragma GCC unroll 3
              for (int d = 0; d < Dim; ++d)
              {
                double t = c[Dim * d] * r[0];
#pragma GCC unroll 3
                for (int k = 1; k < Dim; ++k)
                  t += c[Dim * d + k] * r[k];
                a[d].v[f][i] += w * t;
              }
            });
      });
  for (int d = 0; d < Dim; ++d)
    for (int f = 0; f < F; ++f)
      for (int i = 0; i < K; ++i)
        momentum[d][f][i] += a[d].v[f][i];
}

/// @brief The slot of local field f of a cell at active node a: a with one
/// field, the body's slot with discrete fields, the group's side with damage
/// fields (-1 where that side has no particle at the node).
template <class Fields>
std::int32_t slot_of(const Fields& fields, std::int32_t a, const CellFields& local, int f)
{
  if constexpr (Fields::per_pair)
    return fields.slot(a, local.field[f / 2], f % 2);
  else if constexpr (Fields::discrete)
    return fields.slot(a, local.field[f]);
  else
    return a;
}

/// @brief P2G of mass, momentum, internal and external force into the slots
/// of a partition; at cells next to a contact node also the mass gradient
/// and volume of each field, and with damage fields their damage sums (sum_cell).
///
/// Each cell's particles are summed into a local block per field of the
/// cell, which is then added to the slots once. The internal and external
/// forces are summed apart in the block and added together. A cell whose
/// pairs all map to one field takes the one-field block, whatever the
/// partition. With Affine, the APIC momentum (sum_affine).
template <class Shape, bool External, class Fields, bool Affine>
struct MomentumP2G
{
  static constexpr int Dim = Shape::dim;
  const Grid<Dim>& grid;
  const Fields& fields;
  P2GArrays arrays;
  const std::int32_t* field_of; ///< per particle: its body (discrete) or group (damage fields)
  NodeSums<Dim>* sums;
  SurfaceSums<Dim>* surface;

  void operator()(const Cell<Dim>& cell, const detail::EachParticle<Shape>& each) const
  {
    CellFields local;
    if constexpr (!Fields::discrete)
      scatter<1, false, false>(cell, each, OneField{}, local);
    else if constexpr (!Fields::per_pair)
    {
      local.n = fields.cell_fields(cell.key, local.field);
      if (local.n > 1)
        scatter<max_node_fields, true, false>(cell, each, ByBody{field_of, local}, local);
      else if (fields.touches(cell.key))
        scatter<1, true, false>(cell, each, OneField{}, local);
      else
        scatter<1, false, false>(cell, each, OneField{}, local);
    }
    else
    {
      local.n = fields.cell_groups(cell.key, local.field);
      const BySide<typename Fields::Mask> sides{field_of, fields.mask(), local};
      if (local.n > 1)
        scatter<2 * Fields::max_groups, true, true>(cell, each, sides, local);
      else if (fields.split(cell.key))
        scatter<2, true, true>(cell, each, sides, local);
      else if (fields.touches(cell.key))
        scatter<1, true, true>(cell, each, OneField{}, local);
      else
        scatter<1, false, false>(cell, each, OneField{}, local);
    }
  }

  template <int F, bool Surface, bool Damage, class Select>
  void scatter(const Cell<Dim>& cell, const detail::EachParticle<Shape>& each,
               const Select& select, const CellFields& local) const
  {
    constexpr int K = Shape::size;
    P2GBlock<Dim, F, K, Surface, Damage> b;
    sum_cell<Shape, External, F, Surface, Damage>(each, arrays, select, b);
    if constexpr (Affine)
      sum_affine<Shape, F>(each, arrays.mass, arrays.affine, select, BlockPoints<Shape>(grid, cell),
                           b.p);
    const int nf = F == 1 ? 1 : Fields::per_pair ? 2 * local.n : local.n;
    const CellNodes<Shape> nodes(grid, cell);
    for (int f = 0; f < nf; ++f)
      for (int i = 0; i < K; ++i)
      {
        const std::int32_t slot = slot_of(fields, nodes[i], local, f);
        if (slot < 0)
          continue; // a side no pair of the node chose: its sums are zero
        NodeSums<Dim>& n = sums[slot];
        n.m += b.m[f][i];
        for (int d = 0; d < Dim; ++d)
        {
          n.p[d] += b.p[d][f][i];
          n.f[d] += b.f[d][f][i] + b.e[d][f][i];
          n.e[d] += b.e[d][f][i];
        }
        if constexpr (Surface)
        {
          SurfaceSums<Dim>& u = surface[slot];
          for (int d = 0; d < Dim; ++d)
            u.g[d] += b.g[d][f][i];
          u.V += b.V[f][i];
          if constexpr (Damage)
          {
            u.md += b.md[f][i];
            u.full = std::max(u.full, b.full[f][i]);
          }
        }
      }
  }
};

/// A velocity in Dim directions.
template <int Dim>
using Velocity = std::array<double, Dim>;

/// What the grid update sums over the nodes, in a fixed order (their indices).
template <int Dim>
struct GridUpdate
{
  static constexpr int external_work = 0; ///< work of the external forces over the step
  static constexpr int friction_work = 1; ///< work of the friction forces over the step
  static constexpr int wall_work = 2;     ///< work of the wall constraints over the step (<= 0)
  static constexpr int light = 3;         ///< slots with mass too small to divide by
  static constexpr int region_work = 4;   ///< first of the regions' works over the step, one per region
  /// First of the holders' impulses, Dim holder + d.
  static constexpr int hold_impulse = region_work + max_regions;
  /// First of the contact_counts counters.
  static constexpr int contact = hold_impulse + Dim * num_holders(Dim);
  /// First of the pairs' contact impulses, Dim pair + d.
  static constexpr int pair_impulse = contact + contact_counts;
  /// How many.
  static constexpr int size = pair_impulse + Dim * max_field_pairs;
};

/// @brief The update of a field alone at its node (K&T eqs. 63-65): with no
/// contact force the trial velocity is final; walls, its kinematics, and the
/// work of the external force over the step. Slots lighter than `mass_tol`
/// get zero velocity and are counted. Out of line, so that every partition
/// runs the same arithmetic.
template <int Dim>
void update_free_slot(const NodeSums<Dim>& s, NodeHold hold, const Velocity<Dim>* held, double dt,
                      double mass_tol, NodeKinematics<Dim>& k, double* acc);

/// @brief New velocity vn of a slot with old velocity vo (after contact):
/// walls and regions (a holder sets the new velocity of each direction it
/// holds to its own, u_d, zero for a wall; the acceleration keeps the old
/// velocity so that the particle update, K&T eq. 80, feels the reaction), its
/// kinematics and the work of the external and friction forces over the
/// step (trapezoidal velocity, with u_d for both ends along a held d). A
/// holder's impulse over the step is m (u_d - vn_d), the reaction force
/// times dt, vn_d the velocity the forces alone give; its work is the
/// kinetic energy it adds, m (u_d^2 - vo_d^2) / 2, less the work of the
/// forces it balances while the slot moves at u_d, m (vn_d - vo_d) u_d. For
/// a wall that is -m vo_d^2 / 2: the forces do no work along d, where the
/// slot does not move.
/// @param held Each holder's velocity (Grid::holder_velocity).
template <int Dim>
void finish_slot(const NodeSums<Dim>& s, const double* vo, double* vn, NodeHold hold,
                 const Velocity<Dim>* held, const double* friction, double dt,
                 NodeKinematics<Dim>& k, double* acc);

/// @brief The update of the n >= 2 fields at a contact node (K&T eqs. 63-77):
/// trial momenta and velocities, Coulomb contact between every pair that
/// touches and approaches (coulomb_forces; with two or more touching pairs,
/// Gauss-Seidel sweeps over them), corrected velocities (K&T eq. 65), walls,
/// the work done, and the checks C.3 and C.4.
/// @param field Field index of each slot, into `friction` (nfields x nfields).
/// @param touch_volume What two fields fill where they touch (coulomb_forces).
template <int Dim>
void update_contact_node(int n, const NodeSums<Dim>* sums, const SurfaceSums<Dim>* surface,
                         const std::int32_t* field, const double* friction, int nfields,
                         double touch_volume, NodeHold hold, const Velocity<Dim>* held, double dt,
                         double mass_tol, NodeKinematics<Dim>* k, double* acc);

/// @brief The update of the n >= 2 damage-gradient fields at a node (H&H
/// eq. 21 in Algorithm 3): the two sides of a group are separable where
/// both carry mass, a fully damaged particle maps to one of them, and both
/// mean damages exceed `separability`; sides that are not are summed into
/// one field (the node acts as one field, FLIP update included). The fields
/// that remain, separable sides and other groups, meet by the Coulomb law
/// (update_contact_node), with the friction of their groups' pair (a
/// group's own for its crack faces).
/// @param field Field index of each slot, 2 group + side, sorted.
template <int Dim>
void update_damage_node(int n, const NodeSums<Dim>* sums, const SurfaceSums<Dim>* surface,
                        const std::int32_t* field, const double* friction, int groups,
                        double separability, double touch_volume, NodeHold hold,
                        const Velocity<Dim>* held, double dt, double mass_tol,
                        NodeKinematics<Dim>* k, double* acc);

/// @brief The grid update (K&T eqs. 63-65): trial momentum and velocity of
/// every slot, frictional contact among the slots of a contact node
/// (K&T eqs. 66-77; with damage fields H&H Algorithm 3), walls, and the nodal
/// accelerations that G2P reads. Two fields touch at a node where their
/// volumes there fill `touch_fill` of its volume (coulomb_forces).
/// @return The sums of GridUpdate per slab of nodes (slab_sum).
template <int Dim, class Fields>
std::vector<std::array<double, GridUpdate<Dim>::size>>
update_grid(const Grid<Dim>& grid, Fields& fields, const std::vector<NodeSums<Dim>>& sums,
            const std::vector<SurfaceSums<Dim>>& surface, std::vector<NodeKinematics<Dim>>& kinematics,
            double dt, double mass_tol, double touch_fill)
{
  constexpr int sums_n = GridUpdate<Dim>::size;
  const std::vector<NodeHold>& constrained = grid.constraints();
  const bool holds = !constrained.empty();
  const Velocity<Dim>* held = grid.holder_velocity().data();
  kinematics.resize(sums.size());
  const std::array<int, Dim> nodes = grid.nodes();
  const std::int64_t stride = grid.num_nodes() / nodes[0];
  return slab_sum<sums_n>(
      grid.active_nodes(), stride, num_slabs(nodes[0]),
      [&](std::size_t a, std::array<double, sums_n>& acc)
      {
        const NodeHold hold = holds ? constrained[a] : NodeHold{};
        std::int32_t s0 = static_cast<std::int32_t>(a), n = 1;
        if constexpr (Fields::discrete)
        {
          s0 = fields.slot_start()[a];
          n = fields.slot_start()[a + 1] - s0;
        }
        if (n == 1)
          return update_free_slot<Dim>(sums[s0], hold, held, dt, mass_tol, kinematics[s0], acc.data());
        if constexpr (Fields::discrete)
        {
          acc[GridUpdate<Dim>::contact + count_nodes] += 1.0; // a contact node
          // The volume of two touching fields: a fraction of the node's, the
          // integral of its basis function.
          const std::array<int, Dim> i = lattice_indices<Dim>(
              static_cast<std::size_t>(grid.active_nodes()[a]), grid.nodes());
          double volume = grid.basis(0).integral(i[0]);
          for (int d = 1; d < Dim; ++d)
            volume *= grid.basis(d).integral(i[d]);
          const double touch = touch_fill * volume;
          if constexpr (Fields::per_pair)
            update_damage_node<Dim>(n, &sums[s0], &surface[s0], &fields.slot_field()[s0],
                               fields.friction().data(), fields.size(),
                               fields.options().separability, touch, hold, held, dt, mass_tol,
                               &kinematics[s0], acc.data());
          else
            update_contact_node<Dim>(n, &sums[s0], &surface[s0], &fields.slot_field()[s0],
                                fields.friction().data(), fields.size(), touch, hold, held, dt,
                                mass_tol, &kinematics[s0], acc.data());
        }
      });
}

/// The nodal velocities and accelerations of a cell, per local field and
/// stencil node: v, then a (NodeKinematics' order).
template <int Dim, int F, int K>
struct G2PBlock
{
  double nodal[F][K][2 * Dim];
};

/// The particle arrays that G2P moves.
struct G2PArrays
{
  double *x, *v, *volume;
  double* affine = nullptr; ///< with APIC: B_p
};

/// @brief Move a cell's particles (K&T eqs. 80, 82): velocity from the nodal
/// accelerations (FLIP), or with Affine (APIC) the nodal velocities
/// interpolated and the affine matrix B_p (Jiang et al. 2015, eq. 10, at the
/// position before the move: `points` are the Greville abscissae of the
/// cell's nodes); position from the nodal velocities, each (particle,
/// node) pair reading the values of its local field (`select`); the velocity
/// gradient L_ij = dv_i/dx_j into `L` (Dim x Dim per particle, in sorted order; H&H
/// eq. 7 on the same fields) and the volume from det(I + dt L). Notes the
/// smallest particle with a non-finite position or velocity in `bad`, the
/// largest |v_p|^2 in `speed2` and the largest squared nodal velocity a
/// particle moved with in `drift2`.
///
/// The 2 Dim nodal quantities (v and a) are interpolated together (Shape::interpolate).
/// With more than one field a particle first gathers the values of its
/// fields into one block, so that every partition runs the same arithmetic
/// on the values it reads; not inlined, on purpose, for the same reason (see
/// sum_cell).
template <class Shape, int F, bool Affine, class Select>
[[gnu::noinline]] void move_cell(const detail::EachParticle<Shape>& each, const G2PArrays& a,
                                 const Select& select,
                                 const G2PBlock<Shape::dim, F, Shape::size>& block,
                                 const BlockPoints<Shape>* points, double dt, double* L,
                                 std::size_t& bad, double& speed2, double& drift2)
{
  constexpr int Dim = Shape::dim;
  constexpr int K = Shape::size;
  constexpr int Q = 2 * Dim; // nodal v and a
  double *x = a.x, *v = a.v, *volume = a.volume;
  // APIC (Jiang et al. 2015, eq. 10): B_p = sum_i N_i v_i (x_i - x_p)^T at
  // the particle's position before it moves (apic.h). Generic, so that it
  // is compiled only where APIC calls it.
  [[maybe_unused]] auto affine = [&](std::size_t p, const auto& s, const double (*nodal)[Q])
  {
    const AffineFrame<Shape> frame = affine_frame<false>(s, *points);
    double b[Dim * Dim] = {};
    s.each_node(
        [&](int i, double w, const double*)
        {
          double r[Dim];
          frame.node(i, r);
#pragma GCC unroll 3
          for (int d = 0; d < Dim; ++d)
          {
            const double wv = w * nodal[i][d];
#pragma GCC unroll 3
            for (int k = 0; k < Dim; ++k)
              b[Dim * d + k] += wv * r[k];
          }
        });
    std::copy(b, b + Dim * Dim, &a.affine[Dim * Dim * p]);
  };
  each(
      [&](std::size_t p, const Shape& s)
      {
        double value[Q], grad[Dim][Q]; // (v, a) and their derivatives along each direction
        if constexpr (F == 1)
        {
          s.template interpolate<Q>(block.nodal[0], value, grad);
          if constexpr (Affine)
            affine(p, s, block.nodal[0]);
        }
        else
        {
          const auto fp = select.particle(p);
          double mine[K][Q];
          for (int i = 0; i < K; ++i)
          {
            const int f = Select::at(fp, i);
            for (int q = 0; q < Q; ++q)
              mine[i][q] = block.nodal[f][i][q];
          }
          s.template interpolate<Q>(mine, value, grad);
          if constexpr (Affine)
            affine(p, s, mine);
        }
        // L_ij = dv_i/dx_j, row-major (K&T eq. 78, H&H eq. 7).
        for (int i = 0; i < Dim; ++i)
          for (int j = 0; j < Dim; ++j)
            L[Dim * i + j] = grad[j][i];
        double* const vp = &v[Dim * p];
        double* const xp = &x[Dim * p];
        for (int d = 0; d < Dim; ++d)
        {
          if constexpr (Affine)
            vp[d] = value[d]; // the PIC velocity of APIC (Jiang et al. 2015)
          else
            vp[d] += dt * value[Dim + d]; // K&T eq. 80
        }
        for (int d = 0; d < Dim; ++d)
          xp[d] += dt * value[d]; // K&T eq. 82
        volume[p] *= volume_ratio<Dim>(L, dt);
        double sum = xp[0], speed = vp[0] * vp[0], moved = value[0] * value[0];
        for (int d = 1; d < Dim; ++d)
          sum += xp[d];
        for (int d = 0; d < Dim; ++d)
          sum += vp[d];
        for (int d = 1; d < Dim; ++d)
        {
          speed += vp[d] * vp[d];
          moved += value[d] * value[d];
        }
        if (!std::isfinite(sum))
          bad = std::min(bad, p);
        speed2 = std::max(speed2, speed);
        drift2 = std::max(drift2, moved);
        L += Dim * Dim;
      });
}

/// @brief G2P (K&T eqs. 80, 82, 78): move each cell's particles (move_cell;
/// with Affine the APIC velocity and B_p), each (particle, node) pair
/// reading its slot; then each run of the cell's
/// particles of one material advances its state with the velocity gradient
/// and sets its stress (Material::Bound::update; a cracking particle's only
/// with `stress`), and with CPDI the particle
/// domains are convected (ParticleDomains::convect). Non-finite values and
/// the largest speed are noted for the checks of the step.
template <class Shape, class Fields, bool Affine>
struct KinematicsG2P
{
  static constexpr int Dim = Shape::dim;
  const Grid<Dim>& grid;
  const Fields& fields;
  const NodeKinematics<Dim>* kinematics;
  Particles& particles;
  const std::vector<std::unique_ptr<Material::Bound>>& materials;
  const std::vector<const Degradation*>& degradation;
  const ParticleDomains<Dim>* domains; ///< with CPDI, else null
  double dt;
  const std::int32_t* field_of; ///< per particle: its body (discrete) or group (damage fields)
  /// Whether cracking particles get their stress too (Material::Bound::update).
  bool stress;
  double* affine; ///< with Affine: B_p per particle (the column `affine`), else null

  struct Local
  {
    std::vector<double> L; // the cell's velocity gradients, Dim x Dim per particle
    std::size_t bad;       // first particle with a non-finite value
    double speed2 = 0.0;   // largest |v_p|^2
    double wave = 0.0;     // largest P-wave speed
    double drift2 = 0.0;   // largest squared velocity a particle moved with
  };
  std::size_t bad;
  double speed2 = 0.0, wave = 0.0, drift2 = 0.0;

  Local local() const { return Local{{}, particles.size()}; }
  void merge(const Local& l)
  {
    bad = std::min(bad, l.bad);
    speed2 = std::max(speed2, l.speed2);
    wave = std::max(wave, l.wave);
    drift2 = std::max(drift2, l.drift2);
  }

  void operator()(Local& local, const Cell<Dim>& cell, const detail::EachParticle<Shape>& each) const
  {
    CellFields fields_of;
    if constexpr (Fields::discrete && !Fields::per_pair)
    {
      fields_of.n = fields.cell_fields(cell.key, fields_of.field);
      if (fields_of.n > 1)
        return gather<max_node_fields>(local, cell, each, ByBody{field_of, fields_of},
                                              fields_of);
    }
    if constexpr (Fields::per_pair)
    {
      fields_of.n = fields.cell_groups(cell.key, fields_of.field);
      const BySide<typename Fields::Mask> sides{field_of, fields.mask(), fields_of};
      if (fields_of.n > 1)
        return gather<2 * Fields::max_groups>(local, cell, each, sides, fields_of);
      if (fields.split(cell.key))
        return gather<2>(local, cell, each, sides, fields_of);
    }
    gather<1>(local, cell, each, OneField{}, fields_of);
  }

  template <int F, class Select>
  void gather(Local& local, const Cell<Dim>& cell, const detail::EachParticle<Shape>& each,
              const Select& select, const CellFields& fields_of) const
  {
    constexpr int K = Shape::size;
    constexpr int LL = Dim * Dim; // entries of a velocity gradient
    const int nf = F == 1 ? 1 : Fields::per_pair ? 2 * fields_of.n : fields_of.n;
    // The cell's nodes are read once for all its particles.
    const CellNodes<Shape> active(grid, cell);
    G2PBlock<Dim, F, K> nodes;
    for (int f = 0; f < nf; ++f)
      for (int i = 0; i < K; ++i)
      {
        const std::int32_t slot = slot_of(fields, active[i], fields_of, f);
        const NodeKinematics<Dim> k = slot < 0 ? NodeKinematics<Dim>{} : kinematics[slot];
        static_assert(sizeof k == sizeof nodes.nodal[f][i]);
        std::memcpy(nodes.nodal[f][i], &k, sizeof k);
      }
    local.L.resize(LL * static_cast<std::size_t>(cell.end - cell.begin));
    G2PArrays arrays{particles.x.data(), particles.v.data(), particles.volume.data()};
    if constexpr (Affine)
    {
      arrays.affine = affine;
      const BlockPoints<Shape> points(grid, cell);
      move_cell<Shape, F, true>(each, arrays, select, nodes, &points, dt, local.L.data(),
                                local.bad, local.speed2, local.drift2);
    }
    else
      move_cell<Shape, F, false>(each, arrays, select, nodes, nullptr, dt, local.L.data(),
                                 local.bad, local.speed2, local.drift2);
    // The materials: each run of the cell's particles of one material (with
    // one material, the whole cell).
    auto update = [&](std::int32_t m, const Batch& b)
    {
      const double* L = &local.L[LL * static_cast<std::size_t>(b.index - (each.order + cell.begin))];
      const UpdateResult r = materials[m]->update(b, L, dt, degradation[m], stress);
      local.wave = std::max(local.wave, r.wave);
      local.bad = std::min(local.bad, r.bad);
    };
    if (materials.size() == 1)
      update(0, Batch{each.order + cell.begin, 0, static_cast<std::size_t>(cell.end - cell.begin)});
    else
      for_each_material_run(particles.material.data(), each.order, cell.begin, cell.end, update);
    if constexpr (Shape::domains)
      domains->convect(each.order + cell.begin, static_cast<std::size_t>(cell.end - cell.begin),
                       local.L.data(), dt);
  }
};

} // namespace pfmpm
