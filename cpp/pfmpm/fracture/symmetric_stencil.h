/// @file symmetric_stencil.h
/// @brief Storage of the symmetric (2p+1)^2-point stencil of the phase-field
/// matrix K (eq. 57) on a padded grid-node layout, shared by its assembly, its
/// conjugate gradients and the multigrid levels built from it.
#pragma once

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

} // namespace pfmpm
