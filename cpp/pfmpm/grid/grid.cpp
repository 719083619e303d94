/// @file grid.cpp
/// @brief Active grid nodes and wall constraints, in 2 and 3 directions.
#include "pfmpm/grid/grid.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace pfmpm
{

namespace
{
template <int Dim, std::size_t... D>
std::array<BSpline1D, Dim> make_bases(int degree, const std::array<int, Dim>& cells, double h,
                                 const std::array<double, Dim>& origin, std::index_sequence<D...>)
{
  return {BSpline1D(degree, cells[D], h, origin[D])...};
}

/// Whether a cell of the box [lo, hi] (per direction, inclusive) holds a particle.
template <int Dim>
bool any_occupied(const std::array<int, Dim>& lo, const std::array<int, Dim>& hi,
                  const std::array<int, Dim>& cells, const std::vector<std::int64_t>& cell_start)
{
  for (int d = 0; d < Dim; ++d)
    if (lo[d] > hi[d])
      return false;
  std::array<int, Dim> c = lo;
  for (;;)
  {
    const std::size_t key = lattice_key<Dim>(c, cells);
    if (cell_start[key + 1] > cell_start[key])
      return true;
    int d = Dim - 1; // the next cell: the last direction fastest
    for (; d >= 0 && ++c[d] > hi[d]; --d)
      c[d] = lo[d];
    if (d < 0)
      return false;
  }
}
} // namespace

const char* side_name(int side)
{
  static const char* const names[] = {"left", "right", "bottom", "top", "back", "front"};
  return names[side];
}

template <int Dim>
Grid<Dim>::Grid(int degree, std::array<int, Dim> cells, double h, std::array<double, Dim> origin)
    : _basis(make_bases<Dim>(degree, cells, h, origin, std::make_index_sequence<Dim>{})),
      _block{0, degree + 1}
{
}

template <int Dim>
void Grid<Dim>::set_wall(Side side, Wall wall)
{
  const int s = static_cast<int>(side);
  if (s < 0 || s >= sides)
    throw std::invalid_argument(std::string("wall side ") + (s >= 0 && s < 6 ? side_name(s) : "?")
                                + ": a grid of " + std::to_string(Dim) + " directions has no such side");
  _walls[s] = wall;
}

template <int Dim>
bool Grid<Dim>::has_holds() const
{
  return !_regions.empty()
         || std::any_of(_walls.begin(), _walls.end(), [](Wall w) { return w != Wall::free; });
}

template <int Dim>
int Grid<Dim>::add_region(std::array<double, Dim> min, std::array<double, Dim> max,
                          std::uint8_t components, bool moves)
{
  if (_regions.size() >= static_cast<std::size_t>(max_regions))
    throw std::invalid_argument("a grid holds at most " + std::to_string(max_regions) + " regions");
  for (int d = 0; d < Dim; ++d)
    if (!(min[d] < max[d]))
      throw std::invalid_argument("a region's box needs min < max in every direction");
  if (components == 0 || components >= (1 << Dim))
    throw std::invalid_argument("a region holds some of the velocity components, bit d for direction d");
  // Its nodes on each axis: the control points within [min, max].
  for (int d = 0; d < Dim; ++d)
  {
    bool any = false;
    for (int i = 0; i < _basis[d].size() && !any; ++i)
      any = _basis[d].greville(i) >= min[d] && _basis[d].greville(i) <= max[d];
    if (!any)
      throw std::invalid_argument("a region's box holds no grid node");
  }
  _regions.push_back(Region<Dim>{min, max, components, moves, {}});
  return static_cast<int>(_regions.size()) - 1;
}

template <int Dim>
int Grid<Dim>::add_particle_region(std::uint8_t components)
{
  if (_regions.size() >= static_cast<std::size_t>(max_regions))
    throw std::invalid_argument("a grid holds at most " + std::to_string(max_regions) + " regions");
  if (components == 0 || components >= (1 << Dim))
    throw std::invalid_argument("a region holds some of the velocity components, bit d for direction d");
  Region<Dim> r{{}, {}, components};
  r.particles = true;
  _regions.push_back(r);
  return static_cast<int>(_regions.size()) - 1;
}

template <int Dim>
bool Grid<Dim>::has_particle_regions() const
{
  return std::any_of(_regions.begin(), _regions.end(),
                     [](const Region<Dim>& r) { return r.particles; });
}

template <int Dim>
void Grid<Dim>::move_region(int k, std::array<double, Dim> offset)
{
  if (k < 0 || k >= static_cast<int>(_regions.size()))
    throw std::out_of_range("no region " + std::to_string(k));
  if (_regions[k].moves)
    _regions[k].offset = offset;
}

template <int Dim>
void Grid<Dim>::set_region_velocity(int k, std::array<double, Dim> velocity)
{
  if (k < 0 || k >= static_cast<int>(_regions.size()))
    throw std::out_of_range("no region " + std::to_string(k));
  _velocity[sides + k] = velocity;
}

template <int Dim>
void ActiveNodes<Dim>::activate(const Grid<Dim>& grid, const std::vector<std::int64_t>& cell_start,
                                const NodeBlock& block)
{
  const std::array<int, Dim> cells = grid.cells();
  _n = grid.nodes();
  _index.resize(static_cast<std::size_t>(grid.num_nodes()));

  // Per direction and node i, the cells [lo, hi] whose block holds i (the
  // block moves inwards at the grid's ends): a gather, so every node is
  // written by one thread only.
  std::array<std::vector<int>, Dim> lo, hi;
  for (int d = 0; d < Dim; ++d)
  {
    lo[d].resize(_n[d]);
    hi[d].resize(_n[d]);
    for (int i = 0; i < _n[d]; ++i)
      block.holders(i, cells[d], _n[d], lo[d][i], hi[d][i]);
  }
  // The nodes with first index i0 are keys [i0 * plane, (i0 + 1) * plane).
  const std::size_t plane = _index.size() / _n[0];
#pragma omp parallel for schedule(static)
  for (int i0 = 0; i0 < _n[0]; ++i0)
  {
    std::array<int, Dim> i{};
    i[0] = i0;
    std::array<int, Dim> c0, c1;
    c0[0] = lo[0][i0];
    c1[0] = hi[0][i0];
    for (std::size_t r = 0; r < plane; ++r)
    {
      for (int d = 1; d < Dim; ++d)
      {
        c0[d] = lo[d][i[d]];
        c1[d] = hi[d][i[d]];
      }
      _index[i0 * plane + r] = any_occupied<Dim>(c0, c1, cells, cell_start) ? 0 : -1;
      for (int d = Dim - 1; d > 0 && ++i[d] == _n[d]; --d)
        i[d] = 0;
    }
  }

  _nodes.clear();
  for (std::size_t n = 0; n < _index.size(); ++n)
    if (_index[n] >= 0)
    {
      _index[n] = static_cast<std::int32_t>(_nodes.size());
      _nodes.push_back(static_cast<std::int32_t>(n));
    }
}

template <int Dim>
void Grid<Dim>::activate(const std::vector<std::int64_t>& cell_start,
                         const std::vector<std::vector<std::int64_t>>& region_cells)
{
  _active.activate(*this, cell_start, _block);
  _constraints.clear();
  if (!has_holds())
    return;
  // The nodes each particle region's particles reach, as the active set of
  // those particles alone (its tables kept from step to step).
  _reach.resize(_regions.size());
  for (std::size_t k = 0; k < _regions.size(); ++k)
    if (_regions[k].particles)
    {
      if (k >= region_cells.size() || region_cells[k].empty())
        throw std::logic_error("activate() needs the cells of particle region " + std::to_string(k));
      _reach[k].activate(*this, region_cells[k], _block);
    }
  // Open knot vectors interpolate at the ends: only the first and last node of
  // each line carry the boundary value, so walls act on them alone.
  const std::array<int, Dim> n = nodes();
  const std::vector<std::int32_t>& active = _active.nodes();
  _constraints.assign(active.size(), NodeHold{});
  for (std::size_t a = 0; a < active.size(); ++a)
  {
    const std::array<int, Dim> i = lattice_indices<Dim>(static_cast<std::size_t>(active[a]), n);
    NodeHold& hold = _constraints[a];
    // Direction d held by `holder`, unless something already holds it.
    const auto take = [&hold](int holder, int d)
    {
      if (!(hold.held & (1 << d)))
      {
        hold.held |= static_cast<std::uint8_t>(1 << d);
        hold.by[d] = static_cast<std::uint8_t>(holder);
      }
    };
    // Regions first: their motion is prescribed there, walls included.
    for (std::size_t k = 0; k < _regions.size(); ++k)
    {
      const Region<Dim>& r = _regions[k];
      bool in = true;
      if (r.particles)
        in = _reach[k].index(i) >= 0;
      else
        for (int d = 0; d < Dim; ++d)
        {
          const double g = _basis[d].greville(i[d]) - r.offset[d];
          in = in && g >= r.min[d] && g <= r.max[d];
        }
      if (in)
        for (int d = 0; d < Dim; ++d)
          if (r.components & (1 << d))
            take(sides + static_cast<int>(k), d);
    }
    // Normal walls next, so that at an edge or corner each side's reaction
    // is its own normal force; then the tangential holds of fixed walls.
    const auto on = [&](int side) { return i[side / 2] == (side % 2 == 0 ? 0 : n[side / 2] - 1); };
    for (int side = 0; side < sides; ++side)
      if (on(side) && _walls[side] != Wall::free)
        take(side, side / 2);
    for (int side = 0; side < sides; ++side)
      if (on(side) && _walls[side] == Wall::fixed)
        for (int d = 0; d < Dim; ++d)
          if (d != side / 2)
            take(side, d);
  }
}

template class ActiveNodes<2>;
template class ActiveNodes<3>;
template class Grid<2>;
template class Grid<3>;

} // namespace pfmpm
