/// @file strips.h
/// @brief Cell-to-node scatters without races and with a fixed summation order.
#pragma once

#include "pfmpm/grid/bspline.h"
#include "pfmpm/grid/grid.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// Cell columns per strip. Strips of one parity share no grid node as long as
/// this is at least the B-spline degree.
constexpr int strip_width = 4;
static_assert(strip_width >= max_degree);

/// An occupied cell and the range of its particles in the sort.
template <int Dim>
struct Cell
{
  std::array<int, Dim> index; ///< cell indices (cx, cy[, cz])
  std::size_t key;            ///< lattice_key(index, cells)
  std::int64_t begin, end;    ///< its particles: order[begin, end)
};

/// @brief Call `f(cell)` for every occupied cell of the slab of cells with
/// first index `c0`, in key order.
/// @param cells Cells per direction.
/// @param plane Cells per slab: the product of cells[1..].
template <int Dim, class F>
void for_each_occupied_cell_of_slab(int c0, const std::array<int, Dim>& cells, std::size_t plane,
                                    const std::vector<std::int64_t>& cell_start, F&& f)
{
  std::array<int, Dim> index{};
  index[0] = c0;
  const std::size_t first = static_cast<std::size_t>(c0) * plane;
  for (std::size_t key = first; key < first + plane; ++key)
  {
    if (cell_start[key + 1] > cell_start[key])
      f(Cell<Dim>{index, key, cell_start[key], cell_start[key + 1]});
    for (int d = Dim - 1; d > 0 && ++index[d] == cells[d]; --d)
      index[d] = 0;
  }
}

/// The number of cells of a slab: the product of cells[1..].
template <int Dim>
std::size_t slab_cells(const std::array<int, Dim>& cells)
{
  std::size_t plane = 1;
  for (int d = 1; d < Dim; ++d)
    plane *= cells[d];
  return plane;
}

/// @brief Call `f(cell)` for every occupied cell (Cell: its indices, key and
/// range in the particle sort).
///
/// Cells go in strips of `strip_width` slabs (cells of equal first index):
/// first all even strips in parallel, then all odd ones. Strips of one
/// parity touch disjoint nodes, so `f` may add into its cell's nodes without
/// atomics, and a node receives its cells' contributions in a fixed order
/// (even strip, then odd strip, cells in key order): the same bits for any
/// thread count.
/// @param cells Cells per direction.
/// @param cell_start Offsets of each cell's particles, one per cell + 1.
template <int Dim, class F>
void for_each_cell_by_strips(const std::array<int, Dim>& cells,
                             const std::vector<std::int64_t>& cell_start, F&& f)
{
  const int nstrips = (cells[0] + strip_width - 1) / strip_width;
  const std::size_t plane = slab_cells<Dim>(cells);
  for (int parity = 0; parity < 2; ++parity)
  {
#pragma omp parallel for schedule(dynamic, 1)
    for (int s = parity; s < nstrips; s += 2)
      for (int c0 = s * strip_width; c0 < std::min((s + 1) * strip_width, cells[0]); ++c0)
        for_each_occupied_cell_of_slab<Dim>(c0, cells, plane, cell_start, f);
  }
}

/// @brief for_each_cell_by_strips over the occupied cells among `keys`
/// alone (in increasing order): the same strips, parities and order,
/// without a look at every cell of the grid.
template <int Dim, class F>
void for_each_listed_cell_by_strips(const std::array<int, Dim>& cells,
                                    const std::vector<std::int64_t>& cell_start,
                                    const std::vector<std::int32_t>& keys, F&& f)
{
  const int nstrips = (cells[0] + strip_width - 1) / strip_width;
  const std::int64_t strip_cells = static_cast<std::int64_t>(strip_width) * slab_cells<Dim>(cells);
  for (int parity = 0; parity < 2; ++parity)
  {
#pragma omp parallel for schedule(dynamic, 1)
    for (int s = parity; s < nstrips; s += 2)
    {
      const auto first = std::lower_bound(keys.begin(), keys.end(), s * strip_cells);
      const auto last = std::lower_bound(first, keys.end(), (s + 1) * strip_cells);
      for (auto it = first; it != last; ++it)
      {
        const std::size_t key = static_cast<std::size_t>(*it);
        if (cell_start[key + 1] > cell_start[key])
          f(Cell<Dim>{lattice_indices<Dim>(key, cells), key, cell_start[key], cell_start[key + 1]});
      }
    }
  }
}

} // namespace pfmpm
