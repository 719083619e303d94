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

/// @brief Sides of the grid: the lower and upper end of each direction d
/// are sides 2 d and 2 d + 1 (left/right: x, bottom/top: y, back/front: z);
/// a grid of Dim directions has the first 2 Dim.
enum class Side : int
{
  left = 0,
  right = 1,
  bottom = 2,
  top = 3,
  back = 4,
  front = 5
};

/// The name of side `side` (0 <= side < 6): left, right, bottom, top, back, front.
const char* side_name(int side);

/// Number of sides of a grid of `dim` directions.
constexpr int num_sides(int dim) { return 2 * dim; }

/// Kinematic condition on one side of the grid.
enum class Wall : int
{
  free = 0,  ///< no condition
  fixed = 1, ///< every velocity component zero
  slip = 2   ///< normal velocity component zero
};

/// The most prescribed-velocity regions of a grid (Grid::add_region).
constexpr int max_regions = 4;
/// @brief What may hold a node's velocity in `dim` directions: the walls
/// (holder s for Side s), then the regions (holder num_sides(dim) + k).
constexpr int num_holders(int dim) { return num_sides(dim) + max_regions; }

/// @brief What holds an active node's velocity: bit d of `held` set when
/// direction d (0: x, 1: y, 2: z) is held, by holder `by[d]` (a Side, or
/// num_sides(Dim) + the index of a region).
struct NodeHold
{
  std::uint8_t held = 0;
  std::uint8_t by[3]{};
};

/// @brief Grid nodes whose velocity components `components` (bit d for
/// direction d) are prescribed: those whose control points (Greville
/// abscissae) lie in a box, or those a set of particles reaches.
template <int Dim>
struct Region
{
  std::array<double, Dim> min, max;
  std::uint8_t components;
  bool moves = false;                ///< the box moves with the region's displacement
  std::array<double, Dim> offset{};  ///< how far it has moved (Grid::move_region)
  /// Not a box: the nodes in the stencils of the particles whose column
  /// `held_by` has bit k (the region's index) set, wherever they are.
  bool particles = false;
};

template <int Dim>
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

/// @brief The key of the point with indices `i` on a lattice of `n` points
/// per direction, row-major: the last direction fastest (cx * cells_y + cy
/// in 2D, (cx * cells_y + cy) * cells_z + cz in 3D). Cells and nodes are
/// keyed so.
template <int Dim>
std::size_t lattice_key(const std::array<int, Dim>& i, const std::array<int, Dim>& n)
{
  std::size_t key = static_cast<std::size_t>(i[0]);
  for (int d = 1; d < Dim; ++d)
    key = key * n[d] + i[d];
  return key;
}

/// The indices of the point of key `key` on a lattice of `n` points per direction.
template <int Dim>
std::array<int, Dim> lattice_indices(std::size_t key, const std::array<int, Dim>& n)
{
  std::array<int, Dim> i;
  for (int d = Dim - 1; d > 0; --d)
  {
    i[d] = static_cast<int>(key % n[d]);
    key /= n[d];
  }
  i[0] = static_cast<int>(key);
  return i;
}

/// @brief The nodes in the support of the occupied cells of a particle sort,
/// numbered compactly in increasing node order (K&T Algorithm 1, "find active
/// part of Eulerian grid"); the degree+1 nodes of one grid line along the last
/// direction above a cell then have consecutive indices.
template <int Dim>
class ActiveNodes
{
public:
  /// @brief Rebuild from per-cell particle offsets (num_cells + 1 entries):
  /// a node is active when a cell whose block holds it holds a particle.
  void activate(const Grid<Dim>& grid, const std::vector<std::int64_t>& cell_start,
                const NodeBlock& block);
  /// Number of active nodes.
  std::int32_t size() const { return static_cast<std::int32_t>(_nodes.size()); }
  /// Node index of each active node.
  const std::vector<std::int32_t>& nodes() const { return _nodes; }
  /// Active index of node `i`, or -1 when the node is inactive.
  std::int32_t index(const std::array<int, Dim>& i) const { return _index[lattice_key<Dim>(i, _n)]; }
  /// Active index of node (i_0, .., i_{Dim-1}), or -1 when the node is inactive.
  template <class... I>
  std::int32_t index(I... i) const
  {
    static_assert(sizeof...(I) == Dim, "one index per direction");
    return index(std::array<int, Dim>{static_cast<int>(i)...});
  }

private:
  std::vector<std::int32_t> _index; // per node
  std::vector<std::int32_t> _nodes; // per active node
  std::array<int, Dim> _n{};        // nodes per direction
};

/// @brief Uniform grid of square (cubic) cells in Dim = 2 or 3 directions,
/// carrying a tensor-product B-spline basis.
///
/// Cells and basis functions (grid nodes, i.e. control points) are keyed
/// row-major, the last direction fastest (lattice_key): `cell = cx * cells_y
/// + cy` and `node = ix * nodes_y + iy` in 2D. Only active nodes - those in
/// the support of some particle - carry data: the grid keeps a compact
/// numbering of them, rebuilt every step from the occupied cells
/// (Algorithm 1, "find active part of Eulerian grid"). The class is compiled
/// for 2 and 3 directions (grid.cpp).
template <int Dim>
class Grid
{
  static_assert(Dim == 2 || Dim == 3, "a grid has 2 or 3 directions");

public:
  static constexpr int dim = Dim;
  /// Sides, and what may hold a node: the walls, then the regions.
  static constexpr int sides = num_sides(Dim);
  static constexpr int holders = num_holders(Dim);

