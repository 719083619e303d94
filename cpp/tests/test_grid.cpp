/// @file test_grid.cpp
/// @brief The grid, the cell sort and the transfer loop in 2 and 3
/// directions, from one source: node blocks, active nodes, walls and
/// regions; P2G conserves mass and momentum to round-off, G2P reproduces a
/// linear velocity field exactly (the B-splines' linear precision), and
/// neither depends on the thread count (bitwise); the sums by tile of cells.
#include "pfmpm/common/reduce.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/cell_sort.h"
#include "pfmpm/shape/stencil.h"
#include "pfmpm/transfer/transfer.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

using namespace pfmpm;

namespace
{
/// Particles at random points of the box [lo, hi) (Dim coordinates each),
/// with masses and a velocity field.
template <int Dim>
struct Cloud
{
  std::vector<double> x, v, m;
};

template <int Dim>
Cloud<Dim> cloud(std::size_t n, double lo, double hi, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> at(lo, hi), mass(0.5, 1.5), speed(-1.0, 1.0);
  Cloud<Dim> c;
  for (std::size_t p = 0; p < n; ++p)
  {
    for (int d = 0; d < Dim; ++d)
    {
      c.x.push_back(at(rng));
      c.v.push_back(speed(rng));
    }
    c.m.push_back(mass(rng));
  }
  return c;
}

/// Per node of `grid` (by node key): the mass and momentum the particles
/// give it, by the P2G loop with the degree-P B-spline stencil.
template <int Dim, int P>
std::vector<double> scatter(const Grid<Dim>& grid, const CellSort& sort, const Cloud<Dim>& c)
{
  using Stencil = BSplineStencil<Dim, P>;
  const std::array<int, Dim> nodes = grid.nodes();
  std::vector<double> out(static_cast<std::size_t>(grid.num_nodes()) * (1 + Dim), 0.0);
  particle_to_grid<Stencil>(
      grid, sort, Points{c.x.data()},
      [&](const Cell<Dim>& cell, const auto& each)
      {
        each(
            [&](std::size_t p, const Stencil& s)
            {
              for (int i = 0; i < Stencil::size; ++i)
              {
                std::array<int, Dim> node;
                for (int d = 0; d < Dim; ++d)
                  node[d] = Stencil::first(cell.index[d], nodes[d]) + Stencil::offset(i, d);
                double* row = &out[lattice_key<Dim>(node, nodes) * (1 + Dim)];
                const double w = s.N(i);
                row[0] += w * c.m[p];
                for (int d = 0; d < Dim; ++d)
                  row[1 + d] += w * c.m[p] * c.v[Dim * p + d];
              }
            });
      });
  return out;
}
} // namespace

TEST(NodeBlock, HoldersAreTheCellsWhoseBlockHoldsTheNode)
{
  // B-splines of degree 1-3 on their own grids, and CPDI's block (one node
  // more on each side) on the degree-1 grid.
  struct Case
  {
    NodeBlock block;
    int degree;
  };
  const Case cases[] = {{{0, 2}, 1}, {{0, 3}, 2}, {{0, 4}, 3}, {{-1, 4}, 1}};
  for (const Case& k : cases)
    for (int cells = k.block.width - 1; cells <= 9; ++cells)
    {
      const int nodes = cells + k.degree;
      for (int i = 0; i < nodes; ++i)
      {
        int c0, c1;
        k.block.holders(i, cells, nodes, c0, c1);
        for (int c = 0; c < cells; ++c)
        {
          const int first = k.block.first(c, nodes);
          const bool holds = first <= i && i < first + k.block.width;
          EXPECT_EQ(holds, c >= c0 && c <= c1)
              << "block (" << k.block.lower << ", " << k.block.width << "), " << cells
              << " cells, node " << i << ", cell " << c;
        }
      }
    }
}

