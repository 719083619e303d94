#include "contact.h"
#include "reduce.h"
#include "strips.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace pfmpm
{

namespace
{
/// Relative tolerance of the round-off checks C.1-C.4.
constexpr double check_tol = 1e-9;

/// Insert `f` into the sorted list out[0, n); false when it is full.
bool insert_sorted(std::int32_t f, std::int32_t* out, int& n, int capacity)
{
  int i = 0;
  while (i < n && out[i] < f)
    ++i;
  if (i < n && out[i] == f)
    return true;
  if (n == capacity)
    return false;
  for (int j = n; j > i; --j)
    out[j] = out[j - 1];
  out[i] = f;
  ++n;
  return true;
}

double dot(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1]; }
} // namespace

DiscreteFields::DiscreteFields(const Grid& grid, const Particles& particles,
                               std::vector<double> friction,
                               const std::vector<std::optional<Fracture>>& fracture, double tol,
                               int max_iterations)
    : _grid(grid), _friction(std::move(friction))
{
  _fields = static_cast<int>(std::lround(std::sqrt(static_cast<double>(_friction.size()))));
  if (_fields < 2 || static_cast<std::size_t>(_fields) * _fields != _friction.size())
    throw std::invalid_argument("friction: " + std::to_string(_friction.size())
                                + " entries; need fields x fields with at least 2 fields");
  for (int a = 0; a < _fields; ++a)
    for (int b = 0; b < _fields; ++b)
    {
      const double mu = _friction[a * _fields + b];
      if (!(mu >= 0.0) || !std::isfinite(mu) || mu != _friction[b * _fields + a])
        throw std::invalid_argument("friction[" + std::to_string(a) + "][" + std::to_string(b)
                                    + "] = " + std::to_string(mu)
                                    + ": must be finite, >= 0 and symmetric");
    }
  // A field can crack when its particles' material can (one material per
  // body in practice; any particle of a crackable material makes it so).
  std::vector<char> cracks(_fields, 0);
  for (std::size_t p = 0; p < particles.size(); ++p)
  {
    const std::int32_t f = particles.body[p];
    if (f < 0 || f >= _fields)
      throw std::invalid_argument("particle " + std::to_string(p) + ": body index "
                                  + std::to_string(f) + " is not a field in [0, "
                                  + std::to_string(_fields) + ")");
    const std::int32_t m = particles.material[p];
    if (m >= 0 && static_cast<std::size_t>(m) < fracture.size() && fracture[m])
      cracks[f] = 1;
  }
  _crackable.assign(_fields, -1);
  _phase.reserve(_fields);
  for (int f = 0; f < _fields; ++f)
    if (cracks[f])
    {
      _crackable[f] = static_cast<std::int32_t>(_phase.size());
      _phase.emplace_back(grid, fracture, tol, max_iterations);
      _phase_field_of.push_back(f);
    }
  _field_order.resize(_phase.size());
  _field_cell_start.resize(_phase.size());
}

int DiscreteFields::node_fields(int ix, int iy, std::int32_t* out) const
{
  const int p = _grid.degree();
  const int ncx = _grid.basis(0).cells(), ncy = _grid.basis(1).cells();
  int n = 0;
  for (int cx = std::max(ix - p, 0); cx <= std::min(ix, ncx - 1); ++cx)
    for (int cy = std::max(iy - p, 0); cy <= std::min(iy, ncy - 1); ++cy)
    {
      const std::int32_t tag = _cell_field[static_cast<std::size_t>(cx) * ncy + cy];
      if (tag == -1)
        continue;
      if (tag >= 0)
      {
        if (!insert_sorted(tag, out, n, max_fields_per_node))
          return -1;
        continue;
      }
      const std::int32_t m = -2 - tag;
      for (std::int32_t i = _mixed_start[m]; i < _mixed_start[m + 1]; ++i)
        if (!insert_sorted(_mixed_fields[i], out, n, max_fields_per_node))
          return -1;
    }
  return n;
}

