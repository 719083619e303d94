/// @file moments.h
/// @brief A cell's share of the phase-field system (K&T eqs. 57 and 52) from
/// moments of its particles.
///
/// On one cell every B-spline is a polynomial of degree P in the local
/// coordinate, so N_i N_j, grad N_i . grad N_j and the products of second
/// derivatives of the fourth-order term are, for i = (a, b) and j = (a', b'),
/// products X(xi) Y(eta) of two polynomials of degree at most 2P. The cell's
/// sum over its particles, sum_p w_p X(xi_p) Y(eta_p), is then a fixed
/// combination of the particles' weighted moments
/// M_mn = sum_p w_p xi_p^m eta_p^n: per particle and weight a row of powers
/// of eta per power of xi (a vector multiply-add each) instead of a product
/// per pair of nodes, and per cell one contraction of the moments with the
/// basis's product polynomials, the same for every interior cell.
#pragma once

#include "pfmpm/grid/bspline.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <type_traits>
#include <utility>
#include <vector>

namespace pfmpm
{

/// @brief The powers 1, xi, .., xi^2P of a particle's local coordinates in
/// its cell, for particle_to_grid in place of a stencil (it evaluates no
/// shape function; its block is the B-spline stencil's).
template <int Dim, int P>
struct CellPowers
{
  static constexpr int dim = Dim;
  static constexpr int width = P + 1;
  static constexpr int lower = 0;
  static constexpr bool domains = false;
  static constexpr int count = 2 * P + 1;           ///< powers 0 .. 2P
  static constexpr int padded = (count + 3) / 4 * 4; ///< the last direction's length: whole vectors

  double x[count];                          ///< xi^m, xi = (x - origin) / h - cx, as BSpline1D evaluates
  double y[Dim == 2 ? padded : count];      ///< eta^n; in 2D zero above 2P
  double z[Dim == 3 ? padded : 1];          ///< zeta^n in 3D, zero above 2P

  void evaluate(const std::array<const BSpline1D*, Dim>& basis, const int* cell, const double* point)
  {
    const double xi = basis[0]->coordinate(point[0]) - cell[0];
    const double eta = basis[1]->coordinate(point[1]) - cell[1];
    x[0] = y[0] = 1.0;
    for (int m = 1; m < count; ++m)
    {
      x[m] = x[m - 1] * xi;
      y[m] = y[m - 1] * eta;
    }
    if constexpr (Dim == 2)
      for (int m = count; m < padded; ++m)
        y[m] = 0.0;
    else
    {
      const double zeta = basis[2]->coordinate(point[2]) - cell[2];
      z[0] = 1.0;
      for (int m = 1; m < count; ++m)
        z[m] = z[m - 1] * zeta;
      for (int m = count; m < padded; ++m)
        z[m] = 0.0;
    }
  }
};

/// @brief Along one axis of the grid, per cell: the products of the
/// B-splines nonzero there and of their derivatives, as polynomials in the
/// local coordinate, and the B-splines' own coefficients.
///
/// Only the P cells at each end of an open knot vector have their own
/// polynomials; the interior cells share one table.
class CellProducts
{
public:
  /// The highest derivative in a product: 2, for the fourth-order term (the
  /// second-order one reads the first derivatives' entries only).
  static constexpr int derivatives = 2;

  /// @param basis The axis's B-splines (their polynomials are read here).
  explicit CellProducts(const BSpline1D& basis);

  /// Entries of a product row: the (P + 1)^2 node pairs (a, a'), padded to a
  /// multiple of 4.
  static constexpr int row(int degree) { return ((degree + 1) * (degree + 1) + 3) / 4 * 4; }

  /// @brief Coefficient of xi^m in d^d1 N_a/dx^d1 d^d2 N_a'/dx^d2 on `cell`
  /// is products(cell)[((d1 (D + 1) + d2) (2P + 1) + m) row + a (P + 1) + a'],
  /// with D = derivatives and row = row(P).
  const double* products(int cell) const { return &_table[kind(cell) * _stride]; }
  /// @brief Coefficient of xi^m in N_a on `cell` is values(cell)[m (P + 1) + a].
  const double* values(int cell) const { return &_table[kind(cell) * _stride + _values]; }

private:
  /// The table of `cell`: its own near the ends, the interior one elsewhere.
  std::size_t kind(int cell) const
  {
    const int p = _degree, cells = _cells;
    if (cells <= 2 * p + 1 || cell < p)
      return static_cast<std::size_t>(cell);
    if (cell >= cells - p)
      return static_cast<std::size_t>(cell - (cells - (2 * p + 1)));
    return static_cast<std::size_t>(p);
  }

