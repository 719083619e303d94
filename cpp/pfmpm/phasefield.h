/// @file phasefield.h
/// @brief The phase-field equation on the active grid nodes, second order
/// (gamma = 0) or fourth order with an anisotropy tensor gamma
/// (Kakouris & Triantafyllou 2019, eqs. 4-6, 47-57).
#pragma once

#include "grid.h"
#include "material.h"
#include "multigrid.h"
#include "particles.h"
#include "stencil.h"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace pfmpm
{

/// @brief A 2D anisotropy tensor in Voigt form (eq. 6), row-major 3 x 3. It
/// acts on the curvature kappa = (c_,11, c_,22, c_,12): the fourth-order
/// term of eq. 4 is l0^3 kappa^T gamma kappa.
using Voigt = std::array<double, 9>;

/// Fracture parameters of a material that can crack.
struct Fracture
{
  double Gc;     ///< G_c, or the reference value G-bar_c when gamma != 0 (> 0)
  double l0;     ///< length scale l0 (> 0)
  double k_f;    ///< residual stiffness k_f in [0, 1) (eq. 15)
  Voigt gamma{}; ///< anisotropy in the material frame; zero: the second-order functional

  /// Degradation g(c) = (1 - k_f) c^2 + k_f (eq. 15).
  double degradation(double c) const { return (1.0 - k_f) * c * c + k_f; }
  /// Whether eq. 4 has its fourth-order term.
  bool fourth_order() const;
  /// @brief gamma seen in the global frame by a point whose principal material
  /// direction is turned by `phi` radians clockwise from x (section 4.3.4):
  /// T^T gamma_s T, with gamma_s the symmetric part of gamma and T the map from
  /// global to material-frame curvature. A crack along the principal direction
  /// has the coefficient gamma_1111 (docs/method.md).
  Voigt rotated(double phi) const;
};

/// @brief The preconditioner of the phase-field conjugate gradients.
enum class Preconditioner : int
{
  automatic = 0, ///< jacobi for the second-order model, ssor for the fourth-order one
  jacobi = 1,    ///< z = D^-1 r
  ssor = 2,      ///< symmetric Gauss-Seidel with Eisenstat's trick
  multigrid = 3  ///< a geometric multigrid V-cycle (Multigrid)
};

/// Convergence record of the phase-field solves.
struct PhaseFieldStats
{
  std::int64_t solves = 0;           ///< solves so far
  std::int64_t iterations = 0;       ///< CG iterations over all solves
  std::int32_t last_iterations = 0;  ///< CG iterations of the last solve
  double start_residual = 0.0;       ///< ||R|| / ||F|| of the last solve's warm start
  double last_residual = 0.0;        ///< ||R|| / ||F|| after the last solve
  std::int32_t unknowns = 0;         ///< nodes in the last system
};

/// @brief The last assembled phase-field system K c = F (eqs. 56-57, 52) in
/// compressed rows over the active nodes, both halves of K, with the solution
/// of the last solve: for checks and for comparisons with other solvers.
struct PhaseFieldSystem
{
  std::vector<std::int32_t> nodes;     ///< grid node (ix * nodes_y + iy) of each row
  std::vector<std::int64_t> row_start; ///< rows + 1 offsets into column and value
  std::vector<std::int32_t> column;    ///< row index of each entry's column, ascending per row
  std::vector<double> value;           ///< K's entries
  std::vector<double> rhs;             ///< F
  std::vector<double> solution;        ///< c of the last solve
};

/// @brief What one solve hands to the next: the nodal phase field of the last
/// two solves (the warm start extrapolates from them), the statistics and the
/// per-particle fracture energy. Saving and restoring it makes a resumed run
/// take bitwise the same steps as an uninterrupted one.
struct PhaseFieldState
{
  std::vector<double> c;               ///< nodal phase field, padded node layout
  std::vector<double> c_previous;      ///< the solution before it, same layout
  std::vector<double> fracture_energy; ///< per particle, from the last solve
  PhaseFieldStats stats;
};

/// @brief Assembles and solves K c = F (eqs. 56, 57, 52) for the nodal phase
/// field, and maps the result to the particles (eqs. 53-55).
///
/// The fourth-order term of eq. 57 needs second derivatives of the basis, so
/// C1 splines (degree >= 2); it is assembled only when some material has
/// gamma != 0, with each particle's gamma turned to its orientation
/// Particles::phi. Otherwise no second derivative is evaluated or stored.
///
/// K is stored as the upper half of a (2p+1)^2-point stencil per grid node
/// (padded by p nodes on each side, zero away from active nodes); only particles of
/// materials that can crack contribute. Nodes that no such particle touches
/// keep c = 1. The solve is preconditioned conjugate gradients (by default
/// Jacobi for the second-order model, symmetric Gauss-Seidel for the
/// fourth-order one; either, or a multigrid V-cycle, by set_preconditioner),
/// started from the last two steps' nodal values extrapolated in time, stopped when
/// ||F - K c|| <= tol ||F||. Sums over particles and nodes, and the
/// Gauss-Seidel sweeps, are taken in an order that does not depend on the
/// number of threads.
class PhaseField
{
public:
  /// @param grid The background grid (kept by reference).
  /// @param fracture Per material: its fracture parameters, or none if it cannot crack.
  /// @param tol Relative residual tolerance tol_c.
  /// @param max_iterations CG iteration limit per solve.
  PhaseField(const Grid& grid, std::vector<std::optional<Fracture>> fracture, double tol,
             int max_iterations);

  /// Whether any material can crack.
  bool active() const { return _active; }
  /// @brief Choose the CG preconditioner for the following solves.
  void set_preconditioner(Preconditioner preconditioner);
  /// The preconditioner the solves use (never automatic).
  Preconditioner preconditioner() const;
  /// Whether some material has the fourth-order term (gamma != 0).
  bool fourth_order() const { return _fourth; }
  /// Fracture parameters of `material`, or nullptr when it cannot crack.
  const Fracture* fracture(std::int32_t material) const
  {
    return _fracture[material] ? &*_fracture[material] : nullptr;
  }

  /// @brief Assemble with the current history, solve, set c at the
  /// particles and degrade their stresses (eqs. 14-16).
  ///
  /// Needs the particles sorted by cell (`order`, `cell_start`) and the grid's
  /// active nodes for that sort.
  /// @param materials Elastic models indexed by Particles::material.
  /// @return false if CG did not reach tol within max_iterations.
  template <int P>
  bool solve(Particles& particles, const std::vector<std::int32_t>& order,
             const std::vector<std::int64_t>& cell_start,
             const std::vector<LinearElastic>& materials);

  /// Per particle: G_c V_p Z(c_p) with Z of eq. 4, from the last solve.
  const std::vector<double>& fracture_energy() const { return _fracture_energy; }
  const PhaseFieldStats& stats() const { return _stats; }

  /// @brief The last assembled system and its solution, in compressed rows
  /// over the active nodes of that solve (empty before the first solve).
  PhaseFieldSystem system() const;

  /// @brief A copy of the state carried between solves.
  PhaseFieldState state() const;
  /// @brief Replace the state carried between solves by `state`.
  /// @throws std::invalid_argument if its nodal arrays do not fit this grid.
  void restore(PhaseFieldState state);
  /// @brief Check that `state` could be restored.
  /// @throws std::invalid_argument if its nodal arrays do not fit this grid.
  void check(const PhaseFieldState& state) const;
  double tol() const { return _tol; }
  int max_iterations() const { return _max_iterations; }

private:
  template <int P, bool Fourth>
  void assemble(const Particles& particles, const std::vector<std::int32_t>& order,
                const std::vector<std::int64_t>& cell_start);
  template <int P, bool Fourth>
  bool conjugate_gradient();
  /// @brief The iterations of conjugate_gradient from r = F - K c with
  /// q = K c given: Jacobi-preconditioned, preconditioned by symmetric
  /// Gauss-Seidel with Eisenstat's trick, or by a multigrid V-cycle. Set
  /// `residual` = ||r|| and count iterations in `it`.
  template <int P>
  void jacobi_iterations(double norm_f, double stop, double& residual, int& it);
  template <int P>
  void ssor_iterations(double norm_f, double stop, double& residual, int& it);
  template <int P>
  void multigrid_iterations(double norm_f, double stop, double& residual, int& it);
  /// The Gauss-Seidel order and 1 / K_II of ssor_iterations for the
  /// second-order model (assemble prepares them for the fourth-order one).
  void prepare_ssor();
  template <int P>
  PhaseFieldSystem compressed_rows() const;
  template <int P>
  void multiply(const std::vector<double>& padded, std::vector<double>& out) const;
  template <int P, bool Fourth>
  void map_to_particles(Particles& particles, const std::vector<std::int32_t>& order,
                        const std::vector<std::int64_t>& cell_start,
                        const std::vector<LinearElastic>& materials);
  /// K's stencil storage (stencil.h).
  template <int P>
  using Stencil = SymmetricStencil<P>;
  /// Row `a` (an active node) of K times the padded vector `v`.
  template <int P>
  double row_product(const Stencil<P>& stencil, std::size_t a, const double* v) const
  {
    return pfmpm::row_product(stencil, _stencil.data(), _position[a], v);
  }
  /// Index of node (ix, iy) in the padded node layout.
  std::size_t padded(int ix, int iy) const
  {
    return static_cast<std::size_t>(ix + _pad) * _padded_ny + (iy + _pad);
  }

  const Grid& _grid;
  std::vector<std::optional<Fracture>> _fracture;
  bool _active;
  bool _fourth; // some material has gamma != 0
  double _tol;
  int _max_iterations;
  int _pad;                // padding of the node layout: the degree
  std::size_t _padded_ny;  // nodes per padded column
  std::vector<double> _c;  // nodal phase field, padded layout, kept between steps
  std::vector<double> _c_previous; // the solution before, for the warm start
  std::vector<double> _stencil;       // per padded node: upper-half stencil of K
  std::vector<double> _rhs;           // per active node: F (eq. 52)
  std::vector<double> _diagonal;      // per active node: K_II, 1 where no crack can form
  std::vector<std::size_t> _position; // per active node: its index in the padded layout
  std::vector<double> _r, _z, _q;     // CG work vectors, per active node
  std::vector<double> _search;        // CG search direction, padded layout
  // SSOR-preconditioned CG only: strip s of the Gauss-Seidel
  // order is the grid columns [_strip_column[s], _strip_column[s + 1]), column
  // ix the active nodes [_column_start[ix], _column_start[ix + 1]); 1 / K_II per
  // active node; work vectors _forward (padded layout), _v and _g (per active node).
  std::vector<int> _strip_column;
  std::vector<std::size_t> _column_start;
  std::vector<double> _inverse;
  std::vector<double> _forward, _v, _g;
  Preconditioner _preconditioner = Preconditioner::automatic;
  std::unique_ptr<Multigrid> _multigrid; // with Preconditioner::multigrid
  std::vector<double> _fracture_energy; // per particle
  PhaseFieldStats _stats;
};

} // namespace pfmpm
