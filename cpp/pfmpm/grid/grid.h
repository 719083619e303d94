/// @file grid.h
/// @brief The background grid: a tensor product of two open-knot B-spline bases.
#pragma once

#include "pfmpm/grid/bspline.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// Sides of the rectangular grid.
enum class Side : int
{
  left = 0,
  right = 1,
  bottom = 2,
  top = 3
};

/// Kinematic condition on one side of the grid.
enum class Wall : int
{
  free = 0,  ///< no condition
  fixed = 1, ///< both velocity components zero
  slip = 2   ///< normal velocity component zero
};

/// The most prescribed-velocity regions of a grid (Grid::add_region).
constexpr int max_regions = 4;
/// What may hold a node's velocity: the four walls (Side order), then the regions.
constexpr int max_holders = 4 + max_regions;

/// @brief What holds an active node's velocity: bit d of `held` set when
/// direction d (0: x, 1: y) is held, by holder `by[d]` (a Side, or 4 + the
/// index of a region).
struct NodeHold
{
  std::uint8_t held = 0;
  std::uint8_t by[2]{};
};

/// @brief Grid nodes whose velocity components `components` (bit d for
/// direction d) are prescribed: those whose control points (Greville
/// abscissae) lie in a box, or those a set of particles reaches.
struct Region
{
  std::array<double, 2> min, max;
  std::uint8_t components;
  bool moves = false;                ///< the box moves with the region's displacement
  std::array<double, 2> offset{};    ///< how far it has moved (Grid::move_region)
  /// Not a box: the nodes in the stencils of the particles whose column
  /// `held_by` has bit k (the region's index) set, wherever they are.
  bool particles = false;
};

class Grid;

/// @brief The nodes a cell's particles reach: `width` nodes per direction
/// from first(), `lower` nodes before the cell's own first node, moved
/// inwards at the grid's ends. A B-spline of degree p reaches the p + 1
/// nodes of its cell (lower 0); CPDI one node more on each side.
struct NodeBlock
{
  int lower;
  int width;
  /// First node of the block of `cell` on a line of `nodes` nodes.
  int first(int cell, int nodes) const { return std::clamp(cell + lower, 0, nodes - width); }
  /// @brief The cells [c0, c1] whose block holds node i, on a line of
  /// `cells` cells and `nodes` nodes: [i - lower - width + 1, i - lower],
  /// widened to the line's end where the blocks there move inwards.
  void holders(int i, int cells, int nodes, int& c0, int& c1) const
  {
    c0 = i < width ? 0 : std::max(i - lower - width + 1, 0);
    c1 = i >= nodes - width ? cells - 1 : std::min(i - lower, cells - 1);
  }
  /// @brief The farthest apart two cells whose blocks share a node may lie,
  /// in cells: width - 1, and -lower more for each end of the line whose
  /// blocks move inwards (p for a B-spline of degree p; for CPDI 4 next to
  /// one end, 5 on a line of 6 cells, where the two ends' blocks meet).
  int reach() const { return width - 1 - 2 * lower; }
};

/// @brief The nodes in the support of the occupied cells of a particle sort,
/// numbered compactly in increasing node order (K&T Algorithm 1, "find active
/// part of Eulerian grid"); the degree+1 nodes of one grid column above a cell
/// then have consecutive indices.
class ActiveNodes
{
public:
  /// @brief Rebuild from per-cell particle offsets (num_cells + 1 entries):
  /// a node is active when a cell whose block holds it holds a particle.
  void activate(const Grid& grid, const std::vector<std::int64_t>& cell_start,
                const NodeBlock& block);
  /// Number of active nodes.
  std::int32_t size() const { return static_cast<std::int32_t>(_nodes.size()); }
  /// Node index of each active node.
  const std::vector<std::int32_t>& nodes() const { return _nodes; }
  /// Active index of node (ix, iy), or -1 when the node is inactive.
  std::int32_t index(int ix, int iy) const
  {
    return _index[static_cast<std::size_t>(ix) * _nodes_y + iy];
  }

private:
  std::vector<std::int32_t> _index; // per node
  std::vector<std::int32_t> _nodes; // per active node
  int _nodes_y = 0;
};

