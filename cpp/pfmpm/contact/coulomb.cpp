/// @file coulomb.cpp
/// @brief The pair contact law at a node (K&T eqs. 66-77), its projected
/// Gauss-Seidel sweeps where three or more fields meet, and checks C.1-C.4.
#include "pfmpm/contact/coulomb.h"
#include "pfmpm/common/vector.h"
#include "pfmpm/fields/fields.h"

#include <algorithm>
#include <cmath>

namespace pfmpm
{

namespace
{
/// Relative tolerance of the round-off checks C.1-C.4.
constexpr double check_tol = 1e-9;

/// A pair of fields that touch at a node, and its contact frame.
template <int Dim>
struct PairFrame
{
  int i, j;
  double ni[Dim], nj[Dim]; ///< normals of each side (K&T eq. 71)
  double ti[Dim], tj[Dim]; ///< in 2D the tangents of each side (in 3D the pair law's)
  double reduced;          ///< reduced mass M_i M_j / (M_i + M_j)
  double mu;               ///< friction coefficient
  double scale;            ///< velocity scale of the round-off tolerance
};

/// The contact force on one side of a pair.
template <int Dim>
struct SideForce
{
  double fn, ft; ///< normal force (K&T eqs. 69, 72) and friction (K&T eq. 75) along t
  double fts;    ///< the stick force (K&T eq. 74) along t
  double t[Dim]; ///< the tangent the friction acts along
};

/// @brief The pair law on the velocities vi, vj of the pair's fields: the
/// normal force that stops their relative normal velocity, with the
/// non-tension cut (K&T eqs. 69, 72), and the stick force (K&T eq. 74) capped by
/// Coulomb (K&T eq. 75), on each side. With K&T eq. 66, M_i (u_cm - u_i) =
/// M_i M_j / (M_i + M_j) (u_j - u_i): K&T eqs. 69 and 74 are evaluated in that
/// form, which has no cancellation when one field's mass at the node is tiny.
/// In 2D along the frame's tangent; in 3D along the relative velocity's
/// component in the tangent plane (none where it has none).
template <int Dim>
void pair_law(const PairFrame<Dim>& c, const double* vi, const double* vj, double dt,
              SideForce<Dim>& si, SideForce<Dim>& sj)
{
  double ri[Dim], rj[Dim];
  for (int d = 0; d < Dim; ++d)
    ri[d] = vj[d] - vi[d];
  for (int d = 0; d < Dim; ++d)
    rj[d] = vi[d] - vj[d];
  si.fn = std::min(0.0, c.reduced / dt * dot<Dim>(ri, c.ni));
  sj.fn = std::min(0.0, c.reduced / dt * dot<Dim>(rj, c.nj));
  if constexpr (Dim == 2)
  {
    std::copy(c.ti, c.ti + 2, si.t);
    std::copy(c.tj, c.tj + 2, sj.t);
    si.fts = c.reduced / dt * dot<2>(ri, c.ti);
    sj.fts = c.reduced / dt * dot<2>(rj, c.tj);
  }
  else
  {
    auto tangent = [&](const double* r, const double* n, SideForce<Dim>& side)
    {
      const double rn = dot<Dim>(r, n);
      double rt[Dim];
      for (int d = 0; d < Dim; ++d)
        rt[d] = r[d] - rn * n[d];
      const double slip = length<Dim>(rt);
      for (int d = 0; d < Dim; ++d)
        side.t[d] = slip > 0.0 ? rt[d] / slip : 0.0;
      side.fts = c.reduced / dt * slip;
    };
    tangent(ri, c.ni, si);
    tangent(rj, c.nj, sj);
  }
  si.ft = std::copysign(std::min(c.mu * std::abs(si.fn), std::abs(si.fts)), si.fts);
  sj.ft = std::copysign(std::min(c.mu * std::abs(sj.fn), std::abs(sj.fts)), sj.fts);
}

/// Force vector of one side.
template <int Dim>
void force_of(const SideForce<Dim>& s, const double* n, double* F)
{
  for (int d = 0; d < Dim; ++d)
    F[d] = s.fn * n[d] + s.ft * s.t[d];
}

/// The record of a pair, with side i's force.
template <int Dim>
ContactPair<Dim> record(const PairFrame<Dim>& c, const SideForce<Dim>& si)
{
  ContactPair<Dim> p{c.i, c.j, {}, {}, si.fn, si.ft, si.fts, c.mu, c.scale};
  std::copy(c.ni, c.ni + Dim, p.n);
  std::copy(si.t, si.t + Dim, p.s);
  return p;
}

/// C.3 and C.4 of one pair on the velocities vn, with relative tolerance tol.
template <int Dim>
void pair_checks(const ContactPair<Dim>& c, const double (*vn)[Dim], double tol, bool& c3, bool& c4)
{
  double g[Dim];
  for (int d = 0; d < Dim; ++d)
    g[d] = vn[c.i][d] - vn[c.j][d];
  const double gn = dot<Dim>(g, c.n), gs = dot<Dim>(g, c.s), vtol = tol * c.scale;
  // K&T eqs. 22c-22e: no tension, no approach, and no gap rate where a force acts.
  c3 = c.fn > 0.0 || gn > vtol || (c.fn < 0.0 && std::abs(gn) > vtol);
  // K&T eqs. 23c-23e: stick has no slip; slip has friction at the cap, against the slip.
  // In 3D the slip of a stuck pair is the whole tangential relative velocity.
  double slip = std::abs(gs);
  if constexpr (Dim == 3)
  {
    double gt[Dim];
    for (int d = 0; d < Dim; ++d)
      gt[d] = g[d] - gn * c.n[d];
    slip = length<Dim>(gt);
  }
  const bool stick = std::abs(c.fts) <= c.mu * std::abs(c.fn);
  const double cap = c.mu * std::abs(c.fn);
  c4 = stick ? slip > vtol
             : (std::abs(std::abs(c.ft) - cap) > tol * cap || c.ft * gs > vtol * std::abs(c.ft));
}

/// The sweeps stop once every pair passes C.3 and C.4 to this relative
/// tolerance, well inside the checks' own.
constexpr double sweep_tol = 1e-2 * check_tol;
/// At most this many sweeps (docs/contact.md, "Three or more fields at a node":
/// on random nodes of three and four fields that all touch, the most needed was 3,724).
constexpr int max_sweeps = 10000;
} // namespace

template <int Dim>
int coulomb_forces(int n, const TrialField<Dim>* f, const bool* live, const std::int32_t* field,
                   const double* friction, int nfields, double touch_volume, double dt,
                   double (*fn)[Dim], double (*ft)[Dim], ContactPair<Dim>* pairs, double* count,
                   double* impulse)
{
  // The pairs that touch and have a normal, in the order (i, j), i < j.
  constexpr int max_pairs = max_node_fields * (max_node_fields - 1) / 2;
  PairFrame<Dim> frame[max_pairs];
  int np = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
    {
      if (!live[i] || !live[j])
        continue;
      count[count_pairs] += 1.0;
      const TrialField<Dim>& si = f[i];
      const TrialField<Dim>& sj = f[j];
      // Only bodies that touch: their volumes must fill the node's support
      // (docs/contact.md, "Touching").
      if (si.V + sj.V < touch_volume)
        continue;
      // Outward normals from the mass gradients (K&T eq. 70), made collinear as
      // in K&T eq. 71 but from the gradients before they are normalised:
      // n_i = (g_i - g_j) / |g_i - g_j|. Each field's surface then counts by
      // its mass gradient, so where one field has little mass at the node (a
      // block's corner over the ground) the other's surface sets the normal;
      // with unit vectors first, such a corner would push along a tilted
      // normal and brake a sliding block (docs/contact.md). In 2D tangents
      // complete right-handed bases.
      double di[Dim], dj[Dim];
      for (int d = 0; d < Dim; ++d)
        di[d] = si.g[d] - sj.g[d];
      for (int d = 0; d < Dim; ++d)
        dj[d] = sj.g[d] - si.g[d];
      const double ldi = length<Dim>(di), ldj = length<Dim>(dj);
      if (!(ldi > 0.0))
        continue; // no normal to push along
      PairFrame<Dim>& c = frame[np++];
      c.i = i;
      c.j = j;
      for (int d = 0; d < Dim; ++d)
        c.ni[d] = di[d] / ldi;
      for (int d = 0; d < Dim; ++d)
        c.nj[d] = dj[d] / ldj;
      double sum[Dim];
      for (int d = 0; d < Dim; ++d)
        sum[d] = c.ni[d] + c.nj[d];
      if constexpr (Dim == 2)
      {
        c.ti[0] = -c.ni[1];
        c.ti[1] = c.ni[0];
        c.tj[0] = -c.nj[1];
        c.tj[1] = c.nj[0];
        // C.1: n_i = -n_j, s_i = -s_j.
        if (length<2>(sum) > check_tol || std::hypot(c.ti[0] + c.tj[0], c.ti[1] + c.tj[1]) > check_tol)
          count[count_c1] += 1.0;
      }
      else if (length<Dim>(sum) > check_tol) // C.1: n_i = -n_j (the tangents follow)
        count[count_c1] += 1.0;
      // Centre-of-mass velocity of the pair (K&T eq. 66), for the tolerance's scale.
      const double m = si.m + sj.m;
      double vcm[Dim];
      for (int d = 0; d < Dim; ++d)
        vcm[d] = (si.pt[d] + sj.pt[d]) / m;
      c.reduced = si.m * sj.m / m;
      c.mu = friction[field[i] * nfields + field[j]];
      c.scale = length<Dim>(si.vt) + length<Dim>(sj.vt) + length<Dim>(vcm);
    }
  SideForce<Dim> side[max_pairs][2];
  int active = 0;
  if (np == 1)
  {
    // One pair: K&T's algorithm, from the trial velocities. Where it does
    // not approach (K&T eq. 77), there is no contact force at all.
    const PairFrame<Dim>& c = frame[0];
    double ri[Dim];
    for (int d = 0; d < Dim; ++d)
      ri[d] = f[c.j].vt[d] - f[c.i].vt[d];
    if (!(-dot<Dim>(ri, c.ni) > 0.0))
      return 0;
    pair_law(c, f[c.i].vt, f[c.j].vt, dt, side[0][0], side[0][1]);
  }
  else if (np > 1)
  {
    // Three or more fields: projected Gauss-Seidel over the pairs in their
    // order. Each pair's force is recomputed by the pair law from the
    // velocities all the other pairs' current forces leave, and replaces its
    // previous one; the sweeps stop when the velocities pass C.3 and C.4
    // (docs/contact.md, "Three or more fields at a node").
    double v[max_node_fields][Dim] = {}, Fi[max_pairs][Dim] = {}, Fj[max_pairs][Dim] = {};
    for (int a = 0; a < n; ++a)
      if (live[a])
        for (int d = 0; d < Dim; ++d)
          v[a][d] = f[a].vt[d];
    for (int sweep = 0; sweep < max_sweeps; ++sweep)
    {
      for (int q = 0; q < np; ++q)
      {
        const PairFrame<Dim>& c = frame[q];
        const double mi = f[c.i].m, mj = f[c.j].m;
        double vi[Dim], vj[Dim];
        for (int d = 0; d < Dim; ++d)
          vi[d] = v[c.i][d] - dt * Fi[q][d] / mi;
        for (int d = 0; d < Dim; ++d)
          vj[d] = v[c.j][d] - dt * Fj[q][d] / mj;
        pair_law(c, vi, vj, dt, side[q][0], side[q][1]);
        force_of(side[q][0], c.ni, Fi[q]);
        force_of(side[q][1], c.nj, Fj[q]);
        for (int d = 0; d < Dim; ++d)
        {
          v[c.i][d] = vi[d] + dt * Fi[q][d] / mi;
          v[c.j][d] = vj[d] + dt * Fj[q][d] / mj;
        }
      }
      bool done = true;
      for (int q = 0; q < np && done; ++q)
      {
        bool c3, c4;
        pair_checks(record(frame[q], side[q][0]), v, sweep_tol, c3, c4);
        done = !c3 && !c4;
      }
      if (done)
        break;
    }
  }
  // The forces (K&T eq. 76) of the pairs that push, and their record.
  for (int q = 0; q < np; ++q)
  {
    const PairFrame<Dim>& c = frame[q];
    const SideForce<Dim> &si = side[q][0], &sj = side[q][1];
    // Every pair that pushed is checked (C.3, C.4), and with two or more
    // pairs every pair, pushing or not.
    pairs[active++] = record(c, si);
    if (np > 1 && !(si.fn < 0.0))
      continue;
    count[count_active] += 1.0;
    if (c.mu * std::abs(si.fn) < std::abs(si.fts))
      count[count_sliding] += 1.0;
    // K&T eq. 76 on both sides; C.2: equal and opposite.
    double Fi[Dim], Fj[Dim], net[Dim];
    force_of(si, c.ni, Fi);
    force_of(sj, c.nj, Fj);
    for (int d = 0; d < Dim; ++d)
      net[d] = Fi[d] + Fj[d];
    if (length<Dim>(net) > check_tol * (length<Dim>(Fi) + length<Dim>(Fj)))
      count[count_c2] += 1.0;
    for (int d = 0; d < Dim; ++d)
    {
      fn[c.i][d] += si.fn * c.ni[d];
      ft[c.i][d] += si.ft * si.t[d];
      fn[c.j][d] += sj.fn * c.nj[d];
      ft[c.j][d] += sj.ft * sj.t[d];
    }
    // The pair's impulse, on its lower-numbered field.
    const int a = field[c.i], b = field[c.j];
    if (a != b && std::max(a, b) < max_pair_fields)
    {
      const double* F = a < b ? Fi : Fj;
      double* out = &impulse[Dim * field_pair(std::min(a, b), std::max(a, b))];
      for (int d = 0; d < Dim; ++d)
        out[d] += dt * F[d];
    }
  }
  return active;
}

template <int Dim>
void check_contact(int active, const ContactPair<Dim>* pairs, const double (*vn)[Dim], double* count)
{
  for (int q = 0; q < active; ++q)
  {
    bool c3, c4;
    pair_checks(pairs[q], vn, check_tol, c3, c4);
    count[count_c3] += c3 ? 1.0 : 0.0;
    count[count_c4] += c4 ? 1.0 : 0.0;
  }
}

template int coulomb_forces(int, const TrialField<2>*, const bool*, const std::int32_t*, const double*,
                            int, double, double, double (*)[2], double (*)[2], ContactPair<2>*,
                            double*, double*);
template int coulomb_forces(int, const TrialField<3>*, const bool*, const std::int32_t*, const double*,
                            int, double, double, double (*)[3], double (*)[3], ContactPair<3>*,
                            double*, double*);
template void check_contact(int, const ContactPair<2>*, const double (*)[2], double*);
template void check_contact(int, const ContactPair<3>*, const double (*)[3], double*);

} // namespace pfmpm
