/// @file apic.h
/// @brief The affine particle-in-cell transfer (APIC: Jiang, Schroeder,
/// Selle, Teran & Stomakhin 2015): the transfer scheme of a run, the
/// particles' affine matrix, and the stencils its transfers read.
///
/// Each particle carries, besides v_p, the matrix
///   B_p = sum_i N_i v_i (x_i - x_p)^T                      (eq. 10)
/// of the nodal velocities it was given, so that its velocity about x_p is
/// the affine field v_p + C_p (x - x_p), C_p = B_p D_p^-1, with
///   D_p = sum_i N_i (x_i - x_p) (x_i - x_p)^T.
/// P2G gives node i the momentum m_p N_i (v_p + C_p (x_i - x_p)) (eq. 8) and
/// G2P sets v_p = sum_i N_i v_i and B_p from the new nodal velocities, both
/// at the particle's position before it moves. x_i is the node's Greville
/// abscissa (BSpline1D::greville), where the basis reproduces linear fields:
/// sum_i N_i (x_i - x_p) = 0, which makes the transfers keep linear and
/// angular momentum (the particles' angular momentum counts m_p times the
/// antisymmetric part of B_p, Energies::angular_momentum).
///
/// D_p is formed per particle from its stencil, not taken as a constant:
/// - Quadratic and cubic B-splines: h^2 / 4 I and h^2 / 3 I away from the
///   grid's ends; on the `degree` cells next to an end (open knots) it
///   varies with x_p and falls to zero at the edge. The tensor product makes
///   it diagonal: D_dd = sum_a N_a(x_d) (X_a - x_d)^2 per direction, the
///   cross sums being products of sum_a N_a (X_a - x_d) = 0.
/// - Degree 1: D_dd = xi (1 - xi) h^2 (xi the coordinate in the cell), and
///   N_i D_p^-1 (x_i - x_p) = grad N_i exactly, so C_p is the velocity
///   gradient sum_i v_i grad N_i^T. On a grid line D_dd = 0, the whole
///   weight sits at distance 0 and that direction's affine term is zero.
/// - CPDI: D_p = sum_i Sbar_i (x_i - x_p)(x_i - x_p)^T is the corners' mean
///   of the bilinear D at each corner plus r_1 r_1^T + r_2 r_2^T, positive
///   definite for every domain with det [r_1 r_2] > 0; a full 2 x 2 inverse.
///
/// The column holds B_p, not C_p: P2G divides by D_p at the particle's
/// position then, which keeps the angular momentum of the transfers exact
/// where D_p varies (the ends of the grid, degree 1, CPDI); a C_p formed in
/// G2P would divide by the D_p of the position before the move.
#pragma once

#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/particles.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/shape/stencil.h"
#include "pfmpm/transfer/transfer.h"

namespace pfmpm
{

/// The particle-grid transfer of a run, chosen once.
enum class TransferScheme : int
{
  flip = 0, ///< v_p += dt sum_i N_i a_i: FLIP with the lumped mass (K&T eq. 80)
  apic = 1  ///< v_p = sum_i N_i v_i with the affine matrix B_p (Jiang et al. 2015)
};

/// @brief The column of the APIC affine matrix B_p (eq. 10), (xx, xy, yx, yy)
/// per particle, B_ij = sum_k N_k v_k,i (x_k - x_p)_j.
inline ColumnSpec affine_column()
{
  return ColumnSpec{"affine", 4, DType::f64, {0.0},
                    "APIC affine matrix B_p = sum_i N_i v_i (x_i - x_p)^T (Jiang et al. 2015, eq. 10)",
                    "xx,xy,yx,yy", ""};
}

/// @brief The Greville abscissae of the nodes of a cell's stencil block, per
/// direction, in cells from the block's first node: u[d][a] for node
/// first(cell) + a (exact small fractions).
template <class Shape>
struct BlockPoints
{
  static_assert(Shape::dim == 2, "the grid is two-dimensional");
  double u[2][Shape::width];
  double h; ///< the cell size