void DiscreteFields::detect(const Particles& particles, const std::vector<std::int32_t>& order,
                            const std::vector<std::int64_t>& cell_start)
{
  const int p = _grid.degree();
  const int ncx = _grid.basis(0).cells(), ncy = _grid.basis(1).cells();
  const int nny = _grid.nodes()[1];
  const auto ncells = static_cast<std::ptrdiff_t>(_grid.num_cells());
  const std::int32_t* body = particles.body.data();

  // Cells: empty, one field, or mixed.
  _cell_field.resize(ncells);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
  {
    const std::int64_t begin = cell_start[c], end = cell_start[c + 1];
    std::int32_t tag = -1;
    if (begin < end)
    {
      tag = body[order[begin]];
      for (std::int64_t k = begin + 1; k < end; ++k)
        if (body[order[k]] != tag)
        {
          tag = -2;
          break;
        }
    }
    _cell_field[c] = tag;
  }
  // The fields of each mixed cell (a thin layer where bodies touch).
  _mixed_start.assign(1, 0);
  _mixed_fields.clear();
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
    if (_cell_field[c] == -2)
    {
      std::int32_t list[max_fields_per_node];
      int n = 0;
      for (std::int64_t k = cell_start[c]; k < cell_start[c + 1]; ++k)
        if (!insert_sorted(body[order[k]], list, n, max_fields_per_node))
          throw std::runtime_error("contact: more than " + std::to_string(max_fields_per_node)
                                   + " bodies share one grid cell");
      _cell_field[c] = -2 - static_cast<std::int32_t>(_mixed_start.size() - 1);
      _mixed_fields.insert(_mixed_fields.end(), list, list + n);
      _mixed_start.push_back(static_cast<std::int32_t>(_mixed_fields.size()));
    }

  // Remark 4: a node is a contact node when particles of two or more fields
  // lie in its support.
  const auto na = static_cast<std::ptrdiff_t>(_grid.num_active());
  const std::vector<std::int32_t>& nodes = _grid.active_nodes();
  _count.resize(na);
  std::ptrdiff_t overflow = na;
#pragma omp parallel for schedule(static) reduction(min : overflow)
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    std::int32_t list[max_fields_per_node];
    _count[a] = node_fields(nodes[a] / nny, nodes[a] % nny, list);
    if (_count[a] < 0)
      overflow = std::min(overflow, a);
  }
  if (overflow < na)
    throw std::runtime_error("contact: more than " + std::to_string(max_fields_per_node)
                             + " bodies meet at grid node " + std::to_string(nodes[overflow]));
  _contact.assign(na, -1);
  _contact_node.clear();
  _slot_start.assign(1, 0);
  for (std::ptrdiff_t a = 0; a < na; ++a)
    if (_count[a] >= 2)
    {
      _contact[a] = static_cast<std::int32_t>(_contact_node.size());
      _contact_node.push_back(static_cast<std::int32_t>(a));
      _slot_start.push_back(_slot_start.back() + _count[a]);
    }
  const auto nk = static_cast<std::ptrdiff_t>(_contact_node.size());
  _slot_field.resize(_slot_start.back());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < nk; ++k)
  {
    const std::int32_t n = nodes[_contact_node[k]];
    node_fields(n / nny, n % nny, &_slot_field[_slot_start[k]]);
  }
  _stats.nodes = static_cast<std::int32_t>(nk);

  _touches.assign(ncells, 0);
  if (nk == 0)
    return;
#pragma omp parallel for schedule(static)
  for (int cx = 0; cx < ncx; ++cx)
    for (int cy = 0; cy < ncy; ++cy)
    {
      const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
      if (cell_start[cell + 1] == cell_start[cell])
        continue;
      bool any = false;
      for (int a = 0; a <= p && !any; ++a)
        for (int b = 0; b <= p && !any; ++b)
          any = _contact[_grid.active_index(cx + a, cy + b)] >= 0;
      _touches[cell] = any;
    }
}

void DiscreteFields::split_by_field(const Particles& particles,
                                    const std::vector<std::int32_t>& order,
                                    const std::vector<std::int64_t>& cell_start)
{
  const auto ncells = static_cast<std::ptrdiff_t>(_grid.num_cells());
  const std::size_t nq = _phase.size();
  const std::int32_t* body = particles.body.data();
  for (std::size_t q = 0; q < nq; ++q)
    _field_cell_start[q].resize(ncells + 1);
  // Count each crackable field's particles per cell, then offsets, then fill:
  // every field keeps the global sort order inside a cell.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
  {
    for (std::size_t q = 0; q < nq; ++q)
      _field_cell_start[q][c + 1] = 0;
    for (std::int64_t k = cell_start[c]; k < cell_start[c + 1]; ++k)
      if (const std::int32_t q = _crackable[body[order[k]]]; q >= 0)
        ++_field_cell_start[q][c + 1];
  }
  for (std::size_t q = 0; q < nq; ++q)
  {
    std::vector<std::int64_t>& start = _field_cell_start[q];
    start[0] = 0;
    for (std::ptrdiff_t c = 0; c < ncells; ++c)
      start[c + 1] += start[c];
    _field_order[q].resize(start[ncells]);
  }
#pragma omp parallel
  {
    std::vector<std::int64_t> next(nq);
#pragma omp for schedule(static)
    for (std::ptrdiff_t c = 0; c < ncells; ++c)
    {
      for (std::size_t q = 0; q < nq; ++q)
        next[q] = _field_cell_start[q][c];
      for (std::int64_t k = cell_start[c]; k < cell_start[c + 1]; ++k)
        if (const std::int32_t q = _crackable[body[order[k]]]; q >= 0)
          _field_order[q][next[q]++] = order[k];
    }
  }
}

