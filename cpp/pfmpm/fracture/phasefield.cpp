/// @file phasefield.cpp
/// @brief Phase-field assembly (K&T eqs. 49, 52, 56-57), preconditioned CG
/// and map-back to the particles (K&T eqs. 53-55, 4).
#include "pfmpm/fracture/phasefield.h"
#include "pfmpm/common/reduce.h"
#include "pfmpm/fracture/moments.h"
#include "pfmpm/fracture/mprgp.h"
#include "pfmpm/shape/stencil.h"
#include "pfmpm/transfer/transfer.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace pfmpm
{

std::vector<ParameterSpec> PhaseFieldDeclarations::solver_parameters()
{
  using P = ParameterSpec;
  return {P::number("tol", "1", "tolerance tol_c of the solve, relative to ||F|| (K&T eq. 52)")
              .above(0.0)
              .below(1.0)
              .fallback(default_tol),
          P::integer("max_iterations",
                     "conjugate-gradient iterations allowed per step; a step that needs more stops "
                     "the run")
              .at_least(1.0)
              .at_most(2147483647.0)
              .fallback(default_max_iterations),
          P::word("preconditioner", {"automatic", "jacobi", "ssor", "multigrid"},
                  "of the conjugate gradients: automatic is ssor for the second-order model and "
                  "multigrid for the fourth-order one; the bounded solve takes jacobi or ssor")
              .fallback("automatic")};
}

std::vector<ParameterSpec> Fracture::parameters()
{
  using P = ParameterSpec;
  return {P::number("Gc", "energy/area",
                    "critical energy release rate G_c (K&T eq. 4); with a fourth-order anisotropy "
                    "the reference value G-bar_c (K&T eq. 8)")
              .above(0.0),
          P::number("l0", "length", "length scale l0 of the crack density (K&T eq. 4), >= grid.h")
              .above(0.0),
          P::number("k_f", "1", "residual stiffness in g(c) = (1 - k_f) c^2 + k_f (K&T eq. 15)")
              .at_least(0.0)
              .below(1.0)
              .fallback(0.0),
          P::word("model", {"AT2", "AT1"},
                  "the crack density's local term: AT2 (K&T eq. 4) or AT1, w(d) = d")
              .fallback("AT2")};
}

namespace
{
std::string text(double v) { return std::to_string(v); }

/// kappa^T G kappa for a symmetric Voigt G and kappa = (xx, yy, xy); times
/// l0^3, the fourth-order part of K&T eq. 4. (Scalars, not an array: the
/// interpolation has just written them one by one, and reading them back as
/// a vector would wait for the stores.)
double curvature_energy(const Voigt& G, double kxx, double kyy, double kxy)
{
  return kxx * (G[0] * kxx + G[1] * kyy + G[2] * kxy) + kyy * (G[3] * kxx + G[4] * kyy + G[5] * kxy)
         + kxy * (G[6] * kxx + G[7] * kyy + G[8] * kxy);
}

/// A material's gamma in the global frame (Fracture::rotated), recomputed only
/// when the material or the orientation differs from the last call's. One per
/// thread for a transfer (`per_thread`), so that a body of one orientation
/// pays once per thread, not once per cell.
class alignas(64) RotatedGamma
{
public:
  const Voigt& operator()(const Fracture& fracture, double phi)
  {
    if (&fracture != _fracture || phi != _phi)
    {
      _gamma = fracture.rotated(phi);
      _fracture = &fracture;
      _phi = phi;
    }
    return _gamma;
  }

private:
  Voigt _gamma{};
  const Fracture* _fracture = nullptr;
  double _phi = 0.0;
};

/// A RotatedGamma per thread of the transfers, or none without the
/// fourth-order term.
std::vector<RotatedGamma> per_thread(bool fourth)
{
  return std::vector<RotatedGamma>(fourth ? static_cast<std::size_t>(omp_get_max_threads()) : 0);
}
} // namespace

bool Fracture::fourth_order() const
{
  return std::any_of(gamma.begin(), gamma.end(), [](double g) { return g != 0.0; });
}

Voigt Fracture::rotated(double phi) const
{
  // The principal direction p = (cos phi, -sin phi) (phi clockwise from x)
  // is where a crack has gamma_n = gamma_1111 (section 5.4: the fibres carry
  // G_c,min when gamma_1111 << gamma_2222), so gamma's axis 1 lies across p:
  // e1 = (sin phi, cos phi), e2 = -p. The material-frame curvature is
  // kappa_m = T kappa with kappa_m = (e1.H.e1, e2.H.e2, e1.H.e2) for the
  // Hessian H of c.
  const double cs = std::cos(phi), sn = std::sin(phi);
  const double e1x = sn, e1y = cs, e2x = -cs, e2y = sn;
  const double T[3][3] = {{e1x * e1x, e1y * e1y, 2.0 * e1x * e1y},
                          {e2x * e2x, e2y * e2y, 2.0 * e2x * e2y},
                          {e1x * e2x, e1y * e2y, e1x * e2y + e1y * e2x}};
  // Formed for b >= a and mirrored: exactly symmetric.
  Voigt out{};
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b)
    {
      double sum = 0.0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          sum += T[i][a] * 0.5 * (gamma[3 * i + j] + gamma[3 * j + i]) * T[j][b];
      out[3 * a + b] = out[3 * b + a] = sum;
    }
  return out;
}

