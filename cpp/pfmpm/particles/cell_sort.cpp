/// @file cell_sort.cpp
/// @brief The stable counting sort of particles by cell.
#include "pfmpm/particles/cell_sort.h"

#include <omp.h>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace pfmpm
{

template <int Dim, int Tile>
std::size_t CellSort::sort(const Grid<Dim>& grid, const std::vector<double>& x)
{
  const auto n = static_cast<std::ptrdiff_t>(x.size() / Dim);
  std::array<int, Dim> cells = grid.cells(); // per direction: cells, or tiles
  std::size_t ncells = 1;
  for (int d = 0; d < Dim; ++d)
  {
    cells[d] = (cells[d] + Tile - 1) / Tile;
    ncells *= static_cast<std::size_t>(cells[d]);
  }
  _cell.resize(n);
  _order.resize(n);
  _cell_start.resize(ncells + 1);

  std::ptrdiff_t outside = n;
#pragma omp parallel for schedule(static) reduction(min : outside)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    std::array<int, Dim> c;
    bool inside = true;
    for (int d = 0; d < Dim; ++d)
    {
      c[d] = grid.basis(d).cell(x[Dim * i + d]);
      inside = inside && c[d] >= 0;
      c[d] /= Tile;
    }
    if (!inside)
    {
      outside = std::min(outside, i);
      _cell[i] = 0;
    }
    else
      _cell[i] = static_cast<std::int32_t>(lattice_key<Dim>(c, cells));
  }
  if (outside < n)
    return static_cast<std::size_t>(outside);

  // Each thread counts a contiguous slice; the offsets put slice t before
  // slice t+1 inside every cell, which is the order a serial stable sort
  // gives, whatever the number of threads.
  _histogram.resize(static_cast<std::size_t>(omp_get_max_threads()) * ncells);
#pragma omp parallel
  {
    const std::ptrdiff_t nt = omp_get_num_threads(), t = omp_get_thread_num();
    const std::ptrdiff_t begin = n * t / nt, end = n * (t + 1) / nt;
    std::int64_t* count = &_histogram[t * ncells];
    std::fill(count, count + ncells, 0);
    for (std::ptrdiff_t i = begin; i < end; ++i)
      ++count[_cell[i]];
#pragma omp barrier
#pragma omp single
    {
      std::int64_t running = 0;
      for (std::size_t c = 0; c < ncells; ++c)
      {
        _cell_start[c] = running;
        for (std::ptrdiff_t s = 0; s < nt; ++s)
        {
          std::int64_t& slot = _histogram[s * ncells + c];
          const std::int64_t k = slot;
          slot = running;
          running += k;
        }
      }
      _cell_start[ncells] = running;
    }
    for (std::ptrdiff_t i = begin; i < end; ++i)
      _order[count[_cell[i]]++] = static_cast<std::int32_t>(i);
  }
  return static_cast<std::size_t>(n);
}

std::vector<double> fold_tiles(const TileSums& tiles)
{
  const auto width = static_cast<std::size_t>(tiles.width);
  if (tiles.sums.size() != width * tiles.keys.size())
    throw std::invalid_argument("tile sums: " + std::to_string(tiles.sums.size()) + " values for "
                                + std::to_string(tiles.keys.size()) + " tiles of "
                                + std::to_string(width));
  std::vector<double> total(width, 0.0);
  for (std::size_t i = 0; i < tiles.keys.size(); ++i)
  {
    if (i > 0 && tiles.keys[i] <= tiles.keys[i - 1])
      throw std::invalid_argument("tile sums: tile " + std::to_string(tiles.keys[i]) + " after tile "
                                  + std::to_string(tiles.keys[i - 1]) + " (the keys must ascend)");
    for (std::size_t k = 0; k < width; ++k)
      total[k] += tiles.sums[i * width + k];
  }
  return total;
}

template std::size_t CellSort::sort<2, 1>(const Grid<2>&, const std::vector<double>&);
template std::size_t CellSort::sort<3, 1>(const Grid<3>&, const std::vector<double>&);
template std::size_t CellSort::sort<2, tile_cells>(const Grid<2>&, const std::vector<double>&);
template std::size_t CellSort::sort<3, tile_cells>(const Grid<3>&, const std::vector<double>&);

} // namespace pfmpm