template <int P>
int DiscreteFields::solve_phase_fields(Particles& particles,
                                       const std::vector<std::int32_t>& order,
                                       const std::vector<std::int64_t>& cell_start,
                                       const std::vector<LinearElastic>& materials)
{
  if (_phase.empty())
    return -1;
  split_by_field(particles, order, cell_start);
  // eq. 28: one phase field per discrete field, from its own particles.
  for (std::size_t q = 0; q < _phase.size(); ++q)
    if (!_phase[q].template solve<P>(particles, _field_order[q], _field_cell_start[q], materials))
      return _phase_field_of[q];
  return -1;
}

template <int P, bool External>
void DiscreteFields::particle_to_grid(const Particles& particles,
                                      const std::vector<std::int32_t>& order,
                                      const std::vector<std::int64_t>& cell_start)
{
  constexpr int K = (P + 1) * (P + 1);
  _sums.assign(_slot_field.size(), Sums{});
  _kinematics.resize(_slot_field.size());
  if (_contact_node.empty())
    return;
  const BSpline1D& bx = _grid.basis(0);
  const BSpline1D& by = _grid.basis(1);
  const int ncx = bx.cells(), ncy = by.cells();
  const double* x = particles.x.data();
  const double* v = particles.v.data();
  const double* mass = particles.mass.data();
  const double* volume = particles.volume.data();
  const double* stress = particles.stress.data();
  const double* fext = particles.fext.data();
  const std::int32_t* body = particles.body.data();

  // Only cells with a contact node; each adds into its nodes' slots in sorted
  // particle order (see for_each_cell_by_strips: no races, fixed order).
  auto scatter = [&](int cx, int cy, std::int64_t begin, std::int64_t end)
  {
    if (!_touches[static_cast<std::size_t>(cx) * ncy + cy])
      return;
    std::int32_t contact[K];
    for (int a = 0; a <= P; ++a)
      for (int b = 0; b <= P; ++b)
        contact[a * (P + 1) + b] = _contact[_grid.active_index(cx + a, cy + b)];
    for (std::int64_t k = begin; k < end; ++k)
    {
      const std::size_t p = order[k];
      double Nx[P + 1], dNx[P + 1], Ny[P + 1], dNy[P + 1];
      bx.evaluate<P>(cx, x[2 * p], Nx, dNx);
      by.evaluate<P>(cy, x[2 * p + 1], Ny, dNy);
      const double mp = mass[p];
      const double V = volume[p];
      const double sxx = V * stress[4 * p], syy = V * stress[4 * p + 1],
                   sxy = V * stress[4 * p + 2];
      for (int a = 0; a <= P; ++a)
        for (int b = 0; b <= P; ++b)
        {
          const int i = a * (P + 1) + b;
          if (contact[i] < 0)
            continue;
          Sums& s = _sums[slot(contact[i], body[p])];
          const double w = Nx[a] * Ny[b];
          const double gx = dNx[a] * Ny[b], gy = Nx[a] * dNy[b];
          s.m += w * mp;                     // eq. 46
          s.px += w * mp * v[2 * p];         // eq. 61
          s.py += w * mp * v[2 * p + 1];
          s.fx -= sxx * gx + sxy * gy;       // eq. 62
          s.fy -= sxy * gx + syy * gy;
          if constexpr (External)
          {
            const double ex = w * fext[2 * p], ey = w * fext[2 * p + 1]; // eq. 42
            s.fx += ex;
            s.fy += ey;
            s.ex += ex;
            s.ey += ey;
          }
          s.V += w * V;                      // volume, for the touch check
          s.gx += gx * mp; // eq. 70, before normalisation
          s.gy += gy * mp;
        }
    }
  };
  for_each_cell_by_strips(ncx, ncy, cell_start, scatter);
}

