/// @file symmetric_stencil.h
/// @brief Storage of the symmetric (2p+1)^2-point stencil of the phase-field
/// matrix K (K&T eq. 57) on a padded grid-node layout, shared by its assembly, its
/// conjugate gradients and the multigrid levels built from it.
#pragma once

#include <cmath>
#include <cstddef>

namespace pfmpm
{

/// @brief The upper half of a symmetric (2p+1)^2-point stencil: the centre,
/// then the offsets (0, 1..p), then (1..p, -p..p). The entry for (-dx, -dy)
/// is the (dx, dy) entry of the neighbour's row.
///
/// Nodes lie column by column in a layout padded by p nodes on each side, so
/// every neighbour of a grid node has an index there, at a fixed offset.
template <int P>
struct SymmetricStencil
{
  static constexpr int width = 2 * P + 1, size = (width * width + 1) / 2;
  std::ptrdiff_t offset[size]; ///< in the padded node layout
  int dx[size];                ///< the column offset
  int dy[size];                ///< the row offset
  /// @param padded_ny Nodes per padded grid column.
  explicit SymmetricStencil(std::size_t padded_ny)
  {
    for (int x = 0; x <= P; ++x)
      for (int y = -P; y <= P; ++y)
        if (const int k = slot(x, y); k >= 0)
        {
          offset[k] = x * static_cast<std::ptrdiff_t>(padded_ny) + y;
          dx[k] = x;
          dy[k] = y;
        }
  }
  /// The column offset dx of slot k.
  static constexpr int column(int k) { return k <= P ? 0 : (k - P - 1) / width + 1; }
  /// The row offset dy of slot k.
  static constexpr int row(int k) { return k <= P ? k : (k - P - 1) % width - P; }
  /// Index of offset (dx, dy) in the upper half, or -1 for the lower half.
  static constexpr int slot(int dx, int dy)
  {
    if (dx < 0 || (dx == 0 && dy < 0))
      return -1;
    return dx == 0 ? dy : P + (dx - 1) * width + dy + P + 1;
  }
};

/// @brief b_q - sum_j K_ij x_q[j], into b[q], for each of Q vectors x_q,
/// over the neighbours j != i of padded node i that come before it in the
/// forward Gauss-Seidel order of strips of grid columns (Before), after it
/// (After), or both, with K stored in `rows`; `left` and `right` are the
/// columns of i's strip on either side of i's, `even` whether that strip
/// is. Within i's strip the order is the node order; a neighbour in the next
/// or the last strip comes after i iff i's strip is even.
///
/// The order of the terms serves the sweeps: the other columns' terms are
/// summed per column offset |dx| (independent chains) and subtracted from the
/// farthest column in; then i's own column's, each subtracted alone, those
/// before i and then those after, from the farthest row in. So in a sweep the
/// term of the node updated just before i (i - 1 forward, i + 1 backward)
/// comes last, and what waits for that node is one multiply-add.
template <int P, bool Before, bool After, int Q>
[[gnu::always_inline]] inline void subtract_neighbours(const SymmetricStencil<P>& stencil,
                                                       const double* rows, std::size_t i,
                                                       int left, int right, bool even,
                                                       const double* const (&x)[Q],
                                                       double (&b)[Q])
{
  constexpr int H = SymmetricStencil<P>::size;
  const double* row = &rows[i * H];
  double column[P + 1][Q] = {}; // per column offset dx = 1 .. P
  if (left >= P && right >= P) // away from the strip's edges: the upper half comes after i
  {
#pragma GCC unroll 32
    for (int k = P + 1; k < H; ++k)
    {
      const std::ptrdiff_t o = stencil.offset[k];
      double* c = column[SymmetricStencil<P>::column(k)];
      for (int q = 0; q < Q; ++q)
      {
        if constexpr (After)
          c[q] += row[k] * x[q][i + o];
        if constexpr (Before)
          c[q] += rows[(i - o) * H + k] * x[q][i - o];
      }
    }
  }
  else
  {
#pragma GCC unroll 32
    for (int k = P + 1; k < H; ++k)
    {
      const std::ptrdiff_t o = stencil.offset[k];
      const int dx = SymmetricStencil<P>::column(k);
      for (int q = 0; q < Q; ++q)
      {
        if (dx <= right || even ? After : Before) // i + o
          column[dx][q] += row[k] * x[q][i + o];
        if (dx > left && even ? After : Before) // i - o
          column[dx][q] += rows[(i - o) * H + k] * x[q][i - o];
      }
    }
  }
  for (int q = 0; q < Q; ++q)
    for (int dx = P; dx >= 1; --dx)
      b[q] -= column[dx][q];
  // The own column (slots 1 .. P, dy = k): i - dy before i, i + dy after it.
  if constexpr (Before)
    for (int k = P; k >= 1; --k)
      for (int q = 0; q < Q; ++q)
        b[q] -= rows[(i - k) * H + k] * x[q][i - k];
  if constexpr (After)
    for (int k = P; k >= 1; --k)
      for (int q = 0; q < Q; ++q)
        b[q] -= row[k] * x[q][i + k];
}

/// subtract_neighbours for one vector x: b - sum_j K_ij x_j.
template <int P, bool Before, bool After>
[[gnu::always_inline]] inline double subtract_neighbours(const SymmetricStencil<P>& stencil,
                                                         const double* rows, std::size_t i,
                                                         int left, int right, bool even,
                                                         double b, const double* x)
{
  const double* const v[1] = {x};
  double out[1] = {b};
  subtract_neighbours<P, Before, After, 1>(stencil, rows, i, left, right, even, v, out);
  return out[0];
}

/// @brief Row i (padded index) of the matrix stored in `rows` (SymmetricStencil<P>::size
/// entries per padded node) times the padded vector `v`.
template <int P>
double row_product(const SymmetricStencil<P>& stencil, const double* rows, std::size_t i,
                   const double* v)
{
  constexpr int H = SymmetricStencil<P>::size;
  const double* row = &rows[i * H];
  double sum = row[0] * v[i];
  for (int k = 1; k < H; ++k)
  {
    const std::ptrdiff_t o = stencil.offset[k];
    sum += row[k] * v[i + o] + rows[(i - o) * H + k] * v[i - o];
  }
  return sum;
}

/// @brief Row i (padded index) of |K|, the entries' magnitudes, times the
/// padded vector `v` (row_product with |K_ij|): a Gershgorin bound's row sum.
template <int P>
double row_magnitude_product(const SymmetricStencil<P>& stencil, const double* rows, std::size_t i,
                             const double* v)
{
  constexpr int H = SymmetricStencil<P>::size;
  const double* row = &rows[i * H];
  double sum = std::abs(row[0]) * v[i];
  for (int k = 1; k < H; ++k)
  {
    const std::ptrdiff_t o = stencil.offset[k];
    sum += std::abs(row[k]) * v[i + o] + std::abs(rows[(i - o) * H + k]) * v[i - o];
  }
  return sum;
}

} // namespace pfmpm
