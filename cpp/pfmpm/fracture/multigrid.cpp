/// @file multigrid.cpp
/// @brief Geometric multigrid on the B-spline grid for the phase-field CG.
#include "pfmpm/fracture/multigrid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace pfmpm
{

namespace
{
/// Loops over fewer nodes than this run on one thread: the coarse levels are
/// too small to pay for a parallel region.
constexpr std::size_t parallel_nodes = 8192;

/// Open knot vector in units of the fine cell: `cells` cells of size `step`,
/// the ends repeated p + 1 times.
std::vector<double> open_knots(int cells, int p, int step)
{
  std::vector<double> t(p + 1, 0.0);
  for (int k = 1; k < cells; ++k)
    t.push_back(double(k) * step);
  t.insert(t.end(), p + 1, double(cells) * step);
  return t;
}
} // namespace

Refinement::Refinement(int cells, int degree_) : degree(degree_)
{
  if (cells < 1)
    throw std::invalid_argument("Refinement: cells = " + std::to_string(cells) + ": must be >= 1");
  if (degree < 1 || degree > 3)
    throw std::invalid_argument("Refinement: degree = " + std::to_string(degree)
                                + ": must be 1, 2 or 3");
  const int p = degree, W = width();
  fine = cells + p;
  // One cell cannot be halved: the identity.
  std::vector<double> alpha; // coarse x extended fine, row-major
  int nf = fine;
  if (cells == 1)
  {
    coarse = fine;
    alpha.assign(std::size_t(coarse) * nf, 0.0);
    for (int j = 0; j < coarse; ++j)
      alpha[std::size_t(j) * nf + j] = 1.0;
  }
  else
  {
    const int m = (cells + 1) / 2;
    coarse = m + p;
    const std::vector<double> t = open_knots(m, p, 2);
    std::vector<double> tau = open_knots(cells, p, 1);
    // An odd fine grid ends inside the last coarse cell: extend the fine knots
    // with a (p + 1)-fold knot at the coarse end, so that they contain the
    // coarse ones; the functions of the extension are dropped below.
    if (cells % 2 == 1)
      tau.insert(tau.end(), p + 1, double(2 * m));
    nf = static_cast<int>(tau.size()) - p - 1;
    // The Oslo algorithm: discrete B-splines alpha_{j,k}(i) with
    // alpha_{j,0}(i) = [t_j <= tau_i < t_{j+1}] and
    // alpha_{j,k}(i) = (tau_{i+k} - t_j) / (t_{j+k} - t_j) alpha_{j,k-1}(i)
    //                + (t_{j+k+1} - tau_{i+k}) / (t_{j+k+1} - t_{j+1}) alpha_{j+1,k-1}(i),
    // a term with a zero denominator taken as zero; N_j = sum_i alpha_{j,p}(i) n_i.
    int rows = coarse + p; // j at k = 0
    std::vector<double> a(std::size_t(rows) * nf, 0.0);
    for (int j = 0; j < rows; ++j)
      for (int i = 0; i < nf; ++i)
        a[std::size_t(j) * nf + i] = (t[j] <= tau[i] && tau[i] < t[j + 1]) ? 1.0 : 0.0;
    for (int k = 1; k <= p; ++k)
    {
      --rows;
      std::vector<double> b(std::size_t(rows) * nf, 0.0);
      for (int j = 0; j < rows; ++j)
      {
        const double d1 = t[j + k] - t[j], d2 = t[j + k + 1] - t[j + 1];
        for (int i = 0; i < nf; ++i)
        {
          double v = 0.0;
          if (d1 > 0.0)
            v += (tau[i + k] - t[j]) / d1 * a[std::size_t(j) * nf + i];
          if (d2 > 0.0)
            v += (t[j + k + 1] - tau[i + k]) / d2 * a[std::size_t(j + 1) * nf + i];
          b[std::size_t(j) * nf + i] = v;
        }
      }
      a.swap(b);
    }
    alpha.swap(a);
  }

  // Per coarse function its run of nonzero fine weights, and per fine
  // function its run of coarse ones: for each of n rows of R(row, k),
  // k < m, the first k, the run's length and its values.
  auto runs = [W](int n, int m, auto R, std::vector<int>& lo_of, std::vector<int>& length,
                  std::vector<double>& values)
  {
    lo_of.assign(n, 0);
    length.assign(n, 0);
    values.assign(std::size_t(n) * W, 0.0);
    for (int row = 0; row < n; ++row)
    {
      int lo = m, hi = -1;
      for (int k = 0; k < m; ++k)
        if (R(row, k) != 0.0)
        {
          lo = std::min(lo, k);
          hi = std::max(hi, k);
        }
      if (hi < lo || hi - lo + 1 > W)
        throw std::logic_error("Refinement: function " + std::to_string(row)
                               + " has no run of at most 2p + 1 nonzero weights");
      lo_of[row] = lo;
      length[row] = hi - lo + 1;
      for (int k = lo; k <= hi; ++k)
        values[std::size_t(row) * W + (k - lo)] = R(row, k);
    }
  };
  runs(coarse, fine, [&](int j, int i) { return alpha[std::size_t(j) * nf + i]; }, first, count,
       weight);
  runs(fine, coarse, [&](int i, int j) { return alpha[std::size_t(j) * nf + i]; }, first_coarse,
       count_t, weight_t);
}

Multigrid::Multigrid(std::array<int, 2> cells, int degree, int direct_size)
    : _degree(degree), _direct_size(direct_size)
{
  if (degree < 1 || degree > 3)
    throw std::invalid_argument("multigrid: degree = " + std::to_string(degree)
                                + ": must be 1, 2 or 3");
  if (cells[0] < 1 || cells[1] < 1)
    throw std::invalid_argument("multigrid: the grid needs at least one cell each way");
  if (direct_size < 1)
    throw std::invalid_argument("multigrid: direct_size = " + std::to_string(direct_size)
                                + ": must be >= 1");
  // The geometry of every level down to one cell each way; setup() decides
  // how many of them a system uses.
  for (;;)
  {
    Level level;
    level.nx = cells[0] + degree;
    level.ny = cells[1] + degree;
    level.padded_ny = static_cast<std::size_t>(level.ny + 2 * degree);
    level.padded_size = static_cast<std::size_t>(level.nx + 2 * degree) * level.padded_ny;
    const bool last = cells[0] == 1 && cells[1] == 1;
    if (!last)
    {
      level.refine.emplace_back(cells[0], degree);
      level.refine.emplace_back(cells[1], degree);
    }
    _levels.push_back(std::move(level));
    if (last)
      break;
    cells = {(cells[0] + 1) / 2, (cells[1] + 1) / 2};
  }
}

std::vector<std::int64_t> Multigrid::unknowns() const
{
  std::vector<std::int64_t> out;
  for (std::size_t l = 0; l <= _coarsest && l < _levels.size(); ++l)
    out.push_back(static_cast<std::int64_t>(_levels[l].live.size()));
  return out;
}

double Multigrid::entry(std::size_t level, int ix, int iy, int dx, int dy) const
{
  if (level > _coarsest)
    throw std::out_of_range("multigrid: level " + std::to_string(level) + " of "
                            + std::to_string(_coarsest + 1));
  switch (_degree)
  {
  case 1:
    return stencil_entry<1>(_levels[level], ix, iy, dx, dy);
  case 2:
    return stencil_entry<2>(_levels[level], ix, iy, dx, dy);
  default:
    return stencil_entry<3>(_levels[level], ix, iy, dx, dy);
  }
}

template <int P>
double Multigrid::stencil_entry(const Level& level, int ix, int iy, int dx, int dy) const
{
  constexpr int H = SymmetricStencil<2, P>::size;
  if (std::abs(dx) > P || std::abs(dy) > P)
    throw std::out_of_range("multigrid: offset beyond the stencil");
  const int jx = ix + dx, jy = iy + dy;
  if (!level.rows || ix < 0 || ix >= level.nx || iy < 0 || iy >= level.ny || jx < 0
      || jx >= level.nx || jy < 0 || jy >= level.ny)
    return 0.0;
  if (const int k = SymmetricStencil<2, P>::slot(dx, dy); k >= 0)
    return level.rows[padded(level, ix, iy) * H + k];
  return level.rows[padded(level, jx, jy) * H + SymmetricStencil<2, P>::slot(-dx, -dy)];
}

void Multigrid::number_unknowns(Level& level) const
{
  // The unknowns are in increasing padded order, column by column.
  level.column_start.resize(level.nx + 1);
  for (int ix = 0; ix <= level.nx; ++ix)
    level.column_start[ix] = static_cast<std::size_t>(
        std::lower_bound(level.live.begin(), level.live.end(), padded(level, ix, -_degree))
        - level.live.begin());
}

template <int P>
void Multigrid::setup(const std::vector<double>& rows, const std::vector<std::size_t>& position)
{
  constexpr int H = SymmetricStencil<2, P>::size;
  Level& f = _levels[0];
  if (rows.size() != f.padded_size * H)
    throw std::invalid_argument("multigrid: the stencil does not fit the grid");
  f.rows = rows.data();
  f.live = position;
  number_unknowns(f);
  const auto n = static_cast<std::ptrdiff_t>(f.live.size());
  f.coupled.assign(f.padded_size, 0);
  f.x.assign(f.padded_size, 0.0);
  f.b.assign(f.padded_size, 0.0);
  f.r.assign(f.padded_size, 0.0);
  f.inverse.resize(f.live.size());
  _delta.assign(f.padded_size, 0.0);
  const SymmetricStencil<2, P> stencil(f.padded_ny);
  // A row with no off-diagonal entry (a node no crackable particle touches)
  // is solved exactly by the smoother and stays out of the coarse correction.
#pragma omp parallel for schedule(static) if (f.live.size() > parallel_nodes)
  for (std::ptrdiff_t u = 0; u < n; ++u)
  {
    const std::size_t i = f.live[u];
    bool coupled = false;
    for (int k = 1; k < H && !coupled; ++k)
      coupled = f.rows[i * H + k] != 0.0 || f.rows[(i - stencil.offset[k]) * H + k] != 0.0;
    f.coupled[i] = coupled;
    f.inverse[u] = 1.0 / f.rows[i * H];
  }

  _coarsest = 0;
  while (_levels[_coarsest].live.size() > static_cast<std::size_t>(_direct_size)
         && _coarsest + 1 < _levels.size())
  {
    galerkin<P>(_levels[_coarsest], _levels[_coarsest + 1]);
    ++_coarsest;
  }
  factor_coarsest<P>();
}

namespace
{
/// at[dx * U + dy] += w K_{i, i + (dx, dy)} over K's (2p+1)^2-point stencil
/// at padded node i, K stored in `rows`, for `at` in a window of rows of U.
template <int P, int U, std::size_t... K>
void add_row(double* at, double w, const double* rows, std::size_t i,
             const SymmetricStencil<2, P>& stencil, std::index_sequence<K...>)
{
  constexpr int H = SymmetricStencil<2, P>::size;
  using S = SymmetricStencil<2, P>;
  at[0] += w * rows[i * H];
  ((at[S::column(K + 1) * U + S::row(K + 1)] += w * rows[i * H + K + 1],
    at[-(S::column(K + 1) * U + S::row(K + 1))] += w * rows[(i - stencil.offset[K + 1]) * H + K + 1]),
   ...);
}
} // namespace

/// The Galerkin operator K_2h = P^T K_h P (P = R_x (x) R_y restricted to the
/// coupled fine nodes), row by row: for coarse J, u = K_h P e_J on the fine
/// nodes within p of P e_J's support, then K_2h(J, L) = (P e_L) . u for the
/// upper half of J's stencil. With nested spaces this is K&T eq. 57 assembled from
/// the same particles with the coarse basis. Each coarse row is written by one
/// thread, its terms summed in a fixed order.
template <int P>
void Multigrid::galerkin(const Level& fine, Level& coarse)
{
  constexpr int H = SymmetricStencil<2, P>::size;
  constexpr int W = Refinement::width(P); // fine functions per coarse one, at most
  constexpr int U = W + 2 * P;            // the window of u, per direction
  const SymmetricStencil<2, P> fs(fine.padded_ny), cs(coarse.padded_ny);
  const Refinement& rx = fine.refine[0];
  const Refinement& ry = fine.refine[1];
  coarse.stencil.assign(coarse.padded_size * H, 0.0);
  coarse.rows = coarse.stencil.data();
  const std::size_t fine_nodes = fine.live.size();

#pragma omp parallel for schedule(static) if (fine_nodes > parallel_nodes)
  for (int jx = 0; jx < coarse.nx; ++jx)
    for (int jy = 0; jy < coarse.ny; ++jy)
    {
      const int x0 = rx.first[jx] - P, y0 = ry.first[jy] - P; // window origin
      double u[U][U] = {};
      bool touched = false;
      for (int a = 0; a < rx.count[jx]; ++a)
        for (int b = 0; b < ry.count[jy]; ++b)
        {
          const std::size_t i = padded(fine, rx.first[jx] + a, ry.first[jy] + b);
          if (!fine.coupled[i])
            continue;
          touched = true;
          const double w = rx.weight[std::size_t(jx) * W + a] * ry.weight[std::size_t(jy) * W + b];
          add_row<P, U>(&u[a + P][b + P], w, fine.rows, i, fs, std::make_index_sequence<H - 1>{});
        }
      if (!touched)
        continue;
      double* out = &coarse.stencil[padded(coarse, jx, jy) * H];
      for (int k = 0; k < H; ++k)
      {
        const int lx = jx + cs.d[k][0], ly = jy + cs.d[k][1];
        if (lx >= coarse.nx || ly < 0 || ly >= coarse.ny)
          continue;
        double sum = 0.0;
        for (int a = 0; a < rx.count[lx]; ++a)
        {
          const int wx = rx.first[lx] + a - x0;
          if (wx < 0 || wx >= U)
            continue;
          double column = 0.0;
          for (int b = 0; b < ry.count[ly]; ++b)
          {
            const int wy = ry.first[ly] + b - y0;
            if (wy >= 0 && wy < U)
              column += ry.weight[std::size_t(ly) * W + b] * u[wx][wy];
          }
          sum += rx.weight[std::size_t(lx) * W + a] * column;
        }
        out[k] = sum;
      }
    }

  // The unknowns: nodes with a nonzero diagonal, i.e. a coupled fine node in their support.
  coarse.live.clear();
  for (int jx = 0; jx < coarse.nx; ++jx)
    for (int jy = 0; jy < coarse.ny; ++jy)
      if (const std::size_t j = padded(coarse, jx, jy); coarse.stencil[j * H] > 0.0)
        coarse.live.push_back(j);
  number_unknowns(coarse);
  coarse.coupled.assign(coarse.padded_size, 0);
  coarse.inverse.resize(coarse.live.size());
  for (std::size_t u = 0; u < coarse.live.size(); ++u)
  {
    coarse.coupled[coarse.live[u]] = 1;
    coarse.inverse[u] = 1.0 / coarse.stencil[coarse.live[u] * H];
  }
  coarse.x.assign(coarse.padded_size, 0.0);
  coarse.b.assign(coarse.padded_size, 0.0);
  coarse.r.assign(coarse.padded_size, 0.0);
}

/// The coarsest level's Cholesky factor in band storage, unknowns in their
/// column-by-column order. A pivot that vanishes (a direction in which the
/// Galerkin operator is singular, possible where the coupled fine nodes are
/// too few to tell coarse functions apart) drops that unknown: the solve
/// leaves it zero.
template <int P>
void Multigrid::factor_coarsest()
{
  constexpr int H = SymmetricStencil<2, P>::size;
  Level& c = _levels[_coarsest];
  const SymmetricStencil<2, P> stencil(c.padded_ny);
  const std::size_t n = c.live.size();
  std::vector<std::ptrdiff_t> index(c.padded_size, -1);
  for (std::size_t u = 0; u < n; ++u)
    index[c.live[u]] = static_cast<std::ptrdiff_t>(u);
  // The band: the farthest upper-half neighbour among the unknowns.
  _band = 0;
  for (std::size_t u = 0; u < n; ++u)
    for (int k = 1; k < H; ++k)
      if (const std::ptrdiff_t v = index[c.live[u] + stencil.offset[k]]; v >= 0)
        _band = std::max(_band, static_cast<std::size_t>(v) - u);
  const std::size_t B = _band + 1;
  // Row v of the lower triangle: entry (v, u) at v * B + (u + band - v).
  _factor.assign(n * B, 0.0);
  for (std::size_t u = 0; u < n; ++u)
  {
    const double* row = &c.rows[c.live[u] * H];
    _factor[u * B + _band] = row[0];
    for (int k = 1; k < H; ++k)
      if (const std::ptrdiff_t v = index[c.live[u] + stencil.offset[k]]; v >= 0)
        _factor[std::size_t(v) * B + (u + _band - std::size_t(v))] = row[k];
  }
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::size_t j0 = i >= _band ? i - _band : 0;
    for (std::size_t j = j0; j <= i; ++j)
    {
      double s = _factor[i * B + (j + _band - i)];
      const std::size_t k0 = std::max(j0, j >= _band ? j - _band : 0);
      for (std::size_t k = k0; k < j; ++k)
        s -= _factor[i * B + (k + _band - i)] * _factor[j * B + (k + _band - j)];
      if (j < i)
      {
        const double d = _factor[j * B + _band];
        _factor[i * B + (j + _band - i)] = d > 0.0 ? s / d : 0.0;
      }
      else
      {
        const double diagonal = c.rows[c.live[i] * H];
        _factor[i * B + _band] = s > 1e-12 * diagonal ? std::sqrt(s) : 0.0;
      }
    }
  }
}

