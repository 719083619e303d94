/// @file neighbours.cpp
/// @brief Verlet neighbour lists through the cell sort (H&H section 2.5).
#include "pfmpm/fields/neighbours.h"

#include <algorithm>
#include <cmath>

namespace pfmpm
{

void NeighbourList::build(const Grid& grid, const CellSort& sort, const std::vector<double>& x,
                          double cutoff)
{
  const auto n = x.size() / 2;
  const int ncx = grid.cells()[0], ncy = grid.cells()[1];
  const int reach = static_cast<int>(std::ceil(cutoff / grid.h()));
  const double c2 = cutoff * cutoff;
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  // f(p, q) for every pair within the cutoff; a particle's pairs are visited
  // by the thread of its cell alone.
  auto visit = [&](auto&& f)
  {
#pragma omp parallel for schedule(dynamic, 1)
    for (int cx = 0; cx < ncx; ++cx)
      for (int cy = 0; cy < ncy; ++cy)
      {
        const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
        for (std::int64_t k = start[cell]; k < start[cell + 1]; ++k)
        {
          const std::int32_t p = order[k];
          const double xp = x[2 * p], yp = x[2 * p + 1];
          for (int ax = std::max(cx - reach, 0); ax <= std::min(cx + reach, ncx - 1); ++ax)
            for (int ay = std::max(cy - reach, 0); ay <= std::min(cy + reach, ncy - 1); ++ay)
            {
              const std::size_t other = static_cast<std::size_t>(ax) * ncy + ay;
              for (std::int64_t m = start[other]; m < start[other + 1]; ++m)
              {
                const std::int32_t q = order[m];
                const double dx = x[2 * q] - xp, dy = x[2 * q + 1] - yp;
                if (q != p && dx * dx + dy * dy <= c2)
                  f(p, q);
              }
            }
        }
      }
  };
  _count.assign(n, 0);
  visit([&](std::int32_t p, std::int32_t) { ++_count[p]; });
  _start.resize(n + 1);
  _start[0] = 0;
  for (std::size_t p = 0; p < n; ++p)
    _start[p + 1] = _start[p] + _count[p];
  _index.resize(static_cast<std::size_t>(_start[n]));
  std::fill(_count.begin(), _count.end(), 0);
  visit([&](std::int32_t p, std::int32_t q) { _index[_start[p] + _count[p]++] = q; });
  const auto np = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t p = 0; p < np; ++p)
    std::sort(&_index[_start[p]], &_index[_start[p + 1]]);
  _drift = 0.0;
  _cutoff = cutoff;
  ++_builds;
}

} // namespace pfmpm
