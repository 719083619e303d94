/// @file neighbours.cpp
/// @brief Verlet neighbour lists through the cell sort (H&H section 2.5).
#include "pfmpm/fields/neighbours.h"
#include "pfmpm/common/strips.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace pfmpm
{

namespace
{
/// @brief f(first, last) for each run of cells along the last direction
/// whose cells may hold a point within `rc` cells of cell `c`: for every
/// cell a of the leading directions within `reach` of c whose gap to c
/// (the whole cells between them) leaves room, the cells [first, last] of
/// its line along the last direction within that room, as keys.
template <int Dim, class F>
void each_run_within(const std::array<int, Dim>& c, const std::array<int, Dim>& n, int reach,
                     double rc, F&& f)
{
  std::array<int, Dim> lo, hi, a;
  for (int d = 0; d + 1 < Dim; ++d)
  {
    lo[d] = std::max(c[d] - reach, 0);
    hi[d] = std::min(c[d] + reach, n[d] - 1);
  }
  a = lo;
  constexpr int last = Dim - 1;
  for (;;)
  {
    double left = rc * rc;
    for (int d = 0; d < last; ++d)
    {
      const int gap = std::max(std::abs(a[d] - c[d]) - 1, 0);
      left -= gap * gap;
    }
    if (left >= 0.0)
    {
      const int half = static_cast<int>(std::floor(std::sqrt(left))) + 1;
      a[last] = std::max(c[last] - half, 0);
      const std::size_t first = lattice_key<Dim>(a, n);
      a[last] = std::min(c[last] + half, n[last] - 1);
      f(first, lattice_key<Dim>(a, n));
    }
    int d = last - 1; // the next line: the last leading direction fastest
    for (; d >= 0 && ++a[d] > hi[d]; --d)
      a[d] = lo[d];
    if (d < 0)
      return;
  }
}
} // namespace

template <int Dim>
void NeighbourList<Dim>::build(const Grid<Dim>& grid, const CellSort& sort, const std::vector<double>& x,
                               double cutoff, const std::uint8_t* cells)
{
  const auto n = x.size() / Dim;
  const std::array<int, Dim> nc = grid.cells();
  const int ncx = nc[0];
  const std::size_t slab = slab_cells<Dim>(nc);
  const int reach = static_cast<int>(std::ceil(cutoff / grid.h()));
  const double c2 = cutoff * cutoff;
  // The cutoff in cells, widened by a hair for the rounding of the cell
  // coordinates: every cell that may hold a particle within it is searched.
  const double rc = cutoff / grid.h() * (1.0 + 1e-9);
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  _slabs.resize(static_cast<std::size_t>(ncx));
  _count.resize(n);
  _first.resize(n);
  _listed.resize(n);
  // Each slab of cells lists its particles' neighbours, in sort order, into
  // a buffer of its own: one pass over the pairs. The candidates are those
  // of the cells within the cutoff of the particle's cell, gathered once per
  // cell and sorted by particle index (id order: Particles::id) there, so
  // that every particle of the cell keeps its neighbours in that order by
  // one pass over them.
#pragma omp parallel
  {
    std::vector<std::int32_t> candidate; // of the cell, by particle index
    std::vector<double> cx;              // their positions
    std::vector<std::uint8_t> keep;      // within the cutoff of the particle
#pragma omp for schedule(dynamic, 1)
    for (int s = 0; s < ncx; ++s)
    {
      // The slab's lists, out[0, used); out keeps its size from build to
      // build, so that only its growth is zero-filled.
      std::vector<std::int32_t>& out = _slabs[s];
      std::size_t used = 0;
      for (std::size_t cell = s * slab; cell < (s + 1) * slab; ++cell)
      {
        if (start[cell] == start[cell + 1])
          continue;
        if (cells && !cells[cell])
        {
          for (std::int64_t k = start[cell]; k < start[cell + 1]; ++k)
          {
            _count[order[k]] = 0;
            _listed[order[k]] = 0;
          }
          continue;
        }
        candidate.clear();
        each_run_within<Dim>(lattice_indices<Dim>(cell, nc), nc, reach, rc,
                             [&](std::size_t first, std::size_t last)
                             {
                               candidate.insert(candidate.end(), order + start[first],
                                                order + start[last + 1]);
                             });
        // By particle index (insertion: the cells' runs are in order each).
        const std::size_t m = candidate.size();
        for (std::size_t i = 1; i < m; ++i)
        {
          const std::int32_t q = candidate[i];
          std::size_t j = i;
          for (; j > 0 && candidate[j - 1] > q; --j)
            candidate[j] = candidate[j - 1];
          candidate[j] = q;
        }
        cx.resize(Dim * m);
        keep.resize(m);
        for (std::size_t i = 0; i < m; ++i)
          for (int d = 0; d < Dim; ++d)
            cx[Dim * i + d] = x[Dim * static_cast<std::size_t>(candidate[i]) + d];
        const std::size_t most = used + m * static_cast<std::size_t>(start[cell + 1] - start[cell]);
        if (out.size() < most)
          out.resize(std::max(2 * out.size(), most));
        for (std::int64_t k = start[cell]; k < start[cell + 1]; ++k)
        {
          const std::int32_t p = order[k];
          const double* xp = &x[Dim * static_cast<std::size_t>(p)];
          // The tests first, each on its own; then every candidate is
          // written and kept when within the cutoff: no branch on the
          // distance, which would be mispredicted about one time in two.
          std::uint8_t* in = keep.data();
          const double* c = cx.data();
          for (std::size_t i = 0; i < m; ++i)
          {
            double r2 = 0.0;
            for (int d = 0; d < Dim; ++d)
            {
              const double e = c[Dim * i + d] - xp[d];
              r2 += e * e;
            }
            in[i] = static_cast<std::uint8_t>(r2 <= c2);
          }
          std::int32_t* o = out.data();
          const std::size_t first = used;
          for (std::size_t i = 0; i < m; ++i)
          {
            o[used] = candidate[i];
            used += in[i] & static_cast<std::uint8_t>(candidate[i] != p);
          }
          _count[p] = static_cast<std::int32_t>(used - first);
          _listed[p] = 1;
        }
      }
      // Each particle's list where the slab wrote it (out has stopped growing).
      const std::int32_t* from = out.data();
      for (std::int64_t k = start[s * slab]; k < start[(s + 1) * slab]; ++k)
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

template <int Dim>
bool NeighbourList<Dim>::stale(const Grid<Dim>& grid, const CellSort& sort, const std::vector<double>& x,
                               double skin)
{
  const std::size_t n = x.size() / Dim;
  if (_builds == 0 || _count.size() != n)
    return true;
  if (_drift - _drift_checked <= _slack)
    return false; // no particle moved enough since the last look to use the slack up
  // Each pair's displacements differ by at most 2 skin (less a hair for
  // the rounding of x - X) in either of the two exact tests below.
  const double span = 2.0 * skin * (1.0 - 1e-9);
  const std::array<int, Dim> nc = grid.cells();
  constexpr int last = Dim - 1;
  // Blocks of B^Dim cells, B at least the cells that the radius spans: two
  // particles within the radius lie in one block or in two next to each other.
  const double radius = _cutoff - 2.0 * skin;
  const int B = static_cast<int>(std::floor(radius / grid.h() * (1.0 + 1e-9))) + 1;
  std::array<int, Dim> nb;
  for (int d = 0; d < Dim; ++d)
    nb[d] = (nc[d] + B - 1) / B;
  const std::size_t block_slab = slab_cells<Dim>(nb);
  constexpr double inf = std::numeric_limits<double>::infinity();
  constexpr int R = 2 * Dim; // per block: min and max along each direction
  _range.resize(R * static_cast<std::size_t>(nb[0]) * block_slab);
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  const double* X = _built_at.data();
  const std::size_t cell_slab = slab_cells<Dim>(nc), line = nc[last];
  double largest = 0.0; // the largest |u|^2
#pragma omp parallel for schedule(static) reduction(max : largest)
  for (int bi = 0; bi < nb[0]; ++bi)
  {
    double* range = &_range[R * static_cast<std::size_t>(bi) * block_slab];
    for (std::size_t b = 0; b < block_slab; ++b)
      for (int d = 0; d < Dim; ++d)
      {
        range[R * b + 2 * d] = inf;
        range[R * b + 2 * d + 1] = -inf;
      }
    // Per block of the slab, its cells' particles in one run of the sort
    // per line of cells along the last direction; the range in locals
    // (stores through it could alias x).
    for (int c0 = bi * B; c0 < std::min((bi + 1) * B, nc[0]); ++c0)
      for (std::size_t l = 0; l < cell_slab / line; ++l) // the lines of the slab
      {
        // The line's cell indices but the first and last, and its block's.
        std::array<int, Dim> cell{};
        cell[0] = c0;
        std::size_t rest = l;
        for (int d = last - 1; d > 0; --d)
        {
          cell[d] = static_cast<int>(rest % nc[d]);
          rest /= nc[d];
        }
        std::array<int, Dim> block{};
        block[0] = bi;
        for (int d = 1; d < last; ++d)
          block[d] = cell[d] / B;
        const std::size_t first_cell = static_cast<std::size_t>(c0) * cell_slab + l * line;
        for (int bl = 0; bl < nb[last]; ++bl)
        {
          const std::int64_t k0 = start[first_cell + bl * B];
          const std::int64_t k1 = start[first_cell + std::min<std::size_t>((bl + 1) * B, line)];
          if (k0 == k1)
            continue;
          block[last] = bl;
          double* r = &_range[R * lattice_key<Dim>(block, nb)];
          double lo[Dim], hi[Dim], u2 = largest;
          for (int d = 0; d < Dim; ++d)
          {
            lo[d] = r[2 * d];
            hi[d] = r[2 * d + 1];
          }
          for (std::int64_t k = k0; k < k1; ++k)
          {
            const std::int32_t p = order[k];
            double u[Dim];
            for (int d = 0; d < Dim; ++d)
            {
              u[d] = x[Dim * p + d] - X[Dim * p + d];
              lo[d] = std::min(lo[d], u[d]);
              hi[d] = std::max(hi[d], u[d]);
            }
            double uu = u[0] * u[0];
            for (int d = 1; d < Dim; ++d)
              uu += u[d] * u[d];
            u2 = std::max(u2, uu);
          }
          for (int d = 0; d < Dim; ++d)
          {
            r[2 * d] = lo[d];
            r[2 * d + 1] = hi[d];
          }
          largest = u2;
        }
      }
  }
  // The widest box of the displacements of an occupied block alone and of
  // it with each block next to it (its diagonal squared): two particles
  // within the radius lie in one block or in two next to each other. The
  // block itself and the neighbours after it, those whose first non-zero
  // offset is positive (the others' pairs are those of the blocks before it).
  std::array<std::array<int, Dim>, (Dim == 2 ? 9 : 27) / 2 + 1> next{};
  {
    int k = 0;
    std::array<int, Dim> o;
    o.fill(-1);
    for (;;)
    {
      int d0 = 0;
      while (d0 < Dim && o[d0] == 0)
        ++d0;
      if (d0 == Dim || o[d0] > 0)
        next[k++] = o;
      int d = last;
      for (; d >= 0 && ++o[d] > 1; --d)
        o[d] = -1;
      if (d < 0)
        break;
    }
  }
  const std::size_t nblocks = static_cast<std::size_t>(nb[0]) * block_slab;
  double widest = 0.0;
#pragma omp parallel for schedule(static) reduction(max : widest)
  for (std::size_t b = 0; b < nblocks; ++b)
  {
    const double* own = &_range[R * b];
    if (own[0] == inf)
      continue; // no particle in the block
    const std::array<int, Dim> i = lattice_indices<Dim>(b, nb);
    for (const std::array<int, Dim>& o : next)
    {
      std::array<int, Dim> j;
      bool inside = true;
      for (int d = 0; d < Dim; ++d)
      {
        j[d] = i[d] + o[d];
        inside = inside && j[d] >= 0 && j[d] < nb[d];
      }
      if (!inside)
        continue;
      const double* r = &_range[R * lattice_key<Dim>(j, nb)];
      double e2 = 0.0;
      for (int d = 0; d < Dim; ++d)
      {
        const double e = std::max(own[2 * d + 1], r[2 * d + 1]) - std::min(own[2 * d], r[2 * d]);
        e2 += e * e;
      }
      widest = std::max(widest, e2);
    }
  }
  // The slack of each test, in the distance any particle may move from now
  // on: a displacement grows by at most that, a box's diagonal by 2 sqrt(Dim)
  // times it. The list stands while either test holds.
  const double slack = std::max(0.5 * span - std::sqrt(largest),
                                (span - std::sqrt(widest)) / (2.0 * std::sqrt(double(Dim))));
  if (slack < 0.0)
    return true;
  _slack = slack;
  _drift_checked = _drift;
  return false;
}

template class NeighbourList<2>;
template class NeighbourList<3>;

} // namespace pfmpm
