/// @file coulomb.cpp
/// @brief The pair contact law at a node (K&T eqs. 66-77), its projected
/// Gauss-Seidel sweeps where three or more fields meet, and checks C.1-C.4.
#include "pfmpm/contact/coulomb.h"
#include "pfmpm/fields/fields.h"

#include <algorithm>
#include <cmath>

namespace pfmpm
{

namespace
{
/// Relative tolerance of the round-off checks C.1-C.4.
constexpr double check_tol = 1e-9;

double dot(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1]; }

/// A pair of fields that touch at a node, and its contact frame.
struct PairFrame
{
  int i, j;
  double ni[2], nj[2], ti[2], tj[2]; ///< normals and tangents of each side (K&T eq. 71)
  double reduced;                    ///< reduced mass M_i M_j / (M_i + M_j)
  double mu;                         ///< friction coefficient
  double scale;                      ///< velocity scale of the round-off tolerance
};

/// The contact force on one side of a pair.
struct SideForce
{
  double fn, ft; ///< normal force (K&T eqs. 69, 72) and friction (K&T eq. 75)
  double fts;    ///< the stick force (K&T eq. 74)
};

/// @brief The pair law on the velocities vi, vj of the pair's fields: the
/// normal force that stops their relative normal velocity, with the
/// non-tension cut (K&T eqs. 69, 72), and the stick force (K&T eq. 74) capped by
/// Coulomb (K&T eq. 75), on each side. With K&T eq. 66, M_i (u_cm - u_i) =
/// M_i M_j / (M_i + M_j) (u_j - u_i): K&T eqs. 69 and 74 are evaluated in that
/// form, which has no cancellation when one field's mass at the node is tiny.
void pair_law(const PairFrame& c, const double* vi, const double* vj, double dt, SideForce& si,
              SideForce& sj)
{
  const double ri[2] = {vj[0] - vi[0], vj[1] - vi[1]};
  const double rj[2] = {vi[0] - vj[0], vi[1] - vj[1]};
  si.fn = std::min(0.0, c.reduced / dt * dot(ri, c.ni));
  sj.fn = std::min(0.0, c.reduced / dt * dot(rj, c.nj));
  si.fts = c.reduced / dt * dot(ri, c.ti);
  sj.fts = c.reduced / dt * dot(rj, c.tj);
  si.ft = std::copysign(std::min(c.mu * std::abs(si.fn), std::abs(si.fts)), si.fts);
  sj.ft = std::copysign(std::min(c.mu * std::abs(sj.fn), std::abs(sj.fts)), sj.fts);
}

/// Force vector of one side.
void force_of(const SideForce& s, const double* n, const double* t, double* F)
{
  F[0] = s.fn * n[0] + s.ft * t[0];
  F[1] = s.fn * n[1] + s.ft * t[1];
}

/// C.3 and C.4 of one pair on the velocities vn, with relative tolerance tol.
void pair_checks(const ContactPair& c, const double (*vn)[2], double tol, bool& c3, bool& c4)
{
  const double g[2] = {vn[c.i][0] - vn[c.j][0], vn[c.i][1] - vn[c.j][1]};
  const double gn = dot(g, c.n), gs = dot(g, c.s), vtol = tol * c.scale;
  // K&T eqs. 22c-22e: no tension, no approach, and no gap rate where a force acts.
  c3 = c.fn > 0.0 || gn > vtol || (c.fn < 0.0 && std::abs(gn) > vtol);
  // K&T eqs. 23c-23e: stick has no slip; slip has friction at the cap, against the slip.
  const bool stick = std::abs(c.fts) <= c.mu * std::abs(c.fn);
  const double cap = c.mu * std::abs(c.fn);
  c4 = stick ? std::abs(gs) > vtol
             : (std::abs(std::abs(c.ft) - cap) > tol * cap || c.ft * gs > vtol * std::abs(c.ft));
}

/// The sweeps stop once every pair passes C.3 and C.4 to this relative
/// tolerance, well inside the checks' own.
constexpr double sweep_tol = 1e-2 * check_tol;
/// At most this many sweeps (docs/contact.md, "Three or more fields at a node":
/// on random nodes of three and four fields that all touch, the most needed was 3,724).
constexpr int max_sweeps = 10000;
} // namespace

