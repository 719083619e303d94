/// @file grid.cpp
/// @brief Active grid nodes and wall constraints.
#include "pfmpm/grid/grid.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace pfmpm
{

Grid::Grid(int degree, std::array<int, 2> cells, double h, std::array<double, 2> origin)
    : _basis{BSpline1D(degree, cells[0], h, origin[0]), BSpline1D(degree, cells[1], h, origin[1])},
      _block{0, degree + 1}
{
}

bool Grid::has_holds() const
{
  return !_regions.empty()
         || std::any_of(_walls.begin(), _walls.end(), [](Wall w) { return w != Wall::free; });
}

int Grid::add_region(std::array<double, 2> min, std::array<double, 2> max, std::uint8_t components,
                     bool moves)
{
  if (_regions.size() >= static_cast<std::size_t>(max_regions))
    throw std::invalid_argument("a grid holds at most " + std::to_string(max_regions) + " regions");
  if (!(min[0] < max[0] && min[1] < max[1]))
    throw std::invalid_argument("a region's box needs min < max in both directions");
  if (components == 0 || components > 3)
    throw std::invalid_argument("a region holds the x component, the y component or both");
  // Its nodes on each axis: the control points within [min, max].
  for (int d = 0; d < 2; ++d)
  {
    bool any = false;
    for (int i = 0; i < _basis[d].size() && !any; ++i)
      any = _basis[d].greville(i) >= min[d] && _basis[d].greville(i) <= max[d];
    if (!any)
      throw std::invalid_argument("a region's box holds no grid node");
  }
  _regions.push_back(Region{min, max, components, moves, {0.0, 0.0}});
  return static_cast<int>(_regions.size()) - 1;
}

int Grid::add_particle_region(std::uint8_t components)
{
  if (_regions.size() >= static_cast<std::size_t>(max_regions))
    throw std::invalid_argument("a grid holds at most " + std::to_string(max_regions) + " regions");
  if (components == 0 || components > 3)
    throw std::invalid_argument("a region holds the x component, the y component or both");
  Region r{{0.0, 0.0}, {0.0, 0.0}, components};
  r.particles = true;
  _regions.push_back(r);
  return static_cast<int>(_regions.size()) - 1;
}

bool Grid::has_particle_regions() const
{
  return std::any_of(_regions.begin(), _regions.end(), [](const Region& r) { return r.particles; });
}

void Grid::move_region(int k, std::array<double, 2> offset)
{
  if (k < 0 || k >= static_cast<int>(_regions.size()))
    throw std::out_of_range("no region " + std::to_string(k));
  if (_regions[k].moves)
    _regions[k].offset = offset;
}

void Grid::set_region_velocity(int k, std::array<double, 2> velocity)
{
  if (k < 0 || k >= static_cast<int>(_regions.size()))
    throw std::out_of_range("no region " + std::to_string(k));
  _velocity[4 + k] = velocity;
}

void ActiveNodes::activate(const Grid& grid, const std::vector<std::int64_t>& cell_start,
                           const NodeBlock& block)
{
  const int ncx = grid.cells()[0], ncy = grid.cells()[1];
  const int nnx = grid.nodes()[0], nny = grid.nodes()[1];
  _nodes_y = nny;
  _index.resize(static_cast<std::size_t>(nnx) * nny);
  auto occupied = [&](int cx, int cy)
  {
    const std::size_t c = static_cast<std::size_t>(cx) * ncy + cy;
    return cell_start[c + 1] > cell_start[c];
  };

  // The cells whose block holds node i along a line of n nodes lie in
  // [i - lower - width + 1, i - lower] (one more on each side where the
  // block moves inwards at the grid's ends): a gather, so every node is
  // written by one thread only.
  auto holds = [&](int cell, int i, int n)
  {
    const int first = block.first(cell, n);
    return first <= i && i < first + block.width;
  };
#pragma omp parallel for schedule(static)
  for (int ix = 0; ix < nnx; ++ix)
  {
    const int cx0 = std::max(ix - block.lower - block.width, 0);
    const int cx1 = std::min(ix - block.lower + 1, ncx - 1);
    for (int iy = 0; iy < nny; ++iy)
    {
      const int cy0 = std::max(iy - block.lower - block.width, 0);
      const int cy1 = std::min(iy - block.lower + 1, ncy - 1);
      bool active = false;
      for (int cx = cx0; cx <= cx1 && !active; ++cx)
        for (int cy = cy0; cy <= cy1 && !active; ++cy)
          active = holds(cx, ix, nnx) && holds(cy, iy, nny) && occupied(cx, cy);
      _index[static_cast<std::size_t>(ix) * nny + iy] = active ? 0 : -1;
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

void Grid::activate(const std::vector<std::int64_t>& cell_start,
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
  // each row and column carry the boundary value, so walls act on them alone.
  const int nnx = _basis[0].size(), nny = _basis[1].size();
  const std::vector<std::int32_t>& nodes = _active.nodes();
  _constraints.assign(nodes.size(), NodeHold{});
  for (std::size_t a = 0; a < nodes.size(); ++a)
  {
    const int ix = nodes[a] / nny, iy = nodes[a] % nny;
    const bool on[4] = {ix == 0, ix == nnx - 1, iy == 0, iy == nny - 1};
    NodeHold& n = _constraints[a];
    // Direction d held by `holder`, unless something already holds it.
    const auto hold = [&n](int holder, int d)
    {
      if (!(n.held & (1 << d)))
      {
        n.held |= static_cast<std::uint8_t>(1 << d);
        n.by[d] = static_cast<std::uint8_t>(holder);
      }
    };
    // Regions first: their motion is prescribed there, walls included.
    for (std::size_t k = 0; k < _regions.size(); ++k)
    {
      const Region& r = _regions[k];
      const double gx = _basis[0].greville(ix) - r.offset[0], gy = _basis[1].greville(iy) - r.offset[1];
      const bool in = r.particles ? _reach[k].index(ix, iy) >= 0
                                  : gx >= r.min[0] && gx <= r.max[0] && gy >= r.min[1] && gy <= r.max[1];
      if (in)
        for (int d = 0; d < 2; ++d)
          if (r.components & (1 << d))
            hold(4 + static_cast<int>(k), d);
    }
    // Normal walls next, so that at a corner each side's reaction is its own
    // normal force; then the tangential hold of fixed walls.
    for (int side = 0; side < 4; ++side)
      if (on[side] && wall(static_cast<Side>(side)) != Wall::free)
        hold(side, side / 2);
    for (int side = 0; side < 4; ++side)
      if (on[side] && wall(static_cast<Side>(side)) == Wall::fixed)
        hold(side, 1 - side / 2);
  }
}

} // namespace pfmpm