void Multigrid::solve_coarsest()
{
  Level& c = _levels[_coarsest];
  const std::size_t n = c.live.size(), B = _band + 1;
  std::vector<double>& y = _scratch;
  y.resize(n);
  for (std::size_t i = 0; i < n; ++i) // L y = b
  {
    const double d = _factor[i * B + _band];
    double s = c.b[c.live[i]];
    for (std::size_t k = i >= _band ? i - _band : 0; k < i; ++k)
      s -= _factor[i * B + (k + _band - i)] * y[k];
    y[i] = d > 0.0 ? s / d : 0.0;
  }
  for (std::size_t i = n; i-- > 0;) // L^T x = y
  {
    const double d = _factor[i * B + _band];
    double s = y[i];
    for (std::size_t k = i + 1; k < std::min(n, i + B); ++k)
      s -= _factor[k * B + (i + _band - k)] * y[k];
    y[i] = d > 0.0 ? s / d : 0.0;
  }
  for (std::size_t i = 0; i < n; ++i)
    c.x[c.live[i]] = y[i];
}

/// f(u, left, right, even) for the unknowns u of `level` in the Gauss-Seidel
/// order (Ordered), or in any order with all strips at once. `left` and
/// `right`: the columns of u's strip on either side of u's, `even` whether
/// the strip is. Forward: strip by strip, even strips first, each column by
/// column upwards; backward: the reverse.
template <bool Ordered, class F>
void Multigrid::strips(const Level& level, bool forward, F&& f) const
{
  const int strips = (level.nx + sweep_strip - 1) / sweep_strip;
  auto strip = [&](int s)
  {
    const int begin = s * sweep_strip, end = std::min(begin + sweep_strip, level.nx);
    const bool even = s % 2 == 0;
    for (int n = 0; n < end - begin; ++n)
    {
      const int ix = forward ? begin + n : end - 1 - n;
      const int left = ix - begin, right = end - 1 - ix;
      if (forward)
        for (std::size_t u = level.column_start[ix]; u < level.column_start[ix + 1]; ++u)
          f(u, left, right, even);
      else
        for (std::size_t u = level.column_start[ix + 1]; u-- > level.column_start[ix];)
          f(u, left, right, even);
    }
  };
  if constexpr (Ordered)
  {
    // Strips of one parity share no stencil entry: each half-sweep runs them in parallel.
#pragma omp parallel if (level.live.size() > parallel_nodes)
    for (int pass = 0; pass < 2; ++pass)
    {
      const int parity = forward ? pass : 1 - pass;
#pragma omp for schedule(dynamic)
      for (int s = parity; s < strips; s += 2)
        strip(s);
    }
  }
  else
  {
#pragma omp parallel for schedule(dynamic) if (level.live.size() > parallel_nodes)
    for (int s = 0; s < strips; ++s)
      strip(s);
  }
}