  int _degree, _cells;
  std::size_t _values, _stride;
  std::vector<double> _table;
};

namespace moments
{
/// @brief One term of K_ij (K&T eq. 57): the x derivatives of N_i and N_j, their
/// y derivatives, and the particle weight (CellMoments' moment array) it
/// carries; in 3D their z derivatives too.
struct Term
{
  int xi, xj, yi, yj, weight, zi = 0, zj = 0;
};

/// Weights: reaction(H) V (K&T eq. 49), diffusion V, and with the fourth-order
/// term 4 l0^4 V gamma_rs for the pairs (xx, xx), (yy, yy), (xy, xy), (xx, yy),
/// (xx, xy), (yy, xy) of the curvature kappa = (N_,xx, N_,yy, N_,xy).
inline constexpr int reaction = 0, diffusion = 1;

/// The second-order terms, grouped by their x derivatives.
inline constexpr std::array<Term, 3> second_order{
    {{0, 0, 0, 0, reaction}, {0, 0, 1, 1, diffusion}, {1, 1, 0, 0, diffusion}}};

/// @brief With the fourth-order term e kappa_i^T gamma kappa_j (K&T eq. 57)
/// written out: kappa component s of N_i against component r of N_j carries
/// gamma_rs (gamma symmetric), with xx = (2, 0), yy = (0, 2) and xy = (1, 1)
/// derivatives in (x, y). Grouped by the x derivatives.
inline constexpr std::array<Term, 12> fourth_order{{
    {0, 0, 0, 0, reaction}, {0, 0, 1, 1, diffusion}, {0, 0, 2, 2, 3}, // yy yy
    {1, 1, 0, 0, diffusion}, {1, 1, 1, 1, 4},                         // xy xy
    {2, 2, 0, 0, 2},                                                  // xx xx
    {0, 2, 2, 0, 5}, {2, 0, 0, 2, 5},                                 // yy xx, xx yy
    {0, 1, 2, 1, 7}, {1, 0, 1, 2, 7},                                 // yy xy, xy yy
    {1, 2, 1, 0, 6}, {2, 1, 0, 1, 6}}};                               // xy xx, xx xy

/// The second-order terms in 3D, grouped by their x derivatives.
inline constexpr std::array<Term, 4> second_order_3d{{{0, 0, 0, 0, reaction},
                                                      {0, 0, 0, 0, diffusion, 1, 1},
                                                      {0, 0, 1, 1, diffusion},
                                                      {1, 1, 0, 0, diffusion}}};

/// The terms of the second-order (false) or fourth-order (true, 2D only) functional.
template <int Dim, bool Fourth>
constexpr auto terms()
{
  static_assert(Dim == 2 || !Fourth, "the fourth-order functional is two-dimensional");
  if constexpr (Fourth)
    return fourth_order;
  else if constexpr (Dim == 3)
    return second_order_3d;
  else
    return second_order;
}

template <class F, std::size_t... I>
void unrolled(F&& f, std::index_sequence<I...>)
{
  (f(std::integral_constant<int, static_cast<int>(I)>{}), ...);
}
} // namespace moments

/// @brief The weighted moments of one cell's particles, and the cell's block
/// of K and entries of F from them, for degree P with (Fourth, 2D only) or
/// without the fourth-order term.
///
/// In 3D the moments are M_lmn = sum_p w_p xi^l eta^m zeta^n and each term's
/// polynomial is contracted one axis at a time, z, then y, then x.
template <int Dim, int P, bool Fourth>
struct CellMoments
{
  static constexpr int W = P + 1, Q = 2 * P + 1, D = CellProducts::derivatives;
  static constexpr int weights = Fourth ? 8 : 2;
  static constexpr int R = CellProducts::row(P); // padded (b, b') pairs
  static constexpr int N = CellPowers<Dim, P>::padded; // the last direction's powers, padded
  static constexpr auto terms = moments::terms<Dim, Fourth>();
  static constexpr int term_count = static_cast<int>(terms.size());
  /// The block: per pair (a, a') of x nodes, the pairs of the other directions.
  using Block = std::conditional_t<Dim == 2, double[W * W][R], double[W * W][W * W][R]>;