double DiscreteFields::update(double dt, double mass_tol)
{
  constexpr int F = max_fields_per_node;
  constexpr int max_pairs = F * (F - 1) / 2;
  const std::vector<std::uint8_t>& constrained = _grid.constraints();
  const bool walls = !constrained.empty();
  const int nf = _fields;
  // acc: external work, friction work, pairs, active, sliding, violations of C.1-C.4
  const auto acc = deterministic_sum<9>(
      _contact_node.size(),
      [&](std::size_t k, std::array<double, 9>& acc)
      {
        const std::int32_t s0 = _slot_start[k], n = _slot_start[k + 1] - s0;
        const std::int32_t node = _contact_node[k];
        // The node's volume, the integral of its basis function.
        const std::int32_t id = _grid.active_nodes()[node], ny = _grid.nodes()[1];
        const double full = _grid.basis(0).integral(id / ny) * _grid.basis(1).integral(id % ny);
        double vo[F][2], pt[F][2], vt[F][2], fn[F][2]{}, ft[F][2]{};
        bool live[F];
        for (int j = 0; j < n; ++j)
        {
          const Sums& s = _sums[s0 + j];
          live[j] = s.m > mass_tol;
          if (!live[j])
            continue;
          vo[j][0] = s.px / s.m;
          vo[j][1] = s.py / s.m;
          pt[j][0] = s.px + dt * s.fx; // trial momentum, eq. 63
          pt[j][1] = s.py + dt * s.fy;
          vt[j][0] = pt[j][0] / s.m;   // trial velocity, eq. 64
          vt[j][1] = pt[j][1] / s.m;
        }
        // Forces of each pair that approaches (eqs. 66-77), kept for the checks.
        struct Pair
        {
          int i, j;
          double n[2], s[2], fn, ft, fts, mu, scale;
        } pairs[max_pairs];
        int active = 0;
        for (int i = 0; i < n; ++i)
          for (int j = i + 1; j < n; ++j)
          {
            if (!live[i] || !live[j])
              continue;
            acc[2] += 1.0;
            const Sums& si = _sums[s0 + i];
            const Sums& sj = _sums[s0 + j];
            // Only bodies that touch: their volumes must fill the node's
            // support (docs/contact.md, "Touching").
            if (si.V + sj.V < touch_fill * full)
              continue;
            // Outward normals from the mass gradients (eq. 70), made
            // collinear as in eq. 71 but from the gradients before they are
            // normalised: n_i = (g_i - g_j) / |g_i - g_j|. Each field's
            // surface then counts by its mass gradient, so where one field
            // has little mass at the node (a block's corner over the ground)
            // the other's surface sets the normal; with unit vectors first,
            // such a corner would push along a tilted normal and brake a
            // sliding block (docs/contact.md). Tangents complete
            // right-handed bases.
            const double di[2] = {si.gx - sj.gx, si.gy - sj.gy};
            const double dj[2] = {sj.gx - si.gx, sj.gy - si.gy};
            const double ldi = std::hypot(di[0], di[1]), ldj = std::hypot(dj[0], dj[1]);
            if (!(ldi > 0.0))
              continue; // no normal to push along
            const double ni[2] = {di[0] / ldi, di[1] / ldi}, nj[2] = {dj[0] / ldj, dj[1] / ldj};
            const double ti[2] = {-ni[1], ni[0]}, tj[2] = {-nj[1], nj[0]};
            // C.1: n_i = -n_j, s_i = -s_j.
            if (std::hypot(ni[0] + nj[0], ni[1] + nj[1]) > check_tol
                || std::hypot(ti[0] + tj[0], ti[1] + tj[1]) > check_tol)
              acc[5] += 1.0;
            // Centre-of-mass velocity of the pair (eq. 66). With it,
            // M_i (u_cm - u_i) = M_i M_j / (M_i + M_j) (u_j - u_i): eqs. 69
            // and 74 are evaluated in that form, which has no cancellation
            // when one field's mass at the node is tiny.
            const double m = si.m + sj.m, reduced = si.m * sj.m / m;
            const double vcm[2] = {(pt[i][0] + pt[j][0]) / m, (pt[i][1] + pt[j][1]) / m};
            const double ri[2] = {vt[j][0] - vt[i][0], vt[j][1] - vt[i][1]};
            const double rj[2] = {vt[i][0] - vt[j][0], vt[i][1] - vt[j][1]};
            // Approach condition (eq. 77): field i moves into field j.
            if (!(-dot(ri, ni) > 0.0))
              continue;
            acc[3] += 1.0;
            const double mu = _friction[_slot_field[s0 + i] * nf + _slot_field[s0 + j]];
            // Each side: normal force (eq. 69) with the non-tension cut
            // (eq. 72), stick force (eq. 74) capped by Coulomb (eq. 75).
            const double fni = std::min(0.0, reduced / dt * dot(ri, ni));
            const double fnj = std::min(0.0, reduced / dt * dot(rj, nj));
            const double ftsi = reduced / dt * dot(ri, ti), ftsj = reduced / dt * dot(rj, tj);
            const double fti = std::copysign(std::min(mu * std::abs(fni), std::abs(ftsi)), ftsi);
            const double ftj = std::copysign(std::min(mu * std::abs(fnj), std::abs(ftsj)), ftsj);
            if (mu * std::abs(fni) < std::abs(ftsi))
              acc[4] += 1.0;
            // eq. 76 on both sides; C.2: equal and opposite.
            const double Fi[2] = {fni * ni[0] + fti * ti[0], fni * ni[1] + fti * ti[1]};
            const double Fj[2] = {fnj * nj[0] + ftj * tj[0], fnj * nj[1] + ftj * tj[1]};
            if (std::hypot(Fi[0] + Fj[0], Fi[1] + Fj[1])
                > check_tol * (std::hypot(Fi[0], Fi[1]) + std::hypot(Fj[0], Fj[1])))
              acc[6] += 1.0;
            for (int d = 0; d < 2; ++d)
            {
              fn[i][d] += fni * ni[d];
              ft[i][d] += fti * ti[d];
              fn[j][d] += fnj * nj[d];
              ft[j][d] += ftj * tj[d];
            }
            const double scale = std::hypot(vt[i][0], vt[i][1]) + std::hypot(vt[j][0], vt[j][1])
                                 + std::hypot(vcm[0], vcm[1]);
            pairs[active++] = Pair{i, j, {ni[0], ni[1]}, {ti[0], ti[1]}, fni, fti, ftsi, mu, scale};
          }
        // Corrected velocities (eq. 65), walls, and the work done.
        double vn[F][2];
        for (int j = 0; j < n; ++j)
        {
          Kinematics& kin = _kinematics[s0 + j];
          if (!live[j])
          {
            kin = Kinematics{};
            vn[j][0] = vn[j][1] = 0.0;
            continue;
          }
          const Sums& s = _sums[s0 + j];
          double vw[2] = {vo[j][0], vo[j][1]};
          for (int d = 0; d < 2; ++d)
          {
            vn[j][d] = vt[j][d] + dt * (fn[j][d] + ft[j][d]) / s.m;
            if (walls && (constrained[node] & (1 << d)))
              vn[j][d] = vw[d] = 0.0;
          }
          kin = Kinematics{vn[j][0], vn[j][1], (vn[j][0] - vo[j][0]) / dt,
                           (vn[j][1] - vo[j][1]) / dt};
          // Work over the step with the trapezoidal velocity, as the
          // external work in Solver::update_grid: of the external force and
          // of the friction force (the tangential contact force).
          const double sum[2] = {vw[0] + vn[j][0], vw[1] + vn[j][1]};
          acc[0] += 0.5 * dt * (s.ex * sum[0] + s.ey * sum[1]);
          acc[1] += 0.5 * dt * dot(ft[j], sum);
        }
        // C.3 and C.4 on the corrected velocities.
        for (int q = 0; q < active; ++q)
        {
          const Pair& c = pairs[q];
          const double g[2] = {vn[c.i][0] - vn[c.j][0], vn[c.i][1] - vn[c.j][1]};
          const double gn = dot(g, c.n), gs = dot(g, c.s), tol = check_tol * c.scale;
          // eqs. 22c-22e: no tension, no approach, and no gap rate where a force acts.
          if (c.fn > 0.0 || gn > tol || (c.fn < 0.0 && std::abs(gn) > tol))
            acc[7] += 1.0;
          // eqs. 23c-23e: stick has no slip; slip has friction at the cap, against the slip.
          const bool stick = std::abs(c.fts) <= c.mu * std::abs(c.fn);
          const double cap = c.mu * std::abs(c.fn);
          if (stick ? std::abs(gs) > tol
                    : (std::abs(std::abs(c.ft) - cap) > check_tol * cap || c.ft * gs > tol * std::abs(c.ft)))
            acc[8] += 1.0;
        }
      });
  _stats.friction_work += acc[1];
  _stats.pairs += static_cast<std::int64_t>(acc[2]);
  _stats.active += static_cast<std::int64_t>(acc[3]);
  _stats.sliding += static_cast<std::int64_t>(acc[4]);
  for (int c = 0; c < 4; ++c)
    _stats.violations[c] += static_cast<std::int64_t>(acc[5 + c]);
  return acc[0];
}

