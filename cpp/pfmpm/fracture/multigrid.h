/// @file multigrid.h
/// @brief Geometric multigrid on the B-spline grid: a V-cycle preconditioner
/// for the conjugate gradients of the phase-field system K c = F
/// (Kakouris & Triantafyllou 2019, eqs. 56-57, 52), second or fourth order.
#pragma once

#include "pfmpm/fracture/symmetric_stencil.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// Grid columns per strip of the Gauss-Seidel order: exactly this in the
/// multigrid smoother, about this in PhaseField's preconditioner
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

/// @brief A multigrid V-cycle for the symmetric positive definite
/// phase-field matrix K stored as an upper-half (2p+1)^2-point stencil on the
/// B-spline grid (stencil.h), as a preconditioner B ~ K^-1 for conjugate
/// gradients.
///
/// Levels: the grid of the phase field and grids of cells 2h, 4h, ... with the
/// B-spline bases of the same degree on them, nested by the two-scale relation
/// (Refinement): prolongation P = R_x (x) R_y, restriction P^T, and the
/// Galerkin operator K_2h = P^T K_h P, computed each solve from the stored
/// stencil. It is again a (2p+1)^2-point stencil (a coarse function meets the
/// coarse functions within p nodes), so every level uses the same storage.
/// Only the fine nodes that are coupled to others take part in the coarse
/// correction: the identity rows of the nodes no crackable particle touches
/// are solved exactly by the smoother. Coarsening stops at a level of at most
/// `direct_size` unknowns, which is solved by a banded Cholesky factorisation.
///
/// Smoother: one Gauss-Seidel sweep before the coarse correction and one in
/// the reverse order after it, so that B is symmetric; the order is that of
/// PhaseField's symmetric Gauss-Seidel (strips, here of sweep_strip grid
/// columns exactly, the even strips first, each column by column). Strips of
/// one parity share no matrix entry, so each half-sweep runs them in
/// parallel; every other kernel writes
/// each node from a sum in a fixed order. B, and so the CG iterates, have the
/// same bits for any number of threads.
class Multigrid
{
public:
  /// @param cells Cells of the finest grid in x and y.
  /// @param degree B-spline degree p (1..3).
  /// @param direct_size Unknowns at most on the coarsest level (>= 1).
  Multigrid(std::array<int, 2> cells, int degree, int direct_size = 400);

  /// @brief Build the coarse levels for a new matrix K (once per solve).
  /// @param rows K's upper-half stencil per node of the padded layout of the
  /// finest grid (padded by p nodes on each side); it must stay in place until
  /// the next setup.
  /// @param position The unknowns: the padded index of each active node, in
  /// increasing node order (column by column).
  template <int P>
  void setup(const std::vector<double>& rows, const std::vector<std::size_t>& position);

  /// @brief z = B r: one V-cycle from a zero guess, and K z.
  /// @param r, z, kz Per unknown of the finest level (the order of `position`).
  template <int P>
  void apply(const double* r, double* z, double* kz);

  /// Unknowns per level of the last setup, the finest first.
  std::vector<std::int64_t> unknowns() const;
  /// @brief Entry (i, j) of level l's operator in the last setup (level 0:
  /// K), for node i = (ix, iy) of that level's grid and j = i + (dx, dy),
  /// |dx|, |dy| <= p; zero where j lies off the grid.
  double entry(std::size_t level, int ix, int iy, int dx, int dy) const;

private:
  struct Level
  {
    int nx = 0, ny = 0;           // grid nodes
    std::size_t padded_ny = 0;    // nodes per padded column
    std::size_t padded_size = 0;  // nodes of the padded layout
    const double* rows = nullptr; // the operator's stencil (the finest: K's, borrowed)
    std::vector<double> stencil;  // coarse levels: the Galerkin operator
    std::vector<std::size_t> live;         // padded index of each unknown, column by column
    std::vector<std::size_t> column_start; // per grid column: its unknowns [start, next start)
    std::vector<double> inverse;           // per unknown: 1 / diagonal
    std::vector<std::uint8_t> coupled;     // per padded node: takes part in the coarse correction
    std::vector<double> x, b, r;           // per padded node
    std::vector<Refinement> refine;        // x and y: this level's basis from the next one's
  };

  template <int P>
  void galerkin(const Level& fine, Level& coarse);
  template <int P>
  double stencil_entry(const Level& level, int ix, int iy, int dx, int dy) const;
  template <bool Ordered, class F>
  void strips(const Level& level, bool forward, F&& f) const;
  template <int P>
  void cycle(std::size_t l, double* kx);
  template <int P>
  void factor_coarsest();
  void solve_coarsest();
  void number_unknowns(Level& level) const;
  std::size_t padded(const Level& level, int ix, int iy) const
  {
    return static_cast<std::size_t>(ix + _degree) * level.padded_ny + (iy + _degree);
  }

  int _degree;
  int _direct_size;
  std::vector<Level> _levels;
  std::size_t _coarsest = 0; // the level solved directly in the last setup
  // The coarsest level's banded Cholesky factor K = L L^T over its unknowns:
  // row i holds L_i,i-band .. L_i,i.
  std::size_t _band = 0;
  std::vector<double> _factor;
  std::vector<double> _scratch; // per unknown of the coarsest level
  std::vector<double> _delta;   // the finest level's backward-sweep changes, padded layout
};

} // namespace pfmpm