  /// @param degree B-spline degree (1, 2 or 3), the same in every direction.
  /// @param cells Number of cells per direction.
  /// @param h Cell size.
  /// @param origin The corner of least coordinates.
  Grid(int degree, std::array<int, Dim> cells, double h, std::array<double, Dim> origin);

  int degree() const { return _basis[0].degree(); }
  double h() const { return _basis[0].h(); }
  const BSpline1D& basis(int d) const { return _basis[d]; }
  /// The bases of every direction, for BSplineStencil::evaluate.
  std::array<const BSpline1D*, Dim> bases() const
  {
    std::array<const BSpline1D*, Dim> b;
    for (int d = 0; d < Dim; ++d)
      b[d] = &_basis[d];
    return b;
  }
  std::array<int, Dim> cells() const
  {
    std::array<int, Dim> c;
    for (int d = 0; d < Dim; ++d)
      c[d] = _basis[d].cells();
    return c;
  }
  std::array<int, Dim> nodes() const
  {
    std::array<int, Dim> n;
    for (int d = 0; d < Dim; ++d)
      n[d] = _basis[d].size();
    return n;
  }
  std::int64_t num_cells() const
  {
    std::int64_t n = 1;
    for (int d = 0; d < Dim; ++d)
      n *= _basis[d].cells();
    return n;
  }
  std::int64_t num_nodes() const
  {
    std::int64_t n = 1;
    for (int d = 0; d < Dim; ++d)
      n *= _basis[d].size();
    return n;
  }

  /// @brief The nodes a cell's particles reach in the momentum transfers
  /// (by default the cell's B-spline support).
  void set_block(const NodeBlock& block) { _block = block; }
  const NodeBlock& block() const { return _block; }

  /// @brief f(cell key) for each cell whose block (block()) holds node
  /// `node` (a node key), in key order, until f returns false.
  template <class F>
  void for_each_holder_cell(std::int32_t node, F&& f) const
  {
    const std::array<int, Dim> n = nodes(), c = cells();
    const std::array<int, Dim> i = lattice_indices<Dim>(static_cast<std::size_t>(node), n);
    std::array<int, Dim> lo, hi;
    for (int d = 0; d < Dim; ++d)
      _block.holders(i[d], c[d], n[d], lo[d], hi[d]);
    std::array<int, Dim> cell = lo;
    for (;;)
    {
      if (!f(lattice_key<Dim>(cell, c)))
        return;
      int d = Dim - 1; // the next cell: the last direction fastest
      for (; d >= 0 && ++cell[d] > hi[d]; --d)
        cell[d] = lo[d];
      if (d < 0)
        return;
    }
  }

  /// @brief Set the kinematic condition on one side.
  /// @throws std::invalid_argument for a side the grid does not have (back
  ///         or front in 2D).
  void set_wall(Side side, Wall wall);
  Wall wall(Side side) const { return _walls[static_cast<int>(side)]; }
  /// @brief Add a region of prescribed velocity (at rest until
  /// set_region_velocity); returns its index. With `moves` its box follows
  /// the region's displacement (move_region): a rigid striker or a moving
  /// wall; else it stays where it is, a grip or a support.
  /// @throws std::invalid_argument for a box with min >= max, no component,
  /// no node in the box, or more than max_regions regions.
  int add_region(std::array<double, Dim> min, std::array<double, Dim> max,
                 std::uint8_t components, bool moves = false);
  /// @brief Add a region of the nodes that its particles reach (Region::particles):
  /// a body, a body's face or a set of particles, followed as they move.
  int add_particle_region(std::uint8_t components);
  /// Whether some region is a set of particles.
  bool has_particle_regions() const;
  const std::vector<Region<Dim>>& regions() const { return _regions; }
  /// @brief The velocity region k prescribes from now on (its held components).
  void set_region_velocity(int k, std::array<double, Dim> velocity);
  /// @brief Move a moving region's box by `offset` from where it was added
  /// (its displacement so far); the next activate() holds the nodes there.
  void move_region(int k, std::array<double, Dim> offset);
  /// The velocity each holder prescribes: zero for the walls.
  const std::array<std::array<double, Dim>, holders>& holder_velocity() const { return _velocity; }
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
  const ActiveNodes<Dim>& active() const { return _active; }
  /// Number of active nodes.
  std::int32_t num_active() const { return _active.size(); }
  /// Node index of each active node.
  const std::vector<std::int32_t>& active_nodes() const { return _active.nodes(); }
  /// Active index of node (i_0, .., i_{Dim-1}), or -1 when the node is inactive.
  template <class... I>
  std::int32_t active_index(I... i) const
  {
    return _active.index(i...);
  }
  /// What holds each active node's velocity: a region first, then a wall's
  /// normal, then a fixed wall's tangential holds. Empty without walls and
  /// regions.
  const std::vector<NodeHold>& constraints() const { return _constraints; }

private:
  std::array<BSpline1D, Dim> _basis;
  NodeBlock _block;
  std::array<Wall, sides> _walls{};
  std::vector<Region<Dim>> _regions;
  std::array<std::array<double, Dim>, holders> _velocity{};
  ActiveNodes<Dim> _active;
  std::vector<ActiveNodes<Dim>> _reach; // per region: the nodes a particle region's particles reach
  std::vector<NodeHold> _constraints;   // per active node
};

extern template class ActiveNodes<2>;
extern template class ActiveNodes<3>;
extern template class Grid<2>;
extern template class Grid<3>;

} // namespace pfmpm