template <int P>
void DiscreteFields::field_kinematics(int cx, int cy, std::int32_t field, double* vx, double* vy,
                                      double* ax, double* ay) const
{
  for (int a = 0; a <= P; ++a)
    for (int b = 0; b <= P; ++b)
    {
      const std::int32_t k = _contact[_grid.active_index(cx + a, cy + b)];
      if (k < 0)
        continue;
      const Kinematics& kin = _kinematics[slot(k, field)];
      const int i = a * (P + 1) + b;
      vx[i] = kin.vx;
      vy[i] = kin.vy;
      ax[i] = kin.ax;
      ay[i] = kin.ay;
    }
}

std::vector<double> DiscreteFields::fracture_energies() const
{
  std::vector<double> out(_fields, 0.0);
  for (std::size_t q = 0; q < _phase.size(); ++q)
  {
    const std::vector<double>& e = _phase[q].fracture_energy();
    // Entries of other fields' particles stay zero: a field's solve writes its own.
    out[_phase_field_of[q]] = deterministic_sum<1>(
        e.size(), [&](std::size_t p, std::array<double, 1>& acc) { acc[0] += e[p]; })[0];
  }
  return out;
}

void DiscreteFields::set_phase_field_preconditioner(Preconditioner preconditioner)
{
  for (PhaseField& pf : _phase)
    pf.set_preconditioner(preconditioner);
}