template <int Dim>
PhaseField<Dim>::PhaseField(const Grid<Dim>& grid, std::vector<std::optional<Fracture>> fracture, double tol,
                       int max_iterations)
    : _grid(grid), _fracture(std::move(fracture)), _tol(tol), _max_iterations(max_iterations),
      _pad(grid.degree())
{
  for (int d = 0; d < Dim; ++d)
    _padded[d] = static_cast<std::size_t>(grid.nodes()[d] + 2 * grid.degree());
  _active = std::any_of(_fracture.begin(), _fracture.end(), [](const auto& f) { return f.has_value(); });
  _fourth = std::any_of(_fracture.begin(), _fracture.end(),
                        [](const auto& f) { return f && f->fourth_order(); });
  _bounded = !_fourth && std::any_of(_fracture.begin(), _fracture.end(),
                                     [](const auto& f) { return f && f->bound; });
  for (std::size_t m = 0; m < _fracture.size(); ++m)
  {
    if (!_fracture[m])
      continue;
    const Fracture& f = *_fracture[m];
    const std::string at = "material " + std::to_string(m) + ": ";
    try
    {
      const auto specs = Fracture::parameters();
      declared(specs, "Gc").check(f.Gc);
      declared(specs, "l0").check(f.l0);
      declared(specs, "k_f").check(f.k_f);
    }
    catch (const std::invalid_argument& e)
    {
      throw std::invalid_argument(at + e.what());
    }
    for (double g : f.gamma)
      if (!std::isfinite(g))
        throw std::invalid_argument(at + "gamma = " + text(g) + ": must be finite");
    if (Dim == 3 && f.fourth_order())
      throw std::invalid_argument(at + "gamma != 0: the fourth-order anisotropic phase field is "
                                  "two-dimensional; a 3D scene takes the second-order one");
    if (f.fourth_order() && grid.degree() < 2)
      throw std::invalid_argument(at + "gamma != 0 needs second derivatives of the basis: "
                                  "the grid degree must be >= 2, not 1");
    if (f.model != Model::AT1 && f.model != Model::AT2)
      throw std::invalid_argument(at + "model = " + std::to_string(static_cast<int>(f.model))
                                  + ": must be AT1 or AT2");
    if (f.model == Model::AT1 && !f.bound)
      throw std::invalid_argument(at + "AT1 needs the bound 0 <= c <= 1");
  }
  const bool at1 = std::any_of(_fracture.begin(), _fracture.end(),
                               [](const auto& f) { return f && f->model == Model::AT1; });
  if (at1 && _fourth)
    throw std::invalid_argument("AT1 is solved with the second-order functional only: no "
                                "material of its phase field may have gamma != 0");
  const auto solver = solver_parameters();
  declared(solver, "tol").check(tol);
  declared(solver, "max_iterations").check(max_iterations);
  if (_active)
  {
    std::size_t padded_size = 1;
    for (int d = 0; d < Dim; ++d)
      padded_size *= _padded[d];
    if (padded_size > std::numeric_limits<std::uint32_t>::max())
      throw std::invalid_argument("grid.nodes = " + std::to_string(grid.num_nodes())
                                  + ": the phase field indexes at most 2^32 padded nodes");
    _c.assign(padded_size, 1.0);
    _c_previous = _c;
    _search.assign(_c.size(), 0.0);
    for (int d = 0; d < Dim; ++d)
      _products.emplace_back(grid.basis(d));
  }
  set_preconditioner(Preconditioner::automatic);
}

template <int Dim>
void PhaseField<Dim>::set_preconditioner(Preconditioner preconditioner)
{
  if (_bounded && preconditioner == Preconditioner::multigrid)
    throw std::invalid_argument(
        "phase_field.preconditioner = multigrid: the bounded second-order solve takes jacobi or ssor");
  _preconditioner = preconditioner;
  _multigrid.reset();
  if (!_active)
    return;
  if (this->preconditioner() == Preconditioner::multigrid)
    _multigrid = std::make_unique<Multigrid<Dim>>(_grid.cells(), _grid.degree());
  if (this->preconditioner() == Preconditioner::ssor && _forward.empty())
    _forward.assign(_c.size(), 0.0);
}

template <int Dim>
Preconditioner PhaseField<Dim>::preconditioner() const
{
  if (_preconditioner != Preconditioner::automatic)
    return _preconditioner;
  return _fourth ? Preconditioner::multigrid : Preconditioner::ssor;
}

template <int Dim>
PhaseFieldState PhaseField<Dim>::state() const
{
  return PhaseFieldState{_c, _c_previous, _stats};
}

template <int Dim>
void PhaseField<Dim>::check(const PhaseFieldState& state) const
{
  if (state.c.size() != _c.size() || state.c_previous.size() != _c.size())
    throw std::invalid_argument("phase field state: " + std::to_string(state.c.size()) + " and "
                                + std::to_string(state.c_previous.size())
                                + " nodal values for a grid of " + std::to_string(_c.size()));
}

template <int Dim>
void PhaseField<Dim>::restore(PhaseFieldState state)
{
  check(state);
  _c = std::move(state.c);
  _c_previous = std::move(state.c_previous);
  _stats = state.stats;
}

std::vector<ColumnSpec> PhaseFieldDeclarations::columns(bool fourth_order)
{
  std::vector<ColumnSpec> columns{
      {"c", 1, DType::f64, {1.0}, "phase field: 1 intact, 0 broken (K&T eq. 53)", "", "c"},
      {"history", 1, DType::f64, {0.0}, "history field H (K&T eq. 20)", "", "history"},
      {"fracture_energy", 1, DType::f64, {0.0},
       "G_c V_p Z(c_p) (K&T eqs. 3-4), as of the last step of an advance()", "", ""}};
  if (fourth_order) // only the fourth-order term turns with the material (section 4.3.4)
    columns.push_back({"phi", 1, DType::f64, {0.0},
                       "principal material direction, radians clockwise from x", "", ""});
  return columns;
}

template <int Dim>
PhaseFieldSystem PhaseField<Dim>::system() const
{
  switch (_pad)
  {
  case 1:
    return compressed_rows<1>();
  case 2:
    return compressed_rows<2>();
  default:
    return compressed_rows<3>();
  }
}

