/// @file stencil.h
/// @brief A particle's grid nodes with the values and derivatives of their
/// shape functions: what every particle-grid transfer reads.
#pragma once

#include "pfmpm/grid/grid.h"

#include <array>

namespace pfmpm
{

/// Number of second derivatives of a function of `dim` variables (xx, yy, xy in 2D).
constexpr int hessian_size(int dim) { return dim * (dim + 1) / 2; }

/// @brief value[q] = sum_i N_i nodal[i][q] and grad[k][q] = sum_i dN_i/dx_k
/// nodal[i][q] for Q nodal quantities, node by node in stencil order (the
/// form of any stencil; BSplineStencil::interpolate factors it). Always
/// inlined: called per particle, its sums stay in registers.
template <int Q, class Shape>
[[gnu::always_inline]] inline void interpolate_by_nodes(const Shape& s, const double (*nodal)[Q],
                                                        double (&value)[Q],
                                                        double (&grad)[Shape::dim][Q])
{
  for (int q = 0; q < Q; ++q)
  {
    value[q] = 0.0;
    for (int k = 0; k < Shape::dim; ++k)
      grad[k][q] = 0.0;
  }
  s.each_node(
      [&](int i, double w, const double* g)
      {
#pragma omp simd
        for (int q = 0; q < Q; ++q)
        {
          value[q] += w * nodal[i][q];
          for (int k = 0; k < Shape::dim; ++k)
            grad[k][q] += g[k] * nodal[i][q];
        }
      });
}

/// @brief N_i and grad N_i of every node i of stencil s into arrays in node
/// order (`g[k][i]` = dN_i/dx_k): each_node's products, for loops over the
/// nodes that the compiler vectorises.
template <class Shape>
[[gnu::always_inline]] inline void node_weights(const Shape& s, double (&w)[Shape::size],
                                                double (&g)[Shape::dim][Shape::size])
{
  s.each_node(
      [&](int i, double wi, const double* gi)
      {
        w[i] = wi;
        for (int k = 0; k < Shape::dim; ++k)
          g[k][i] = gi[k];
      });
}

/// @brief Tensor-product B-spline stencil of degree P in `Dim` dimensions.
///
/// A particle in cell (c_0, .., c_{Dim-1}) sees the width^Dim nodes
/// (c_d + lower + a_d) with a_d in [0, width). Node i of the stencil has
/// a_0 = i / width^(Dim-1) (slowest) ... a_{Dim-1} = i % width (fastest), the
/// order in which the grid numbers its nodes, so a row of the stencil is a run
/// of consecutive active nodes. At a point x it holds the univariate values
/// and derivatives, and gives the shape function N_i(x) = prod_d N_{a_d}(x_d)
/// (K&T eq. 34), its gradient (K&T eq. 54) and, when Order is 2, its second
/// derivatives (K&T eq. 55), each a product in direction order, so every
/// transfer multiplies the same factors the same way; the products are formed
/// where a transfer reads them, in registers.
///
/// CPDI (CpdiStencil, shape/cpdi.h) provides the same members: `dim`,
/// `degree`, `width`, `lower`, `size`, `domains`, `offset`, `first`, `N`,
/// `dN`, `each_node`, `interpolate` and `evaluate`.
template <int Dim, int P, int Order = 1>
struct BSplineStencil
{
  static_assert(Order == 1 || Order == 2, "first or second derivatives");
  static constexpr int dim = Dim;
  static constexpr int degree = P;
  static constexpr int width = P + 1; ///< nodes per direction
  static constexpr int lower = 0;     ///< first node relative to the cell
  static constexpr int size = Dim == 1 ? width : Dim == 2 ? width * width : width * width * width;
  /// The stencil reads the particle centres only, no domains.
  static constexpr bool domains = false;

  /// Offset a_d of stencil node i in direction d.
  static constexpr int offset(int i, int d)
  {
    int stride = 1;
    for (int e = Dim - 1; e > d; --e)
      stride *= width;
    return (i / stride) % width;
  }
  /// First node of the block of `cell`: the cell's own first node.
  static int first(int cell, int /*nodes*/) { return cell + lower; }

  double n[Dim][width];                  ///< N_a(x_d) per direction
  double dn[Dim][width];                 ///< dN_a/dx_d
  double ddn[Order == 2 ? Dim : 1][width]; ///< d2N_a/dx_d^2, only for Order 2