  /// Highest power of xi (axis 0) or eta (axis 1) that weight k's terms need.
  static constexpr int highest(int k, int axis = 0)
  {
    int h = 0;
    for (const moments::Term& t : terms)
    {
      const int power = axis == 0 ? 2 * P - t.xi - t.xj : 2 * P - t.yi - t.yj;
      if (t.weight == k && power > h)
        h = power;
    }
    return h;
  }

  /// sum_p w_p xi^m eta^n (2D) or xi^l eta^m zeta^n (3D)
  std::conditional_t<Dim == 2, double[weights][Q][N], double[weights][Q][Q][N]> moment = {};
  /// sum_p s_p xi^m eta^n (zeta^o), each power <= P
  std::conditional_t<Dim == 2, double[W][W], double[W][W][W]> source = {};

  /// Add a particle at `s` with weights `w` (in the order of moments'
  /// weights) and F's coefficient `src` (K&T eq. 52).
  void add(const CellPowers<Dim, P>& s, const double (&w)[weights], double src)
  {
    moments::unrolled(
        [&](auto k)
        {
          constexpr int K = decltype(k)::value;
          for (int m = 0; m <= highest(K); ++m)
          {
            const double t = w[K] * s.x[m];
            if constexpr (Dim == 2)
            {
#pragma omp simd
              for (int n = 0; n < N; ++n) // one vector; zero above 2P
                moment[K][m][n] += t * s.y[n];
            }
            else
              for (int l = 0; l <= highest(K, 1); ++l)
              {
                const double u = t * s.y[l];
#pragma omp simd
                for (int n = 0; n < N; ++n)
                  moment[K][m][l][n] += u * s.z[n];
              }
          }
        },
        std::make_index_sequence<weights>{});
    for (int m = 0; m <= P; ++m)
    {
      const double t = src * s.x[m];
      for (int n = 0; n <= P; ++n)
        if constexpr (Dim == 2)
          source[m][n] += t * s.y[n];
        else
        {
          const double u = t * s.y[n];
          for (int o = 0; o <= P; ++o)
            source[m][n][o] += u * s.z[o];
        }
    }
  }