template <int Dim>
template <int P>
PhaseFieldSystem PhaseField<Dim>::compressed_rows() const
{
  constexpr int H = Stencil<P>::size;
  PhaseFieldSystem out;
  const std::size_t na = _rhs.size();
  if (na == 0)
    return out;
  constexpr int width = 2 * P + 1;
  const std::array<int, Dim> n = _grid.nodes();
  out.nodes.assign(_nodes.nodes().begin(), _nodes.nodes().end());
  out.rhs = _rhs;
  out.row_start.push_back(0);
  for (std::size_t a = 0; a < na; ++a)
  {
    const std::array<int, Dim> i = lattice_indices<Dim>(static_cast<std::size_t>(out.nodes[a]), n);
    out.solution.push_back(_c[_position[a]]);
    // Neighbours in increasing node order, hence increasing active index.
    for (int rank = 0; rank < Stencil<P>::size * 2 - 1; ++rank)
    {
      std::array<int, Dim> d, j, minus;
      bool inside = true;
      for (int e = Dim - 1, r = rank; e >= 0; --e, r /= width)
      {
        d[e] = r % width - P;
        j[e] = i[e] + d[e];
        minus[e] = -d[e];
        inside = inside && j[e] >= 0 && j[e] < n[e];
      }
      if (!inside || _nodes.index(j) < 0)
        continue;
      const int k = Stencil<P>::slot(d);
      const double v = k >= 0 ? _stencil[_position[a] * H + k]
                              : _stencil[padded(j) * H + Stencil<P>::slot(minus)];
      out.column.push_back(_nodes.index(j));
      out.value.push_back(v);
    }
    out.row_start.push_back(static_cast<std::int64_t>(out.column.size()));
  }
  return out;
}

template <int Dim>
template <int P>
bool PhaseField<Dim>::solve(Particles& particles, const CellSort& sort, bool energy)
{
  auto run = [&](auto fourth)
  {
    constexpr bool Fourth = decltype(fourth)::value;
    assemble<P, Fourth>(particles, sort);
    bool converged;
    if constexpr (Fourth) // never bounded (the constructor refuses AT1 with gamma != 0)
      converged = conjugate_gradient<P, true>();
    else
      converged = _bounded ? bounded_solve<P>() : conjugate_gradient<P, false>();
    if (energy)
      map_to_particles<P, Fourth, true>(particles, sort);
    else
      map_to_particles<P, Fourth, false>(particles, sort);
    return converged;
  };
  if constexpr (P >= 2 && Dim == 2) // degree 1 (or 3D) with gamma != 0 is refused by the constructor
    if (_fourth)
      return run(std::true_type{});
  return run(std::false_type{});
}

template <int Dim>
template <int P, bool Fourth>
void PhaseField<Dim>::assemble(const Particles& particles, const CellSort& sort)
{
  using Shape = BSplineStencil<Dim, P>;
  using Moments = CellMoments<Dim, P, Fourth>;
  constexpr int K = Shape::size;      // nodes of one cell
  constexpr int W = Shape::width;     // nodes of one cell per direction
  constexpr int H = Stencil<P>::size; // stored entries per node
  // The system's unknowns: the nodes in the support of the sort's particles
  // (with discrete fields, of this body's particles alone).
  _nodes.activate(_grid, sort.cell_start(), NodeBlock{0, _grid.degree() + 1}); // B-spline support
  const auto na = static_cast<std::size_t>(_nodes.size());
  const double* volume = particles.volume.data();
  const double* history = particles.f64("history").data();
  const double* phi = Fourth ? particles.f64("phi").data() : nullptr;
  const std::int32_t* material = particles.material.data();

  _stencil.resize(_c.size() * H);
  _rhs.resize(na);
  _diagonal.resize(na);
  _position.resize(na);
  _r.resize(na);
  _z.resize(na);
  _q.resize(na);
  const std::vector<std::int32_t>& nodes = _nodes.nodes();
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(na); ++a)
  {
    _position[a] = padded_node(nodes[a]);
    _rhs[a] = 0.0;
  }
  // All nodes, not only active ones: a product reads neighbours' rows.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(_stencil.size()); ++k)
    _stencil[k] = 0.0;

  // Per cell, the moments of its particles in sorted order (moments.h), and
  // from them its K x K block of K&T eq. 57 and K entries of K&T eq. 52, added to the
  // stencil rows.
  [[maybe_unused]] std::vector<RotatedGamma> rotated = per_thread(Fourth);
  const std::array<std::size_t, Dim> padded_n = _padded;
  particle_to_grid<CellPowers<Dim, P>>(
      _grid, sort, Points{particles.x.data()},
      [&](const Cell<Dim>& cell, const auto& each)
      {
        Moments sums; // the cell's moments
        [[maybe_unused]] RotatedGamma* mine = Fourth ? &rotated[omp_get_thread_num()] : nullptr;
        each(
            [&](std::size_t p, const CellPowers<Dim, P>& s)
            {
              const Fracture& fr = *fracture(material[p]);
              const double V = volume[p];
              double w[Moments::weights];
              // K&T eq. 49 (AT1: Fracture::reaction)
              w[moments::reaction] = fr.reaction(history[p]) * V;
              w[moments::diffusion] = fr.diffusion() * V;
              if constexpr (Fourth)
              {
                // kappa_i^T gamma kappa_j (K&T eq. 57), gamma turned to the particle
                // (symmetric: one weight per pair of components).
                const Voigt& G = (*mine)(fr, phi[p]);
                const double e = 4.0 * fr.l0 * fr.l0 * fr.l0 * fr.l0 * V;
                w[2] = e * G[0]; // xx xx
                w[3] = e * G[4]; // yy yy
                w[4] = e * G[8]; // xy xy
                w[5] = e * G[1]; // xx yy
                w[6] = e * G[2]; // xx xy
                w[7] = e * G[5]; // yy xy
              }
              sums.add(s, w, fr.source() * V);
            });
        alignas(64) typename Moments::Block block;
        double f[K];
        const int* c = cell.index.data();
        const CellProducts* along = _products.data();
        const double* z_products = Dim == 3 ? along[Dim - 1].products(c[Dim - 1]) : nullptr;
        const double* z_values = Dim == 3 ? along[Dim - 1].values(c[Dim - 1]) : nullptr;
        sums.block(along[0].products(c[0]), along[1].products(c[1]), z_products, block);
        sums.rhs(along[0].values(c[0]), along[1].values(c[1]), z_values, f);
        for (int i = 0; i < K; ++i)
        {
          std::array<int, Dim> node;
          for (int d = 0; d < Dim; ++d)
            node[d] = c[d] + Shape::offset(i, d);
          _rhs[_nodes.index(node)] += f[i];
        }
        // Node i = (a, b) of the cell, row a W + b of the block, has its
        // stored row at padded(cx, cy) + a padded_ny + b; the row takes its
        // upper half, the nodes j = (a', b') after i (a' > a, or a' = a and
        // b' >= b). In 3D likewise with i = (a, b, c) and the pairs (b, b')
        // and (c, c') of the block's other directions. The bounds are
        // constants: the loops unroll to a straight run of additions.
        double* corner = &_stencil[padded(cell.index) * H];
        if constexpr (Dim == 2)
        {
          const std::size_t padded_ny = padded_n[1];
#pragma GCC unroll 4
          for (int ai = 0; ai < W; ++ai)
#pragma GCC unroll 4
            for (int bi = 0; bi < W; ++bi)
            {
              double* row = corner + (ai * padded_ny + bi) * H;
#pragma GCC unroll 4
              for (int aj = ai; aj < W; ++aj)
#pragma GCC unroll 4
                for (int bj = aj == ai ? bi : 0; bj < W; ++bj)
                  row[Stencil<P>::slot(aj - ai, bj - bi)] += block[ai * W + aj][bi * W + bj];
            }
        }
        else
        {
          const std::size_t ny = padded_n[1], nz = padded_n[2];
          for (int ai = 0; ai < W; ++ai)
            for (int bi = 0; bi < W; ++bi)
              for (int ci = 0; ci < W; ++ci)
              {
                double* row = corner + ((ai * ny + bi) * nz + ci) * H;
                for (int aj = ai; aj < W; ++aj)
                  for (int bj = 0; bj < W; ++bj)
                    for (int cj = 0; cj < W; ++cj)
                      if (const int k = Stencil<P>::slot(aj - ai, bj - bi, cj - ci); k >= 0)
                        row[k] += block[ai * W + aj][bi * W + bj][ci * W + cj];
              }
        }
      });

  // Nodes that no crackable particle touches keep c = 1: an identity row.
  // So do nodes that one touches so little that their diagonal is within
  // the round-off of the moments (moments.h), whose error scales with the
  // cell's heaviest particle: K_II <= 1e-10 of the largest diagonal of the
  // node's stencil. Round-off there can be larger than the entry itself,
  // of either sign, and a negative K_II makes K indefinite (seen at
  // -5e-11 beside 3e5, next to a particle of huge history). Such a node
  // moves a particle's c by at most its B-spline value there, about
  // 1e-5, so it is uncoupled: its row and column are zeroed.
  // (Only a node below the bound set by the largest diagonal of all looks
  // at its stencil.)
  const Stencil<P> stencil = this->template stencil<P>();
  const double* rows = _stencil.data();
  double heaviest = 0.0;
