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

/// @brief Every particle's neighbours within a cutoff, kept while no particle
/// can have moved more than a skin distance since the list was built.
///
/// Built with cutoff r + 2 delta, the list holds every pair within r as long
/// as no particle has moved more than delta since (each of two particles
/// closes the gap by at most delta): the paper's re-sort rule with a Verlet
/// skin, so that the kernel sums between rebuilds are exact. How far
/// particles have moved is bounded by the sum over the steps of the
/// largest distance any particle moved in the step (moved()), which the
/// step knows at no cost, rather than measured particle by particle. Each
/// particle's list is sorted by particle index, so a sum over the neighbours
/// within r has an order fixed by the positions alone, whenever the list was
/// built (a resumed run gives the bits of an uninterrupted one).
class NeighbourList
{
public:
  /// @brief Whether the list must be rebuilt: it was never built, the
  /// particle count changed, or the particles may have moved more than
  /// `skin` since the build.
  bool stale(std::size_t particles, double skin) const
  {
    return _builds == 0 || _start.size() != particles + 1 || !(_drift <= skin);
  }
  /// @brief Note that no particle moved more than `distance` in a step.
  void moved(double distance) { _drift += distance; }

  /// @brief For every particle, the others within `cutoff` of it, searched in
  /// the cells of `sort` around its own.
  void build(const Grid& grid, const CellSort& sort, const std::vector<double>& x, double cutoff);

  /// The neighbours of particle p: index()[start()[p] .. start()[p + 1]).
  const std::vector<std::int64_t>& start() const { return _start; }
  const std::vector<std::int32_t>& index() const { return _index; }
  /// Builds so far.
  std::int64_t builds() const { return _builds; }
  /// Cutoff of the last build.
  double cutoff() const { return _cutoff; }

private:
  std::vector<std::int64_t> _start; // per particle + 1
  std::vector<std::int32_t> _index;
  std::vector<std::int32_t> _count; // scratch
  double _drift = 0.0;              // bound on any particle's motion since the build
  double _cutoff = 0.0;
  std::int64_t _builds = 0;
};

} // namespace pfmpm