PhaseFieldStats DiscreteFields::phase_field_stats() const
{
  PhaseFieldStats total;
  for (const PhaseField& pf : _phase)
  {
    const PhaseFieldStats& s = pf.stats();
    total.solves += s.solves;
    total.iterations += s.iterations;
    total.last_iterations = std::max(total.last_iterations, s.last_iterations);
    total.start_residual = std::max(total.start_residual, s.start_residual);
    total.last_residual = std::max(total.last_residual, s.last_residual);
    total.unknowns += s.unknowns;
  }
  return total;
}

DiscreteFieldsState DiscreteFields::state() const
{
  DiscreteFieldsState out{{}, _stats};
  out.phase_fields.reserve(_phase.size());
  for (const PhaseField& pf : _phase)
    out.phase_fields.push_back(pf.state());
  return out;
}

void DiscreteFields::restore(DiscreteFieldsState state)
{
  if (state.phase_fields.size() != _phase.size())
    throw std::invalid_argument("discrete fields state: "
                                + std::to_string(state.phase_fields.size()) + " phase fields for "
                                + std::to_string(_phase.size()) + " crackable fields");
  for (std::size_t q = 0; q < _phase.size(); ++q)
    _phase[q].check(state.phase_fields[q]);
  for (std::size_t q = 0; q < _phase.size(); ++q)
    _phase[q].restore(std::move(state.phase_fields[q]));
  _stats = state.stats;
}

#define PFMPM_INSTANTIATE(P)                                                                    \
  template int DiscreteFields::solve_phase_fields<P>(Particles&, const std::vector<std::int32_t>&, \
                                                     const std::vector<std::int64_t>&,          \
                                                     const std::vector<LinearElastic>&);        \
  template void DiscreteFields::particle_to_grid<P, true>(                                      \
      const Particles&, const std::vector<std::int32_t>&, const std::vector<std::int64_t>&);    \
  template void DiscreteFields::particle_to_grid<P, false>(                                     \
      const Particles&, const std::vector<std::int32_t>&, const std::vector<std::int64_t>&);    \
  template void DiscreteFields::field_kinematics<P>(int, int, std::int32_t, double*, double*,   \
                                                    double*, double*) const;
PFMPM_INSTANTIATE(1)
PFMPM_INSTANTIATE(2)
PFMPM_INSTANTIATE(3)
#undef PFMPM_INSTANTIATE

} // namespace pfmpm
