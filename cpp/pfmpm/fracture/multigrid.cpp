/// @file multigrid.cpp
/// @brief Geometric multigrid on the B-spline grid for the phase-field CG.
#include "pfmpm/fracture/multigrid.h"

#include <algorithm>
#include <array>
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

namespace
{
/// f() for every multi-index k[A..N) of the box count[A..N), lexicographic
/// (the last index fastest).
template <int N, int A = 0, class F>
[[gnu::always_inline]] inline void for_each_index(const int* count, int* k, F& f)
{
  if constexpr (A == N)
    f();
  else
    for (k[A] = 0; k[A] < count[A]; ++k[A])
      for_each_index<N, A + 1>(count, k, f);
}

/// sum_a w_0[a] sum_b w_1[b] .. v[i(first + (a, b, ..))] over the box count:
/// one node of a transfer, P^T r or P x_2h, with the tensor-product weights
/// of R (the innermost sum over the last direction, then outwards). `base`:
/// the padded index so far, `stride` the padded layout's, `pad` = p.
template <int Dim, int A = 0>
[[gnu::always_inline]] inline double tensor_gather(const double* const (&w)[Dim], const int (&count)[Dim],
                                                   const int (&first)[Dim],
                                                   const std::array<std::size_t, Dim>& stride, int pad,
                                                   const double* v, std::size_t base = 0)
{
  double sum = 0.0;
  for (int a = 0; a < count[A]; ++a)
  {
    const std::size_t i = base + static_cast<std::size_t>(first[A] + a + pad) * stride[A];
    if constexpr (A == Dim - 1)
      sum += w[A][a] * v[i];
    else
      sum += w[A][a] * tensor_gather<Dim, A + 1>(w, count, first, stride, pad, v, i);
  }
  return sum;
}

/// (P e_L) . u over the window u of U^Dim entries (the last direction
/// fastest) from `origin`: sum_a w_0[a] sum_b w_1[b] .. u[first + (a, b, ..)
/// - origin], the terms off the window skipped.
template <int Dim, int U, int A = 0>
[[gnu::always_inline]] inline double window_product(const double* const (&w)[Dim], const int (&count)[Dim],
                                                    const int (&first)[Dim], const int (&origin)[Dim],
                                                    const double* u)
{
  constexpr int step = [] { int s = 1; for (int a = A + 1; a < Dim; ++a) s *= U; return s; }();
  double sum = 0.0;
  for (int a = 0; a < count[A]; ++a)
  {
    const int k = first[A] + a - origin[A];
    if (k < 0 || k >= U)
      continue;
    if constexpr (A == Dim - 1)
      sum += w[A][a] * u[k];
    else
      sum += w[A][a] * window_product<Dim, U, A + 1>(w, count, first, origin, u + k * step);
  }
  return sum;
}

/// The offset of stencil slot k in a window of U^Dim entries, the last
/// direction fastest.
template <int Dim, int P, int U>
constexpr int window_offset(int k)
{
  constexpr int width = 2 * P + 1;
  int rank = SymmetricStencil<Dim, P>::centre + k, offset = 0, scale = 1;
  for (int a = Dim - 1; a >= 0; --a, rank /= width, scale *= U)
    offset += (rank % width - P) * scale;
  return offset;
}

/// at[o(d)] += w K_{i, i + d} over K's (2p+1)^Dim-point stencil at padded node
/// i, K stored in `rows`, for `at` in a window of U^Dim entries (o: its
/// offsets, window_offset): per upper-half slot, d and then -d.
template <int Dim, int P, int U, std::size_t... K>
[[gnu::always_inline]] inline void add_row(double* at, double w, const double* rows, std::size_t i,
                                           const SymmetricStencil<Dim, P>& stencil,
                                           std::index_sequence<K...>)
{
  constexpr int H = SymmetricStencil<Dim, P>::size;
  at[0] += w * rows[i * H];
  ((at[window_offset<Dim, P, U>(K + 1)] += w * rows[i * H + K + 1],
    at[-window_offset<Dim, P, U>(K + 1)] += w * rows[(i - stencil.offset[K + 1]) * H + K + 1]),
   ...);
}

constexpr int power(int base, int exponent)
{
  int out = 1;
  for (int k = 0; k < exponent; ++k)
    out *= base;
  return out;
}
} // namespace

