/// @file apic.h
/// @brief The affine particle-in-cell transfer (APIC: Jiang, Schroeder,
/// Selle, Teran & Stomakhin 2015): the transfer scheme of a run, the
/// particles' affine matrix, and the frame of node offsets and D_p that its
/// transfers read.
///
/// Each particle carries, besides v_p, the matrix
///   B_p = sum_i N_i v_i (x_i - x_p)^T                      (Jiang et al. 2015, eq. 10)
/// of the nodal velocities it was given, so that its velocity about x_p is
/// the affine field v_p + C_p (x - x_p), C_p = B_p D_p^-1, with
///   D_p = sum_i N_i (x_i - x_p) (x_i - x_p)^T.
/// P2G gives node i the momentum m_p N_i (v_p + C_p (x_i - x_p)) (Jiang et al. 2015, eq. 8) and
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
///   of the multilinear D at each corner plus sum_k r_k r_k^T, positive
///   definite for every domain with det R > 0; a full Dim x Dim inverse.
///
/// The column holds B_p, not C_p: P2G divides by D_p at the particle's
/// position then, which keeps the angular momentum of the transfers exact
/// where D_p varies (the ends of the grid, degree 1, CPDI); a C_p formed in
/// G2P would divide by the D_p of the position before the move.
#pragma once

#include <algorithm>
#include <array>

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

/// @brief The column of the APIC affine matrix B_p (Jiang et al. 2015, eq. 10), row-major
/// Dim x Dim per particle (xx, xy, yx, yy in 2D), B_ij = sum_k N_k v_k,i (x_k - x_p)_j.
inline ColumnSpec affine_column(int dim = 2)
{
  return ColumnSpec{"affine", dim * dim, DType::f64, {0.0},
                    "APIC affine matrix B_p = sum_i N_i v_i (x_i - x_p)^T (Jiang et al. 2015, eq. 10)",
                    dim == 2 ? "xx,xy,yx,yy" : "xx,xy,xz,yx,yy,yz,zx,zy,zz", ""};
}

/// @brief The Greville abscissae of the nodes of a cell's stencil block, per
/// direction, in cells from the block's first node: u[d][a] for node
/// first(cell) + a (exact small fractions).
template <class Shape>
struct BlockPoints
{
  static constexpr int Dim = Shape::dim;
  double u[Dim][Shape::width];
  double h; ///< the cell size

  BlockPoints(const Grid<Dim>& grid, const Cell<Dim>& cell) : h(grid.h())
  {
    for (int d = 0; d < Dim; ++d)
    {
      const BSpline1D& basis = grid.basis(d);
      const int first = Shape::first(cell.index[d], basis.size());
      for (int a = 0; a < Shape::width; ++a)
        u[d][a] = basis.greville_coordinate(first + a) - first;
    }
  }
};

/// @brief The frame of a particle's affine velocity: the offsets x_i - x_p
/// of its block's nodes per direction (node i of the stencil lies at
/// (r[0][offset(i, 0)], r[1][offset(i, 1)], ..) from the particle) and, where
/// asked for (inertia), D_p = sum_i N_i (x_i - x_p)(x_i - x_p)^T: with
/// B-splines its diagonal (D_00, D_11[, D_22]), with CPDI its upper triangle
/// row by row, (xx, xy, yy) in 2D and (xx, xy, xz, yy, yz, zz) in 3D.
///
/// The offsets are measured from the point the weights reproduce,
/// sum_i N_i x_i / sum_i N_i (x_p up to round-off), in the block's cells:
/// then sum_i N_i (x_i - x_p) vanishes up to a rounding without bias. From
/// x_p itself, the evaluation error of the N_i leaves a residue of one sign,
/// of the size of the round-off of x_p's coordinates, which the affine
/// momentum (Jiang et al. 2015, eq. 8) turns into a steady leak of linear and angular momentum.
/// The weights sum to 1 up to round-off, so 1 / sum_i N_i is 2 - sum_i N_i
/// to rounding (the error is the square of the sum's): no division.
template <class Shape>
struct AffineFrame
{
  /// Stored entries of D_p: Dim (the diagonal), with CPDI Dim (Dim + 1) / 2.
  static constexpr int inertia_size =
      Shape::domains ? Shape::dim * (Shape::dim + 1) / 2 : Shape::dim;
  double r[Shape::dim][Shape::width];
  double D[inertia_size];