#pragma omp parallel for schedule(static) reduction(max : heaviest)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(na); ++a)
    heaviest = std::max(heaviest, rows[_position[a] * H]);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(na); ++a)
  {
    const std::size_t i = _position[a];
    const double d = rows[i * H];
    double largest = heaviest;
    if (!(d > negligible_diagonal * heaviest))
    {
      largest = 0.0;
      for (int k = 1; k < H; ++k)
        largest = std::max({largest, rows[(i + stencil.offset[k]) * H], rows[(i - stencil.offset[k]) * H]});
    }
    _diagonal[a] = d > negligible_diagonal * largest ? d : 0.0; // 0: uncoupled below
  }
  for (std::size_t a = 0; a < na; ++a) // few nodes, in order: no two write one entry at once
    if (_diagonal[a] == 0.0)
    {
      const std::size_t i = _position[a];
      double* row = &_stencil[i * H];
      for (int k = 1; k < H; ++k)
      {
        row[k] = 0.0;
        _stencil[(i - stencil.offset[k]) * H + k] = 0.0;
      }
      row[0] = _diagonal[a] = 1.0;
      _rhs[a] = 1.0;
    }
}

template <int Dim>
template <int P>
void PhaseField<Dim>::multiply(const std::vector<double>& in, std::vector<double>& out) const
{
  const Stencil<P> stencil = this->template stencil<P>();
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(out.size()); ++a)
    out[a] = row_product(stencil, a, in.data());
}