TEST(Grid3, SizesKeysAndSort)
{
  const Grid<3> grid(2, {4, 5, 6}, 0.5, {-1.0, 0.0, 2.0});
  EXPECT_EQ(grid.num_cells(), 4 * 5 * 6);
  EXPECT_EQ(grid.nodes(), (std::array<int, 3>{6, 7, 8}));
  EXPECT_EQ(grid.num_nodes(), 6 * 7 * 8);
  EXPECT_EQ(lattice_key<3>({1, 2, 3}, {4, 5, 6}), std::size_t((1 * 5 + 2) * 6 + 3));
  EXPECT_EQ(lattice_indices<3>(45, {4, 5, 6}), (std::array<int, 3>{1, 2, 3}));

  // Each particle in its cell's range, in index order within the cell.
  const Cloud<3> c = cloud<3>(500, 0.0, 1.9, 3);
  std::vector<double> x = c.x;
  for (std::size_t p = 0; p < x.size() / 3; ++p)
  {
    x[3 * p] = -1.0 + x[3 * p];
    x[3 * p + 2] += 2.0;
  }
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, x), x.size() / 3);
  for (std::int64_t key = 0; key < grid.num_cells(); ++key)
    for (std::int64_t k = sort.cell_start()[key]; k < sort.cell_start()[key + 1]; ++k)
    {
      const std::size_t p = sort.order()[k];
      std::array<int, 3> cell;
      for (int d = 0; d < 3; ++d)
        cell[d] = static_cast<int>(std::floor((x[3 * p + d] - grid.basis(d).origin()) / 0.5));
      EXPECT_EQ(lattice_key<3>(cell, grid.cells()), static_cast<std::size_t>(key));
      if (k > sort.cell_start()[key])
        EXPECT_LT(sort.order()[k - 1], sort.order()[k]);
    }
  // A particle past the front (z) side is reported.
  x[3 * 7 + 2] = 5.0 + 1e-9;
  EXPECT_EQ(sort.sort(grid, x), 7u);
}

TEST(TileSort, TilesHoldTheirParticlesInIndexOrderAndSumTheSameOnAnyArrayOrder)
{
  // 21 x 13 cells: tiles of 8 x 8 cells, the last ones cut (3 x 2 tiles).
  Grid<2> grid(2, {21, 13}, 0.5, {-1.0, 2.0});
  const Cloud<2> c = cloud<2>(3000, 0.0, 6.49, 5);
  std::vector<double> x = c.x;
  for (std::size_t p = 0; p < 3000; ++p)
    x[2 * p] -= 1.0, x[2 * p + 1] += 2.0;
  CellSort tiles;
  ASSERT_EQ((tiles.sort<2, tile_cells>(grid, x)), 3000u);
  ASSERT_EQ(tiles.cell_start().size(), 3u * 2u + 1u);
  std::vector<int> tile_of(3000);
  for (std::int64_t t = 0; t < 6; ++t)
    for (std::int64_t k = tiles.cell_start()[t]; k < tiles.cell_start()[t + 1]; ++k)
    {
      const std::size_t p = tiles.order()[k];
      const int tx = grid.basis(0).cell(x[2 * p]) / 8, ty = grid.basis(1).cell(x[2 * p + 1]) / 8;
      EXPECT_EQ(tx * 2 + ty, t);
      if (k > tiles.cell_start()[t])
        EXPECT_LT(tiles.order()[k - 1], tiles.order()[k]);
      tile_of[p] = static_cast<int>(t);
    }
  // Terms of very different sizes, so that the order of the additions shows.
  std::vector<double> term(3000);
  for (std::size_t p = 0; p < 3000; ++p)
    term[p] = c.m[p] * std::pow(10.0, 8.0 * c.v[2 * p]);
  const auto sum = [](const CellSort& sort, const std::vector<double>& f)
  {
    return fold_tiles(tile_sums(sort, 1,
                                [&](const std::int32_t* order, std::int64_t begin, std::int64_t end, double* acc)
                                {
                                  for (std::int64_t k = begin; k < end; ++k)
                                    acc[0] += f[order[k]];
                                }))[0];
  };
  // By hand: each tile's terms in index order, the tiles in key order.
  double expected = 0.0;
  for (int t = 0; t < 6; ++t)
  {
    double part = 0.0;
    for (std::size_t p = 0; p < 3000; ++p)
      if (tile_of[p] == t)
        part += term[p];
    expected += part;
  }
  const int threads = omp_get_max_threads();
  for (int n : {1, 2})
  {
    omp_set_num_threads(n);
    EXPECT_EQ(sum(tiles, term), expected);
  }
  // The arrays in another order that keeps each tile's particles in their
  // order (the tiles interleaved backwards, as another process's arrays
  // would hold them): the same bits.
  std::vector<std::size_t> moved(3000);
  std::iota(moved.begin(), moved.end(), 0);
  std::stable_sort(moved.begin(), moved.end(), [&](auto a, auto b) { return tile_of[a] > tile_of[b]; });
  std::vector<double> x2(6000), term2(3000);
  for (std::size_t k = 0; k < 3000; ++k)
  {
    x2[2 * k] = x[2 * moved[k]], x2[2 * k + 1] = x[2 * moved[k] + 1];
    term2[k] = term[moved[k]];
  }
  CellSort other;
  ASSERT_EQ((other.sort<2, tile_cells>(grid, x2)), 3000u);
  EXPECT_EQ(sum(other, term2), expected);
  omp_set_num_threads(threads);
  // Two processes' tiles, each sent apart: the fold gives the same bits;
  // tiles out of order are refused.
  const TileSums all = tile_sums(tiles, 1,
                                 [&](const std::int32_t* order, std::int64_t begin, std::int64_t end, double* acc)
                                 {
                                   for (std::int64_t k = begin; k < end; ++k)
                                     acc[0] += term[order[k]];
                                 });
  ASSERT_GE(all.keys.size(), 2u);
  EXPECT_EQ(fold_tiles(all)[0], expected);
  TileSums swapped = all;
  std::swap(swapped.keys[0], swapped.keys[1]);
  EXPECT_THROW(fold_tiles(swapped), std::invalid_argument);
}

