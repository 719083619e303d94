#include "multigrid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pfmpm
{

namespace
{
/// Grid columns per strip of the Gauss-Seidel order. Strips of one parity
/// share no stencil entry while this is at least the degree.
constexpr int sweep_strip = 32;
static_assert(sweep_strip >= 3, "a strip must be at least as wide as the stencil's reach p");
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

  // Per coarse function its nonzero run of fine weights, and the transpose.
  first.assign(coarse, 0);
  count.assign(coarse, 0);
  weight.assign(std::size_t(coarse) * W, 0.0);
  first_coarse.assign(fine, 0);
  count_t.assign(fine, 0);
  weight_t.assign(std::size_t(fine) * W, 0.0);
  for (int j = 0; j < coarse; ++j)
  {
    int lo = fine, hi = -1;
    for (int i = 0; i < fine; ++i)
      if (alpha[std::size_t(j) * nf + i] != 0.0)
      {
        lo = std::min(lo, i);
        hi = std::max(hi, i);
      }
    if (hi < lo || hi - lo + 1 > W)
      throw std::logic_error("Refinement: coarse function " + std::to_string(j)
                             + " has no run of at most 2p + 1 fine functions");
    first[j] = lo;
    count[j] = hi - lo + 1;
    for (int i = lo; i <= hi; ++i)
      weight[std::size_t(j) * W + (i - lo)] = alpha[std::size_t(j) * nf + i];
  }
  for (int i = 0; i < fine; ++i)
  {
    int lo = coarse, hi = -1;
    for (int j = 0; j < coarse; ++j)
      if (alpha[std::size_t(j) * nf + i] != 0.0)
      {
        lo = std::min(lo, j);
        hi = std::max(hi, j);
      }
    if (hi < lo || hi - lo + 1 > W)
      throw std::logic_error("Refinement: fine function " + std::to_string(i)
                             + " lies in no run of at most 2p + 1 coarse functions");
    first_coarse[i] = lo;
    count_t[i] = hi - lo + 1;
    for (int j = lo; j <= hi; ++j)
      weight_t[std::size_t(i) * W + (j - lo)] = alpha[std::size_t(j) * nf + i];
  }
}

Multigrid::Multigrid(std::array<int, 2> cells, int degree, int sweeps, int direct_size)
    : _degree(degree), _sweeps(sweeps), _direct_size(direct_size)
{
  if (degree < 1 || degree > 3)
    throw std::invalid_argument("multigrid: degree = " + std::to_string(degree)
                                + ": must be 1, 2 or 3");
  if (cells[0] < 1 || cells[1] < 1)
    throw std::invalid_argument("multigrid: the grid needs at least one cell each way");
  if (sweeps < 1)
    throw std::invalid_argument("multigrid: sweeps = " + std::to_string(sweeps) + ": must be >= 1");
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

void Multigrid::number_unknowns(Level& level) const
{
  // Columns from the padded index: the unknowns are in increasing padded order.
  level.column_start.assign(level.nx + 1, 0);
  for (std::size_t i : level.live)
    ++level.column_start[i / level.padded_ny - _degree + 1];
  for (int ix = 0; ix < level.nx; ++ix)
    level.column_start[ix + 1] += level.column_start[ix];
}

template <int P>
void Multigrid::setup(const std::vector<double>& rows, const std::vector<std::size_t>& position)
{
  constexpr int H = SymmetricStencil<P>::size;
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
  const SymmetricStencil<P> stencil(f.padded_ny);
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

/// The Galerkin operator K_2h = P^T K_h P (P = R_x (x) R_y restricted to the
/// coupled fine nodes), row by row: for coarse J, u = K_h P e_J on the fine
/// nodes within p of P e_J's support, then K_2h(J, L) = (P e_L) . u for the
/// upper half of J's stencil. Each coarse row is written by one thread, its
/// terms summed in a fixed order.
template <int P>
void Multigrid::galerkin(const Level& fine, Level& coarse)
{
  constexpr int H = SymmetricStencil<P>::size;
  constexpr int W = Refinement::width(P); // fine functions per coarse one, at most
  constexpr int U = W + 2 * P;            // the window of u, per direction
  const SymmetricStencil<P> fs(fine.padded_ny), cs(coarse.padded_ny);
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
          const double* row = &fine.rows[i * H];
          u[a + P][b + P] += w * row[0];
          for (int k = 1; k < H; ++k)
          {
            const int dx = fs.dx[k], dy = fs.dy[k];
            u[a + P + dx][b + P + dy] += w * row[k];
            u[a + P - dx][b + P - dy] += w * fine.rows[(i - fs.offset[k]) * H + k];
          }
        }
      if (!touched)
        continue;
      double* out = &coarse.stencil[padded(coarse, jx, jy) * H];
      for (int k = 0; k < H; ++k)
      {
        const int lx = jx + cs.dx[k], ly = jy + cs.dy[k];
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
  constexpr int H = SymmetricStencil<P>::size;
  Level& c = _levels[_coarsest];
  const SymmetricStencil<P> stencil(c.padded_ny);
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

/// One Gauss-Seidel sweep x_i += (b_i - (K x)_i) / K_ii over the unknowns of
/// `level` in the strip order, or in the reverse order (backward).
template <int P>
void Multigrid::sweep(Level& level, bool forward)
{
  const SymmetricStencil<P> stencil(level.padded_ny);
  const int strips = (level.nx + sweep_strip - 1) / sweep_strip;
  const double* rows = level.rows;
  double* x = level.x.data();
  const double* b = level.b.data();
  auto node = [&](std::size_t u)
  {
    const std::size_t i = level.live[u];
    x[i] += (b[i] - row_product(stencil, rows, i, x)) * level.inverse[u];
  };
#pragma omp parallel if (level.live.size() > parallel_nodes)
  for (int pass = 0; pass < 2; ++pass)
  {
    const int parity = forward ? pass : 1 - pass;
#pragma omp for schedule(dynamic)
    for (int s = parity; s < strips; s += 2)
    {
      const int begin = s * sweep_strip, end = std::min(begin + sweep_strip, level.nx);
      if (forward)
        for (std::size_t u = level.column_start[begin]; u < level.column_start[end]; ++u)
          node(u);
      else
        for (std::size_t u = level.column_start[end]; u-- > level.column_start[begin];)
          node(u);
    }
  }
}

/// The V-cycle on level l for b_l, from x_l = 0: pre-smoothing, the coarse
/// correction x_l += P K_2h^-1 P^T (b_l - K_l x_l) (the coarse solve
/// recursive), post-smoothing in the reverse order.
template <int P>
void Multigrid::cycle(std::size_t l)
{
  if (l == _coarsest)
  {
    solve_coarsest();
    return;
  }
  constexpr int W = Refinement::width(P);
  Level& f = _levels[l];
  Level& c = _levels[l + 1];
  const SymmetricStencil<P> stencil(f.padded_ny);
  const auto n = static_cast<std::ptrdiff_t>(f.live.size());
  const bool parallel = f.live.size() > parallel_nodes;
#pragma omp parallel for schedule(static) if (parallel)
  for (std::ptrdiff_t u = 0; u < n; ++u)
    f.x[f.live[u]] = 0.0;
  for (int s = 0; s < _sweeps; ++s)
    sweep<P>(f, true);
  // The residual at the coupled nodes (zero elsewhere, from setup).
#pragma omp parallel for schedule(static) if (parallel)
  for (std::ptrdiff_t u = 0; u < n; ++u)
    if (const std::size_t i = f.live[u]; f.coupled[i])
      f.r[i] = f.b[i] - row_product(stencil, f.rows, i, f.x.data());
  // Restriction b_2h = P^T r.
  const Refinement& rx = f.refine[0];
  const Refinement& ry = f.refine[1];
  const auto nc = static_cast<std::ptrdiff_t>(c.live.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (std::ptrdiff_t v = 0; v < nc; ++v)
  {
    const std::size_t j = c.live[v];
    const int jx = static_cast<int>(j / c.padded_ny) - P, jy = static_cast<int>(j % c.padded_ny) - P;
    double sum = 0.0;
    for (int a = 0; a < rx.count[jx]; ++a)
    {
      double column = 0.0;
      for (int b = 0; b < ry.count[jy]; ++b)
        column += ry.weight[std::size_t(jy) * W + b]
                  * f.r[padded(f, rx.first[jx] + a, ry.first[jy] + b)];
      sum += rx.weight[std::size_t(jx) * W + a] * column;
    }
    c.b[j] = sum;
  }
  cycle<P>(l + 1);
  // Prolongation x += P x_2h at the coupled nodes.
#pragma omp parallel for schedule(static) if (parallel)
  for (std::ptrdiff_t u = 0; u < n; ++u)
  {
    const std::size_t i = f.live[u];
    if (!f.coupled[i])
      continue;
    const int ix = static_cast<int>(i / f.padded_ny) - P, iy = static_cast<int>(i % f.padded_ny) - P;
    double sum = 0.0;
    for (int a = 0; a < rx.count_t[ix]; ++a)
    {
      double column = 0.0;
      for (int b = 0; b < ry.count_t[iy]; ++b)
        column += ry.weight_t[std::size_t(iy) * W + b]
                  * c.x[padded(c, rx.first_coarse[ix] + a, ry.first_coarse[iy] + b)];
      sum += rx.weight_t[std::size_t(ix) * W + a] * column;
    }
    f.x[i] += sum;
  }
  for (int s = 0; s < _sweeps; ++s)
    sweep<P>(f, false);
}

template <int P>
void Multigrid::apply(const double* r, double* z)
{
  Level& f = _levels[0];
  const auto n = static_cast<std::ptrdiff_t>(f.live.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t u = 0; u < n; ++u)
    f.b[f.live[u]] = r[u];
  cycle<P>(0);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t u = 0; u < n; ++u)
    z[u] = f.x[f.live[u]];
}

#define PFMPM_MULTIGRID(P)                                                                         \
  template void Multigrid::setup<P>(const std::vector<double>&, const std::vector<std::size_t>&);  \
  template void Multigrid::apply<P>(const double*, double*);
PFMPM_MULTIGRID(1)
PFMPM_MULTIGRID(2)
PFMPM_MULTIGRID(3)
#undef PFMPM_MULTIGRID

} // namespace pfmpm
