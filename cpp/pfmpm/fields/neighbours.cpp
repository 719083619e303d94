/// @file neighbours.cpp
/// @brief Verlet neighbour lists through the cell sort (H&H section 2.5).
#include "pfmpm/fields/neighbours.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pfmpm
{

void NeighbourList::build(const Grid<2>& grid, const CellSort& sort, const std::vector<double>& x,
                          double cutoff)
{
  const auto n = x.size() / 2;
  const int ncx = grid.cells()[0], ncy = grid.cells()[1];
  const int reach = static_cast<int>(std::ceil(cutoff / grid.h()));
  const double c2 = cutoff * cutoff;
  // The cutoff in cells, widened by a hair for the rounding of the cell
  // coordinates: every cell that may hold a particle within it is searched.
  const double rc = cutoff / grid.h() * (1.0 + 1e-9);
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  _columns.resize(static_cast<std::size_t>(ncx));
  _count.resize(n);
  _first.resize(n);
  // Each cell column lists its particles' neighbours, in sort order, into a
  // buffer of its own: one pass over the pairs. The candidates are those of
  // the cells within the cutoff of the particle's cell, gathered once per
  // cell and sorted by particle index there, so that every particle of the
  // cell keeps its neighbours in that order by one pass over them.
#pragma omp parallel
  {
    std::vector<std::int32_t> candidate; // of the cell, by particle index
    std::vector<double> cxy;             // their positions
    std::vector<std::uint8_t> keep;      // within the cutoff of the particle
#pragma omp for schedule(dynamic, 1)
    for (int cx = 0; cx < ncx; ++cx)
    {
      // The column's lists, out[0, used); out keeps its size from build to
      // build, so that only its growth is zero-filled.
      std::vector<std::int32_t>& out = _columns[cx];
      std::size_t used = 0;
      for (int cy = 0; cy < ncy; ++cy)
      {
        const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
        if (start[cell] == start[cell + 1])
          continue;
        // The cells of each column ax within the cutoff of the cell, rows
        // [ay0, ay1], consecutive in the sort (the cell is `gap` cells from
        // the column, and the rows within `half` of it).
        candidate.clear();
        for (int ax = std::max(cx - reach, 0); ax <= std::min(cx + reach, ncx - 1); ++ax)
        {
          const int gap = std::max(std::abs(ax - cx) - 1, 0);
          const double left = rc * rc - gap * gap;
          if (left < 0.0)
            continue;
          const int half = static_cast<int>(std::floor(std::sqrt(left))) + 1;
          const int ay0 = std::max(cy - half, 0), ay1 = std::min(cy + half, ncy - 1);
          candidate.insert(candidate.end(), order + start[static_cast<std::size_t>(ax) * ncy + ay0],
                           order + start[static_cast<std::size_t>(ax) * ncy + ay1 + 1]);
        }
        // By particle index (insertion: the cells' runs are in order each).
        const std::size_t nc = candidate.size();
        for (std::size_t i = 1; i < nc; ++i)
        {
          const std::int32_t q = candidate[i];
          std::size_t j = i;
          for (; j > 0 && candidate[j - 1] > q; --j)
            candidate[j] = candidate[j - 1];
          candidate[j] = q;
        }
        cxy.resize(2 * nc);
        keep.resize(nc);
        for (std::size_t i = 0; i < nc; ++i)
        {
          cxy[2 * i] = x[2 * static_cast<std::size_t>(candidate[i])];
          cxy[2 * i + 1] = x[2 * static_cast<std::size_t>(candidate[i]) + 1];
        }
        const std::size_t most = used + nc * static_cast<std::size_t>(start[cell + 1] - start[cell]);
        if (out.size() < most)
          out.resize(std::max(2 * out.size(), most));
        for (std::int64_t k = start[cell]; k < start[cell + 1]; ++k)
        {
          const std::int32_t p = order[k];
          const double xp = x[2 * p], yp = x[2 * p + 1];
          // The tests first, each on its own; then every candidate is
          // written and kept when within the cutoff: no branch on the
          // distance, which would be mispredicted about one time in two.
          std::uint8_t* in = keep.data();
          const double* c = cxy.data();
          for (std::size_t i = 0; i < nc; ++i)
          {
            const double dx = c[2 * i] - xp, dy = c[2 * i + 1] - yp;
            in[i] = static_cast<std::uint8_t>(dx * dx + dy * dy <= c2);
          }
          std::int32_t* o = out.data();
          const std::size_t first = used;
          for (std::size_t i = 0; i < nc; ++i)
          {
            o[used] = candidate[i];
            used += in[i] & static_cast<std::uint8_t>(candidate[i] != p);
          }
          _count[p] = static_cast<std::int32_t>(used - first);
        }
      }
      // Each particle's list where the column wrote it (out has stopped growing).
      const std::int32_t* from = out.data();
      for (std::int64_t k = start[static_cast<std::size_t>(cx) * ncy];
           k < start[static_cast<std::size_t>(cx + 1) * ncy]; ++k)
      {
        const std::int32_t p = order[k];
        _first[p] = from;
        from += _count[p];
      }
    }
  }
  _built_at = x;
  _drift = _drift_checked = 0.0;
  _slack = -1.0; // the first look measures it
  _cutoff = cutoff;
  ++_builds;
}

bool NeighbourList::stale(const Grid<2>& grid, const CellSort& sort, const std::vector<double>& x,
                          double skin)
{
  const std::size_t n = x.size() / 2;
  if (_builds == 0 || _count.size() != n)
    return true;
  if (_drift - _drift_checked <= _slack)
    return false; // no particle moved enough since the last look to use the slack up
  // Each pair's displacements differ by at most 2 skin (less a hair for
  // the rounding of x - X) in either of the two exact tests below.
  const double span = 2.0 * skin * (1.0 - 1e-9);
  const int ncx = grid.cells()[0], ncy = grid.cells()[1];
  // Blocks of B x B cells, B at least the cells that the radius spans: two
  // particles within the radius lie in one block or in two next to each other.
  const double radius = _cutoff - 2.0 * skin;
  const int B = static_cast<int>(std::floor(radius / grid.h() * (1.0 + 1e-9))) + 1;
  const int nbx = (ncx + B - 1) / B, nby = (ncy + B - 1) / B;
  constexpr double inf = std::numeric_limits<double>::infinity();
  _range.resize(4 * static_cast<std::size_t>(nbx) * nby);
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  const double* X = _built_at.data();
  double largest = 0.0; // the largest |u|^2
#pragma omp parallel for schedule(static) reduction(max : largest)
  for (int bi = 0; bi < nbx; ++bi)
  {
    double* range = &_range[4 * static_cast<std::size_t>(bi) * nby];
    for (int bj = 0; bj < nby; ++bj)
    {
      double* r = &range[4 * bj];
      r[0] = r[2] = inf;
      r[1] = r[3] = -inf;
    }
    // Per block of the column, its cells' particles in one run of the sort
    // per cell column; the range in locals (stores through r could alias x).
    for (int cx = bi * B; cx < std::min((bi + 1) * B, ncx); ++cx)
      for (int bj = 0; bj < nby; ++bj)
      {
        const std::size_t col = static_cast<std::size_t>(cx) * ncy;
        const std::int64_t k0 = start[col + bj * B], k1 = start[col + std::min((bj + 1) * B, ncy)];
        if (k0 == k1)
          continue;
        double* r = &range[4 * bj];
        double x0 = r[0], x1 = r[1], y0 = r[2], y1 = r[3], u2 = largest;
        for (std::int64_t k = k0; k < k1; ++k)
        {
          const std::int32_t p = order[k];
          const double ux = x[2 * p] - X[2 * p], uy = x[2 * p + 1] - X[2 * p + 1];
          x0 = std::min(x0, ux);
          x1 = std::max(x1, ux);
          y0 = std::min(y0, uy);
          y1 = std::max(y1, uy);
          u2 = std::max(u2, ux * ux + uy * uy);
        }
        r[0] = x0;
        r[1] = x1;
        r[2] = y0;
        r[3] = y1;
        largest = u2;
      }
  }
  // The widest box of the displacements of an occupied block alone and of
  // it with each block next to it (its diagonal squared): two particles
  // within the radius lie in one block or in two next to each other.
  double widest = 0.0;
#pragma omp parallel for schedule(static) reduction(max : widest)
  for (int bi = 0; bi < nbx; ++bi)
    for (int bj = 0; bj < nby; ++bj)
    {
      const double* own = &_range[4 * (static_cast<std::size_t>(bi) * nby + bj)];
      if (own[0] == inf)
        continue; // no particle in the block
      // The block itself and the four after it (the other four pairs are
      // those of the blocks before it); an empty block widens nothing.
      constexpr int next[5][2] = {{0, 0}, {0, 1}, {1, -1}, {1, 0}, {1, 1}};
      for (const auto& [di, dj] : next)
      {
        const int i = bi + di, j = bj + dj;
        if (i >= nbx || j < 0 || j >= nby)
          continue;
        const double* r = &_range[4 * (static_cast<std::size_t>(i) * nby + j)];
        const double ex = std::max(own[1], r[1]) - std::min(own[0], r[0]);
        const double ey = std::max(own[3], r[3]) - std::min(own[2], r[2]);
        widest = std::max(widest, ex * ex + ey * ey);
      }
    }
  // The slack of each test, in the distance any particle may move from now
  // on: a displacement grows by at most that, a box's diagonal by 2 sqrt 2
  // times it. The list stands while either test holds.
  const double slack = std::max(0.5 * span - std::sqrt(largest),
                                (span - std::sqrt(widest)) / (2.0 * std::sqrt(2.0)));
  if (slack < 0.0)
    return true;
  _slack = slack;
  _drift_checked = _drift;
  return false;
}

} // namespace pfmpm