template <int Dim>
template <int P>
void PhaseField<Dim>::ssor_iterations(double stop, double& start, double& residual, int& it)
{
  const Stencil<P> stencil = this->template stencil<P>();
  const std::size_t na = _rhs.size();
  const auto strips = static_cast<std::ptrdiff_t>(_strip_column.size()) - 1;
  double* t = _search.data();  // the search direction p
  double* w = _forward.data(); // (D + L)^-1 (v - D t)
  const double* rows = _stencil.data();

  // f(a, left, right, even) for the nodes of strip s, forward or backward.
  // The held nodes are skipped: t and w stay 0 there.
  const std::int8_t* held = _bound.data();
  auto strip = [&](std::ptrdiff_t s, bool forward, auto&& f)
  {
    const int begin = _strip_column[s], end = _strip_column[s + 1];
    const bool even = s % 2 == 0;
    for (int n = 0; n < end - begin; ++n)
    {
      const int ix = forward ? begin + n : end - 1 - n;
      const int left = ix - begin, right = end - 1 - ix;
      if (forward)
      {
        for (std::size_t a = _column_start[ix]; a < _column_start[ix + 1]; ++a)
          if (held[a] == 0)
            f(a, left, right, even);
      }
      else
        for (std::size_t a = _column_start[ix + 1]; a-- > _column_start[ix];)
          if (held[a] == 0)
            f(a, left, right, even);
    }
  };

  // r = F - K c on the free nodes (K&T eq. 50), 0 on the held ones, as are
  // t, w, v, g and q, so that every update below leaves them 0.
  residual = std::sqrt(deterministic_sum<1>(na,
                                            [&](std::size_t a, std::array<double, 1>& acc)
                                            {
                                              const std::size_t i = _position[a];
                                              t[i] = 0.0;
                                              w[i] = 0.0;
                                              _q[a] = 0.0;
                                              _r[a] = held[a] == 0
                                                          ? _rhs[a] - row_product(stencil, a, _c.data())
                                                          : 0.0;
                                              acc[0] += _r[a] * _r[a];
                                            })[0]);
  start = residual;
  if (residual <= stop)
    return;

  // Strips of one parity share no entry of K (they are >= p columns apart),
  // so they are swept in parallel, in any order.
  // g = (D + L)^-1 r, v = D g, r . M^-1 r = g . D g.
#pragma omp parallel
  for (int parity = 0; parity < 2; ++parity)
  {
#pragma omp for schedule(dynamic)
    for (std::ptrdiff_t s = parity; s < strips; s += 2)
      strip(s, true, [&](std::size_t a, int left, int right, bool even)
            {
              const std::size_t i = _position[a];
              w[i] = subtract_neighbours<Dim, P, true, false>(stencil, rows, i, left, right, even,
                                                         _r[a], w)
                     * _inverse[a];
            });
  }
  double rz = deterministic_sum<1>(na,
                                   [&](std::size_t a, std::array<double, 1>& acc)
                                   {
                                     _g[a] = w[_position[a]];
                                     _v[a] = 0.0;
                                     acc[0] += _g[a] * _diagonal[a] * _g[a];
                                   })[0];
  double beta = 0.0; // the first direction is p~ = r~, v = D g
  while (residual > stop && it < _max_iterations)
  {
    ++it;
    // Eisenstat: t = (D + U)^-1 v backward, then forward w = (D + L)^-1 (v - D t),
    // so that K~ p~ = D^1/2 (t + w), and q = K t = L t + v in the same pass.
#pragma omp parallel
    {
      for (int parity = 1; parity >= 0; --parity)
      {
#pragma omp for schedule(dynamic)
        for (std::ptrdiff_t s = parity; s < strips; s += 2)
          strip(s, false, [&](std::size_t a, int left, int right, bool even)
                {
                  _v[a] = _diagonal[a] * _g[a] + beta * _v[a]; // p~ = r~ + beta p~
                  const std::size_t i = _position[a];
                  t[i] = subtract_neighbours<Dim, P, false, true>(stencil, rows, i, left, right,
                                                             even, _v[a], t)
                         * _inverse[a];
                });
      }
      for (int parity = 0; parity < 2; ++parity)
      {
#pragma omp for schedule(dynamic)
        for (std::ptrdiff_t s = parity; s < strips; s += 2)
          strip(s, true, [&](std::size_t a, int left, int right, bool even)
                {
                  const std::size_t i = _position[a];
                  // v - D t - (L w)_a and -(L t)_a
                  double b[2] = {_v[a] - _diagonal[a] * t[i], 0.0};
                  subtract_neighbours<Dim, P, true, false, 2>(stencil, rows, i, left, right, even,
                                                         {w, t}, b);
                  w[i] = b[0] * _inverse[a];
                  _q[a] = _v[a] - b[1];
                });
      }
    }
    // p~ . K~ p~ = v . (t + w); c += alpha t, r -= alpha K t, g -= alpha (t + w).
    const double pq = deterministic_sum<1>(
        na, [&](std::size_t a, std::array<double, 1>& acc)
        { acc[0] += _v[a] * (t[_position[a]] + w[_position[a]]); })[0];
    if (!(pq > 0.0)) // a breakdown: K is semi-definite to round-off; residual > stop tells the caller
      break;
    const double alpha = rz / pq;
    const auto rr = deterministic_sum<2>(
        na,
        [&](std::size_t a, std::array<double, 2>& acc)
        {
          const std::size_t i = _position[a];
          _c[i] += alpha * t[i];
          _r[a] -= alpha * _q[a];
          _g[a] -= alpha * (t[i] + w[i]);
          acc[0] += _r[a] * _r[a];
          acc[1] += _g[a] * _diagonal[a] * _g[a];
        });
    residual = std::sqrt(rr[0]);
    beta = rr[1] / rz;
    rz = rr[1];
  }
}

template <int Dim>
void PhaseField<Dim>::prepare_ssor()
{
  const std::vector<std::int32_t>& nodes = _nodes.nodes();
  const auto na = static_cast<std::ptrdiff_t>(_rhs.size());
  // About Multigrid's strip width of columns (2D) or planes (3D) per strip,
  // the number of strips a multiple of 4, so that two or four threads get as
  // many strips of each parity, and each strip at least p columns wide
  // (strips of one parity must not touch); widths differ by at most one.
  constexpr int multiple = 4, width = Multigrid<Dim>::strip;
  const int nx = _grid.nodes()[0];
  const std::size_t slab = static_cast<std::size_t>(_grid.num_nodes()) / static_cast<std::size_t>(nx);
  const int wanted = ((nx + width - 1) / width + multiple - 1) / multiple * multiple;
  const int strips = std::max(1, std::min(wanted, nx / _grid.degree()));
  _strip_column.resize(strips + 1);
  for (int s = 0; s <= strips; ++s)
    _strip_column[s] = static_cast<int>(static_cast<std::int64_t>(s) * nx / strips);
  _column_start.resize(nx + 1);
  for (int ix = 0; ix <= nx; ++ix)
    _column_start[ix] = static_cast<std::size_t>(
        std::lower_bound(nodes.begin(), nodes.end(), static_cast<std::int64_t>(ix * slab)) - nodes.begin());
  _inverse.resize(na);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < na; ++a)
    _inverse[a] = 1.0 / _diagonal[a];
  _v.resize(na);
  _g.resize(na);
}

/// PCG with z = B r, B one V-cycle of Multigrid (symmetric positive definite),
/// set up for this K only when the warm start has not yet converged.
template <int Dim>
template <int P>
void PhaseField<Dim>::multigrid_iterations(double norm_f, double stop, double& residual, int& it)
{
  const std::size_t na = _rhs.size();
  residual = std::sqrt(deterministic_sum<1>(na,
                                            [&](std::size_t a, std::array<double, 1>& acc)
                                            {
                                              _r[a] = _rhs[a] - _q[a];
                                              acc[0] += _r[a] * _r[a];
                                            })[0]);
  _stats.start_residual = norm_f > 0.0 ? residual / norm_f : 0.0;
  if (residual <= stop)
    return;
  _v.resize(na);
  _multigrid->template setup<P>(_stencil, _position);
  // z = B r and K z from the V-cycle; then p = z + beta p and K p = K z + beta K p.
  double* kz = _v.data();
  double rz = 0.0;
  for (;;)
  {
    _multigrid->template apply<P>(_r.data(), _z.data(), kz);
    const double rz_next = deterministic_sum<1>(
        na, [&](std::size_t a, std::array<double, 1>& acc) { acc[0] += _r[a] * _z[a]; })[0];
    const double beta = it == 0 ? 0.0 : rz_next / rz;
    rz = rz_next;
    ++it;
    const double pq = deterministic_sum<1>(
        na,
        [&](std::size_t a, std::array<double, 1>& acc)
        {
          double& p = _search[_position[a]];
          p = _z[a] + beta * p;
          _q[a] = kz[a] + beta * _q[a];
          acc[0] += p * _q[a];
        })[0];
    if (!(pq > 0.0)) // a breakdown: K is semi-definite to round-off; residual > stop tells the caller
      return;
    const double alpha = rz / pq;
    residual = std::sqrt(deterministic_sum<1>(na,
                                              [&](std::size_t a, std::array<double, 1>& acc)
                                              {
                                                _c[_position[a]] += alpha * _search[_position[a]];
                                                _r[a] -= alpha * _q[a];
                                                acc[0] += _r[a] * _r[a];
                                              })[0]);
    if (residual <= stop || it >= _max_iterations)
      return;
  }
}