  BlockPoints(const Grid& grid, const Cell& cell) : h(grid.h())
  {
    const int c[2] = {cell.cx, cell.cy};
    for (int d = 0; d < 2; ++d)
    {
      const BSpline1D& basis = grid.basis(d);
      const int first = Shape::first(c[d], basis.size());
      for (int a = 0; a < Shape::width; ++a)
        u[d][a] = basis.greville_coordinate(first + a) - first;
    }
  }
};

// The offsets x_i - x_p are measured from the point the stencil reproduces,
// sum_i N_i x_i / sum_i N_i (x_p up to round-off), in the block's cells: then
// sum_i N_i (x_i - x_p) vanishes up to a rounding without bias. With x_p itself
// the evaluation error of the N_i leaves a residue of a fixed sign, of the size
// of the round-off of x_p's coordinates, that the affine momentum (eq. 8) turns
// into a steady leak of linear and angular momentum, step after step.

/// @brief The stencil s of a particle with its gradients replaced by the
/// first moments N_i (x_i - x_p), and D_p as (xx, xy, yy) (diagonal for the
/// tensor product): its `interpolate` then gives sum_i N_i u_i (x_i - x_p)^T
/// in place of the gradient of u (eq. 10).
template <int P>
BSplineStencil<2, P> first_moments(const BSplineStencil<2, P>& s,
                                   const BlockPoints<BSplineStencil<2, P>>& X, double (&D)[3])
{
  BSplineStencil<2, P> m = s;
  double diagonal[2];
  for (int d = 0; d < 2; ++d)
  {
    double weight = 0.0, first = 0.0;
    for (int a = 0; a <= P; ++a)
    {
      weight += s.n[d][a];
      first += s.n[d][a] * X.u[d][a];
    }
    const double centre = first / weight;
    diagonal[d] = 0.0;
    for (int a = 0; a <= P; ++a)
    {
      const double r = X.h * (X.u[d][a] - centre);
      m.dn[d][a] = s.n[d][a] * r;
      diagonal[d] += m.dn[d][a] * r;
    }
  }
  D[0] = diagonal[0];
  D[1] = 0.0;
  D[2] = diagonal[1];
  return m;
}

/// @brief first_moments for CPDI: Sbar_i (x_i - x_p) node by node, and the
/// full D_p.
inline CpdiStencil first_moments(const CpdiStencil& s, const BlockPoints<CpdiStencil>& X,
                                 double (&D)[3])
{
  constexpr int K = CpdiStencil::size;
  double weight = 0.0, first[2] = {0.0, 0.0};
  for (int i = 0; i < K; ++i)
  {
    weight += s.n[i];
    first[0] += s.n[i] * X.u[0][CpdiStencil::offset(i, 0)];
    first[1] += s.n[i] * X.u[1][CpdiStencil::offset(i, 1)];
  }
  const double centre[2] = {first[0] / weight, first[1] / weight};
  CpdiStencil m = s;
  D[0] = D[1] = D[2] = 0.0;
  for (int i = 0; i < K; ++i)
  {
    const double rx = X.h * (X.u[0][CpdiStencil::offset(i, 0)] - centre[0]);
    const double ry = X.h * (X.u[1][CpdiStencil::offset(i, 1)] - centre[1]);
    m.dn[0][i] = s.n[i] * rx;
    m.dn[1][i] = s.n[i] * ry;
    D[0] += m.dn[0][i] * rx;
    D[1] += m.dn[0][i] * ry;
    D[2] += m.dn[1][i] * ry;
  }
  return m;
}

/// @brief The stencil whose gradients are N_i D_p^-1 (x_i - x_p), from the
/// first moments m and D_p: the weights of the affine momentum of eq. 8.
/// With B-splines per direction; a direction with D_dd = 0 (a particle on
/// a degree-1 grid line or on the grid's edge) has all its moments zero
/// and keeps them.
template <int P>
BSplineStencil<2, P> affine_weights(BSplineStencil<2, P> m, const double (&D)[3])
{
  const double inverse[2] = {D[0] > 0.0 ? 1.0 / D[0] : 0.0, D[2] > 0.0 ? 1.0 / D[2] : 0.0};
  for (int d = 0; d < 2; ++d)
    for (int a = 0; a <= P; ++a)
      m.dn[d][a] *= inverse[d];
  return m;
}

/// @brief affine_weights for CPDI: D_p^-1 applied node by node.
inline CpdiStencil affine_weights(CpdiStencil m, const double (&D)[3])
{
  const double det = D[0] * D[2] - D[1] * D[1];
  const double a = D[2] / det, b = -D[1] / det, c = D[0] / det;
  for (int i = 0; i < CpdiStencil::size; ++i)
  {
    const double mx = m.dn[0][i], my = m.dn[1][i];
    m.dn[0][i] = a * mx + b * my;
    m.dn[1][i] = b * mx + c * my;
  }
  return m;
}

} // namespace pfmpm