  /// The offset x_i - x_p of stencil node i, per direction.
  [[gnu::always_inline]] void node(int i, double (&x)[Shape::dim]) const
  {
#pragma GCC unroll 3
    for (int k = 0; k < Shape::dim; ++k)
      x[k] = r[k][Shape::offset(i, k)];
  }
};

/// @brief The offsets of the frame with B-splines, per direction.
template <int Dim, int P>
[[gnu::always_inline]] inline void offsets(const BSplineStencil<Dim, P>& s,
                                           const BlockPoints<BSplineStencil<Dim, P>>& X,
                                           AffineFrame<BSplineStencil<Dim, P>>& f)
{
  for (int d = 0; d < Dim; ++d)
  {
    double weight = 0.0, first = 0.0;
    for (int a = 0; a <= P; ++a)
    {
      weight += s.n[d][a];
      first += s.n[d][a] * X.u[d][a];
    }
    const double centre = first * (2.0 - weight);
    for (int a = 0; a <= P; ++a)
      f.r[d][a] = X.h * (X.u[d][a] - centre);
  }
}

/// @brief The offsets of the frame with CPDI, from the 4^Dim nodes.
template <int Dim>
[[gnu::always_inline]] inline void offsets(const CpdiStencil<Dim>& s,
                                           const BlockPoints<CpdiStencil<Dim>>& X,
                                           AffineFrame<CpdiStencil<Dim>>& f)
{
  using S = CpdiStencil<Dim>;
  double weight = 0.0, first[Dim] = {};
  for (int i = 0; i < S::size; ++i)
  {
    weight += s.n[i];
#pragma GCC unroll 3
    for (int d = 0; d < Dim; ++d)
      first[d] += s.n[i] * X.u[d][S::offset(i, d)];
  }
  for (int d = 0; d < Dim; ++d)
  {
    const double centre = first[d] * (2.0 - weight);
    for (int a = 0; a < S::width; ++a)
      f.r[d][a] = X.h * (X.u[d][a] - centre);
  }
}

/// @brief D_p of the frame from its offsets: with B-splines diagonal, per
/// direction (the cross sums are products of sum_a N_a (X_a - x_d) = 0).
template <int Dim, int P>
[[gnu::always_inline]] inline void inertia(const BSplineStencil<Dim, P>& s,
                                           AffineFrame<BSplineStencil<Dim, P>>& f)
{
  for (int d = 0; d < Dim; ++d)
  {
    double diagonal = 0.0;
    for (int a = 0; a <= P; ++a)
      diagonal += s.n[d][a] * f.r[d][a] * f.r[d][a];
    f.D[d] = diagonal;
  }
}

/// @brief D_p of the frame with CPDI, in full over the 4^Dim nodes: its
/// upper triangle row by row.
template <int Dim>
[[gnu::always_inline]] inline void inertia(const CpdiStencil<Dim>& s,
                                           AffineFrame<CpdiStencil<Dim>>& f)
{
  using S = CpdiStencil<Dim>;
  std::fill(f.D, f.D + AffineFrame<S>::inertia_size, 0.0);
  for (int i = 0; i < S::size; ++i)
  {
    double r[Dim];
#pragma GCC unroll 3
    for (int d = 0; d < Dim; ++d)
      r[d] = f.r[d][S::offset(i, d)];
    int k = 0;
#pragma GCC unroll 3
    for (int a = 0; a < Dim; ++a)
#pragma GCC unroll 3
      for (int b = a; b < Dim; ++b)
        f.D[k++] += s.n[i] * r[a] * r[b];
  }
}

