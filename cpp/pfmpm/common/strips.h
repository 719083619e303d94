/// @file strips.h
/// @brief Cell-to-node scatters without races and with a fixed summation order.
#pragma once

#include "pfmpm/grid/bspline.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// Cell columns per strip. Strips of one parity share no grid node as long as
/// this is at least the B-spline degree.
constexpr int strip_width = 4;
static_assert(strip_width >= max_degree);

/// @brief Call `f(cx, cy, begin, end)` for every occupied cell, where
/// [begin, end) is the cell's range in the particle sort.
///
/// Cells go in strips of `strip_width` columns: first all even strips in
/// parallel, then all odd ones. Strips of one parity touch disjoint nodes, so
/// `f` may add into its cell's nodes without atomics, and a node receives its
/// cells' contributions in a fixed order (even strip, then odd strip, cells in
/// key order): the same bits for any thread count.
/// @param ncx, ncy Cells in x and y.
/// @param cell_start Offsets of each cell's particles, ncx * ncy + 1 entries.
template <class F>
void for_each_cell_by_strips(int ncx, int ncy, const std::vector<std::int64_t>& cell_start, F&& f)
{
  const int nstrips = (ncx + strip_width - 1) / strip_width;
  for (int parity = 0; parity < 2; ++parity)
  {
#pragma omp parallel for schedule(dynamic, 1)
    for (int s = parity; s < nstrips; s += 2)
      for (int cx = s * strip_width; cx < std::min((s + 1) * strip_width, ncx); ++cx)
        for (int cy = 0; cy < ncy; ++cy)
        {
          const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
          if (cell_start[cell + 1] > cell_start[cell])
            f(cx, cy, cell_start[cell], cell_start[cell + 1]);
        }
  }
}

/// @brief for_each_cell_by_strips over the occupied cells among `cells`
/// alone (keys in increasing order): the same strips, parities and order,
/// without a look at every cell of the grid.
template <class F>
void for_each_listed_cell_by_strips(int ncx, int ncy, const std::vector<std::int64_t>& cell_start,
                                    const std::vector<std::int32_t>& cells, F&& f)
{
  const int nstrips = (ncx + strip_width - 1) / strip_width;
  const std::int64_t strip_cells = static_cast<std::int64_t>(strip_width) * ncy;
  for (int parity = 0; parity < 2; ++parity)
  {
#pragma omp parallel for schedule(dynamic, 1)
    for (int s = parity; s < nstrips; s += 2)
    {
      const auto first = std::lower_bound(cells.begin(), cells.end(), s * strip_cells);
      const auto last = std::lower_bound(first, cells.end(), (s + 1) * strip_cells);
      for (auto it = first; it != last; ++it)
      {
        const std::size_t cell = static_cast<std::size_t>(*it);
        if (cell_start[cell + 1] > cell_start[cell])
          f(static_cast<int>(cell / ncy), static_cast<int>(cell % ncy), cell_start[cell],
            cell_start[cell + 1]);
      }
    }
  }
}

} // namespace pfmpm
