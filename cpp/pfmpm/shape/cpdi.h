/// @file cpdi.h
/// @brief Convected particle domains: the CPDI1 stencil (Sadeghirad et al.
/// 2011, as Homel & Herbold 2017 run it, H&H §2.6) on the degree-1 grid, and
/// the particle domains it reads, convected by the deformation gradient, with
/// the scaling of failed particles' domains.
#pragma once

#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/particles.h"
#include "pfmpm/shape/stencil.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// The shape functions of a run, chosen once: B-splines at the particle
/// centres, or CPDI1 averages over the particle domains.
enum class ShapeFunctions : int
{
  bspline = 0,
  cpdi = 1
};

/// @brief CPDI1 on the degree-1 grid: the shape functions and their
/// gradients averaged over a particle's parallelogram domain.
///
/// The domain has centre x_p and half-edge vectors r_1, r_2; its corners are
/// x_c = x_p + xi_1 r_1 + xi_2 r_2 with xi in {-1, +1}^2. With R = [r_1 r_2],
/// the averages are (H&H eqs. 1-4 with the CPDI1 functions of the method
/// card, §1.1)
///   Sbar_i = 1/4 sum_c S_i(x_c),
///   grad Sbar_i = 1/(4 det R) sum_c S_i(x_c) cof(R) xi_c
///              = sum_c S_i(x_c)/4 R^{-T} xi_c,
/// the exact averages of the bilinear interpolant of S_i between the
/// corners. A corner lies in the particle's cell or a neighbour (the
/// domains' check), so the nodes of the cells c-1 .. c+1 hold them all: a
/// block of 4 x 4 nodes starting one node before the cell, moved inwards at
/// the grid's ends (first()). A corner beyond the grid's edge (a body
/// against it) takes the edge cell's functions, extended linearly: they stay
/// a partition of unity and reproduce linear fields. Provides the members of
/// BSplineStencil that the transfers read.
struct CpdiStencil
{
  static constexpr int dim = 2;
  static constexpr int degree = 1;
  static constexpr int width = 4;  ///< nodes per direction
  static constexpr int lower = -1; ///< first node relative to the cell, away from the grid's ends
  static constexpr int size = width * width;
  /// The stencil reads the particle domains.
  static constexpr bool domains = true;

  static constexpr int offset(int i, int d) { return d == 0 ? i / width : i % width; }
  /// First node of the block of `cell` on a line of `nodes` nodes.
  static int first(int cell, int nodes) { return std::clamp(cell + lower, 0, nodes - width); }

  /// xi_k of corner c (0 .. 3: (-,-), (+,-), (+,+), (-,+)).
  static double xi(int c, int k) { return (k == 0 ? c == 1 || c == 2 : c >= 2) ? 1.0 : -1.0; }
  /// Coordinate d of corner c of the domain with centre x and half-edges r1, r2.
  static double corner(const double* x, const double* r1, const double* r2, int c, int d)
  {
    return x[d] + xi(c, 0) * r1[d] + xi(c, 1) * r2[d];
  }

  double n[size];     ///< Sbar_i
  double dn[2][size]; ///< grad Sbar_i

  double N(int i) const { return n[i]; }
  double dN(int k, int i) const { return dn[k][i]; }

  /// The values and gradients of Q nodal quantities (interpolate_by_nodes).
  template <int Q>
  [[gnu::always_inline]] void interpolate(const double (*nodal)[Q], double (&value)[Q],
                                          double (&grad)[dim][Q]) const
  {
    interpolate_by_nodes<Q>(*this, nodal, value, grad);
  }

  /// f(i, Sbar_i, grad Sbar_i) for every node i in order.
  template <class F>
  void each_node(F&& f) const
  {
    for (int i = 0; i < size; ++i)
    {
      const double g[2] = {dn[0][i], dn[1][i]};
      f(i, n[i], g);
    }
  }

