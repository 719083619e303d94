/// @file cell_sort.h
/// @brief Particles sorted by grid cell: the order every particle-grid loop takes.
#pragma once

#include "pfmpm/grid/grid.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// @brief A stable counting sort of particles by the grid cell holding them.
///
/// Cells are keyed as the grid keys them (lattice_key: `cell = cx * cells_y + cy`
/// in 2D); the
/// particles of cell c are order()[cell_start()[c] .. cell_start()[c + 1]).
/// Within a cell they keep their index order, whatever the thread count, so
/// every sum taken in this order has the same bits on any number of threads.
/// The particles are in ascending id order (Particles::id), so this is
/// (cell, id) order: the order a process holding any part of the particles,
/// in any array order, would restore by sorting its arrays by id.
class CellSort
{
public:
  /// @brief Sort the particles at positions `x` (N x Dim) into the cells of `grid`,
  /// or with `Tile` > 1 into its tiles: boxes of `Tile` cells per side from the
  /// grid's origin (the last ones cut by the grid's end), keyed as cells are.
  /// @return N when all lie on the grid, else the first particle that does not
  ///         (the sort is then incomplete).
  template <int Dim, int Tile = 1>
  std::size_t sort(const Grid<Dim>& grid, const std::vector<double>& x);

  /// @brief The particles of `all` for which keep(p) holds, in the same order.
  template <class Keep>
  void select(const CellSort& all, Keep&& keep);

  const std::vector<std::int32_t>& order() const { return _order; }
  const std::vector<std::int64_t>& cell_start() const { return _cell_start; }
  /// Per particle: the key of its cell, from the last sort() (not select()).
  const std::vector<std::int32_t>& cell() const { return _cell; }
  /// Particles in the sort.
  std::size_t size() const { return _order.size(); }

private:
  std::vector<std::int32_t> _cell;       // per particle: cell key (sort() only)
  std::vector<std::int32_t> _order;      // particles sorted by cell, stable
  std::vector<std::int64_t> _cell_start; // offsets into _order, per cell + 1
  std::vector<std::int64_t> _histogram;  // threads x cells, scratch
};

/// Cells per side of the tiles that particle sums run by (Solver::energies):
/// a sum in the same order on any split of the grid into whole tiles.
inline constexpr int tile_cells = 8;

extern template std::size_t CellSort::sort<2, 1>(const Grid<2>&, const std::vector<double>&);
extern template std::size_t CellSort::sort<3, 1>(const Grid<3>&, const std::vector<double>&);
extern template std::size_t CellSort::sort<2, tile_cells>(const Grid<2>&, const std::vector<double>&);
extern template std::size_t CellSort::sort<3, tile_cells>(const Grid<3>&, const std::vector<double>&);

template <class Keep>
void CellSort::select(const CellSort& all, Keep&& keep)
{
  const auto ncells = static_cast<std::ptrdiff_t>(all._cell_start.size()) - 1;
  _cell_start.assign(ncells + 1, 0);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
  {
    std::int64_t count = 0;
    for (std::int64_t k = all._cell_start[c]; k < all._cell_start[c + 1]; ++k)
      count += keep(static_cast<std::size_t>(all._order[k])) ? 1 : 0;
    _cell_start[c + 1] = count;
  }
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
    _cell_start[c + 1] += _cell_start[c];
  _order.resize(static_cast<std::size_t>(_cell_start[ncells]));
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
  {
    std::int64_t next = _cell_start[c];
    for (std::int64_t k = all._cell_start[c]; k < all._cell_start[c + 1]; ++k)
      if (keep(static_cast<std::size_t>(all._order[k])))
        _order[next++] = all._order[k];
  }
}

/// @brief Sums of `width` quantities per tile of particles, as a process
/// holding some whole tiles gives them to the one that adds them (fold_tiles).
struct TileSums
{
  int width = 0;                  ///< quantities per tile
  std::vector<std::int64_t> keys; ///< the non-empty tiles' keys, ascending
  std::vector<double> sums;       ///< per tile, its `width` sums
};

/// @brief The sums per non-empty tile of a tile sort (CellSort::sort<Dim,
/// tile_cells>): f(order, begin, end, row) adds the terms of the particles
/// order[begin, end), one tile's in index (id) order, into row (`width`
/// values, zero at the start). The bits depend neither on the thread count
/// nor on the process that holds the tile.
template <class F>
TileSums tile_sums(const CellSort& tiles, int width, F&& f)
{
  const std::vector<std::int64_t>& start = tiles.cell_start();
  const std::int32_t* order = tiles.order().data();
  const auto ntiles = static_cast<std::int64_t>(start.size()) - 1;
  TileSums out;
  out.width = width;
  for (std::int64_t t = 0; t < ntiles; ++t)
    if (start[t] < start[t + 1])
      out.keys.push_back(t);
  const auto n = static_cast<std::ptrdiff_t>(out.keys.size());
  out.sums.assign(n * width, 0.0);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const std::int64_t t = out.keys[i];
    f(order, start[t], start[t + 1], &out.sums[i * width]);
  }
  return out;
}

/// @brief The sum of each quantity over the tiles: each tile's sum added to
/// zero in the order of `tiles.keys`, which must ascend. The tiles of all
/// processes, each from the one that holds it, give the sums of one process.
/// @throws std::invalid_argument if the keys do not ascend strictly.
std::vector<double> fold_tiles(const TileSums& tiles);

} // namespace pfmpm
