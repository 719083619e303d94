/// @file neighbours.h
/// @brief Verlet neighbour lists of the particles, found through the cell
/// sort (Homel & Herbold 2017, section 2.5).
#pragma once

#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/cell_sort.h"

#include <cstdint>
#include <vector>

namespace pfmpm
{

/// @brief Every particle's neighbours within a cutoff, kept while no pair of
/// particles can have come within the radius r of the sums from outside the
/// cutoff.
///
/// Built with cutoff r + 2 delta at positions X, the list holds every pair
/// (p, q) within r at positions x as long as the displacements u = x - X of
/// the two differ by at most 2 delta: |X_p - X_q| <= |x_p - x_q| + |u_p - u_q|.
/// That is the paper's re-sort rule with a Verlet skin, so that the sums
/// between rebuilds are exact. stale() looks at the displacements: the list
/// stands if no particle is displaced by more than delta, or if, with the
/// cells in blocks as wide as r, the displacements of the particles of each
/// block, and of each block with any one next to it (two particles within r
/// lie in one block or in two such), lie in a box whose diagonal is at most
/// 2 delta: a fragment or a platen that translates as a whole
/// does not make the lists stale, only motion relative to the particles
/// around. Each look also gives its slack: how far any particle may move
/// before either test could fail (a displacement grows by at most that
/// distance, a box's diagonal by 2 sqrt(Dim) times it). Until the sum over the
/// steps of the largest distance any particle moved in the step (moved(),
/// which the step knows at no cost) uses the slack up, stale() does not look.
/// Each particle's list is sorted by particle index, which is id order (the
/// particles are in ascending id order: Particles::id), so a sum over the
/// neighbours within r has an order fixed by the positions and ids alone,
/// whenever the list was built (a resumed run gives the bits of an
/// uninterrupted one), and whichever other particles it lists.
/// Explicitly instantiated for Dim = 2 and 3.
template <int Dim>
class NeighbourList
{
public:
  NeighbourList() = default;
  // The lists point into the slabs' buffers: a copy would point into the
  // original's. A move keeps the buffers, and so the lists.
  NeighbourList(const NeighbourList&) = delete;
  NeighbourList& operator=(const NeighbourList&) = delete;
  NeighbourList(NeighbourList&&) = default;
  NeighbourList& operator=(NeighbourList&&) = default;

  /// @brief Whether the list must be rebuilt before sums within the radius
  /// `cutoff() - 2 skin` are taken at positions `x`, sorted into the cells
  /// of `grid` by `sort`: it was never built, the particle count changed, or
  /// a pair may have come within that radius from beyond the cutoff.
  bool stale(const Grid<Dim>& grid, const CellSort& sort, const std::vector<double>& x, double skin);
  /// @brief Note that no particle moved more than `distance` in a step.
  void moved(double distance) { _drift += distance; }

  /// @brief For every particle, or with `cells` those of the cells whose
  /// entry is set, the others within `cutoff` of it, searched in the cells
  /// of `sort` around its own. A particle not listed has no neighbours
  /// (listed() tells).
  void build(const Grid<Dim>& grid, const CellSort& sort, const std::vector<double>& x, double cutoff,
             const std::uint8_t* cells = nullptr);
  /// Whether the last build listed particle p's neighbours.
  bool listed(std::size_t p) const { return _listed[p] != 0; }

  /// The neighbours of particle p, by index (so by id).
  struct Range
  {
    const std::int32_t* first;
    std::int32_t size;
    const std::int32_t* begin() const { return first; }
    const std::int32_t* end() const { return first + size; }
  };
  Range of(std::size_t p) const { return {_first[p], _count[p]}; }
  /// Particles of the last build.
  std::size_t size() const { return _count.size(); }
  /// Builds so far.
  std::int64_t builds() const { return _builds; }
  /// Cutoff of the last build.
  double cutoff() const { return _cutoff; }

private:
  // Per particle: its list, in the buffer of its slab of cells, and its length.
  std::vector<const std::int32_t*> _first;
  std::vector<std::int32_t> _count;
  std::vector<std::uint8_t> _listed;
  std::vector<double> _built_at;    // positions at the build, N x Dim
  double _drift = 0.0;              // bound on any particle's motion since the build
  double _drift_checked = 0.0;      // _drift at the last look at the displacements
  double _slack = -1.0;             // motion the last look allows (< 0: look)
  double _cutoff = 0.0;
  std::int64_t _builds = 0;
  // Per slab of cells (equal first index) the lists of its particles in
  // sort order (the lists' storage); scratch: per block of cells the range
  // of the displacements (min and max along each direction).
  std::vector<std::vector<std::int32_t>> _slabs;
  std::vector<double> _range;
};

extern template class NeighbourList<2>;
extern template class NeighbourList<3>;

} // namespace pfmpm
