/// @file phasefield.h
/// @brief The phase-field equation on the active grid nodes, second order
/// (gamma = 0) or fourth order with an anisotropy tensor gamma
/// (Kakouris & Triantafyllou 2019, eqs. 4, 6, 47-57).
#pragma once

#include "pfmpm/common/parameters.h"

#include "pfmpm/grid/grid.h"
#include "pfmpm/particles/cell_sort.h"
#include "pfmpm/particles/particles.h"
#include "pfmpm/fracture/moments.h"
#include "pfmpm/fracture/multigrid.h"
#include "pfmpm/fracture/symmetric_stencil.h"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace pfmpm
{

/// @brief A 2D anisotropy tensor in Voigt form (K&T eq. 6), row-major 3 x 3. It
/// acts on the curvature kappa = (c_,11, c_,22, c_,12): the fourth-order
/// term of K&T eq. 4 is l0^3 kappa^T gamma kappa.
using Voigt = std::array<double, 9>;

/// @brief The local term w(d) of the crack density, d = 1 - c. In the
/// standard form (G_c / c_w) (w(d) / l + l |grad d|^2) with l = 2 l0
/// (docs/method.md):
enum class Model : int
{
  AT2 = 0, ///< w = d^2, c_w = 2: K&T eq. 4; damage at any tension
  AT1 = 1  ///< w = d, c_w = 8/3: an elastic threshold and a band of finite width
};

/// Fracture parameters of a material that can crack.
struct Fracture
{
  double Gc;     ///< G_c, or the reference value G-bar_c when gamma != 0 (> 0)
  double l0;     ///< length scale l0 (> 0)
  double k_f;    ///< residual stiffness k_f in [0, 1) (K&T eq. 15)
  Voigt gamma{}; ///< anisotropy in the material frame; zero: the second-order functional
  Model model = Model::AT2; ///< AT1 only with gamma = 0
  /// Solve with the bound 0 <= c <= 1 (PhaseField::bounded_solve); AT1 needs
  /// it, the fourth-order functional (gamma != 0) is solved without it.
  bool bound = true;

  /// @brief The declarations of a material's fracture table: Gc, l0, k_f
  /// and model, checked by the phase field and by the scene reader.
  static std::vector<ParameterSpec> parameters();

  /// Degradation g(c) = (1 - k_f) c^2 + k_f (K&T eq. 15).
  double degradation(double c) const { return (1.0 - k_f) * c * c + k_f; }

  /// @brief Per unit volume, the coefficient of N_I N_J in K (K&T eq. 57) at
  /// history H: K&T eq. 49's F_p = 4 l0 (1 - k_f) H / G_c + 1 for AT2, and
  /// 16 l0 (1 - k_f) H / (3 G_c) for AT1, whose crack density has no
  /// (1 - c)^2 term.
  double reaction(double H) const
  {
    if (model == Model::AT1)
      return 16.0 * l0 * (1.0 - k_f) * H / (3.0 * Gc);
    return 4.0 * l0 * (1.0 - k_f) * H / Gc + 1.0;
  }
  /// @brief Per unit volume, the coefficient of grad N_I . grad N_J in K
  /// (K&T eq. 57): 4 l0^2 for both models.
  double diffusion() const { return 4.0 * l0 * l0; }
  /// @brief Per unit volume, the coefficient of N_I in F (K&T eq. 52): 1 for
  /// AT2, 1/2 for AT1 (its linear term (3 / 16 l0) (1 - c), scaled like
  /// the rest of AT1's equation by 8 l0 / (3 G_c)).
  double source() const { return model == Model::AT1 ? 0.5 : 1.0; }
  /// @brief Crack density Z at phase field c with |grad c|^2 = `grad2`
  /// (K&T eq. 4 with gamma = 0): (1 - c)^2 / (4 l0) + l0 |grad c|^2 for AT2,
  /// 3 (1 - c) / (16 l0) + (3/4) l0 |grad c|^2 for AT1.
  double crack_density(double c, double grad2) const
  {
    const double d = 1.0 - c;
    if (model == Model::AT1)
      return 3.0 * d / (16.0 * l0) + 0.75 * l0 * grad2;
    return d * d / (4.0 * l0) + l0 * grad2;
  }
  /// Whether K&T eq. 4 has its fourth-order term.
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
  automatic = 0, ///< jacobi for the second-order model, multigrid for the fourth-order one
  jacobi = 1,    ///< z = D^-1 r
  ssor = 2,      ///< symmetric Gauss-Seidel with Eisenstat's trick
  multigrid = 3  ///< a geometric multigrid V-cycle (Multigrid)
};

/// Convergence record of the phase-field solves.
struct PhaseFieldStats
{
  std::int64_t solves = 0;           ///< solves so far
  std::int64_t iterations = 0;       ///< CG iterations over all solves
  std::int32_t last_iterations = 0;  ///< CG iterations of the last solve (all its passes)
  double start_residual = 0.0;       ///< ||R|| / ||F|| of the last solve's warm start
  double last_residual = 0.0;        ///< ||R|| / ||F|| after the last solve
  std::int32_t unknowns = 0;         ///< nodes in the last system
  std::int64_t passes = 0;           ///< active-set passes over all bounded solves
  std::int32_t last_passes = 0;      ///< active-set passes of the last bounded solve
  std::int32_t at_bound = 0;         ///< nodes held at c = 0 or 1 by the last bounded solve
  std::int64_t handovers = 0;        ///< bounded solves finished by MPRGP (mprgp.h)

  /// How a statistic of several phase fields (one per crackable body or
  /// group) combines into the run's: summed, or the largest.
  enum class Combine
  {
    sum,
    max
  };

  /// @brief Call `visit(name, combine, s.member...)` for every statistic
  /// of the Stats `s...` (one or more), in one order: the one list that the
  /// solver's state, its restore, the run's total and the bindings iterate.
  template <class Visit, class... Stats>
  static void each(Visit&& visit, Stats&... s)
  {
    visit("solves", Combine::sum, s.solves...);
    visit("iterations", Combine::sum, s.iterations...);
    visit("last_iterations", Combine::max, s.last_iterations...);
    visit("start_residual", Combine::max, s.start_residual...);
    visit("last_residual", Combine::max, s.last_residual...);
    visit("unknowns", Combine::sum, s.unknowns...);
    visit("passes", Combine::sum, s.passes...);
    visit("last_passes", Combine::max, s.last_passes...);
    visit("at_bound", Combine::sum, s.at_bound...);
    visit("handovers", Combine::sum, s.handovers...);
  }
};

/// @brief The last assembled phase-field system K c = F (K&T eqs. 56-57, 52) in
/// compressed rows over the active nodes, both halves of K, with the solution
/// of the last solve: for checks and for comparisons with other solvers.
struct PhaseFieldSystem
{
  std::vector<std::int32_t> nodes;     ///< grid node (its lattice key, ix * nodes_y + iy in 2D) of each row
  std::vector<std::int64_t> row_start; ///< rows + 1 offsets into column and value
  std::vector<std::int32_t> column;    ///< row index of each entry's column, ascending per row
  std::vector<double> value;           ///< K's entries
  std::vector<double> rhs;             ///< F
  std::vector<double> solution;        ///< c of the last solve
};

/// @brief What one solve hands to the next: the nodal phase field of the last
/// two solves (the warm start extrapolates from them) and the statistics.
/// With the particle columns, saving and restoring it makes a resumed run
/// take bitwise the same steps as an uninterrupted one.
struct PhaseFieldState
{
  std::vector<double> c;          ///< nodal phase field, padded node layout
  std::vector<double> c_previous; ///< the solution before it, same layout
  PhaseFieldStats stats;
};

/// @brief Assembles and solves K c = F (K&T eqs. 56, 57, 52) for the nodal phase
/// field, and maps the result to the particles (K&T eqs. 53-55). It writes the
/// particles' c and fracture energy only: the stresses that c degrades are
/// the materials' business (Material::stress).
///
/// The fourth-order term of K&T eq. 57 needs second derivatives of the basis, so
/// C1 splines (degree >= 2); it is assembled only when some material has
/// gamma != 0, with each particle's gamma turned to its orientation
/// Particles::phi. Otherwise no second derivative is evaluated or stored.
///
/// K is stored as the upper half of a (2p+1)^2-point stencil per grid node
/// (padded by p nodes on each side, zero away from active nodes); only particles of
/// materials that can crack contribute. Nodes that no such particle touches
/// keep c = 1. The solve is preconditioned conjugate gradients (by default
/// symmetric Gauss-Seidel for the second-order model, a multigrid V-cycle for
/// the fourth-order one; either, or Jacobi, by set_preconditioner),
/// started from the last two steps' nodal values extrapolated in time, stopped when
/// ||F - K c|| <= tol ||F||. Sums over particles and nodes, and the
/// Gauss-Seidel sweeps, are taken in an order that does not depend on the
/// number of threads.
///
/// The second-order system is solved with the bound 0 <= c <= 1 on every
/// node instead (bounded_solve) unless every material asks for no bound
/// (Fracture::bound, AT2 only): AT1 has no solution without it, and it keeps
/// AT2's nodal values, which undershoot next to a band of huge history, in
/// [0, 1].
///
/// The phase field is dimension-generic, instantiated for Dim = 2 and 3: the
/// stencil has (2p+1)^Dim points, the Gauss-Seidel strips are of grid columns
/// (2D) or planes (3D). The fourth-order model is two-dimensional (its
/// anisotropy tensor acts on 2D curvatures): the 3D constructor refuses it.
struct PhaseFieldDeclarations
{
  /// @brief The declarations of the solve's parameters, a scene's
  /// [phase_field] keys: tol, max_iterations and preconditioner, with the
  /// defaults StepConfig takes.
  static std::vector<ParameterSpec> solver_parameters();
  static constexpr double default_tol = 1e-6;
  static constexpr int default_max_iterations = 1000;

  /// The particle columns of the phase field: c, history H and fracture
  /// energy G_c V_p Z(c_p); with the fourth-order term also the orientation phi.
  static std::vector<ColumnSpec> columns(bool fourth_order);
};

template <int Dim>
class PhaseField : public PhaseFieldDeclarations
{
public:
  /// @param grid The background grid (kept by reference).
  /// @param fracture Per material: its fracture parameters, or none if it cannot crack.
  /// @param tol Relative residual tolerance tol_c.
  /// @param max_iterations CG iteration limit per solve.
  PhaseField(const Grid<Dim>& grid, std::vector<std::optional<Fracture>> fracture, double tol,
             int max_iterations);

  /// Whether any material can crack.
  bool active() const { return _active; }
  /// @brief Choose the CG preconditioner for the following solves.
  /// @throws std::invalid_argument multigrid for the bounded solve, whose
  /// held nodes the V-cycle does not know.
  void set_preconditioner(Preconditioner preconditioner);
  /// The preconditioner the solves use (never automatic).
  Preconditioner preconditioner() const;
  /// Whether some material has the fourth-order term (gamma != 0).
  bool fourth_order() const { return _fourth; }
  /// Whether the nodal phase field is solved with the bound 0 <= c <= 1.
  bool bounded() const { return _bounded; }
  /// Fracture parameters of `material`, or nullptr when it cannot crack.
  const Fracture* fracture(std::int32_t material) const
  {
    return _fracture[material] ? &*_fracture[material] : nullptr;
  }

  /// @brief Assemble with the current history, solve, and set c at the
  /// particles of `sort`, with `energy` their fracture energy too.
  ///
  /// `sort` holds the particles that take part, all of crackable materials,
  /// sorted by cell; its unknowns are the nodes these particles touch.
  /// @return false if CG did not reach tol within max_iterations.
  template <int P>
  bool solve(Particles& particles, const CellSort& sort, bool energy);

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
  void assemble(const Particles& particles, const CellSort& sort);
  /// ||F||, the scale of the solves' stopping test ||F - K c|| <= tol ||F||.
  double rhs_norm() const;
  /// @brief The warm start of the solves at padded node i: the last two
  /// solutions extrapolated linearly in time, or the last one while there is
  /// no earlier solution to extrapolate from; c_previous takes the last one.
  double warm_start(std::size_t i);
  template <int P, bool Fourth>
  bool conjugate_gradient();
  /// @brief CG on the free nodes (`_bound` 0), the held ones fixed at their
  /// values, preconditioned by symmetric Gauss-Seidel with Eisenstat's trick;
  /// the arguments as free_set_iterations.
  template <int P>
  void ssor_iterations(double stop, double& start, double& residual, int& it);
  /// @brief The iterations of conjugate_gradient from r = F - K c with
  /// q = K c given, preconditioned by a multigrid V-cycle. Set `residual` =
  /// ||r|| and count iterations in `it`.
  template <int P>
  void multigrid_iterations(double norm_f, double stop, double& residual, int& it);
  /// The Gauss-Seidel order and 1 / K_II of ssor_iterations, for this step's
  /// active nodes and K.
  void prepare_ssor();
  template <int P>
  PhaseFieldSystem compressed_rows() const;
  template <int P>
  void multiply(const std::vector<double>& padded, std::vector<double>& out) const;
  /// @brief K c = F (K&T eq. 50) with the bound 0 <= c <= 1 on every active
  /// node, by a primal-dual active-set method around CG on the free nodes
  /// (free_set_solve), handed over to MPRGP (mprgp.h) when its passes do not
  /// settle (see the definition).
  /// @return false if MPRGP did not reach tol within max_iterations.
  template <int P>
  bool bounded_solve();
  /// The most active-set passes of a bounded solve before MPRGP takes over
  /// (a cold start with l0 = 8 h takes about 16).
  static constexpr int max_passes = 50;
  /// A node whose K_II is at most this fraction of the largest diagonal in
  /// its stencil is uncoupled, c = 1 (see assemble).
  static constexpr double negligible_diagonal = 1e-10;
  /// @brief (K c)_a into _q[a] at the nodes held on a bound, the only rows
  /// update_active_set reads (a free node's state follows from c alone).
  template <int P>
  void held_products();
  /// @brief One active-set update from c and r = F - K c (in _q as K c, read
  /// at the held nodes only):
  /// a node at a bound is released when its multiplier pulls it into the box
  /// by at least `margin` K_II (a negative margin: unless it pushes it
  /// outwards by more than -margin K_II), a free node outside [0, 1] is put
  /// on the bound it crossed (and c set to it). Rebuilds the free list `_free`.
  /// @return how many nodes changed their state.
  std::int64_t update_active_set(double margin);
  /// The free nodes (`_bound` 0) into `_free`, `_free_node` and `_free_diagonal`.
  void list_free();
  /// @brief CG on the free nodes with the preconditioner of
  /// set_preconditioner: ssor_iterations, else free_set_iterations (Jacobi).
  template <int P>
  void free_set_solve(double stop, double& start, double& residual, int& it);
  /// @brief Jacobi-preconditioned CG on the free nodes (`_free`), the others
  /// held at their values: the rows of the held nodes are identity rows.
  /// Sets `start` and `residual` to ||r|| over the free nodes before and
  /// after and `it` to the iterations; stops at `stop` or max_iterations.
  template <int P>
  void free_set_iterations(double stop, double& start, double& residual, int& it);
  template <int P, bool Fourth, bool Energy>
  void map_to_particles(Particles& particles, const CellSort& sort);
  /// K's stencil storage (symmetric_stencil.h).
  template <int P>
  using Stencil = SymmetricStencil<Dim, P>;
  /// K's stencil on this grid's padded node layout.
  template <int P>
  Stencil<P> stencil() const
  {
    if constexpr (Dim == 2)
      return Stencil<P>(_padded[1]);
    else
      return Stencil<P>(_padded[1], _padded[2]);
  }
  /// Row `a` (an active node) of K times the padded vector `v`.
  template <int P>
  double row_product(const Stencil<P>& stencil, std::size_t a, const double* v) const
  {
    return pfmpm::row_product(stencil, _stencil.data(), _position[a], v);
  }
  /// Index of node (i_0, .., i_Dim-1) in the padded node layout.
  std::size_t padded(const std::array<int, Dim>& i) const
  {
    std::size_t k = static_cast<std::size_t>(i[0] + _pad);
    for (int d = 1; d < Dim; ++d)
      k = k * _padded[d] + static_cast<std::size_t>(i[d] + _pad);
    return k;
  }
  template <class... I>
  std::size_t padded(I... i) const
  {
    static_assert(sizeof...(I) == Dim, "one index per direction");
    return padded(std::array<int, Dim>{static_cast<int>(i)...});
  }
  /// Index in the padded node layout of the grid node of key `node`.
  std::size_t padded_node(std::int32_t node) const
  {
    return padded(lattice_indices<Dim>(static_cast<std::size_t>(node), _grid.nodes()));
  }

  const Grid<Dim>& _grid;
  ActiveNodes<Dim> _nodes; // the unknowns: the nodes the solve's particles touch
  std::vector<std::optional<Fracture>> _fracture;
  std::vector<CellProducts> _products; // per direction: the basis's products on each cell (moments.h)
  bool _active;
  bool _fourth; // some material has gamma != 0
  bool _bounded; // second order and some material bounded: 0 <= c <= 1 is imposed
  double _tol;
  int _max_iterations;
  int _pad;                // padding of the node layout: the degree
  std::array<std::size_t, Dim> _padded{}; // nodes per direction of the padded layout
  std::vector<double> _c;  // nodal phase field, padded layout, kept between steps
  std::vector<double> _c_previous; // the solution before, for the warm start
  std::vector<double> _stencil;       // per padded node: upper-half stencil of K
  std::vector<double> _rhs;           // per active node: F (K&T eq. 52)
  std::vector<double> _diagonal;      // per active node: K_II, 1 where no crack can form
  std::vector<std::size_t> _position; // per active node: its index in the padded layout
  std::vector<double> _r, _z, _q;     // CG work vectors, per active node
  std::vector<double> _search;        // CG search direction, padded layout
  // SSOR-preconditioned CG only: strip s of the Gauss-Seidel
  // order is the grid columns (2D) or planes (3D) of first index
  // [_strip_column[s], _strip_column[s + 1]), column or plane ix the active
  // nodes [_column_start[ix], _column_start[ix + 1]); 1 / K_II per
  // active node; work vectors _forward (padded layout), _v and _g (per active node).
  std::vector<int> _strip_column;
  std::vector<std::size_t> _column_start;
  std::vector<double> _inverse;
  std::vector<double> _forward, _v, _g;
  // CG on the free nodes (free_set_solve): per active node -1 (held
  // at c = 0), 0 (free) or +1 (held at c = 1), all 0 unbounded; the free
  // active nodes in ascending order, and for the Jacobi iterations their
  // padded positions and K_II, read without indirection.
  std::vector<std::int8_t> _bound;
  std::vector<std::size_t> _free;
  std::vector<std::uint32_t> _free_node;
  std::vector<double> _free_diagonal;
  Preconditioner _preconditioner = Preconditioner::automatic;
  std::unique_ptr<Multigrid<Dim>> _multigrid; // with Preconditioner::multigrid
  PhaseFieldStats _stats;
};

extern template class PhaseField<2>;
extern template class PhaseField<3>;

} // namespace pfmpm