template <int Dim>
double PhaseField<Dim>::rhs_norm() const
{
  return std::sqrt(deterministic_sum<1>(_rhs.size(), [&](std::size_t a, std::array<double, 1>& acc)
                                        { acc[0] += _rhs[a] * _rhs[a]; })[0]);
}

template <int Dim>
double PhaseField<Dim>::warm_start(std::size_t i)
{
  const double trend = _stats.solves >= 2 ? 1.0 : 0.0;
  const double now = _c[i];
  const double guess = now + trend * (now - _c_previous[i]);
  _c_previous[i] = now;
  return guess;
}

/// Preconditioned conjugate gradients for K c = F (K&T eq. 50), from the warm
/// start until ||F - K c|| <= tol ||F||, with the preconditioner of
/// set_preconditioner(). (The second-order model with the bound, its
/// default, is solved by bounded_solve, whose passes run the same Jacobi or
/// Gauss-Seidel iterations on the free nodes; here every node is free.)
///
/// By default the second-order model takes symmetric Gauss-Seidel (SSOR with
/// omega = 1, ssor_iterations): with K = L + D + U in the Gauss-Seidel order,
/// M = (D + L) D^-1 (D + U), symmetric positive definite since D > 0. The
/// order: strips of about sweep_strip (32) grid columns (prepare_ssor), the
/// even strips first, then the odd ones, each strip column by column; strips
/// of one parity share no entry of K, so they are swept in parallel and the
/// result does not depend on the number of threads. It is applied with
/// Eisenstat's trick (Eisenstat 1981): CG on K~ = E^-1 K E^-T, E = (D + L)
/// D^-1/2, whose product is one backward and one forward sweep, about the
/// cost of one product with K, instead of two sweeps and a product; c and the true residual r = F - K c are updated alongside.
/// The CG scalars are those of PCG with M: 4.65 iterations per solve on the
/// default Borden plate to 40 us against 12.8 with Jacobi, z = D^-1 r
/// (free_set_iterations), and 7.8 against 25.7 over the whole
/// paper-resolution run (docs/performance/phase-field.md).
///
/// The fourth-order model, whose condition number grows like
/// gamma_n (l0/h)^4, takes the multigrid V-cycle by default
/// (multigrid_iterations, Multigrid), a few iterations where Gauss-Seidel
/// takes hundreds (docs/performance/fourth-order.md).
template <int Dim>
template <int P, bool Fourth>
bool PhaseField<Dim>::conjugate_gradient()
{
  const std::size_t na = _rhs.size();
  const double norm_f = rhs_norm();
  const double stop = _tol * norm_f;

  // The warm start, not clamped to [0, 1]: B-spline control values may lie outside it.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(na); ++a)
    _c[_position[a]] = warm_start(_position[a]);

  double residual = 0.0;
  int it = 0;
  if (preconditioner() == Preconditioner::multigrid)
  {
    multiply<P>(_c, _q); // the residual of the warm start, r = F - K c (K&T eq. 50)
    multigrid_iterations<P>(norm_f, stop, residual, it);
  }
  else // the bounded solve's CG with every node free
  {
    _bound.assign(na, 0);
    list_free();
    double start = 0.0;
    free_set_solve<P>(stop, start, residual, it);
    _stats.start_residual = norm_f > 0.0 ? start / norm_f : 0.0;
  }
  _stats.solves += 1;
  _stats.iterations += it;
  _stats.last_iterations = it;
  _stats.last_residual = norm_f > 0.0 ? residual / norm_f : 0.0;
  _stats.unknowns = static_cast<std::int32_t>(na);
  return residual <= stop;
}