  /// @brief The cell's K_ij (K&T eq. 57) for i = (a, b), j = (a', b') with
  /// a' >= a (all that the upper-half stencil stores) as
  /// block[a W + a'][b W + b'], from the x and y tables of its cell
  /// (CellProducts::products): per term, U_m = sum_n Y_n M_mn along y, then
  /// sum_m X_m U_m along x, the terms that share their x polynomial summed
  /// in U first. The rows a' < a are zero. In 3D, i = (a, b, c) and
  /// j = (a', b', c') as block[a W + a'][b W + b'][c W + c'], from the
  /// tables `x`, `y` and `z`, with V_lm = sum_n Z_n M_lmn first.
  void block(const double* x, const double* y, const double* z, Block& out) const
  {
    zero(out);
    using Sum = std::conditional_t<Dim == 2, double[Q][R], double[Q][W * W][R]>;
    alignas(64) Sum U = {};
    moments::unrolled(
        [&](auto index)
        {
          constexpr int T = decltype(index)::value;
          constexpr moments::Term t = terms[T];
          constexpr int DX = 2 * P - t.xi - t.xj, DY = 2 * P - t.yi - t.yj;
          const double* Y = &y[std::size_t((t.yi * (D + 1) + t.yj) * Q) * R];
          if constexpr (Dim == 2)
          {
            // Each sum in a register over its terms, stored once (a vector read
            // back soon after partial stores of it would wait for them).
            for (int m = 0; m <= DX; ++m)
            {
              const double* M = moment[t.weight][m];
#pragma omp simd
              for (int e = 0; e < R; ++e)
              {
                double sum = U[m][e];
                for (int n = 0; n <= DY; ++n)
                  sum += M[n] * Y[n * R + e];
                U[m][e] = sum;
              }
            }
          }
          else
          {
            constexpr int DZ = 2 * P - t.zi - t.zj;
            const double* Z = &z[std::size_t((t.zi * (D + 1) + t.zj) * Q) * R];
            for (int m = 0; m <= DX; ++m)
              for (int l = 0; l <= DY; ++l)
              {
                const double* M = moment[t.weight][m][l];
                alignas(64) double V[R];
#pragma omp simd
                for (int e = 0; e < R; ++e)
                {
                  double sum = 0.0;
                  for (int n = 0; n <= DZ; ++n)
                    sum += M[n] * Z[n * R + e];
                  V[e] = sum;
                }
                for (int f = 0; f < W * W; ++f)
                {
                  const double yf = Y[l * R + f];
#pragma omp simd
                  for (int e = 0; e < R; ++e)
                    U[m][f][e] += yf * V[e];
                }
              }
          }
          constexpr bool last = T + 1 == term_count || terms[T + 1].xi != t.xi
                                || terms[T + 1].xj != t.xj;
          if constexpr (last)
          {
            const double* X = &x[std::size_t((t.xi * (D + 1) + t.xj) * Q) * R];
            for (int a = 0; a < W; ++a)
              for (int aa = a * W + a; aa < (a + 1) * W; ++aa) // a' >= a
              {
                if constexpr (Dim == 2)
                {
#pragma omp simd
                  for (int e = 0; e < R; ++e)
                  {
                    double sum = out[aa][e];
                    for (int m = 0; m <= DX; ++m)
                      sum += X[m * R + aa] * U[m][e];
                    out[aa][e] = sum;
                  }
                }
                else
                  for (int f = 0; f < W * W; ++f)
                  {
#pragma omp simd
                    for (int e = 0; e < R; ++e)
                    {
                      double sum = out[aa][f][e];
                      for (int m = 0; m <= DX; ++m)
                        sum += X[m * R + aa] * U[m][f][e];
                      out[aa][f][e] = sum;
                    }
                  }
              }
            zero(U);
          }
        },
        std::make_index_sequence<term_count>{});
  }

  /// @brief The cell's F_i (K&T eq. 52) for i = (a, b) as f[a W + b] (3D:
  /// i = (a, b, c) as f[(a W + b) W + c]), from the value tables of its cell
  /// (CellProducts::values).
  void rhs(const double* x, const double* y, const double* z, double* f) const
  {
    if constexpr (Dim == 2)
    {
      double T[W][W] = {}; // [m][b]
      for (int m = 0; m <= P; ++m)
        for (int n = 0; n <= P; ++n)
          for (int b = 0; b < W; ++b)
            T[m][b] += source[m][n] * y[n * W + b];
      for (int i = 0; i < W * W; ++i)
        f[i] = 0.0;
      for (int m = 0; m <= P; ++m)
        for (int a = 0; a < W; ++a)
          for (int b = 0; b < W; ++b)
            f[a * W + b] += x[m * W + a] * T[m][b];
    }
    else
    {
      double T[W][W][W] = {}; // [m][n][c]
      for (int m = 0; m <= P; ++m)
        for (int n = 0; n <= P; ++n)
          for (int o = 0; o <= P; ++o)
            for (int c = 0; c < W; ++c)
              T[m][n][c] += source[m][n][o] * z[o * W + c];
      double S[W][W][W] = {}; // [m][b][c]
      for (int m = 0; m <= P; ++m)
        for (int n = 0; n <= P; ++n)
          for (int b = 0; b < W; ++b)
            for (int c = 0; c < W; ++c)
              S[m][b][c] += y[n * W + b] * T[m][n][c];
      for (int i = 0; i < W * W * W; ++i)
        f[i] = 0.0;
      for (int m = 0; m <= P; ++m)
        for (int a = 0; a < W; ++a)
          for (int b = 0; b < W; ++b)
            for (int c = 0; c < W; ++c)
              f[(a * W + b) * W + c] += x[m * W + a] * S[m][b][c];
    }
  }

private:
  /// Zero a multidimensional array of doubles.
  template <class A>
  static void zero(A& a)
  {
    std::fill_n(reinterpret_cast<double*>(&a), sizeof(A) / sizeof(double), 0.0);
  }
};

} // namespace pfmpm
