/// @file symmetric_stencil.h
/// @brief Storage of the symmetric (2p+1)^Dim-point stencil of the phase-field
/// matrix K (K&T eq. 57) on a padded grid-node layout, shared by its assembly, its
/// conjugate gradients and the multigrid levels built from it.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

namespace pfmpm
{

/// @brief The upper half of a symmetric (2p+1)^Dim-point stencil: the
/// offsets that come after the centre in lexicographic order (the first
/// nonzero component positive), in that order, after the centre. In 2D: the
/// centre, (0, 1..p), then (1..p, -p..p); in 3D: the centre, (0, 0, 1..p),
/// (0, 1..p, -p..p), then (1..p, -p..p, -p..p). The entry for -d is the d
/// entry of the neighbour's row.
///
/// Nodes lie in a layout padded by p nodes on each side, the last direction
/// fastest, so every neighbour of a grid node has an index there, at a fixed
/// offset. The slabs of nodes of one first index are the grid's columns
/// (2D) or planes (3D), the unit of the Gauss-Seidel strips.
template <int Dim, int P>
struct SymmetricStencil
{
  static_assert(Dim == 2 || Dim == 3, "a 2D or 3D stencil");
  static constexpr int width = 2 * P + 1;
  static constexpr int slab = Dim == 2 ? width : width * width; ///< offsets of one first component
  static constexpr int centre = (slab * width - 1) / 2;          ///< the centre's rank in the full box
  static constexpr int size = centre + 1;
  /// Slots 1 .. own are the offsets within the centre's column or plane (first component 0).
  static constexpr int own = (slab - 1) / 2;
  std::ptrdiff_t offset[size]; ///< in the padded node layout
  int d[size][Dim];            ///< the offset per direction

  /// @param inner Nodes of the padded layout along each direction but the first.
  template <class... N>
  explicit SymmetricStencil(N... inner)
  {
    static_assert(sizeof...(N) == Dim - 1, "the padded node counts of the directions after the first");
    const std::size_t n[Dim - 1] = {static_cast<std::size_t>(inner)...};
    std::ptrdiff_t stride[Dim];
    stride[Dim - 1] = 1;
    for (int k = Dim - 2; k >= 0; --k)
      stride[k] = stride[k + 1] * static_cast<std::ptrdiff_t>(n[k]);
    for (int k = 0; k < size; ++k)
    {
      int rank = centre + k;
      offset[k] = 0;
      for (int a = Dim - 1; a >= 0; --a, rank /= width)
      {
        d[k][a] = rank % width - P;
        offset[k] += d[k][a] * stride[a];
      }
    }
  }
  /// The first component (the column or plane offset) of slot k.
  static constexpr int column(int k) { return (centre + k) / slab - P; }
  /// The second component of slot k.
  static constexpr int row(int k) { return (centre + k) % slab / (slab / width) - P; }
  /// Index of offset (d_0, .., d_Dim-1) in the upper half, or -1 for the lower half.
  template <class... I>
  static constexpr int slot(I... offset)
  {
    static_assert(sizeof...(I) == Dim, "one offset per direction");
    int rank = 0;
    ((rank = rank * width + static_cast<int>(offset) + P), ...);
    return rank >= centre ? rank - centre : -1;
  }
  /// slot of the offset `offset`.
  static constexpr int slot(const std::array<int, Dim>& offset)
  {
    int rank = 0;
    for (int a = 0; a < Dim; ++a)
      rank = rank * width + offset[a] + P;
    return rank >= centre ? rank - centre : -1;
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
template <int Dim, int P, bool Before, bool After, int Q>
[[gnu::always_inline]] inline void subtract_neighbours(const SymmetricStencil<Dim, P>& stencil,
                                                       const double* rows, std::size_t i,
                                                       int left, int right, bool even,
                                                       const double* const (&x)[Q],
                                                       double (&b)[Q])
{
  using S = SymmetricStencil<Dim, P>;
  constexpr int H = S::size, own = S::own;
  const double* row = &rows[i * H];
  double column[P + 1][Q] = {}; // per column offset dx = 1 .. P
  if (left >= P && right >= P) // away from the strip's edges: the upper half comes after i
  {
#pragma GCC unroll 32
    for (int k = own + 1; k < H; ++k)
    {
      const std::ptrdiff_t o = stencil.offset[k];
      double* c = column[S::column(k)];
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
    for (int k = own + 1; k < H; ++k)
    {
      const std::ptrdiff_t o = stencil.offset[k];
      const int dx = S::column(k);
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
  // The own column or plane (slots 1 .. own, offset o_k > 0 in the node
  // order): i - o_k before i, i + o_k after it. In 2D o_k = k, a constant.
  auto own_offset = [&](int k) -> std::ptrdiff_t
  {
    if constexpr (Dim == 2)
      return k;
    else
      return stencil.offset[k];
  };
  if constexpr (Before)
    for (int k = own; k >= 1; --k)
      for (int q = 0; q < Q; ++q)
        b[q] -= rows[(i - own_offset(k)) * H + k] * x[q][i - own_offset(k)];
  if constexpr (After)
    for (int k = own; k >= 1; --k)
      for (int q = 0; q < Q; ++q)
        b[q] -= row[k] * x[q][i + own_offset(k)];
}

/// subtract_neighbours for one vector x: b - sum_j K_ij x_j.
template <int Dim, int P, bool Before, bool After>
[[gnu::always_inline]] inline double subtract_neighbours(const SymmetricStencil<Dim, P>& stencil,
                                                         const double* rows, std::size_t i,
                                                         int left, int right, bool even,
                                                         double b, const double* x)
{
  const double* const v[1] = {x};
  double out[1] = {b};
  subtract_neighbours<Dim, P, Before, After, 1>(stencil, rows, i, left, right, even, v, out);
  return out[0];
}

/// @brief Row i (padded index) of the matrix stored in `rows` (SymmetricStencil<Dim, P>::size
/// entries per padded node) times the padded vector `v`.
template <int Dim, int P>
double row_product(const SymmetricStencil<Dim, P>& stencil, const double* rows, std::size_t i,
                   const double* v)
{
  constexpr int H = SymmetricStencil<Dim, P>::size;
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
template <int Dim, int P>
double row_magnitude_product(const SymmetricStencil<Dim, P>& stencil, const double* rows, std::size_t i,
                             const double* v)
{
  constexpr int H = SymmetricStencil<Dim, P>::size;
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
