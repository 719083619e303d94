/// @file neighbours.cpp
/// @brief Verlet neighbour lists through the cell sort (H&H section 2.5).
#include "pfmpm/fields/neighbours.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pfmpm
{

void NeighbourList::build(const Grid& grid, const CellSort& sort, const std::vector<double>& x,
                          double cutoff)
{
  const auto n = x.size() / 2;
  const BSpline1D& bx = grid.basis(0);
  const BSpline1D& by = grid.basis(1);
  const int ncx = bx.cells(), ncy = by.cells();
  const int reach = static_cast<int>(std::ceil(cutoff / grid.h()));
  const double c2 = cutoff * cutoff;
  // The cutoff in cells, widened by a hair for the rounding of the cell
  // coordinates: every cell that may hold a particle within it is searched.
  const double rc = cutoff / grid.h() * (1.0 + 1e-9);
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  _columns.resize(static_cast<std::size_t>(ncx));
  _count.resize(n);
  // Each cell column lists its particles' neighbours, in sort order, into a
  // buffer of its own: one pass over the pairs.
#pragma omp parallel for schedule(dynamic, 1)
  for (int cx = 0; cx < ncx; ++cx)
  {
    // The column's lists, out[0, used); out keeps its size from build to
    // build, so that only its growth is zero-filled.
    std::vector<std::int32_t>& out = _columns[cx];
    std::size_t used = 0;
    // Per column within reach: the candidates' range in the sort.
    std::vector<std::int64_t> from(2 * reach + 1), to(2 * reach + 1);
    for (int cy = 0; cy < ncy; ++cy)
    {
      const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
      for (std::int64_t k = start[cell]; k < start[cell + 1]; ++k)
      {
        const std::int32_t p = order[k];
        const double xp = x[2 * p], yp = x[2 * p + 1];
        const double sx = bx.coordinate(xp), sy = by.coordinate(yp);
        // The cells of each column ax within the cutoff of p, rows
        // [ay0, ay1] (in cells: p is `gap` from the column, and the rows
        // within `half` of it). Columns outer, rows inner: with particles
        // numbered by cell column by column, as the seeding numbers a body's
        // lattice, the candidates then come nearly in index order.
        const int ax0 = std::max(cx - reach, 0), ax1 = std::min(cx + reach, ncx - 1);
        std::int64_t candidates = 0;
        for (int ax = ax0; ax <= ax1; ++ax)
        {
          const double gap = ax < cx ? sx - (ax + 1) : ax > cx ? ax - sx : 0.0;
          const double left = rc * rc - gap * gap;
          std::int64_t& m0 = from[ax - ax0];
          std::int64_t& m1 = to[ax - ax0];
          m0 = m1 = 0;
          if (left < 0.0)
            continue;
          const double half = std::sqrt(left);
          const int ay0 = std::max({cy - reach, 0, static_cast<int>(std::floor(sy - half))});
          const int ay1 = std::min({cy + reach, ncy - 1, static_cast<int>(std::floor(sy + half))});
          // The cells ay0..ay1 of a column are consecutive in the sort.
          m0 = start[static_cast<std::size_t>(ax) * ncy + ay0];
          m1 = start[static_cast<std::size_t>(ax) * ncy + ay1 + 1];
          candidates += m1 - m0;
        }
        // Every candidate is written, and kept when within the cutoff: no
        // branch on the distance, which would be mispredicted about one
        // time in two.
        const std::size_t first = used;
        if (out.size() < first + static_cast<std::size_t>(candidates))
          out.resize(std::max(2 * out.size(), first + static_cast<std::size_t>(candidates)));
        std::size_t kept = first;
        for (int ax = ax0; ax <= ax1; ++ax)
          for (std::int64_t m = from[ax - ax0]; m < to[ax - ax0]; ++m)
          {
            const std::int32_t q = order[m];
            const double dx = x[2 * q] - xp, dy = x[2 * q + 1] - yp;
            out[kept] = q;
            kept += static_cast<std::size_t>((q != p) & (dx * dx + dy * dy <= c2));
          }
        used = kept;
        // By particle index (insertion: nearly in order already).
        for (std::size_t i = first + 1; i < used; ++i)
        {
          const std::int32_t q = out[i];
          std::size_t j = i;
          for (; j > first && out[j - 1] > q; --j)
            out[j] = out[j - 1];
          out[j] = q;
        }
        _count[p] = static_cast<std::int32_t>(used - first);
      }
    }
  }
  _start.resize(n + 1);
  _start[0] = 0;
  for (std::size_t p = 0; p < n; ++p)
    _start[p + 1] = _start[p] + _count[p];
  _index.resize(static_cast<std::size_t>(_start[n]));
#pragma omp parallel for schedule(dynamic, 1)
  for (int cx = 0; cx < ncx; ++cx)
  {
    const std::int32_t* from = _columns[cx].data();
    for (std::int64_t k = start[static_cast<std::size_t>(cx) * ncy];
         k < start[static_cast<std::size_t>(cx + 1) * ncy]; ++k)
    {
      const std::int32_t p = order[k];
      std::copy(from, from + _count[p], &_index[_start[p]]);
      from += _count[p];
    }
  }
  _built_at = x;
  _drift = _drift_checked = 0.0;
  _slack = -1.0; // the first look measures it
  _cutoff = cutoff;
  ++_builds;
}

bool NeighbourList::stale(const Grid& grid, const CellSort& sort, const std::vector<double>& x,
                          double skin)
{
  const std::size_t n = x.size() / 2;
  if (_builds == 0 || _start.size() != n + 1)
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
    for (int cx = bi * B; cx < std::min((bi + 1) * B, ncx); ++cx)
      for (int cy = 0; cy < ncy; ++cy)
      {
        const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
        double* r = &range[4 * (cy / B)];
        for (std::int64_t k = start[cell]; k < start[cell + 1]; ++k)
        {
          const std::int32_t p = order[k];
          const double ux = x[2 * p] - X[2 * p], uy = x[2 * p + 1] - X[2 * p + 1];
          r[0] = std::min(r[0], ux);
          r[1] = std::max(r[1], ux);
          r[2] = std::min(r[2], uy);
          r[3] = std::max(r[3], uy);
          largest = std::max(largest, ux * ux + uy * uy);
        }
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