  /// N_i(x).
  double N(int i) const
  {
    double value = n[0][offset(i, 0)];
    for (int d = 1; d < Dim; ++d)
      value *= n[d][offset(i, d)];
    return value;
  }
  /// dN_i/dx_k.
  double dN(int k, int i) const
  {
    double g = k == 0 ? dn[0][offset(i, 0)] : n[0][offset(i, 0)];
    for (int d = 1; d < Dim; ++d)
      g *= d == k ? dn[d][offset(i, d)] : n[d][offset(i, d)];
    return g;
  }
  /// Second derivative h of N_i: the pure ones first (xx, yy, ..), then the
  /// mixed ones (xy, ..); only for Order 2.
  double d2N(int h, int i) const
  {
    static_assert(Order == 2, "second derivatives need Order 2");
    if (h < Dim)
    {
      double g = h == 0 ? ddn[0][offset(i, 0)] : n[0][offset(i, 0)];
      for (int d = 1; d < Dim; ++d)
        g *= d == h ? ddn[d][offset(i, d)] : n[d][offset(i, d)];
      return g;
    }
    int k = 0, l = 1; // the h-th mixed pair (k < l)
    for (int m = Dim; m < h; ++m)
      if (++l == Dim)
        l = ++k + 1;
    double g = k == 0 ? dn[0][offset(i, 0)] : n[0][offset(i, 0)];
    for (int d = 1; d < Dim; ++d)
      g *= (d == k || d == l) ? dn[d][offset(i, d)] : n[d][offset(i, d)];
    return g;
  }

  /// @brief f(i, N_i, grad N_i) for every node i in order, the products
  /// formed in the loops over the directions (for transfers that need no
  /// second derivatives).
  template <class F>
  void each_node(F&& f) const
  {
    if constexpr (Dim == 2)
      for (int a = 0; a < width; ++a)
        for (int b = 0; b < width; ++b)
        {
          const double g[2] = {dn[0][a] * n[1][b], n[0][a] * dn[1][b]};
          f(a * width + b, n[0][a] * n[1][b], g);
        }
    else
    {
      static_assert(Dim == 3, "each_node: 2 or 3 directions");
      // The (x, y) products once per line along z, then times its factors:
      // the products of N and dN, in the same order.
      for (int a = 0; a < width; ++a)
        for (int b = 0; b < width; ++b)
        {
          const double nn = n[0][a] * n[1][b], dx = dn[0][a] * n[1][b], dy = n[0][a] * dn[1][b];
          for (int c = 0; c < width; ++c)
          {
            const double g[3] = {dx * n[2][c], dy * n[2][c], nn * dn[2][c]};
            f((a * width + b) * width + c, nn * n[2][c], g);
          }
        }
    }
  }

  /// @brief The values and gradients at the point of Q quantities given at
  /// the stencil's nodes (`nodal[i][q]`), as interpolate_by_nodes. In 2D by
  /// the tensor product: along y within each column of the stencil first,
  /// t_a = sum_b N_b(y) nodal[a, b] and u_a = sum_b N_b'(y) nodal[a, b], then
  /// along x, value = sum_a N_a(x) t_a, d/dx = sum_a N_a'(x) t_a and
  /// d/dy = sum_a N_a(x) u_a: (P + 1)(2 P + 5) multiply-adds of Q-vectors
  /// (27 for P = 2) instead of 3 (P + 1)^2 per quantity, and no products of
  /// the factors formed.
  template <int Q>
  void interpolate(const double (*nodal)[Q], double (&value)[Q], double (&grad)[Dim][Q]) const
  {
    if constexpr (Dim == 2)
      by_columns<Q, 1>(nodal, value, grad, nullptr);
    else
      by_lines<Q, true>(nodal, value, grad);
  }
  /// @brief The values alone at the point of Q quantities given at the
  /// stencil's nodes, by the same columns: (P + 1)(P + 2) multiply-adds of
  /// Q-vectors (12 for P = 2); in 3D by the same lines.
  template <int Q>
  void interpolate(const double (*nodal)[Q], double (&value)[Q]) const
  {
    if constexpr (Dim == 2)
      by_columns<Q, 0>(nodal, value, nullptr, nullptr);
    else
      by_lines<Q, false>(nodal, value, nullptr);
  }
  /// @brief interpolate with the second derivatives too (`hessian[h][q]`, in
  /// d2N's order xx, yy, xy); only for Order 2, only in 2D. By the same
  /// columns: with v_a = sum_b N_b''(y) nodal[a, b], d2/dx2 = sum_a N_a''(x)
  /// t_a, d2/dy2 = sum_a N_a(x) v_a and d2/dxdy = sum_a N_a'(x) u_a.
  template <int Q>
  void interpolate(const double (*nodal)[Q], double (&value)[Q], double (&grad)[Dim][Q],
                   double (&hessian)[hessian_size(Dim)][Q]) const
  {
    static_assert(Order == 2 && Dim == 2, "second derivatives: Order 2, in 2D");
    by_columns<Q, 2>(nodal, value, grad, hessian);
  }

