/// @file momentum.cpp
/// @brief The grid update of one slot (K&T eqs. 63-65), out of line so that
/// every velocity-field partition runs the same arithmetic, and of the
/// fields at a contact node (K&T eqs. 66-77, H&H Algorithm 3).
#include "pfmpm/solver/momentum.h"

namespace pfmpm
{

void update_free_slot(const NodeSums& s, NodeHold hold, const Velocity* held, double dt,
                      double mass_tol, NodeKinematics& k, double* acc)
{
  if (s.m <= mass_tol)
  {
    k = NodeKinematics{};
    if (s.m > 0.0)
      acc[sum_light] += 1.0; // a light slot, counted
    return;
  }
  // Trial momentum (K&T eq. 63) and velocity (K&T eq. 64); with no contact force,
  // these are final (K&T eq. 65).
  const double vo[2] = {s.px / s.m, s.py / s.m};
  double vn[2] = {vo[0] + dt * s.fx / s.m, vo[1] + dt * s.fy / s.m};
  finish_slot(s, vo, vn, hold, held, nullptr, dt, k, acc);
}

void finish_slot(const NodeSums& s, const double* vo, double* vn, NodeHold hold, const Velocity* held,
                 const double* friction, double dt, NodeKinematics& k, double* acc)
{
  double vw[2] = {vo[0], vo[1]}; // old velocity as the holders allow it
  if (hold.held)
    for (int d = 0; d < 2; ++d)
      if (hold.held & (1 << d))
      {
        // The holder's work and impulse (the momentum it adds along d).
        const int h = hold.by[d];
        const double u = held[h][d];
        if (h < 4)
          acc[sum_wall_work] -= 0.5 * s.m * vo[d] * vo[d];
        else
          acc[sum_region_work + h - 4] += 0.5 * s.m * (u * u - vo[d] * vo[d]) - s.m * (vn[d] - vo[d]) * u;
        acc[sum_hold_impulse + 2 * h + d] += s.m * (u - vn[d]);
        vn[d] = vw[d] = u;
      }
  k = NodeKinematics{vn[0], vn[1], (vn[0] - vo[0]) / dt, (vn[1] - vo[1]) / dt};
  acc[sum_external_work] += 0.5 * dt * (s.ex * (vw[0] + vn[0]) + s.ey * (vw[1] + vn[1]));
  if (friction)
    acc[sum_friction_work] +=
        0.5 * dt * (friction[0] * (vw[0] + vn[0]) + friction[1] * (vw[1] + vn[1]));
}

void update_contact_node(int n, const NodeSums* sums, const SurfaceSums* surface,
                         const std::int32_t* field, const double* friction, int nfields,
                         double touch_volume, NodeHold hold, const Velocity* held, double dt,
                         double mass_tol, NodeKinematics* k, double* acc)
{
  constexpr int F = BodyFields::max_fields;
  TrialField trial[F]{};
  bool live[F]{};
  double vo[F][2], fn[F][2]{}, ft[F][2]{};
  for (int j = 0; j < n; ++j)
  {
    const NodeSums& s = sums[j];
    const SurfaceSums& u = surface[j];
    live[j] = s.m > mass_tol;
    if (!live[j])
    {
      if (s.m > 0.0)
        acc[sum_light] += 1.0;
      continue;
    }
    vo[j][0] = s.px / s.m;
    vo[j][1] = s.py / s.m;
    trial[j] = TrialField{s.m,
                          {s.px + dt * s.fx, s.py + dt * s.fy},                       // K&T eq. 63
                          {vo[j][0] + dt * s.fx / s.m, vo[j][1] + dt * s.fy / s.m}, // K&T eq. 64
                          {u.gx, u.gy},
                          u.V};
  }
  ContactPair pairs[F * (F - 1) / 2];
  const int active = coulomb_forces(n, trial, live, field, friction, nfields, touch_volume, dt, fn,
                                    ft, pairs, &acc[sum_contact], &acc[sum_pair_impulse]);
  // Corrected velocities (K&T eq. 65), checked (C.3, C.4) before the walls act
  // on them; walls, and the work done.
  double vn[F][2]{}, vc[F][2]{};
  for (int j = 0; j < n; ++j)
    if (live[j])
      for (int d = 0; d < 2; ++d)
        vc[j][d] = vn[j][d] = trial[j].vt[d] + dt * (fn[j][d] + ft[j][d]) / sums[j].m;
  check_contact(active, pairs, vc, &acc[sum_contact]);
  for (int j = 0; j < n; ++j)
  {
    if (!live[j])
      k[j] = NodeKinematics{};
    else
      finish_slot(sums[j], vo[j], vn[j], hold, held, ft[j], dt, k[j], acc);
  }
}

void update_damage_node(int n, const NodeSums* sums, const SurfaceSums* surface,
                        const std::int32_t* field, const double* friction, int groups,
                        double separability, double touch_volume, NodeHold hold,
                        const Velocity* held, double dt, double mass_tol, NodeKinematics* k,
                        double* acc)
{
  constexpr int F = BodyFields::max_fields;
  // The fields that act: a separable side on its own, the two sides of a
  // group that are not separable summed into one.
  NodeSums unit[F];
  SurfaceSums usurf[F];
  std::int32_t group[F], of[F];
  int units = 0;
  for (int j = 0; j < n; ++j)
  {
    const bool side_b = field[j] % 2 == 1;
    if (side_b && j > 0 && field[j - 1] == field[j] - 1)
    {
      // Sides A (slot j - 1) and B (slot j) of one group: H&H eq. 21.
      acc[sum_contact + count_split] += 1.0;
      const NodeSums &a = sums[j - 1], &b = sums[j];
      const SurfaceSums &sa = surface[j - 1], &sb = surface[j];
      const bool apart = a.m > mass_tol && b.m > mass_tol && std::max(sa.full, sb.full) > 0.0
                         && std::min(sa.md / a.m, sb.md / b.m) > separability;
      if (apart)
        acc[sum_contact + count_separable] += 1.0;
      else
      {
        NodeSums& u = unit[units - 1];
        u.m += b.m;
        u.px += b.px;
        u.py += b.py;
        u.fx += b.fx;
        u.fy += b.fy;
        u.ex += b.ex;
        u.ey += b.ey;
        SurfaceSums& v = usurf[units - 1];
        v.gx += sb.gx;
        v.gy += sb.gy;
        v.V += sb.V;
        of[j] = units - 1;
        continue;
      }
    }
    unit[units] = sums[j];
    usurf[units] = surface[j];
    group[units] = field[j] / 2;
    of[j] = units++;
  }
  NodeKinematics kin[F];
  if (units == 1)
    update_free_slot(unit[0], hold, held, dt, mass_tol, kin[0], acc);
  else
    update_contact_node(units, unit, usurf, group, friction, groups, touch_volume, hold, held, dt,
                        mass_tol, kin, acc);
  for (int j = 0; j < n; ++j)
    k[j] = kin[of[j]];
}

} // namespace pfmpm
