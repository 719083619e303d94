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
#include <string>
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
/// gradients averaged over a particle's domain, a parallelogram in 2D and a
/// parallelepiped in 3D.
///
/// The domain has centre x_p and half-edge vectors r_1 .. r_Dim; its 2^Dim
/// corners are x_c = x_p + sum_k xi_k r_k with xi in {-1, +1}^Dim. With
/// R = [r_1 .. r_Dim], the averages are (H&H eqs. 1-4 with the CPDI1
/// functions of the method card, §1.1)
///   Sbar_i = 2^-Dim sum_c S_i(x_c),
///   grad Sbar_i = 1/(2^Dim det R) sum_c S_i(x_c) cof(R) xi_c
///              = sum_c S_i(x_c)/2^Dim R^{-T} xi_c,
/// the exact averages of the multilinear interpolant of S_i between the
/// corners. A corner lies in the particle's cell or a neighbour (the
/// domains' check), so the nodes of the cells c-1 .. c+1 hold them all: a
/// block of 4 nodes per direction (4 x 4, or 4 x 4 x 4) starting one node
/// before the cell, moved inwards at the grid's ends (first()). A corner
/// beyond the grid's edge (a body against it) takes the edge cell's
/// functions, extended linearly: they stay a partition of unity and
/// reproduce linear fields. Provides the members of BSplineStencil that the
/// transfers read.
template <int Dim>
struct CpdiStencil
{
  static_assert(Dim == 2 || Dim == 3, "CPDI domains in 2 or 3 directions");
  static constexpr int dim = Dim;
  static constexpr int degree = 1;
  static constexpr int width = 4;  ///< nodes per direction
  static constexpr int lower = -1; ///< first node relative to the cell, away from the grid's ends
  static constexpr int size = Dim == 2 ? width * width : width * width * width;
  static constexpr int corners = 1 << Dim; ///< of a domain
  /// The stencil reads the particle domains.
  static constexpr bool domains = true;

  /// Offset a_d of stencil node i in direction d (the last direction fastest).
  static constexpr int offset(int i, int d)
  {
    int stride = 1;
    for (int e = Dim - 1; e > d; --e)
      stride *= width;
    return (i / stride) % width;
  }
  /// First node of the block of `cell` on a line of `nodes` nodes.
  static int first(int cell, int nodes) { return std::clamp(cell + lower, 0, nodes - width); }

  /// xi_k of corner c: 0 .. 3 are (-,-), (+,-), (+,+), (-,+) in (xi_1, xi_2),
  /// in 3D at xi_3 = -1, and 4 .. 7 the same at xi_3 = +1.
  static double xi(int c, int k)
  {
    static constexpr double sign[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                          {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    return sign[c][k];
  }
  /// Coordinate d of corner c of the domain with centre x and half-edges r.
  static double corner(const double* x, const double* const (&r)[Dim], int c, int d)
  {
    double xc = x[d];
    for (int k = 0; k < Dim; ++k)
      xc += xi(c, k) * r[k][d];
    return xc;
  }
  /// det R of R = [r_1 .. r_Dim] by columns: the domain's volume over 2^Dim.
  static double determinant(const double* const (&r)[Dim])
  {
    if constexpr (Dim == 2)
      return r[0][0] * r[1][1] - r[1][0] * r[0][1];
    else
      return r[0][0] * (r[1][1] * r[2][2] - r[2][1] * r[1][2])
             + r[1][0] * (r[2][1] * r[0][2] - r[0][1] * r[2][2])
             + r[2][0] * (r[0][1] * r[1][2] - r[1][1] * r[0][2]);
  }

  double n[size];       ///< Sbar_i
  double dn[Dim][size]; ///< grad Sbar_i

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
      double g[Dim];
      for (int k = 0; k < Dim; ++k)
        g[k] = dn[k][i];
      f(i, n[i], g);
    }
  }