/// K c = F (K&T eq. 50) with the bound 0 <= c <= 1 at every active node: AT1
/// needs it (without it its equation has no solution where H = 0, and c
/// would exceed 1 where H is small), and for both models it keeps
/// c_p = sum N_I c_I, a convex combination of nodal values, in [0, 1]
/// (unbounded, AT2's nodal values undershoot below 0 next to a band of huge
/// history).
///
/// K is symmetric positive semi-definite, so this is the minimisation of
/// c.K c / 2 - F.c over the box, whose optimality conditions are, with the
/// multiplier r = F - K c: r_I = 0 where 0 < c_I < 1, r_I >= 0 where
/// c_I = 1 and r_I <= 0 where c_I = 0. The primal-dual active-set method
/// (Hintermüller, Ito & Kunisch 2002; for phase-field fracture Heister,
/// Wheeler & Wick 2015) solves them by passes:
/// 1. warm start as conjugate_gradient, projected onto [0, 1]; nodes on a
///    bound are held there only if their multiplier pushes them outwards by
///    more than tol K_II (update_active_set with the margin -tol): a node that
///    no history reaches, where r = 0 up to round-off of either sign, starts
///    free, so a cold start does not release the nodes one layer per pass;
/// 2. update_active_set with r at the current c;
/// 3. CG on the free nodes, the held ones as identity rows with their bound
///    as right-hand side (free_set_solve: preconditioned by symmetric
///    Gauss-Seidel or Jacobi, the held nodes skipped by the sweeps), to
///    ||r_free|| <= tol ||F||;
/// 4. r = F - K c and update_active_set again; stop when no node changes,
///    else back to 3.
/// The updates of steps 1 and 4 read r only at the held nodes (a free node
/// is held when c leaves the box, which c alone tells), so K c is formed
/// there alone (held_products; 1.5 % of the rows on the paper-resolution
/// Borden plate), not by a full product, which costs a CG iteration; step 3
/// starts from the true residual on the free nodes.
/// Each pass is warm-started from the last, and a step's first pass from
/// the last step's solution, so after the first steps one or two passes
/// suffice; a cold start (an initial crack at t = 0) takes about one pass
/// per two grid spacings of the AT1 band's half-width 4 l0, as each pass
/// releases the nodes next to the damaged ones.
///
/// The passes converge for an M-matrix, which K is not: the B-spline mass
/// term has positive off-diagonal entries, and at a node that a particle
/// barely touches K_II is 1e-16 of its neighbours'. There the passes can
/// cycle, a node's multiplier changing sign each time it is held or freed
/// (two bodies in contact, where particles sit anywhere in their cells, do
/// this: docs/performance/bounded.md). So the solve hands the current c over to
/// MPRGP (mprgp.h), which lowers the energy at every step and provably
/// converges, when a pass returns to an active set that an earlier pass of
/// this solve had, when CG on the free nodes does not reach the tolerance,
/// or after max_passes passes.
///
/// Every update is per node and every sum is a deterministic_sum, so the
/// result has the same bits on any number of threads. The CG iterations of
/// each pass, and those of MPRGP, are each limited to max_iterations.
template <int Dim>
template <int P>
bool PhaseField<Dim>::bounded_solve()
{
  const std::size_t na = _rhs.size();
  const double norm_f = rhs_norm();
  const double stop = _tol * norm_f;

  // The warm start, projected onto the bounds.
  _bound.resize(na);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(na); ++a)
  {
    const std::size_t i = _position[a];
    const double c = std::clamp(warm_start(i), 0.0, 1.0);
    _c[i] = c;
    _bound[a] = c == 1.0 ? 1 : c == 0.0 ? -1 : 0;
  }
  held_products<P>();
  update_active_set(-_tol);

  // The active sets of this solve's passes, by their hashes (a collision
  // only hands over to MPRGP early).
  auto active_set = [&]()
  {
    std::uint64_t h = 14695981039346656037ull; // FNV-1a
    for (const std::int8_t b : _bound)
    {
      h ^= static_cast<std::uint8_t>(b);
      h *= 1099511628211ull;
    }
    return h;
  };
  std::vector<std::uint64_t> seen{active_set()};
  double residual = 0.0;
  int it = 0, passes = 0;
  bool settled = false;
  while (!settled)
  {
    ++passes;
    double start = 0.0;
    int pass_it = 0;
    free_set_solve<P>(stop, start, residual, pass_it);
    it += pass_it;
    if (passes == 1)
      _stats.start_residual = norm_f > 0.0 ? start / norm_f : 0.0;
    if (residual > stop)
      break; // CG ran out of iterations
    held_products<P>();
    settled = update_active_set(_tol) == 0;
    if (!settled)
    {
      const std::uint64_t h = active_set();
      if (passes == max_passes || std::find(seen.begin(), seen.end(), h) != seen.end())
        break; // cycling, or no end in sight
      seen.push_back(h);
    }
  }
  if (!settled) // MPRGP from here
  {
    std::fill(_search.begin(), _search.end(), 0.0);
    const StencilSystem<Dim, P> system{this->template stencil<P>(), _stencil.data(), _position.data(),
                                  _diagonal.data(), _rhs.data(), na};
    const MprgpResult r = mprgp<Dim, P>(system, _c.data(), _search.data(), _r, _q, stop, _tol, _max_iterations);
    it += r.iterations;
    residual = r.residual;
    settled = r.converged;
    _stats.handovers += 1;
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(na); ++a)
    {
      const double c = _c[_position[a]];
      _bound[a] = c == 1.0 ? 1 : c == 0.0 ? -1 : 0;
    }
    list_free();
  }
  _stats.solves += 1;
  _stats.iterations += it;
  _stats.last_iterations = it;
  _stats.passes += passes;
  _stats.last_passes = passes;
  _stats.last_residual = norm_f > 0.0 ? residual / norm_f : 0.0;
  _stats.unknowns = static_cast<std::int32_t>(na);
  _stats.at_bound = static_cast<std::int32_t>(na - _free.size());
  return settled;
}

template <int Dim>
template <int P>
void PhaseField<Dim>::held_products()
{
  const Stencil<P> stencil = this->template stencil<P>();
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < static_cast<std::ptrdiff_t>(_bound.size()); ++a)
    if (_bound[a] != 0)
      _q[a] = row_product(stencil, a, _c.data());
}

template <int Dim>
std::int64_t PhaseField<Dim>::update_active_set(double margin)
{
  const auto na = static_cast<std::ptrdiff_t>(_rhs.size());
  std::int64_t changed = 0;
#pragma omp parallel for schedule(static) reduction(+ : changed)
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    const std::size_t i = _position[a];
    std::int8_t b = _bound[a];
    if (b != 0)
    {
      // The multiplier r_a over K_aa: how far a Jacobi step would move c_a.
      // Released when it pulls the node into the box by at least the margin.
      const double step = (_rhs[a] - _q[a]) / _diagonal[a];
      if ((b == 1 && step <= -margin) || (b == -1 && step >= margin))
        b = 0;
    }
    else if (_c[i] > 1.0 || _c[i] < 0.0)
      b = _c[i] > 1.0 ? 1 : -1; // hold it on the bound it crossed
    if (b != _bound[a])
    {
      ++changed;
      _bound[a] = b;
      if (b != 0)
        _c[i] = b > 0 ? 1.0 : 0.0;
    }
  }
  list_free();
  return changed;
}

template <int Dim>
void PhaseField<Dim>::list_free()
{
  _free.clear();
  _free_node.clear();
  _free_diagonal.clear();
  for (std::size_t a = 0; a < _bound.size(); ++a)
    if (_bound[a] == 0)
    {
      _free.push_back(a);
      _free_node.push_back(static_cast<std::uint32_t>(_position[a]));
      _free_diagonal.push_back(_diagonal[a]);
    }
}