  /// @brief Average over the domain with centre x and half-edges r1, r2 of
  /// a particle in cell `cell`.
  void evaluate(const std::array<const BSpline1D*, 2>& basis, const int* cell, const double* x,
                const double* r1, const double* r2)
  {
    const int first_x = first(cell[0], basis[0]->size());
    const int first_y = first(cell[1], basis[1]->size());
    // R^{-T} = cof(R) / det R, with R = [r_1 r_2] by columns.
    const double inv = 1.0 / (r1[0] * r2[1] - r2[0] * r1[1]);
    const double t[2][2] = {{r2[1] * inv, -r1[1] * inv}, {-r2[0] * inv, r1[0] * inv}};
    std::fill(n, n + size, 0.0);
    std::fill(dn[0], dn[0] + size, 0.0);
    std::fill(dn[1], dn[1] + size, 0.0);
    for (int c = 0; c < 4; ++c)
    {
      const double xi1 = xi(c, 0), xi2 = xi(c, 1);
      const double xc[2] = {corner(x, r1, r2, c, 0), corner(x, r1, r2, c, 1)};
      const double g[2] = {t[0][0] * xi1 + t[0][1] * xi2, t[1][0] * xi1 + t[1][1] * xi2};
      // The corner's cell in the block (the domains' check puts it there; the
      // clamp only keeps a corner on a cell face, which the check may have
      // rounded the other way, in the block: the functions are continuous).
      const int ax = std::clamp(basis[0]->clamped_cell(xc[0]) - first_x, 0, 2);
      const int ay = std::clamp(basis[1]->clamped_cell(xc[1]) - first_y, 0, 2);
      double sx[2], sy[2], unused[2];
      basis[0]->evaluate<1>(first_x + ax, xc[0], sx, unused);
      basis[1]->evaluate<1>(first_y + ay, xc[1], sy, unused);
      for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
        {
          const int i = (ax + a) * width + ay + b;
          const double w = 0.25 * sx[a] * sy[b];
          n[i] += w;
          dn[0][i] += w * g[0];
          dn[1][i] += w * g[1];
        }
    }
  }
};

/// A CPDI particle maps to a node (the damage-gradient partition: H&H
/// eq. 21 and Algorithms 1-2) where its averaged shape function exceeds this:
/// the functions sum to 1, and a corner on a cell face gives the far node of
/// its cell a weight of round-off size.
inline constexpr double cpdi_maps_to = 1e-12;

/// @brief Which particles are failed, and whether their domains are scaled.
struct DomainScaling
{
  bool enabled = true; ///< scale the domains of failed particles (H&H §2.6)
  /// A particle with phase field c below this is failed (0: only damage D = 1 is).
  double c_failed = 0.0;
};

/// @brief The particle domains of a CPDI run: the half-edge vectors as
/// named particle columns.
///
/// `convected_r1`, `convected_r2` hold r_k = F r_k^0 (method card §1.1): each step's
/// G2P advances them with the velocity gradient as H&H eq. 8 advances F,
/// r_k <- (I + dt L) r_k. `domain_r1`, `domain_r2` hold the integration
/// domain the stencil reads: the convected one, or for a failed particle
/// (damage D = 1, or phase field c below DomainScaling::c_failed) with
/// scaling on, the convected one with each half-diagonal shortened to at
/// most h / 2 (H&H §2.6, method card §1.3), so its diagonal spans at most a
/// cell. F, J, V_p and the stress do not change.
class ParticleDomains
{
public:
  /// The columns of the domains, each (x, y) per particle.
  static std::vector<ColumnSpec> columns();

  ParticleDomains(double h, DomainScaling scaling) : _h(h), _scaling(scaling) {}

  /// @brief Find the columns in `P` (and its damage and phase field, where present).
  void bind(Particles& P);

  /// The integration domains' half-edges r_1 and r_2, (x, y) per particle.
  const double* r1() const { return _d1; }
  const double* r2() const { return _d2; }

  /// @brief Advance the convected half-edges of the particles index[0, n)
  /// by dt with their velocity gradients L (4 per particle, in that order).
  void convect(const std::int32_t* index, std::size_t n, const double* L, double dt) const;

  /// @brief Set every particle's integration domain from its convected one
  /// and its failure state (at the start of a step, after the phase-field
  /// solve).
  /// @return The first particle whose domain reaches past the cells next
  ///         to its own (beyond the grid's edge: past the one cell a corner
  ///         may extend there), or n when there is none.
  std::size_t update(const Grid<2>& grid, const double* x, std::size_t n) const;

  /// @brief The first particle whose domain is wider than a cell in x or y,
  /// or not positively oriented (det R <= 0), or n when there is none.
  std::size_t oversized(std::size_t n) const;

private:
  /// The integration domain of particle p from its convected one.
  void integration_domain(std::size_t p) const;

  double _h;
  DomainScaling _scaling;
  double *_r1 = nullptr, *_r2 = nullptr; // convected, F r^0
  double *_d1 = nullptr, *_d2 = nullptr; // integration domain
  const double* _damage = nullptr;       // D per particle, or null
  const double* _c = nullptr;            // phase field per particle, or null
};

} // namespace pfmpm