  /// @brief Average over the domain with centre x and half-edges r_1 ..
  /// r_Dim (one pointer each) of a particle in cell `cell`.
  template <class... Edge>
  void evaluate(const std::array<const BSpline1D*, Dim>& basis, const int* cell, const double* x,
                const Edge*... edges)
  {
    static_assert(sizeof...(Edge) == Dim, "one half-edge per direction");
    const double* const r[Dim] = {edges...};
    int first_node[Dim];
    for (int d = 0; d < Dim; ++d)
      first_node[d] = first(cell[d], basis[d]->size());
    // t = R^{-T} = cof(R) / det R, with R = [r_1 .. r_Dim] by columns: in 3D
    // the columns of cof(R) are r_2 x r_3, r_3 x r_1, r_1 x r_2.
    const double inv = 1.0 / determinant(r);
    double t[Dim][Dim];
    if constexpr (Dim == 2)
    {
      t[0][0] = r[1][1] * inv;
      t[0][1] = -r[0][1] * inv;
      t[1][0] = -r[1][0] * inv;
      t[1][1] = r[0][0] * inv;
    }
    else
      for (int k = 0; k < 3; ++k)
      {
        const double* a = r[(k + 1) % 3];
        const double* b = r[(k + 2) % 3];
        t[0][k] = (a[1] * b[2] - a[2] * b[1]) * inv;
        t[1][k] = (a[2] * b[0] - a[0] * b[2]) * inv;
        t[2][k] = (a[0] * b[1] - a[1] * b[0]) * inv;
      }
    std::fill(n, n + size, 0.0);
    for (int k = 0; k < Dim; ++k)
      std::fill(dn[k], dn[k] + size, 0.0);
#pragma GCC unroll 8
    for (int c = 0; c < corners; ++c)
    {
      // The corner's gradient weight R^{-T} xi_c and, per direction, its
      // cell in the block (the domains' check puts it there; the clamp only
      // keeps a corner on a cell face, which the check may have rounded the
      // other way, in the block: the functions are continuous) and the two
      // hat functions of that cell at the corner.
      double g[Dim], s[Dim][2];
      int a[Dim];
      for (int d = 0; d < Dim; ++d)
      {
        g[d] = t[d][0] * xi(c, 0);
        for (int k = 1; k < Dim; ++k)
          g[d] += t[d][k] * xi(c, k);
        const double xc = corner(x, r, c, d);
        a[d] = std::clamp(basis[d]->clamped_cell(xc) - first_node[d], 0, 2);
        double unused[2];
        basis[d]->template evaluate<1>(first_node[d] + a[d], xc, s[d], unused);
      }
      // The 2^Dim nodes of the corner's cell, the last direction fastest.
#pragma GCC unroll 8
      for (int m = 0; m < corners; ++m)
      {
        int i = 0;
        double w = 1.0 / corners;
        for (int d = 0; d < Dim; ++d)
        {
          const int b = (m >> (Dim - 1 - d)) & 1;
          i = i * width + a[d] + b;
          w *= s[d][b];
        }
        n[i] += w;
        for (int k = 0; k < Dim; ++k)
          dn[k][i] += w * g[k];
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

/// @brief The particle domains of a CPDI run in Dim directions: the
/// half-edge vectors as named particle columns.
///
/// `convected_r1` .. `convected_r<Dim>` hold r_k = F r_k^0 (method card
/// §1.1): each step's G2P advances them with the velocity gradient as H&H
/// eq. 8 advances F, r_k <- (I + dt L) r_k. `domain_r1` .. `domain_r<Dim>`
/// hold the integration domain the stencil reads: the convected one, or for
/// a failed particle (damage D = 1, or phase field c below
/// DomainScaling::c_failed) with scaling on, the convected one with each
/// half-diagonal (2 in 2D, 4 in 3D) shortened to at most h / 2 (H&H §2.6,
/// method card §1.3), so its diagonals span at most a cell. F, J, V_p and
/// the stress do not change.
template <int Dim>
class ParticleDomains
{
public:
  /// The columns of the domains, each Dim components per particle.
  static std::vector<ColumnSpec> columns();

  ParticleDomains(double h, DomainScaling scaling) : _h(h), _scaling(scaling) {}

  /// @brief Find the columns in `P` (and its damage and phase field, where present).
  void bind(Particles& P);

  /// The integration domains' half-edges r_(k+1), Dim components per particle.
  const double* r(int k) const { return _d[k]; }

  /// @brief Advance the convected half-edges of the particles index[0, n)
  /// by dt with their velocity gradients L (Dim x Dim per particle, row-major).
  void convect(const std::int32_t* index, std::size_t n, const double* L, double dt) const;

  /// @brief Set every particle's integration domain from its convected one
  /// and its failure state (at the start of a step, after the phase-field
  /// solve).
  /// @return The first particle whose domain reaches past the cells next
  ///         to its own (beyond the grid's edge: past the one cell a corner
  ///         may extend there), or n when there is none.
  std::size_t update(const Grid<Dim>& grid, const double* x, std::size_t n) const;

  /// @brief The first particle whose domain is wider than a cell in some
  /// direction, or not positively oriented (det R <= 0), or n when there is none.
  std::size_t oversized(std::size_t n) const;

  /// The half-edges of particle p's integration domain as text, "r1 = (..), r2 = (..)".
  std::string describe(std::size_t p) const;

private:
  /// The integration domain of particle p from its convected one.
  void integration_domain(std::size_t p) const;

  double _h;
  DomainScaling _scaling;
  double* _r[Dim] = {}; // convected, F r^0
  double* _d[Dim] = {}; // integration domain
  const double* _damage = nullptr; // D per particle, or null
  const double* _c = nullptr;      // phase field per particle, or null
};

} // namespace pfmpm