TEST(SlabSum, EachSlabSumsItsNodesInIndexOrderOnAnyThreadCount)
{
  // Active nodes of a 21 x 5 node lattice (stride 5): every third node, so
  // that slabs of 8 x-columns hold runs of unequal length.
  std::vector<std::int32_t> nodes;
  for (std::int32_t key = 0; key < 21 * 5; key += 3)
    nodes.push_back(key);
  std::vector<double> term(nodes.size());
  for (std::size_t a = 0; a < nodes.size(); ++a)
    term[a] = std::pow(10.0, static_cast<double>(a % 17)) / 3.0;
  ASSERT_EQ(num_slabs(21), 3);
  std::array<double, 3> expected{};
  for (std::size_t a = 0; a < nodes.size(); ++a)
    expected[nodes[a] / 5 / slab_nodes] += term[a];
  const int threads = omp_get_max_threads();
  for (int n : {1, 2})
  {
    omp_set_num_threads(n);
    const auto slabs = slab_sum<1>(nodes, 5, 3, [&](std::size_t a, std::array<double, 1>& acc) { acc[0] += term[a]; });
    ASSERT_EQ(slabs.size(), 3u);
    for (int s = 0; s < 3; ++s)
      EXPECT_EQ(slabs[s][0], expected[s]) << s;
  }
  omp_set_num_threads(threads);
}

TEST(Grid3, ActiveNodesAreTheSupportsOfTheOccupiedCells)
{
  for (int degree = 1; degree <= 3; ++degree)
  {
    Grid<3> grid(degree, {6, 5, 7}, 1.0, {0.0, 0.0, 0.0});
    const Cloud<3> c = cloud<3>(12, 0.0, 4.99, 11 + degree);
    CellSort sort;
    ASSERT_EQ(sort.sort(grid, c.x), 12u);
    grid.activate(sort.cell_start());
    std::vector<int> expected(static_cast<std::size_t>(grid.num_nodes()), 0);
    for (std::size_t p = 0; p < 12; ++p)
    {
      std::array<int, 3> cell;
      for (int d = 0; d < 3; ++d)
        cell[d] = grid.basis(d).cell(c.x[3 * p + d]);
      for (int a = 0; a <= degree; ++a)
        for (int b = 0; b <= degree; ++b)
          for (int e = 0; e <= degree; ++e)
            expected[lattice_key<3>({cell[0] + a, cell[1] + b, cell[2] + e}, grid.nodes())] = 1;
    }
    std::int32_t count = 0;
    for (std::size_t n = 0; n < expected.size(); ++n)
    {
      const std::array<int, 3> i = lattice_indices<3>(n, grid.nodes());
      EXPECT_EQ(grid.active_index(i[0], i[1], i[2]) >= 0, expected[n] == 1) << "node " << n;
      if (expected[n])
        EXPECT_EQ(grid.active_index(i[0], i[1], i[2]), count++);
    }
    EXPECT_EQ(grid.num_active(), count);
  }
}

