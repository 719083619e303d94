/// @file multigrid.h
/// @brief Geometric multigrid on the B-spline grid: a V-cycle preconditioner
/// for the conjugate gradients of the phase-field system K c = F
/// (Kakouris & Triantafyllou 2019, eqs. 56-57, 52), second or fourth order
/// in 2D, second order in 3D.
#pragma once

#include "pfmpm/fracture/symmetric_stencil.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// Grid columns per strip of the 2D Gauss-Seidel order: exactly this in the
/// 2D multigrid smoother, about this in PhaseField's preconditioner
/// (PhaseField::prepare_ssor). Strips of one parity share no stencil entry
/// while a strip is at least the degree wide.
constexpr int sweep_strip = 32;
static_assert(sweep_strip >= 3, "a strip must be at least as wide as the stencil's reach p");

/// @brief The two-scale relation of an open-knot-vector B-spline basis:
/// with `fine` cells of size h and ceil(fine / 2) cells of size 2h on the
/// same origin, each coarse function is a combination of fine ones,
/// N^2h_J = sum_i R_iJ N^h_i, and the coarse space lies in the fine one.
///
/// The weights come from knot insertion (the Oslo algorithm, Cohen, Lyche &
/// Riesenfeld 1980): in the interior they are the binomial weights
/// 2^-p C(p+1, k) of fine functions 2J - p + k, k = 0..p+1; at the ends of the
/// open knot vector they differ. An odd number of fine cells leaves the last
/// coarse cell half outside the fine grid; the coarse functions restricted to
/// the fine grid still lie in the fine space (its end knot has full
/// multiplicity), so the relation holds on the grid.
struct Refinement
{
  int degree = 0;                 ///< p
  int coarse = 0;                 ///< coarse functions, ceil(fine cells / 2) + p
  int fine = 0;                   ///< fine functions, fine cells + p
  std::vector<int> first;        ///< per coarse J: the first fine i with R_iJ != 0
  std::vector<int> count;        ///< per coarse J: the length of its run of fine functions
  std::vector<double> weight;    ///< per coarse J: width() slots, R_iJ for i = first[J] + 0, 1, ..
  std::vector<int> first_coarse; ///< per fine i: the first coarse J with R_iJ != 0
  std::vector<int> count_t;      ///< per fine i: the length of its run of coarse functions
  std::vector<double> weight_t;  ///< per fine i: width() slots, R_iJ for J = first_coarse[i] + 0, 1, ..

  /// @param cells Fine cells (>= 1); one cell is not halved (the identity).
  /// @param degree B-spline degree p (1..3).
  Refinement(int cells, int degree);
  /// @brief Weights stored per coarse and per fine function: a run has at
  /// most p + 2 fine functions in the interior and 2p + 1 next to the end of
  /// an odd fine grid; at most p + 1 coarse functions cover a fine one.
  static constexpr int width(int degree) { return 2 * degree + 1; }
  int width() const { return width(degree); }
};

/// x-planes per strip of the Gauss-Seidel order of the 3D multigrid
/// smoother. A plane holds ny nz nodes, so strips of a few planes already
/// carry enough work each, and a grid of a few dozen planes still has strips
/// for every thread; strips of one parity share no stencil entry while a
/// strip is at least the degree wide.
constexpr int sweep_planes = 4;
static_assert(sweep_planes >= 3, "a strip must be at least as wide as the stencil's reach p");