template <int Dim>
Multigrid<Dim>::Multigrid(std::array<int, Dim> cells, int degree, int direct_size, int sweeps)
    : _degree(degree), _direct_size(direct_size), _sweeps(sweeps)
{
  if (degree < 1 || degree > 3)
    throw std::invalid_argument("multigrid: degree = " + std::to_string(degree)
                                + ": must be 1, 2 or 3");
  for (int a = 0; a < Dim; ++a)
    if (cells[a] < 1)
      throw std::invalid_argument("multigrid: the grid needs at least one cell each way");
  if (direct_size < 1)
    throw std::invalid_argument("multigrid: direct_size = " + std::to_string(direct_size)
                                + ": must be >= 1");
  if (sweeps < 1)
    throw std::invalid_argument("multigrid: sweeps = " + std::to_string(sweeps) + ": must be >= 1");
  // The geometry of every level down to one cell each way; setup() decides
  // how many of them a system uses.
  for (;;)
  {
    Level level;
    std::size_t size = 1;
    bool last = true;
    for (int a = Dim - 1; a >= 0; --a)
    {
      level.n[a] = cells[a] + degree;
      level.stride[a] = size;
      size *= static_cast<std::size_t>(level.n[a] + 2 * degree);
      last = last && cells[a] == 1;
    }
    level.padded_size = size;
    if (!last)
      for (int a = 0; a < Dim; ++a)
        level.refine.emplace_back(cells[a], degree);
    _levels.push_back(std::move(level));
    if (last)
      break;
    for (int a = 0; a < Dim; ++a)
      cells[a] = (cells[a] + 1) / 2;
  }
}

template <int Dim>
std::vector<std::int64_t> Multigrid<Dim>::unknowns() const
{
  std::vector<std::int64_t> out;
  for (std::size_t l = 0; l <= _coarsest && l < _levels.size(); ++l)
    out.push_back(static_cast<std::int64_t>(_levels[l].live.size()));
  return out;
}

template <int Dim>
double Multigrid<Dim>::entry(std::size_t level, std::array<int, Dim> node,
                             std::array<int, Dim> offset) const
{
  if (level > _coarsest)
    throw std::out_of_range("multigrid: level " + std::to_string(level) + " of "
                            + std::to_string(_coarsest + 1));
  switch (_degree)
  {
  case 1:
    return stencil_entry<1>(_levels[level], node, offset);
  case 2:
    return stencil_entry<2>(_levels[level], node, offset);
  default:
    return stencil_entry<3>(_levels[level], node, offset);
  }
}

template <int Dim>
template <int P>
double Multigrid<Dim>::stencil_entry(const Level& level, const std::array<int, Dim>& node,
                                     const std::array<int, Dim>& offset) const
{
  using S = SymmetricStencil<Dim, P>;
  constexpr int H = S::size;
  std::array<int, Dim> other, back;
  bool on_grid = level.rows != nullptr;
  for (int a = 0; a < Dim; ++a)
  {
    if (std::abs(offset[a]) > P)
      throw std::out_of_range("multigrid: offset beyond the stencil");
    other[a] = node[a] + offset[a];
    back[a] = -offset[a];
    on_grid = on_grid && node[a] >= 0 && node[a] < level.n[a] && other[a] >= 0
              && other[a] < level.n[a];
  }
  if (!on_grid)
    return 0.0;
  auto slot = [](const std::array<int, Dim>& d)
  {
    if constexpr (Dim == 2)
      return S::slot(d[0], d[1]);
    else
      return S::slot(d[0], d[1], d[2]);
  };
  if (const int k = slot(offset); k >= 0)
    return level.rows[padded(level, node) * H + k];
  return level.rows[padded(level, other) * H + slot(back)];
}

template <int Dim>
void Multigrid<Dim>::number_unknowns(Level& level) const
{
  // The unknowns are in increasing padded order, x-slab by x-slab.
  level.slab_start.resize(level.n[0] + 1);
  for (int ix = 0; ix <= level.n[0]; ++ix)
    level.slab_start[ix] = static_cast<std::size_t>(
        std::lower_bound(level.live.begin(), level.live.end(),
                         static_cast<std::size_t>(ix + _degree) * level.stride[0])
        - level.live.begin());
}