/// @brief D_p of a frame in full, Dim x Dim row-major (the B-splines' off-diagonal zero).
template <class Shape>
std::array<double, Shape::dim * Shape::dim> inertia_matrix(const AffineFrame<Shape>& f)
{
  constexpr int Dim = Shape::dim;
  std::array<double, Dim * Dim> D{};
  if constexpr (Shape::domains)
  {
    int k = 0;
    for (int a = 0; a < Dim; ++a)
      for (int b = a; b < Dim; ++b, ++k)
        D[Dim * a + b] = D[Dim * b + a] = f.D[k];
  }
  else
    for (int d = 0; d < Dim; ++d)
      D[Dim * d + d] = f.D[d];
  return D;
}

/// @brief The frame of a particle with stencil s: its offsets and, with
/// `Inertia`, D_p.
template <bool Inertia, class Shape>
[[gnu::always_inline]] inline AffineFrame<Shape> affine_frame(const Shape& s,
                                                              const BlockPoints<Shape>& X)
{
  AffineFrame<Shape> f;
  offsets(s, X, f);
  if constexpr (Inertia)
    inertia(s, f);
  return f;
}

/// @brief The affine velocity C_p = B_p D_p^-1 of Jiang et al. 2015, eq. 8,
/// row-major Dim x Dim. With B-splines D_p is diagonal, and a direction with
/// D_dd = 0 (a particle on a degree-1 grid line or on the grid's edge: all
/// its weight at distance 0) gets no affine velocity; with CPDI D_p is
/// positive definite, inverted in full (in 3D by its cofactors).
template <class Shape>
[[gnu::always_inline]] inline void affine_velocity(
    const double* B, const double (&D)[AffineFrame<Shape>::inertia_size],
    double (&C)[Shape::dim * Shape::dim])
{
  constexpr int Dim = Shape::dim;
  if constexpr (Shape::domains && Dim == 2)
  {
    const double det = D[0] * D[2] - D[1] * D[1];
    const double ixx = D[2] / det, ixy = -D[1] / det, iyy = D[0] / det;
    C[0] = B[0] * ixx + B[1] * ixy;
    C[1] = B[0] * ixy + B[1] * iyy;
    C[2] = B[2] * ixx + B[3] * ixy;
    C[3] = B[2] * ixy + B[3] * iyy;
  }
  else if constexpr (Shape::domains)
  {
    // D = (xx, xy, xz, yy, yz, zz); D^-1 = cof(D) / det D, symmetric.
    const double xx = D[0], xy = D[1], xz = D[2], yy = D[3], yz = D[4], zz = D[5];
    const double cxx = yy * zz - yz * yz, cxy = xz * yz - xy * zz, cxz = xy * yz - xz * yy;
    const double det = xx * cxx + xy * cxy + xz * cxz;
    const double cyy = xx * zz - xz * xz, cyz = xy * xz - xx * yz, czz = xx * yy - xy * xy;
    const double inverse[3][3] = {{cxx / det, cxy / det, cxz / det},
                                  {cxy / det, cyy / det, cyz / det},
                                  {cxz / det, cyz / det, czz / det}};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        C[3 * i + j] = B[3 * i] * inverse[0][j] + B[3 * i + 1] * inverse[1][j]
                       + B[3 * i + 2] * inverse[2][j];
  }
  else
  {
    double inverse[Dim];
    for (int j = 0; j < Dim; ++j)
      inverse[j] = D[j] > 0.0 ? 1.0 / D[j] : 0.0;
    for (int i = 0; i < Dim; ++i)
      for (int j = 0; j < Dim; ++j)
        C[Dim * i + j] = B[Dim * i + j] * inverse[j];
  }
}

} // namespace pfmpm
