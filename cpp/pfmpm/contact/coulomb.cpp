/// @file coulomb.cpp
/// @brief The pair contact law at a node (K&T eqs. 66-77) and checks C.1-C.4.
#include "pfmpm/contact/coulomb.h"

#include <algorithm>
#include <cmath>

namespace pfmpm
{

namespace
{
/// Relative tolerance of the round-off checks C.1-C.4.
constexpr double check_tol = 1e-9;

double dot(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1]; }
} // namespace

int coulomb_forces(int n, const TrialField* f, const bool* live, const std::int32_t* field,
                   const double* friction, int nfields, double full, double dt, double (*fn)[2],
                   double (*ft)[2], ContactPair* pairs, double* count)
{
  int active = 0;
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
      if (si.V + sj.V < touch_fill * full)
        continue;
      // Outward normals from the mass gradients (eq. 70), made collinear as
      // in eq. 71 but from the gradients before they are normalised:
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
      const double ni[2] = {di[0] / ldi, di[1] / ldi}, nj[2] = {dj[0] / ldj, dj[1] / ldj};
      const double ti[2] = {-ni[1], ni[0]}, tj[2] = {-nj[1], nj[0]};
      // C.1: n_i = -n_j, s_i = -s_j.
      if (std::hypot(ni[0] + nj[0], ni[1] + nj[1]) > check_tol
          || std::hypot(ti[0] + tj[0], ti[1] + tj[1]) > check_tol)
        count[count_c1] += 1.0;
      // Centre-of-mass velocity of the pair (eq. 66). With it,
      // M_i (u_cm - u_i) = M_i M_j / (M_i + M_j) (u_j - u_i): eqs. 69 and 74
      // are evaluated in that form, which has no cancellation when one
      // field's mass at the node is tiny.
      const double m = si.m + sj.m, reduced = si.m * sj.m / m;
      const double vcm[2] = {(si.pt[0] + sj.pt[0]) / m, (si.pt[1] + sj.pt[1]) / m};
      const double ri[2] = {sj.vt[0] - si.vt[0], sj.vt[1] - si.vt[1]};
      const double rj[2] = {si.vt[0] - sj.vt[0], si.vt[1] - sj.vt[1]};
      // Approach condition (eq. 77): field i moves into field j.
      if (!(-dot(ri, ni) > 0.0))
        continue;
      count[count_active] += 1.0;
      const double mu = friction[field[i] * nfields + field[j]];
      // Each side: normal force (eq. 69) with the non-tension cut (eq. 72),
      // stick force (eq. 74) capped by Coulomb (eq. 75).
      const double fni = std::min(0.0, reduced / dt * dot(ri, ni));
      const double fnj = std::min(0.0, reduced / dt * dot(rj, nj));
      const double ftsi = reduced / dt * dot(ri, ti), ftsj = reduced / dt * dot(rj, tj);
      const double fti = std::copysign(std::min(mu * std::abs(fni), std::abs(ftsi)), ftsi);
      const double ftj = std::copysign(std::min(mu * std::abs(fnj), std::abs(ftsj)), ftsj);
      if (mu * std::abs(fni) < std::abs(ftsi))
        count[count_sliding] += 1.0;
      // eq. 76 on both sides; C.2: equal and opposite.
      const double Fi[2] = {fni * ni[0] + fti * ti[0], fni * ni[1] + fti * ti[1]};
      const double Fj[2] = {fnj * nj[0] + ftj * tj[0], fnj * nj[1] + ftj * tj[1]};
      if (std::hypot(Fi[0] + Fj[0], Fi[1] + Fj[1])
          > check_tol * (std::hypot(Fi[0], Fi[1]) + std::hypot(Fj[0], Fj[1])))
        count[count_c2] += 1.0;
      for (int d = 0; d < 2; ++d)
      {
        fn[i][d] += fni * ni[d];
        ft[i][d] += fti * ti[d];
        fn[j][d] += fnj * nj[d];
        ft[j][d] += ftj * tj[d];
      }
      const double scale = std::hypot(si.vt[0], si.vt[1]) + std::hypot(sj.vt[0], sj.vt[1])
                           + std::hypot(vcm[0], vcm[1]);
      pairs[active++] = ContactPair{i, j, {ni[0], ni[1]}, {ti[0], ti[1]}, fni, fti, ftsi, mu, scale};
    }
  return active;
}

void check_contact(int active, const ContactPair* pairs, const double (*vn)[2], double* count)
{
  for (int q = 0; q < active; ++q)
  {
    const ContactPair& c = pairs[q];
    const double g[2] = {vn[c.i][0] - vn[c.j][0], vn[c.i][1] - vn[c.j][1]};
    const double gn = dot(g, c.n), gs = dot(g, c.s), tol = check_tol * c.scale;
    // eqs. 22c-22e: no tension, no approach, and no gap rate where a force acts.
    if (c.fn > 0.0 || gn > tol || (c.fn < 0.0 && std::abs(gn) > tol))
      count[count_c3] += 1.0;
    // eqs. 23c-23e: stick has no slip; slip has friction at the cap, against the slip.
    const bool stick = std::abs(c.fts) <= c.mu * std::abs(c.fn);
    const double cap = c.mu * std::abs(c.fn);
    if (stick ? std::abs(gs) > tol
              : (std::abs(std::abs(c.ft) - cap) > check_tol * cap || c.ft * gs > tol * std::abs(c.ft)))
      count[count_c4] += 1.0;
  }
}

} // namespace pfmpm
