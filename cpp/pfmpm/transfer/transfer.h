/// @file transfer.h
/// @brief The particle-grid loop, written once: particle-to-grid (P2G) and
/// grid-to-particle (G2P) drivers that every transfer of the step goes through.
///
/// A transfer is a kernel called once per occupied cell with a `Cell` and an
/// `each` function; `each(f)` evaluates the stencil at every particle of the
/// cell, in sorted order, and calls f(p, stencil). So the kernel holds the
/// physics (what a particle adds to its nodes, or reads from them, with the
/// paper's equations) and chooses its own per-cell storage, while the loop
/// over cells and particles and the evaluation of the shape functions are
/// here. The kernels of pfmpm: momentum P2G and kinematics G2P
/// (solver/momentum.h), phase-field assembly and map-back (fracture/phasefield.cpp).
#pragma once

#include "pfmpm/common/strips.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/cell_sort.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>

namespace pfmpm
{

/// The particle data a stencil is evaluated from: the centres and, for a
/// stencil with domains (CPDI), the half-edges of the particle domains.
struct Points
{
  const double* x;              ///< centres, Dim coordinates per particle
  const double* r1 = nullptr;   ///< domain half-edge r_1, Dim components per particle
  const double* r2 = nullptr;   ///< domain half-edge r_2
  const double* r3 = nullptr;   ///< domain half-edge r_3 (3D)
};

/// @brief Evaluate stencil s at particle p of `points`, a particle of cell
/// `cell`: at its centre, and over its domain's half-edges where the stencil
/// reads them (CPDI).
template <class Stencil>
[[gnu::always_inline]] inline void evaluate_at(Stencil& s,
                                               const std::array<const BSpline1D*, Stencil::dim>& basis,
                                               const int* cell, const Points& points, std::size_t p)
{
  constexpr int Dim = Stencil::dim;
  const double* x = &points.x[Dim * p];
  if constexpr (Stencil::domains && Dim == 2)
    s.evaluate(basis, cell, x, &points.r1[Dim * p], &points.r2[Dim * p]);
  else if constexpr (Stencil::domains)
    s.evaluate(basis, cell, x, &points.r1[Dim * p], &points.r2[Dim * p], &points.r3[Dim * p]);
  else
    s.evaluate(basis, cell, x);
}

namespace detail
{
/// `each` of a cell: evaluate the stencil at each of its particles and call f.
template <class Stencil>
struct EachParticle
{
  static constexpr int Dim = Stencil::dim;
  const std::array<const BSpline1D*, Dim>& basis;
  const std::int32_t* order;
  Points points;
  const Cell<Dim>& cell;

  template <class F>
  void operator()(F&& f) const
  {
    const std::array<int, Dim> index = cell.index;
    const std::array<const BSpline1D*, Dim> local = basis;
    const Points at = points;
    const std::int32_t* const sorted = order;
    for (std::int64_t k = cell.begin; k < cell.end; ++k)
    {
      const std::size_t p = sorted[k];
      Stencil s;
      evaluate_at(s, local, index.data(), at, p);
      f(p, s);
    }
  }
};
} // namespace detail

/// @brief P2G: call kernel(cell, each) for every occupied cell, cells of one
/// strip parity in parallel (for_each_cell_by_strips).
///
/// A kernel adds only into the nodes of its cell's stencil block. Strips of
/// one parity share no node, so it may add without atomics, and every node
/// receives its cells' contributions in an order fixed by the sort: the same
/// bits on any number of threads.
template <class Stencil, class Kernel>
void particle_to_grid(const Grid<Stencil::dim>& grid, const CellSort& sort, const Points& points,
                      Kernel&& kernel)
{
  // A cell's block is at most strip_width nodes from at most one node before
  // the cell, so the blocks of two strips of one parity, strip_width cells
  // apart, never meet (at the grid's ends a block moves one node inwards,
  // which the first and last strip's neighbours of one parity stay clear of).
  static_assert(Stencil::lower >= -1 && Stencil::width <= strip_width,
                "strips of one parity must not share a node");
  constexpr int Dim = Stencil::dim;
  const std::array<const BSpline1D*, Dim> basis = grid.bases();
  const std::int32_t* order = sort.order().data();
  for_each_cell_by_strips<Dim>(grid.cells(), sort.cell_start(),
                               [&](const Cell<Dim>& cell) {
                                 kernel(cell, detail::EachParticle<Stencil>{basis, order, points, cell});
                               });
}

/// @brief G2P: call kernel(local, cell, each) for every occupied cell, the
/// slabs of cells (of equal first index) statically shared among the threads.
///
/// `local` is the thread's own `Kernel::Local`, made by kernel.local() at the
/// start and handed to kernel.merge(local) at the end, one thread at a time:
/// for reductions (a minimum or maximum, whose result does not depend on the
/// order) and per-thread scratch. A kernel writes only to its cell's particles.
template <class Stencil, class Kernel>
void grid_to_particle(const Grid<Stencil::dim>& grid, const CellSort& sort, const Points& points,
                      Kernel&& kernel)
{
  constexpr int Dim = Stencil::dim;
  const std::array<const BSpline1D*, Dim> basis = grid.bases();
  const std::array<int, Dim> cells = grid.cells();
  const std::size_t plane = slab_cells<Dim>(cells);
  const std::int32_t* order = sort.order().data();
#pragma omp parallel
  {
    auto local = kernel.local();
#pragma omp for schedule(static)
    for (int c0 = 0; c0 < cells[0]; ++c0)
      for_each_occupied_cell_of_slab<Dim>(
          c0, cells, plane, sort.cell_start(), [&](const Cell<Dim>& cell)
          { kernel(local, cell, detail::EachParticle<Stencil>{basis, order, points, cell}); });
#pragma omp critical
    kernel.merge(local);
  }
}

/// @brief A G2P kernel from f(cell, each), for a transfer with nothing to
/// reduce over the threads.
template <class F>
struct Unreduced
{
  F f;
  struct Local
  {
  };
  Local local() const { return {}; }
  void merge(Local&) const {}
  template <class C, class Each>
  void operator()(Local&, const C& cell, const Each& each) const
  {
    f(cell, each);
  }
};

template <class F>
Unreduced<F> unreduced(F f)
{
  return {std::move(f)};
}

} // namespace pfmpm