TEST(Grid3, WallsHoldTheirNodesOnAllSixSides)
{
  Grid<3> grid(2, {3, 3, 3}, 1.0, {0.0, 0.0, 0.0});
  grid.set_wall(Side::front, Wall::fixed); // z = 3: every component
  grid.set_wall(Side::left, Wall::slip);   // x = 0: x alone
  const Cloud<3> c = cloud<3>(200, 0.0, 2.99, 5);
  CellSort sort;
  sort.sort(grid, c.x);
  grid.activate(sort.cell_start());
  ASSERT_EQ(grid.num_active(), 5 * 5 * 5);
  for (std::int32_t a = 0; a < grid.num_active(); ++a)
  {
    const std::array<int, 3> i = lattice_indices<3>(grid.active_nodes()[a], grid.nodes());
    const NodeHold h = grid.constraints()[a];
    const bool front = i[2] == 4, left = i[0] == 0;
    EXPECT_EQ(h.held, (front ? 7 : 0) | (left ? 1 : 0)) << a;
    if (left)
      EXPECT_EQ(h.by[0], static_cast<int>(Side::left)); // the normal hold comes first
    if (front)
    {
      EXPECT_EQ(h.by[2], static_cast<int>(Side::front));
      EXPECT_EQ(h.by[1], static_cast<int>(Side::front));
    }
  }
  // A box region: the nodes whose control points lie in it, held in z.
  const int k = grid.add_region({-0.1, -0.1, -0.1}, {0.6, 3.1, 3.1}, 4);
  EXPECT_EQ(Grid<3>::sides + k, 6);
  grid.activate(sort.cell_start());
  for (std::int32_t a = 0; a < grid.num_active(); ++a)
  {
    const std::array<int, 3> i = lattice_indices<3>(grid.active_nodes()[a], grid.nodes());
    const bool in = grid.basis(0).greville(i[0]) <= 0.6; // nodes 0 and 1 (0 and 0.5)
    EXPECT_EQ((grid.constraints()[a].held & 4) != 0, in || i[2] == 4) << a;
    if (in)
      EXPECT_EQ(grid.constraints()[a].by[2], 6);
  }
}

TEST(Grid2, HasNoBackOrFrontSide)
{
  Grid<2> grid(2, {4, 4}, 1.0, {0.0, 0.0});
  EXPECT_THROW(grid.set_wall(Side::back, Wall::fixed), std::invalid_argument);
  EXPECT_THROW(grid.add_region({0.0, 0.0}, {1.0, 1.0}, 4), std::invalid_argument);
  Grid<3> grid3(2, {4, 4, 4}, 1.0, {0.0, 0.0, 0.0});
  EXPECT_NO_THROW(grid3.set_wall(Side::back, Wall::fixed));
}

namespace
{
/// P2G of mass and momentum with the degree-P stencil in Dim directions:
/// the sums equal the particles' to round-off; with 1 and 2 threads the
/// same bits.
template <int Dim, int P>
void expect_p2g_conserves()
{
  std::array<int, Dim> cells;
  for (int d = 0; d < Dim; ++d)
    cells[d] = Dim == 2 ? 12 - 3 * d : 9 - d; // 12 x 9, or 9 x 8 x 7
  std::array<double, Dim> origin{};
  origin[0] = -0.5;
  const Grid<Dim> grid(P, cells, 0.25, origin);
  Cloud<Dim> c = cloud<Dim>(3000, 0.0, 1.74, 17);
  for (std::size_t p = 0; p < c.m.size(); ++p)
    c.x[Dim * p] -= 0.5;
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, c.x), c.m.size());
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const std::vector<double> one = scatter<Dim, P>(grid, sort, c);
  omp_set_num_threads(2);
  const std::vector<double> two = scatter<Dim, P>(grid, sort, c);
  omp_set_num_threads(threads);
  EXPECT_EQ(one, two) << "P2G depends on the thread count";

  double mass = 0.0, nodal_mass = 0.0;
  std::array<double, Dim> momentum{}, nodal{};
  for (std::size_t p = 0; p < c.m.size(); ++p)
  {
    mass += c.m[p];
    for (int d = 0; d < Dim; ++d)
      momentum[d] += c.m[p] * c.v[Dim * p + d];
  }
  for (std::size_t n = 0; n < one.size() / (1 + Dim); ++n)
  {
    nodal_mass += one[(1 + Dim) * n];
    for (int d = 0; d < Dim; ++d)
      nodal[d] += one[(1 + Dim) * n + 1 + d];
  }
  EXPECT_NEAR(nodal_mass, mass, 1e-13 * mass);
  for (int d = 0; d < Dim; ++d)
    EXPECT_NEAR(nodal[d], momentum[d], 1e-13 * mass);
}