/// @brief Uniform 2D grid of square cells carrying a tensor-product B-spline basis.
///
/// Cells are keyed column by column, `cell = cx * cells_y + cy`, and the basis
/// functions (grid nodes, i.e. control points) likewise, `node = ix * nodes_y + iy`.
/// Only active nodes - those in the support of some particle - carry data: the
/// grid keeps a compact numbering of them, rebuilt every step from the occupied
/// cells (Algorithm 1, "find active part of Eulerian grid").
class Grid
{
public:
  /// @param degree B-spline degree (1, 2 or 3), the same in both directions.
  /// @param cells Number of cells in x and y.
  /// @param h Cell size.
  /// @param origin Lower-left corner.
  Grid(int degree, std::array<int, 2> cells, double h, std::array<double, 2> origin);

  int degree() const { return _basis[0].degree(); }
  double h() const { return _basis[0].h(); }
  const BSpline1D& basis(int dim) const { return _basis[dim]; }
  std::array<int, 2> cells() const { return {_basis[0].cells(), _basis[1].cells()}; }
  std::array<int, 2> nodes() const { return {_basis[0].size(), _basis[1].size()}; }
  std::int64_t num_cells() const { return std::int64_t(_basis[0].cells()) * _basis[1].cells(); }
  std::int64_t num_nodes() const { return std::int64_t(_basis[0].size()) * _basis[1].size(); }

  /// @brief The nodes a cell's particles reach in the momentum transfers
  /// (by default the cell's B-spline support).
  void set_block(const NodeBlock& block) { _block = block; }
  const NodeBlock& block() const { return _block; }

  /// @brief Set the kinematic condition on one side.
  void set_wall(Side side, Wall wall) { _walls[static_cast<int>(side)] = wall; }
  Wall wall(Side side) const { return _walls[static_cast<int>(side)]; }
  /// @brief Add a region of prescribed velocity (at rest until
  /// set_region_velocity); returns its index. With `moves` its box follows
  /// the region's displacement (move_region): a rigid striker or a moving
  /// wall; else it stays where it is, a grip or a support.
  /// @throws std::invalid_argument for a box with min >= max, no component,
  /// no node in the box, or more than max_regions regions.
  int add_region(std::array<double, 2> min, std::array<double, 2> max, std::uint8_t components,
                 bool moves = false);
  /// @brief Add a region of the nodes that its particles reach (Region::particles):
  /// a body, a body's face or a set of particles, followed as they move.
  int add_particle_region(std::uint8_t components);
  /// Whether some region is a set of particles.
  bool has_particle_regions() const;
  const std::vector<Region>& regions() const { return _regions; }
  /// @brief The velocity region k prescribes from now on (its held components).
  void set_region_velocity(int k, std::array<double, 2> velocity);
  /// @brief Move a moving region's box by `offset` from where it was added
  /// (its displacement so far); the next activate() holds the nodes there.
  void move_region(int k, std::array<double, 2> offset);
  /// The velocity each holder prescribes: zero for the walls.
  const std::array<std::array<double, 2>, max_holders>& holder_velocity() const { return _velocity; }
  /// Whether a wall or a region holds some node.
  bool has_holds() const;

  /// @brief Rebuild the active node set (ActiveNodes, with block()) of all
  /// particles and what holds its nodes (constraints()).
  /// @param cell_start Offsets of each cell's particles, num_cells()+1 entries.
  /// @param region_cells Per region, the offsets of each cell's particles of
  ///        a particle region, as cell_start (empty for a box); may be empty
  ///        without particle regions.
  void activate(const std::vector<std::int64_t>& cell_start,
                const std::vector<std::vector<std::int64_t>>& region_cells = {});

  /// The active nodes of all particles.
  const ActiveNodes& active() const { return _active; }
  /// Number of active nodes.
  std::int32_t num_active() const { return _active.size(); }
  /// Node index of each active node.
  const std::vector<std::int32_t>& active_nodes() const { return _active.nodes(); }
  /// Active index of node (ix, iy), or -1 when the node is inactive.
  std::int32_t active_index(int ix, int iy) const { return _active.index(ix, iy); }
  /// What holds each active node's velocity: a region first, then a wall's
  /// normal, then a fixed wall's tangential hold. Empty without walls and
  /// regions.
  const std::vector<NodeHold>& constraints() const { return _constraints; }

private:
  std::array<BSpline1D, 2> _basis;
  NodeBlock _block;
  std::array<Wall, 4> _walls{Wall::free, Wall::free, Wall::free, Wall::free};
  std::vector<Region> _regions;
  std::array<std::array<double, 2>, max_holders> _velocity{};
  ActiveNodes _active;
  std::vector<ActiveNodes> _reach;     // per region: the nodes a particle region's particles reach
  std::vector<NodeHold> _constraints; // per active node
};

} // namespace pfmpm