/// @brief A multigrid V-cycle for the symmetric positive definite
/// phase-field matrix K stored as an upper-half (2p+1)^Dim-point stencil on
/// the B-spline grid (SymmetricStencil), as a preconditioner B ~ K^-1 for
/// conjugate gradients (Kakouris & Triantafyllou 2019, eqs. 56-57, 52; in 3D
/// the second-order K&T eq. 57 on the trivariate tensor-product basis).
///
/// Levels: the grid of the phase field and grids of cells 2h, 4h, ... with the
/// B-spline bases of the same degree on them, nested by the two-scale relation
/// (Refinement): prolongation P = R_x (x) R_y (x) R_z (in 2D R_x (x) R_y),
/// restriction P^T, and the Galerkin operator K_2h = P^T K_h P, computed each
/// solve from the stored stencil. It is again a (2p+1)^Dim-point stencil (a
/// coarse function meets the coarse functions within p nodes each way), so
/// every level uses the same storage. A direction of one cell is not halved
/// (its Refinement is the identity): a thin slab coarsens in its plane only
/// once its thickness is one cell. Only the fine nodes that are coupled to
/// others take part in the coarse correction: the identity rows of the nodes
/// no crackable particle touches are solved exactly by the smoother.
/// Coarsening stops at a level of at most `direct_size` unknowns, which is
/// solved by a banded Cholesky factorisation. In 3D its band is about
/// p ny nz of that level's nodes (the unknowns plane by plane): with at most
/// 400 unknowns the factor has at most 400^2 entries (1.3 MB) and costs at
/// most about 400^3 / 2 flops a setup, less than the Galerkin products of
/// any grid large enough to need multigrid; so the default is the 2D one.
///
/// Smoother: one Gauss-Seidel sweep (or `sweeps`) before the coarse
/// correction and as many in the reverse order after it, so that B is
/// symmetric. One each way (2D's choice, kept for its bits) is also the
/// cheaper solve in 3D: there (quadratic B-splines, l0 = 2h to 4h) two sweeps
/// take 30 % fewer CG iterations at 1.8 times the cost of a cycle. The smoother weakens with the degree,
/// most in 3D, where the B-spline mass term's smallest eigenvalues are
/// those of high frequency (Hofreither & Takacs 2017): on a 3D phase-field
/// system with a broken band (test_multigrid.cpp, 16^3 cells, l0 = 2h) CG
/// takes 8, 22 and 73 iterations for p = 1, 2, 3, Jacobi 31, 81 and 352;
/// the counts do not grow as h shrinks. The order is that of
/// PhaseField's symmetric Gauss-Seidel: strips of `strip` x-slabs (grid
/// columns in 2D, sweep_strip of them; x-planes in 3D, sweep_planes), the even
/// strips first, each slab by slab in node order. Strips of one parity share no
/// matrix entry, so each half-sweep runs them in parallel; every other kernel
/// writes each node from a sum in a fixed order. B, and so the CG iterates,
/// have the same bits for any number of threads.
template <int Dim>
class Multigrid
{
  static_assert(Dim == 2 || Dim == 3, "a 2D or 3D grid");

public:
  /// x-slabs (columns in 2D, planes in 3D) per strip of the smoother's order.
  static constexpr int strip = Dim == 2 ? sweep_strip : sweep_planes;

  /// @param cells Cells of the finest grid per direction.
  /// @param degree B-spline degree p (1..3).
  /// @param direct_size Unknowns at most on the coarsest level (>= 1).
  /// @param sweeps Gauss-Seidel sweeps before and after the coarse correction (>= 1).
  Multigrid(std::array<int, Dim> cells, int degree, int direct_size = 400, int sweeps = 1);

  /// @brief Build the coarse levels for a new matrix K (once per solve).
  /// @param rows K's upper-half stencil (SymmetricStencil<Dim, P>) per node of
  /// the padded layout of the finest grid (padded by p nodes on each side,
  /// the last direction fastest); it must stay in place until the next setup.
  /// @param position The unknowns: the padded index of each active node, in
  /// increasing node order (x-slab by x-slab).
  template <int P>
  void setup(const std::vector<double>& rows, const std::vector<std::size_t>& position);

  /// @brief z = B r: one V-cycle from a zero guess, and K z.
  /// @param r, z, kz Per unknown of the finest level (the order of `position`);
  /// kz may be null.
  template <int P>
  void apply(const double* r, double* z, double* kz);