int coulomb_forces(int n, const TrialField* f, const bool* live, const std::int32_t* field,
                   const double* friction, int nfields, double touch_volume, double dt,
                   double (*fn)[2], double (*ft)[2], ContactPair* pairs, double* count,
                   double* impulse)
{
  // The pairs that touch and have a normal, in the order (i, j), i < j.
  constexpr int max_pairs = BodyFields::max_fields * (BodyFields::max_fields - 1) / 2;
  PairFrame frame[max_pairs];
  int np = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
    {
      if (!live[i] || !live[j])
        continue;
      count[count_pairs] += 1.0;
      const TrialField& si = f[i];
      const TrialField& sj = f[j];
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
      // normal and brake a sliding block (docs/contact.md). Tangents complete
      // right-handed bases.
      const double di[2] = {si.g[0] - sj.g[0], si.g[1] - sj.g[1]};
      const double dj[2] = {sj.g[0] - si.g[0], sj.g[1] - si.g[1]};
      const double ldi = std::hypot(di[0], di[1]), ldj = std::hypot(dj[0], dj[1]);
      if (!(ldi > 0.0))
        continue; // no normal to push along
      PairFrame& c = frame[np++];
      c.i = i;
      c.j = j;
      c.ni[0] = di[0] / ldi;
      c.ni[1] = di[1] / ldi;
      c.nj[0] = dj[0] / ldj;
      c.nj[1] = dj[1] / ldj;
      c.ti[0] = -c.ni[1];
      c.ti[1] = c.ni[0];
      c.tj[0] = -c.nj[1];
      c.tj[1] = c.nj[0];
      // C.1: n_i = -n_j, s_i = -s_j.
      if (std::hypot(c.ni[0] + c.nj[0], c.ni[1] + c.nj[1]) > check_tol
          || std::hypot(c.ti[0] + c.tj[0], c.ti[1] + c.tj[1]) > check_tol)
        count[count_c1] += 1.0;
      // Centre-of-mass velocity of the pair (K&T eq. 66), for the tolerance's scale.
      const double m = si.m + sj.m;
      const double vcm[2] = {(si.pt[0] + sj.pt[0]) / m, (si.pt[1] + sj.pt[1]) / m};
      c.reduced = si.m * sj.m / m;
      c.mu = friction[field[i] * nfields + field[j]];
      c.scale = std::hypot(si.vt[0], si.vt[1]) + std::hypot(sj.vt[0], sj.vt[1])
                + std::hypot(vcm[0], vcm[1]);
    }
  SideForce side[max_pairs][2];
  int active = 0;
  if (np == 1)
  {
    // One pair: K&T's algorithm, from the trial velocities. Where it does
    // not approach (K&T eq. 77), there is no contact force at all.
    const PairFrame& c = frame[0];
    const double ri[2] = {f[c.j].vt[0] - f[c.i].vt[0], f[c.j].vt[1] - f[c.i].vt[1]};
    if (!(-dot(ri, c.ni) > 0.0))
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
    double v[BodyFields::max_fields][2] = {}, Fi[max_pairs][2] = {}, Fj[max_pairs][2] = {};
    for (int a = 0; a < n; ++a)
      if (live[a])
      {
        v[a][0] = f[a].vt[0];
        v[a][1] = f[a].vt[1];
      }
    for (int sweep = 0; sweep < max_sweeps; ++sweep)
    {
      for (int q = 0; q < np; ++q)
      {
        const PairFrame& c = frame[q];
        const double mi = f[c.i].m, mj = f[c.j].m;
        const double vi[2] = {v[c.i][0] - dt * Fi[q][0] / mi, v[c.i][1] - dt * Fi[q][1] / mi};
        const double vj[2] = {v[c.j][0] - dt * Fj[q][0] / mj, v[c.j][1] - dt * Fj[q][1] / mj};
        pair_law(c, vi, vj, dt, side[q][0], side[q][1]);
        force_of(side[q][0], c.ni, c.ti, Fi[q]);
        force_of(side[q][1], c.nj, c.tj, Fj[q]);
        for (int d = 0; d < 2; ++d)
        {
          v[c.i][d] = vi[d] + dt * Fi[q][d] / mi;
          v[c.j][d] = vj[d] + dt * Fj[q][d] / mj;
        }
      }
      bool done = true;
      for (int q = 0; q < np && done; ++q)
      {
        const PairFrame& c = frame[q];
        const ContactPair p{c.i, c.j, {c.ni[0], c.ni[1]}, {c.ti[0], c.ti[1]}, side[q][0].fn,
                            side[q][0].ft, side[q][0].fts, c.mu, c.scale};
        bool c3, c4;
        pair_checks(p, v, sweep_tol, c3, c4);
        done = !c3 && !c4;
      }
      if (done)
        break;
    }
  }
  // The forces (K&T eq. 76) of the pairs that push, and their record.
  for (int q = 0; q < np; ++q)
  {
    const PairFrame& c = frame[q];
    const SideForce &si = side[q][0], &sj = side[q][1];
    // Every pair that pushed is checked (C.3, C.4), and with two or more
    // pairs every pair, pushing or not.
    pairs[active++] = ContactPair{c.i, c.j, {c.ni[0], c.ni[1]}, {c.ti[0], c.ti[1]}, si.fn, si.ft,
                                  si.fts, c.mu, c.scale};
    if (np > 1 && !(si.fn < 0.0))
      continue;
    count[count_active] += 1.0;
    if (c.mu * std::abs(si.fn) < std::abs(si.fts))
      count[count_sliding] += 1.0;
    // K&T eq. 76 on both sides; C.2: equal and opposite.
    double Fi[2], Fj[2];
    force_of(si, c.ni, c.ti, Fi);
    force_of(sj, c.nj, c.tj, Fj);
    if (std::hypot(Fi[0] + Fj[0], Fi[1] + Fj[1])
        > check_tol * (std::hypot(Fi[0], Fi[1]) + std::hypot(Fj[0], Fj[1])))
      count[count_c2] += 1.0;
    for (int d = 0; d < 2; ++d)
    {
      fn[c.i][d] += si.fn * c.ni[d];
      ft[c.i][d] += si.ft * c.ti[d];
      fn[c.j][d] += sj.fn * c.nj[d];
      ft[c.j][d] += sj.ft * c.tj[d];
    }
    // The pair's impulse, on its lower-numbered field.
    const int a = field[c.i], b = field[c.j];
    if (a != b && std::max(a, b) < max_pair_fields)
    {
      const double* F = a < b ? Fi : Fj;
      double* out = &impulse[2 * field_pair(std::min(a, b), std::max(a, b))];
      out[0] += dt * F[0];
      out[1] += dt * F[1];
    }
  }
  return active;
}

void check_contact(int active, const ContactPair* pairs, const double (*vn)[2], double* count)
{
  for (int q = 0; q < active; ++q)
  {
    bool c3, c4;
    pair_checks(pairs[q], vn, check_tol, c3, c4);
    count[count_c3] += c3 ? 1.0 : 0.0;
    count[count_c4] += c4 ? 1.0 : 0.0;
  }
}

} // namespace pfmpm