namespace
{
/// sum_a wx[a] sum_e wy[e] v[index(x0 + a, y0 + e)] over a < nx, e < ny: one
/// node of a transfer, P^T r or P x_2h, with the tensor-product weights of R.
template <class Index>
double tensor_gather(const double* wx, int nx, int x0, const double* wy, int ny, int y0,
                     const std::vector<double>& v, Index index)
{
  double sum = 0.0;
  for (int a = 0; a < nx; ++a)
  {
    double column = 0.0;
    for (int e = 0; e < ny; ++e)
      column += wy[e] * v[index(x0 + a, y0 + e)];
    sum += wx[a] * column;
  }
  return sum;
}
} // namespace

/// The V-cycle on level l for b_l (K&T eq. 50's residual restricted to it), from
/// x_l = 0:
///  - a forward Gauss-Seidel sweep, x_i = (b_i - sum_{j before i} K_ij x_j) / K_ii
///    (the nodes after i are still zero), after which the residual is
///    r_i = -sum_{j after i} K_ij x_j: the two passes read K once;
///  - the coarse correction x += P x_2h with x_2h = K_2h^-1 P^T r, the coarse
///    solve the same cycle one level down (a Cholesky solve on the coarsest);
///  - a backward sweep x_i = (b_i - sum_{j != i} K_ij x_j) / K_ii in the
///    reverse order, the adjoint of the forward one, so that the cycle is
///    symmetric.
/// On the finest level the backward sweep keeps its changes delta, and
/// K x = b + (sum_{j before i} K_ij delta_j)_i, half a product, is returned in
/// `kx` (when not null) for the conjugate gradients.
template <int P>
void Multigrid::cycle(std::size_t l, double* kx)
{
  if (l == _coarsest)
  {
    solve_coarsest();
    if (kx) // the finest level is the coarsest: K x by a product
    {
      const Level& f = _levels[l];
      const SymmetricStencil<2, P> stencil(f.padded_ny);
      for (std::size_t u = 0; u < f.live.size(); ++u)
        kx[u] = row_product(stencil, f.rows, f.live[u], f.x.data());
    }
    return;
  }
  constexpr int W = Refinement::width(P);
  Level& f = _levels[l];
  Level& c = _levels[l + 1];
  const SymmetricStencil<2, P> stencil(f.padded_ny);
  const double* rows = f.rows;
  double* x = f.x.data();
  const double* b = f.b.data();
  const bool parallel = f.live.size() > parallel_nodes;
  strips<true>(f, true,
               [&](std::size_t u, int left, int right, bool even)
               {
                 const std::size_t i = f.live[u];
                 x[i] = subtract_neighbours<2, P, true, false>(stencil, rows, i, left, right, even,
                                                            b[i], x)
                        * f.inverse[u];
               });
  // The residual at the coupled nodes (zero elsewhere, from setup).
  strips<false>(f, true,
                [&](std::size_t u, int left, int right, bool even)
                {
                  if (const std::size_t i = f.live[u]; f.coupled[i])
                    f.r[i] = subtract_neighbours<2, P, false, true>(stencil, rows, i, left, right,
                                                                 even, 0.0, x);
                });

  // Restriction b_2h = P^T r.
  const Refinement& rx = f.refine[0];
  const Refinement& ry = f.refine[1];
#pragma omp parallel for schedule(static) if (parallel)
  for (int jx = 0; jx < c.nx; ++jx)
    for (std::size_t v = c.column_start[jx]; v < c.column_start[jx + 1]; ++v)
    {
      const std::size_t j = c.live[v];
      const int jy = static_cast<int>(j - padded(c, jx, 0));
      c.b[j] = tensor_gather(&rx.weight[std::size_t(jx) * W], rx.count[jx], rx.first[jx],
                             &ry.weight[std::size_t(jy) * W], ry.count[jy], ry.first[jy], f.r,
                             [&](int ix, int iy) { return padded(f, ix, iy); });
    }
  cycle<P>(l + 1, nullptr);
  // Prolongation x += P x_2h at the coupled nodes.
#pragma omp parallel for schedule(static) if (parallel)
  for (int ix = 0; ix < f.nx; ++ix)
    for (std::size_t u = f.column_start[ix]; u < f.column_start[ix + 1]; ++u)
    {
      const std::size_t i = f.live[u];
      if (!f.coupled[i])
        continue;
      const int iy = static_cast<int>(i - padded(f, ix, 0));
      x[i] += tensor_gather(&rx.weight_t[std::size_t(ix) * W], rx.count_t[ix], rx.first_coarse[ix],
                            &ry.weight_t[std::size_t(iy) * W], ry.count_t[iy], ry.first_coarse[iy],
                            c.x, [&](int jx, int jy) { return padded(c, jx, jy); });
    }

  double* delta = _delta.data();
  strips<true>(f, false,
               [&](std::size_t u, int left, int right, bool even)
               {
                 const std::size_t i = f.live[u];
                 const double next
                     = subtract_neighbours<2, P, true, true>(stencil, rows, i, left, right, even,
                                                         b[i], x)
                       * f.inverse[u];
                 if (kx)
                   delta[i] = next - x[i];
                 x[i] = next;
               });
  if (!kx)
    return;
  strips<false>(f, true,
                [&](std::size_t u, int left, int right, bool even)
                {
                  const std::size_t i = f.live[u];
                  // b + sum_{j before i} K_ij delta_j
                  kx[u] = b[i] - subtract_neighbours<2, P, true, false>(stencil, rows, i, left,
                                                                     right, even, 0.0, delta);
                });
}

template <int P>
void Multigrid::apply(const double* r, double* z, double* kz)
{
  Level& f = _levels[0];
  const auto n = static_cast<std::ptrdiff_t>(f.live.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t u = 0; u < n; ++u)
    f.b[f.live[u]] = r[u];
  cycle<P>(0, kz);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t u = 0; u < n; ++u)
    z[u] = f.x[f.live[u]];
}

#define PFMPM_MULTIGRID(P)                                                                         \
  template void Multigrid::setup<P>(const std::vector<double>&, const std::vector<std::size_t>&);  \
  template void Multigrid::apply<P>(const double*, double*, double*);
PFMPM_MULTIGRID(1)
PFMPM_MULTIGRID(2)
PFMPM_MULTIGRID(3)
#undef PFMPM_MULTIGRID

} // namespace pfmpm