template <int Dim>
template <int P>
void PhaseField<Dim>::free_set_solve(double stop, double& start, double& residual, int& it)
{
  if (preconditioner() == Preconditioner::ssor)
  {
    prepare_ssor();
    ssor_iterations<P>(stop, start, residual, it);
  }
  else
    free_set_iterations<P>(stop, start, residual, it);
}

template <int Dim>
template <int P>
void PhaseField<Dim>::free_set_iterations(double stop, double& start, double& residual, int& it)
{
  const std::size_t nf = _free.size();
  const Stencil<P> stencil = this->template stencil<P>();
  const double* rows = _stencil.data();
  const std::uint32_t* node = _free_node.data(); // padded positions of the free nodes
  const double* diagonal = _free_diagonal.data();
  // The search direction is zero on the held nodes, so K p touches only the
  // free ones: CG on K restricted to them.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(_search.size()); ++k)
    _search[k] = 0.0;
  auto rr = deterministic_sum<2>(
      nf,
      [&](std::size_t k, std::array<double, 2>& acc)
      {
        // K&T eq. 50
        _r[k] = _rhs[_free[k]] - pfmpm::row_product(stencil, rows, node[k], _c.data());
        _z[k] = _r[k] / diagonal[k];
        _search[node[k]] = _z[k];
        acc[0] += _r[k] * _r[k];
        acc[1] += _r[k] * _z[k];
      });
  residual = std::sqrt(rr[0]);
  start = residual;
  double rz = rr[1];
  while (residual > stop && it < _max_iterations)
  {
    ++it;
    const double pq = deterministic_sum<1>(
        nf,
        [&](std::size_t k, std::array<double, 1>& acc)
        {
          _q[k] = pfmpm::row_product(stencil, rows, node[k], _search.data());
          acc[0] += _search[node[k]] * _q[k];
        })[0];
    if (!(pq > 0.0)) // a breakdown: K is semi-definite to round-off; residual > stop tells the caller
      break;
    const double alpha = rz / pq;
    rr = deterministic_sum<2>(
        nf,
        [&](std::size_t k, std::array<double, 2>& acc)
        {
          const std::size_t i = node[k];
          _c[i] += alpha * _search[i];
          _r[k] -= alpha * _q[k];
          _z[k] = _r[k] / diagonal[k];
          acc[0] += _r[k] * _r[k];
          acc[1] += _r[k] * _z[k];
        });
    residual = std::sqrt(rr[0]);
    const double beta = rr[1] / rz;
    rz = rr[1];
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(nf); ++k)
    {
      const std::size_t i = node[k];
      _search[i] = _z[k] + beta * _search[i];
    }
  }
}

/// c_p (K&T eq. 53) at the particles; with Energy their fracture energy too,
/// which the step reads nowhere: the solver asks for it in the last step of
/// each advance(), after which energies and output read it.
template <int Dim>
template <int P, bool Fourth, bool Energy>
void PhaseField<Dim>::map_to_particles(Particles& particles, const CellSort& sort)
{
  using Shape = BSplineStencil<Dim, P, Fourth && Energy ? 2 : 1>;
  constexpr int K = Shape::size;
  const double* volume = particles.volume.data();
  const double* phi = Fourth ? particles.f64("phi").data() : nullptr;
  const std::int32_t* material = particles.material.data();
  double* c = particles.f64("c").data();
  double* energy = particles.f64("fracture_energy").data();
  [[maybe_unused]] std::vector<RotatedGamma> rotated = per_thread(Fourth && Energy);

  grid_to_particle<Shape>(
      _grid, sort, Points{particles.x.data()},
      unreduced(
          [&](const Cell<Dim>& cell, const auto& each)
          {
            double nodal[K][1];
            [[maybe_unused]] RotatedGamma* mine =
                Fourth && Energy ? &rotated[omp_get_thread_num()] : nullptr;
            for (int i = 0; i < K; ++i)
            {
              std::array<int, Dim> node;
              for (int d = 0; d < Dim; ++d)
                node[d] = cell.index[d] + Shape::offset(i, d);
              nodal[i][0] = _c[padded(node)];
            }
            each(
                [&](std::size_t p, const Shape& s)
                {
                  if constexpr (!Energy)
                  {
                    double cp[1];
                    s.template interpolate<1>(nodal, cp); // K&T eq. 53
                    c[p] = cp[0];
                  }
                  else
                  {
                    const Fracture& fr = *fracture(material[p]);
                    // c_p (K&T eq. 53) and its gradient (K&T eq. 54), with the fourth
                    // order its second derivatives kappa (K&T eq. 55).
                    double cp[1], g[Dim][1];
                    [[maybe_unused]] double kappa[3][1];
                    if constexpr (Fourth)
                      s.template interpolate<1>(nodal, cp, g, kappa);
                    else
                      s.template interpolate<1>(nodal, cp, g);
                    c[p] = cp[0];
                    // G_c V Z with Z of K&T eq. 4 (AT1: Fracture::crack_density).
                    double grad2 = g[0][0] * g[0][0];
                    for (int d = 1; d < Dim; ++d)
                      grad2 += g[d][0] * g[d][0];
                    double Z = fr.crack_density(cp[0], grad2);
                    if constexpr (Fourth) // zero for a material with gamma = 0
                      Z += fr.l0 * fr.l0 * fr.l0
                           * curvature_energy((*mine)(fr, phi[p]), kappa[0][0], kappa[1][0],
                                              kappa[2][0]);
                    energy[p] = fr.Gc * volume[p] * Z;
                  }
                });
          }));
}

template class PhaseField<2>;
template class PhaseField<3>;
template bool PhaseField<2>::solve<1>(Particles&, const CellSort&, bool);
template bool PhaseField<2>::solve<2>(Particles&, const CellSort&, bool);
template bool PhaseField<2>::solve<3>(Particles&, const CellSort&, bool);
template bool PhaseField<3>::solve<1>(Particles&, const CellSort&, bool);
template bool PhaseField<3>::solve<2>(Particles&, const CellSort&, bool);
template bool PhaseField<3>::solve<3>(Particles&, const CellSort&, bool);

} // namespace pfmpm