  /// Unknowns per level of the last setup, the finest first.
  std::vector<std::int64_t> unknowns() const;
  /// @brief Entry (i, j) of level l's operator in the last setup (level 0:
  /// K), for node i of that level's grid and j = i + offset, |offset| <= p
  /// each way; zero where j lies off the grid.
  double entry(std::size_t level, std::array<int, Dim> node, std::array<int, Dim> offset) const;
  /// entry(level, {i_x, i_y[, i_z]}, {d_x, d_y[, d_z]}) from 2 Dim integers.
  template <class... I>
  double entry(std::size_t level, I... index) const
  {
    static_assert(sizeof...(I) == 2 * Dim, "a node and an offset");
    const int all[2 * Dim] = {static_cast<int>(index)...};
    std::array<int, Dim> node, offset;
    for (int a = 0; a < Dim; ++a)
    {
      node[a] = all[a];
      offset[a] = all[Dim + a];
    }
    return entry(level, node, offset);
  }

private:
  struct Level
  {
    std::array<int, Dim> n{};              // grid nodes per direction
    std::array<std::size_t, Dim> stride{}; // of the padded layout, stride[Dim - 1] = 1
    std::size_t padded_size = 0;           // nodes of the padded layout
    const double* rows = nullptr; // the operator's stencil (the finest: K's, borrowed)
    std::vector<double> stencil;  // coarse levels: the Galerkin operator
    std::vector<std::size_t> live;        // padded index of each unknown, in node order
    std::vector<std::size_t> slab_start;  // per x-slab: its unknowns [start, next start)
    std::vector<double> inverse;          // per unknown: 1 / diagonal
    std::vector<std::uint8_t> coupled;    // per padded node: takes part in the coarse correction
    std::vector<double> x, b, r;          // per padded node
    std::vector<Refinement> refine;       // per direction: this level's basis from the next one's
  };

  template <int P>
  void galerkin(const Level& fine, Level& coarse);
  template <int P>
  double stencil_entry(const Level& level, const std::array<int, Dim>& node,
                       const std::array<int, Dim>& offset) const;
  template <bool Ordered, class F>
  void strips(const Level& level, bool forward, F&& f) const;
  template <int P>
  void cycle(std::size_t l, double* kx);
  template <int P>
  void factor_coarsest();
  void solve_coarsest();
  void number_unknowns(Level& level) const;
  template <int P>
  static SymmetricStencil<Dim, P> stencil(const Level& level)
  {
    if constexpr (Dim == 2)
      return SymmetricStencil<2, P>(level.stride[0]);
    else
      return SymmetricStencil<3, P>(level.stride[0] / level.stride[1], level.stride[1]);
  }
  std::size_t padded(const Level& level, const std::array<int, Dim>& node) const
  {
    std::size_t i = 0;
    for (int a = 0; a < Dim; ++a)
      i += static_cast<std::size_t>(node[a] + _degree) * level.stride[a];
    return i;
  }
  /// The node of padded index i, which lies in x-slab ix.
  std::array<int, Dim> node_of(const Level& level, int ix, std::size_t i) const
  {
    std::array<int, Dim> node;
    node[0] = ix;
    std::size_t rest = i - static_cast<std::size_t>(ix + _degree) * level.stride[0];
    for (int a = 1; a < Dim - 1; ++a)
    {
      node[a] = static_cast<int>(rest / level.stride[a]) - _degree;
      rest %= level.stride[a];
    }
    node[Dim - 1] = static_cast<int>(rest) - _degree;
    return node;
  }

  int _degree;
  int _direct_size;
  int _sweeps; // Gauss-Seidel sweeps each way
  std::vector<Level> _levels;
  std::size_t _coarsest = 0; // the level solved directly in the last setup
  // The coarsest level's banded Cholesky factor K = L L^T over its unknowns:
  // row i holds L_i,i-band .. L_i,i.
  std::size_t _band = 0;
  std::vector<double> _factor;
  std::vector<double> _scratch; // per unknown of the coarsest level
  std::vector<double> _delta;   // the finest level's backward-sweep changes, padded layout
};

/// Multigrid from a grid's cells (std::array's size is a std::size_t).
template <std::size_t N>
Multigrid(std::array<int, N>, int) -> Multigrid<static_cast<int>(N)>;
template <std::size_t N>
Multigrid(std::array<int, N>, int, int) -> Multigrid<static_cast<int>(N)>;
template <std::size_t N>
Multigrid(std::array<int, N>, int, int, int) -> Multigrid<static_cast<int>(N)>;

extern template class Multigrid<2>;
extern template class Multigrid<3>;

} // namespace pfmpm