template <int Dim>
template <int P>
void Multigrid<Dim>::setup(const std::vector<double>& rows, const std::vector<std::size_t>& position)
{
  constexpr int H = SymmetricStencil<Dim, P>::size;
  if (P != _degree)
    throw std::invalid_argument("multigrid: a stencil of degree " + std::to_string(P)
                                + " for a grid of degree " + std::to_string(_degree));
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
  const SymmetricStencil<Dim, P> s = stencil<P>(f);
  // A row with no off-diagonal entry (a node no crackable particle touches)
  // is solved exactly by the smoother and stays out of the coarse correction.
#pragma omp parallel for schedule(static) if (f.live.size() > parallel_nodes)
  for (std::ptrdiff_t u = 0; u < n; ++u)
  {
    const std::size_t i = f.live[u];
    bool coupled = false;
    for (int k = 1; k < H && !coupled; ++k)
      coupled = f.rows[i * H + k] != 0.0 || f.rows[(i - s.offset[k]) * H + k] != 0.0;
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

/// The Galerkin operator K_2h = P^T K_h P (P = R_x (x) R_y [(x) R_z]
/// restricted to the coupled fine nodes), row by row: for coarse J, u = K_h P
/// e_J on the fine nodes within p of P e_J's support (a window of U^Dim),
/// then K_2h(J, L) = (P e_L) . u for the upper half of J's stencil. With
/// nested spaces this is K&T eq. 57 assembled from the same particles with
/// the coarse basis. Each coarse row is written by one thread, its terms
/// summed in a fixed order.
template <int Dim>
template <int P>
void Multigrid<Dim>::galerkin(const Level& fine, Level& coarse)
{
  constexpr int H = SymmetricStencil<Dim, P>::size;
  constexpr int W = Refinement::width(P); // fine functions per coarse one, at most
  constexpr int U = W + 2 * P;            // the window of u, per direction
  constexpr int window = power(U, Dim);
  const SymmetricStencil<Dim, P> fs = stencil<P>(fine), cs = stencil<P>(coarse);
  coarse.stencil.assign(coarse.padded_size * H, 0.0);
  coarse.rows = coarse.stencil.data();
  const std::size_t fine_nodes = fine.live.size();
  int rest[Dim - 1]; // coarse nodes per x-plane, per direction
  for (int a = 1; a < Dim; ++a)
    rest[a - 1] = coarse.n[a];

#pragma omp parallel for schedule(static) if (fine_nodes > parallel_nodes)
  for (int jx = 0; jx < coarse.n[0]; ++jx)
  {
    std::array<int, Dim> J;
    J[0] = jx;
    auto row = [&]
    {
      const double* w[Dim];
      int count[Dim], first[Dim], origin[Dim], k[Dim];
      for (int a = 0; a < Dim; ++a)
      {
        const Refinement& R = fine.refine[a];
        w[a] = &R.weight[std::size_t(J[a]) * W];
        count[a] = R.count[J[a]];
        first[a] = R.first[J[a]];
        origin[a] = first[a] - P;
      }
      double u[window] = {};
      bool touched = false;
      auto add = [&]
      {
        // Fine node first + k, its slot in the window and its weight (P e_J)_i.
        std::array<int, Dim> node;
        int slot = 0;
        double weight = w[0][k[0]];
        for (int a = 0; a < Dim; ++a)
        {
          node[a] = first[a] + k[a];
          slot = slot * U + (k[a] + P);
        }
        for (int a = 1; a < Dim; ++a)
          weight *= w[a][k[a]];
        const std::size_t i = padded(fine, node);
        if (!fine.coupled[i])
          return;
        touched = true;
        add_row<Dim, P, U>(&u[slot], weight, fine.rows, i, fs, std::make_index_sequence<H - 1>{});
      };
      for_each_index<Dim>(count, k, add);
      if (!touched)
        return;
      double* out = &coarse.stencil[padded(coarse, J) * H];
      for (int s = 0; s < H; ++s)
      {
        std::array<int, Dim> L;
        bool on_grid = true;
        for (int a = 0; a < Dim; ++a)
        {
          L[a] = J[a] + cs.d[s][a];
          on_grid = on_grid && L[a] < coarse.n[a] && (a == 0 || L[a] >= 0);
        }
        if (!on_grid)
          continue;
        const double* wl[Dim];
        int cl[Dim], fl[Dim];
        for (int a = 0; a < Dim; ++a)
        {
          const Refinement& R = fine.refine[a];
          wl[a] = &R.weight[std::size_t(L[a]) * W];
          cl[a] = R.count[L[a]];
          fl[a] = R.first[L[a]];
        }
        out[s] = window_product<Dim, U>(wl, cl, fl, origin, u);
      }
    };
    int jr[Dim - 1];
    auto each = [&]
    {
      for (int a = 1; a < Dim; ++a)
        J[a] = jr[a - 1];
      row();
    };
    for_each_index<Dim - 1>(rest, jr, each);
  }

  // The unknowns: nodes with a nonzero diagonal, i.e. a coupled fine node in their support.
  coarse.live.clear();
  {
    std::array<int, Dim> J;
    int all[Dim];
    for (int a = 0; a < Dim; ++a)
      all[a] = coarse.n[a];
    auto each = [&]
    {
      if (const std::size_t j = padded(coarse, J); coarse.stencil[j * H] > 0.0)
        coarse.live.push_back(j);
    };
    for_each_index<Dim>(all, J.data(), each);
  }
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
/// node order. A pivot that vanishes (a direction in which the Galerkin
/// operator is singular, possible where the coupled fine nodes are too few to
/// tell coarse functions apart) drops that unknown: the solve leaves it zero.
template <int Dim>
template <int P>
void Multigrid<Dim>::factor_coarsest()
{
  constexpr int H = SymmetricStencil<Dim, P>::size;
  Level& c = _levels[_coarsest];
  const SymmetricStencil<Dim, P> s = stencil<P>(c);
  const std::size_t n = c.live.size();
  std::vector<std::ptrdiff_t> index(c.padded_size, -1);
  for (std::size_t u = 0; u < n; ++u)
    index[c.live[u]] = static_cast<std::ptrdiff_t>(u);
  // The band: the farthest upper-half neighbour among the unknowns.
  _band = 0;
  for (std::size_t u = 0; u < n; ++u)
    for (int k = 1; k < H; ++k)
      if (const std::ptrdiff_t v = index[c.live[u] + s.offset[k]]; v >= 0)
        _band = std::max(_band, static_cast<std::size_t>(v) - u);
  const std::size_t B = _band + 1;
  // Row v of the lower triangle: entry (v, u) at v * B + (u + band - v).
  _factor.assign(n * B, 0.0);
  for (std::size_t u = 0; u < n; ++u)
  {
    const double* row = &c.rows[c.live[u] * H];
    _factor[u * B + _band] = row[0];
    for (int k = 1; k < H; ++k)
      if (const std::ptrdiff_t v = index[c.live[u] + s.offset[k]]; v >= 0)
        _factor[std::size_t(v) * B + (u + _band - std::size_t(v))] = row[k];
  }
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::size_t j0 = i >= _band ? i - _band : 0;
    for (std::size_t j = j0; j <= i; ++j)
    {
      double sum = _factor[i * B + (j + _band - i)];
      const std::size_t k0 = std::max(j0, j >= _band ? j - _band : 0);
      for (std::size_t k = k0; k < j; ++k)
        sum -= _factor[i * B + (k + _band - i)] * _factor[j * B + (k + _band - j)];
      if (j < i)
      {
        const double d = _factor[j * B + _band];
        _factor[i * B + (j + _band - i)] = d > 0.0 ? sum / d : 0.0;
      }
      else
      {
        const double diagonal = c.rows[c.live[i] * H];
        _factor[i * B + _band] = sum > 1e-12 * diagonal ? std::sqrt(sum) : 0.0;
      }
    }
  }
}

template <int Dim>
void Multigrid<Dim>::solve_coarsest()
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
/// `right`: the x-slabs of u's strip on either side of u's, `even` whether
/// the strip is. Forward: strip by strip, even strips first, each slab by
/// slab in node order; backward: the reverse.
template <int Dim>
template <bool Ordered, class F>
void Multigrid<Dim>::strips(const Level& level, bool forward, F&& f) const
{
  const int nx = level.n[0];
  const int strips = (nx + strip - 1) / strip;
  auto one = [&](int s)
  {
    const int begin = s * strip, end = std::min(begin + strip, nx);
    const bool even = s % 2 == 0;
    for (int n = 0; n < end - begin; ++n)
    {
      const int ix = forward ? begin + n : end - 1 - n;
      const int left = ix - begin, right = end - 1 - ix;
      if (forward)
        for (std::size_t u = level.slab_start[ix]; u < level.slab_start[ix + 1]; ++u)
          f(u, left, right, even);
      else
        for (std::size_t u = level.slab_start[ix + 1]; u-- > level.slab_start[ix];)
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
        one(s);
    }
  }
  else
  {
#pragma omp parallel for schedule(dynamic) if (level.live.size() > parallel_nodes)
    for (int s = 0; s < strips; ++s)
      one(s);
  }
}

/// The V-cycle on level l for b_l (K&T eq. 50's residual restricted to it), from
/// x_l = 0:
///  - a forward Gauss-Seidel sweep, x_i = (b_i - sum_{j before i} K_ij x_j) / K_ii
///    (the nodes after i are still zero), after which the residual is
///    r_i = -sum_{j after i} K_ij x_j: the two passes read K once; with
///    `sweeps` > 1, sweeps - 1 more forward sweeps
///    x_i = (b_i - sum_{j != i} K_ij x_j) / K_ii and then r = b - K x;
///  - the coarse correction x += P x_2h with x_2h = K_2h^-1 P^T r, the coarse
///    solve the same cycle one level down (a Cholesky solve on the coarsest);
///  - `sweeps` backward sweeps x_i = (b_i - sum_{j != i} K_ij x_j) / K_ii in
///    the reverse order, the adjoint of the forward ones, so that the cycle is
///    symmetric.
/// On the finest level the last backward sweep keeps its changes delta, and
/// K x = b + (sum_{j before i} K_ij delta_j)_i, half a product, is returned in
/// `kx` (when not null) for the conjugate gradients.
template <int Dim>
template <int P>
void Multigrid<Dim>::cycle(std::size_t l, double* kx)
{
  if (l == _coarsest)
  {
    solve_coarsest();
    if (kx) // the finest level is the coarsest: K x by a product
    {
      const Level& f = _levels[l];
      const SymmetricStencil<Dim, P> s = stencil<P>(f);
      for (std::size_t u = 0; u < f.live.size(); ++u)
        kx[u] = row_product(s, f.rows, f.live[u], f.x.data());
    }
    return;
  }
  constexpr int W = Refinement::width(P);
  Level& f = _levels[l];
  Level& c = _levels[l + 1];
  const SymmetricStencil<Dim, P> s = stencil<P>(f);
  const double* rows = f.rows;
  double* x = f.x.data();
  const double* b = f.b.data();
  const bool parallel = f.live.size() > parallel_nodes;
  strips<true>(f, true,
               [&](std::size_t u, int left, int right, bool even)
               {
                 const std::size_t i = f.live[u];
                 x[i] = subtract_neighbours<Dim, P, true, false>(s, rows, i, left, right, even, b[i], x)
                        * f.inverse[u];
               });
  for (int sweep = 1; sweep < _sweeps; ++sweep)
    strips<true>(f, true,
                 [&](std::size_t u, int left, int right, bool even)
                 {
                   const std::size_t i = f.live[u];
                   x[i] = subtract_neighbours<Dim, P, true, true>(s, rows, i, left, right, even, b[i], x)
                          * f.inverse[u];
                 });
  // The residual at the coupled nodes (zero elsewhere, from setup).
  if (_sweeps == 1)
    strips<false>(f, true,
                  [&](std::size_t u, int left, int right, bool even)
                  {
                    if (const std::size_t i = f.live[u]; f.coupled[i])
                      f.r[i] = subtract_neighbours<Dim, P, false, true>(s, rows, i, left, right, even,
                                                                        0.0, x);
                  });
  else
    strips<false>(f, true,
                  [&](std::size_t u, int left, int right, bool even)
                  {
                    if (const std::size_t i = f.live[u]; f.coupled[i])
                      f.r[i] = subtract_neighbours<Dim, P, true, true>(s, rows, i, left, right, even,
                                                                       b[i], x)
                               - rows[i * SymmetricStencil<Dim, P>::size] * x[i];
                  });

  // Restriction b_2h = P^T r: per coarse node J, the fine nodes of its run
  // in each direction.
#pragma omp parallel for schedule(static) if (parallel)
  for (int jx = 0; jx < c.n[0]; ++jx)
    for (std::size_t v = c.slab_start[jx]; v < c.slab_start[jx + 1]; ++v)
    {
      const std::size_t j = c.live[v];
      const std::array<int, Dim> J = node_of(c, jx, j);
      const double* w[Dim];
      int count[Dim], first[Dim];
      for (int a = 0; a < Dim; ++a)
      {
        const Refinement& R = f.refine[a];
        w[a] = &R.weight[std::size_t(J[a]) * W];
        count[a] = R.count[J[a]];
        first[a] = R.first[J[a]];
      }
      c.b[j] = tensor_gather<Dim>(w, count, first, f.stride, _degree, f.r.data());
    }
  cycle<P>(l + 1, nullptr);
  // Prolongation x += P x_2h at the coupled nodes: per fine node, the
  // coarse nodes of its run in each direction.
#pragma omp parallel for schedule(static) if (parallel)
  for (int ix = 0; ix < f.n[0]; ++ix)
    for (std::size_t u = f.slab_start[ix]; u < f.slab_start[ix + 1]; ++u)
    {
      const std::size_t i = f.live[u];
      if (!f.coupled[i])
        continue;
      const std::array<int, Dim> I = node_of(f, ix, i);
      const double* w[Dim];
      int count[Dim], first[Dim];
      for (int a = 0; a < Dim; ++a)
      {
        const Refinement& R = f.refine[a];
        w[a] = &R.weight_t[std::size_t(I[a]) * W];
        count[a] = R.count_t[I[a]];
        first[a] = R.first_coarse[I[a]];
      }
      x[i] += tensor_gather<Dim>(w, count, first, c.stride, _degree, c.x.data());
    }

  double* delta = _delta.data();
  for (int sweep = 0; sweep < _sweeps; ++sweep)
  {
    const bool last = sweep + 1 == _sweeps;
    strips<true>(f, false,
                 [&](std::size_t u, int left, int right, bool even)
                 {
                   const std::size_t i = f.live[u];
                   const double next
                       = subtract_neighbours<Dim, P, true, true>(s, rows, i, left, right, even, b[i], x)
                         * f.inverse[u];
                   if (kx && last)
                     delta[i] = next - x[i];
                   x[i] = next;
                 });
  }
  if (!kx)
    return;
  strips<false>(f, true,
                [&](std::size_t u, int left, int right, bool even)
                {
                  const std::size_t i = f.live[u];
                  // b + sum_{j before i} K_ij delta_j
                  kx[u] = b[i] - subtract_neighbours<Dim, P, true, false>(s, rows, i, left, right,
                                                                          even, 0.0, delta);
                });
}

template <int Dim>
template <int P>
void Multigrid<Dim>::apply(const double* r, double* z, double* kz)
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

template class Multigrid<2>;
template class Multigrid<3>;
#define PFMPM_MULTIGRID(D, P)                                                                      \
  template void Multigrid<D>::setup<P>(const std::vector<double>&,                                 \
                                       const std::vector<std::size_t>&);                           \
  template void Multigrid<D>::apply<P>(const double*, double*, double*);
PFMPM_MULTIGRID(2, 1)
PFMPM_MULTIGRID(2, 2)
PFMPM_MULTIGRID(2, 3)
PFMPM_MULTIGRID(3, 1)
PFMPM_MULTIGRID(3, 2)
PFMPM_MULTIGRID(3, 3)
#undef PFMPM_MULTIGRID

} // namespace pfmpm