/// G2P of the nodal velocity v_I = b + A X_I, X_I the Greville abscissae:
/// at every particle b + A x_p and gradient A (linear precision of the
/// B-splines, open knots included), to round-off.
template <int Dim, int P>
void expect_g2p_reproduces_linear_fields()
{
  using Stencil = BSplineStencil<Dim, P>;
  std::array<int, Dim> cells;
  std::array<double, Dim> origin;
  for (int d = 0; d < Dim; ++d)
  {
    cells[d] = 6 + d;
    origin[d] = 0.1 * d;
  }
  Grid<Dim> grid(P, cells, 0.5, origin);
  Cloud<Dim> c = cloud<Dim>(400, 0.0, 2.99, 23);
  for (std::size_t p = 0; p < c.m.size(); ++p)
    for (int d = 0; d < Dim; ++d)
      c.x[Dim * p + d] += origin[d];
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, c.x), c.m.size());
  double A[Dim][Dim], b[Dim];
  for (int i = 0; i < Dim; ++i)
  {
    b[i] = 0.3 - 0.2 * i;
    for (int j = 0; j < Dim; ++j)
      A[i][j] = 0.1 * (i + 1) - 0.35 * j + 0.05 * i * j;
  }
  const std::array<int, Dim> nodes = grid.nodes();
  std::vector<double> vel(static_cast<std::size_t>(grid.num_nodes()) * Dim);
  for (std::size_t n = 0; n < vel.size() / Dim; ++n)
  {
    const std::array<int, Dim> i = lattice_indices<Dim>(n, nodes);
    for (int r = 0; r < Dim; ++r)
    {
      vel[Dim * n + r] = b[r];
      for (int k = 0; k < Dim; ++k)
        vel[Dim * n + r] += A[r][k] * grid.basis(k).greville(i[k]);
    }
  }
  // Per particle, written by its cell's thread; -1 until visited.
  std::vector<double> error(c.m.size(), -1.0);
  grid_to_particle<Stencil>(
      grid, sort, Points{c.x.data()},
      unreduced(
          [&](const Cell<Dim>& cell, const auto& each)
          {
            each(
                [&](std::size_t p, const Stencil& s)
                {
                  double block[Stencil::size][Dim];
                  for (int i = 0; i < Stencil::size; ++i)
                  {
                    std::array<int, Dim> node;
                    for (int d = 0; d < Dim; ++d)
                      node[d] = Stencil::first(cell.index[d], nodes[d]) + Stencil::offset(i, d);
                    for (int r = 0; r < Dim; ++r)
                      block[i][r] = vel[Dim * lattice_key<Dim>(node, nodes) + r];
                  }
                  double value[Dim], grad[Dim][Dim];
                  s.template interpolate<Dim>(block, value, grad);
                  error[p] = 0.0;
                  for (int r = 0; r < Dim; ++r)
                  {
                    double exact = b[r];
                    for (int k = 0; k < Dim; ++k)
                    {
                      exact += A[r][k] * c.x[Dim * p + k];
                      error[p] = std::max(error[p], std::abs(grad[k][r] - A[r][k]));
                    }
                    error[p] = std::max(error[p], std::abs(value[r] - exact));
                  }
                });
          }));
  EXPECT_GE(*std::min_element(error.begin(), error.end()), 0.0) << "a particle was not visited";
  EXPECT_LT(*std::max_element(error.begin(), error.end()), 1e-13);
}
} // namespace

TEST(Transfer, P2GConservesMassAndMomentumIn2DAnd3D)
{
  expect_p2g_conserves<2, 1>();
  expect_p2g_conserves<2, 2>();
  expect_p2g_conserves<2, 3>();
  expect_p2g_conserves<3, 1>();
  expect_p2g_conserves<3, 2>();
  expect_p2g_conserves<3, 3>();
}

TEST(Transfer, G2PReproducesLinearFieldsIn2DAnd3D)
{
  expect_g2p_reproduces_linear_fields<2, 1>();
  expect_g2p_reproduces_linear_fields<2, 2>();
  expect_g2p_reproduces_linear_fields<2, 3>();
  expect_g2p_reproduces_linear_fields<3, 1>();
  expect_g2p_reproduces_linear_fields<3, 2>();
  expect_g2p_reproduces_linear_fields<3, 3>();
}