  /// @brief Evaluate at x, a point of cell `cell` (per direction).
  void evaluate(const std::array<const BSpline1D*, Dim>& basis, const int* cell, const double* x)
  {
    direction<0>(basis, cell, x);
  }

private:
  /// interpolate in 2D, with the derivatives up to order Derivatives (0, 1
  /// or 2; `grad` and `hessian` are written only for the orders asked for):
  /// the sums along y in column a of the stencil, then their terms of the
  /// sums along x, column by column (each column's sums used as soon as they
  /// are formed: kept in registers, not stored and read back).
  template <int Q, int Derivatives>
  void by_columns(const double (*nodal)[Q], double (&value)[Q], double (*grad)[Q],
                  double (*hessian)[Q]) const
  {
    for (int q = 0; q < Q; ++q)
    {
      value[q] = 0.0;
      if constexpr (Derivatives >= 1)
        grad[0][q] = grad[1][q] = 0.0;
      if constexpr (Derivatives == 2)
        hessian[0][q] = hessian[1][q] = hessian[2][q] = 0.0;
    }
    for (int a = 0; a < width; ++a)
    {
      const double* column = nodal[a * width];
#pragma omp simd
      for (int q = 0; q < Q; ++q)
      {
        double t = 0.0, u = 0.0, w = 0.0;
        for (int b = 0; b < width; ++b)
        {
          t += n[1][b] * column[b * Q + q];
          if constexpr (Derivatives >= 1)
            u += dn[1][b] * column[b * Q + q];
          if constexpr (Derivatives == 2)
            w += ddn[1][b] * column[b * Q + q];
        }
        value[q] += n[0][a] * t;
        if constexpr (Derivatives >= 1)
        {
          grad[0][q] += dn[0][a] * t;
          grad[1][q] += n[0][a] * u;
        }
        if constexpr (Derivatives == 2)
        {
          hessian[0][q] += ddn[0][a] * t;
          hessian[1][q] += n[0][a] * w;
          hessian[2][q] += dn[0][a] * u;
        }
      }
    }
  }

  /// @brief interpolate in 3D by the tensor product: along z on each line
  /// (a, b) of the stencil, t_ab = sum_c N_c(z) nodal[a, b, c] and u_ab =
  /// sum_c N_c'(z) nodal[a, b, c]; along y on each plane a, T_a = sum_b N_b(y)
  /// t_ab, U_a = sum_b N_b'(y) t_ab and W_a = sum_b N_b(y) u_ab; then value =
  /// sum_a N_a(x) T_a and the derivatives sum_a N_a'(x) T_a, sum_a N_a(x) U_a
  /// and sum_a N_a(x) W_a: (P + 1)(2 (P + 1)^2 + 3 (P + 1) + 4) multiply-adds of
  /// Q-vectors (93 for P = 2), against 4 (P + 1)^3 (108) node by node with the
  /// products formed. Without the Gradient, the sums of N alone.
  template <int Q, bool Gradient>
  void by_lines(const double (*nodal)[Q], double (&value)[Q], double (*grad)[Q]) const
  {
    for (int q = 0; q < Q; ++q)
    {
      value[q] = 0.0;
      if constexpr (Gradient)
        grad[0][q] = grad[1][q] = grad[2][q] = 0.0;
    }
    for (int a = 0; a < width; ++a)
    {
      double T[Q] = {}, U[Q] = {}, W[Q] = {};
      for (int b = 0; b < width; ++b)
      {
        const double* line = nodal[(a * width + b) * width];
#pragma omp simd
        for (int q = 0; q < Q; ++q)
        {
          double t = 0.0, u = 0.0;
          for (int c = 0; c < width; ++c)
          {
            t += n[2][c] * line[c * Q + q];
            if constexpr (Gradient)
              u += dn[2][c] * line[c * Q + q];
          }
          T[q] += n[1][b] * t;
          if constexpr (Gradient)
          {
            U[q] += dn[1][b] * t;
            W[q] += n[1][b] * u;
          }
        }
      }
#pragma omp simd
      for (int q = 0; q < Q; ++q)
      {
        value[q] += n[0][a] * T[q];
        if constexpr (Gradient)
        {
          grad[0][q] += dn[0][a] * T[q];
          grad[1][q] += n[0][a] * U[q];
          grad[2][q] += n[0][a] * W[q];
        }
      }
    }
  }

  /// The values of direction D, then of the next ones (unrolled at compile time).
  template <int D>
  void direction(const std::array<const BSpline1D*, Dim>& basis, const int* cell, const double* x)
  {
    if constexpr (Order == 2)
      basis[D]->template evaluate<P>(cell[D], x[D], n[D], dn[D], ddn[D]);
    else
      basis[D]->template evaluate<P>(cell[D], x[D], n[D], dn[D]);
    if constexpr (D + 1 < Dim)
      direction<D + 1>(basis, cell, x);
  }
};

} // namespace pfmpm
