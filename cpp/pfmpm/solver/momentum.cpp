/// @file momentum.cpp
/// @brief The grid update of one slot (K&T eqs. 63-65), out of line so that
/// every velocity-field partition runs the same arithmetic, and of the
/// fields at a contact node (K&T eqs. 66-77, H&H Algorithm 3).
#include "pfmpm/solver/momentum.h"

namespace pfmpm
{

template <int Dim>
void update_free_slot(const NodeSums<Dim>& s, NodeHold hold, const Velocity<Dim>* held, double dt,
                      double mass_tol, NodeKinematics<Dim>& k, double* acc)
{
  if (s.m <= mass_tol)
  {
    k = NodeKinematics<Dim>{};
    if (s.m > 0.0)
      acc[GridUpdate<Dim>::light] += 1.0; // a light slot, counted
    return;
  }
  // Trial momentum (K&T eq. 63) and velocity (K&T eq. 64); with no contact force,
  // these are final (K&T eq. 65).
  double vo[Dim], vn[Dim];
  for (int d = 0; d < Dim; ++d)
    vo[d] = s.p[d] / s.m;
  for (int d = 0; d < Dim; ++d)
    vn[d] = vo[d] + dt * s.f[d] / s.m;
  finish_slot<Dim>(s, vo, vn, hold, held, nullptr, dt, k, acc);
}

template <int Dim>
void finish_slot(const NodeSums<Dim>& s, const double* vo, double* vn, NodeHold hold,
                 const Velocity<Dim>* held, const double* friction, double dt,
                 NodeKinematics<Dim>& k, double* acc)
{
  using U = GridUpdate<Dim>;
  constexpr int sides = num_sides(Dim);
  double vw[Dim]; // old velocity as the holders allow it
  for (int d = 0; d < Dim; ++d)
    vw[d] = vo[d];
  if (hold.held)
    for (int d = 0; d < Dim; ++d)
      if (hold.held & (1 << d))
      {
        // The holder's work and impulse (the momentum it adds along d).
        const int h = hold.by[d];
        const double u = held[h][d];
        if (h < sides)
          acc[U::wall_work] -= 0.5 * s.m * vo[d] * vo[d];
        else
          acc[U::region_work + h - sides] += 0.5 * s.m * (u * u - vo[d] * vo[d]) - s.m * (vn[d] - vo[d]) * u;
        acc[U::hold_impulse + Dim * h + d] += s.m * (u - vn[d]);
        vn[d] = vw[d] = u;
      }
  for (int d = 0; d < Dim; ++d)
  {
    k.v[d] = vn[d];
    k.a[d] = (vn[d] - vo[d]) / dt;
  }
  double work = s.e[0] * (vw[0] + vn[0]);
  for (int d = 1; d < Dim; ++d)
    work += s.e[d] * (vw[d] + vn[d]);
  acc[U::external_work] += 0.5 * dt * work;
  if (friction)
  {
    double rub = friction[0] * (vw[0] + vn[0]);
    for (int d = 1; d < Dim; ++d)
      rub += friction[d] * (vw[d] + vn[d]);
    acc[U::friction_work] += 0.5 * dt * rub;
  }
}

template void update_free_slot<2>(const NodeSums<2>&, NodeHold, const Velocity<2>*, double, double,
                                  NodeKinematics<2>&, double*);
template void update_free_slot<3>(const NodeSums<3>&, NodeHold, const Velocity<3>*, double, double,
                                  NodeKinematics<3>&, double*);

template <int Dim>
void update_contact_node(int n, const NodeSums<Dim>* sums, const SurfaceSums<Dim>* surface,
                         const std::int32_t* field, const double* friction, int nfields,
                         double touch_volume, NodeHold hold, const Velocity<Dim>* held, double dt,
                         double mass_tol, NodeKinematics<Dim>* k, double* acc)
{
  using U = GridUpdate<Dim>;
  constexpr int F = max_node_fields;
  TrialField<Dim> trial[F]{};
  bool live[F]{};
  double vo[F][Dim], fn[F][Dim]{}, ft[F][Dim]{};
  for (int j = 0; j < n; ++j)
  {
    const NodeSums<Dim>& s = sums[j];
    const SurfaceSums<Dim>& u = surface[j];
    live[j] = s.m > mass_tol;
    if (!live[j])
    {
      if (s.m > 0.0)
        acc[U::light] += 1.0;
      continue;
    }
    TrialField<Dim>& t = trial[j];
    t.m = s.m;
    for (int d = 0; d < Dim; ++d)
    {
      vo[j][d] = s.p[d] / s.m;
      t.pt[d] = s.p[d] + dt * s.f[d];             // K&T eq. 63
      t.vt[d] = vo[j][d] + dt * s.f[d] / s.m;     // K&T eq. 64
      t.g[d] = u.g[d];
    }
    t.V = u.V;
  }
  ContactPair<Dim> pairs[F * (F - 1) / 2];
  const int active = coulomb_forces<Dim>(n, trial, live, field, friction, nfields, touch_volume, dt,
                                         fn, ft, pairs, &acc[U::contact], &acc[U::pair_impulse]);
  // Corrected velocities (K&T eq. 65), checked (C.3, C.4) before the walls act
  // on them; walls, and the work done.
  double vn[F][Dim]{}, vc[F][Dim]{};
  for (int j = 0; j < n; ++j)
    if (live[j])
      for (int d = 0; d < Dim; ++d)
        vc[j][d] = vn[j][d] = trial[j].vt[d] + dt * (fn[j][d] + ft[j][d]) / sums[j].m;
  check_contact<Dim>(active, pairs, vc, &acc[U::contact]);
  for (int j = 0; j < n; ++j)
  {
    if (!live[j])
      k[j] = NodeKinematics<Dim>{};
    else
      finish_slot<Dim>(sums[j], vo[j], vn[j], hold, held, ft[j], dt, k[j], acc);
  }
}

template <int Dim>
void update_damage_node(int n, const NodeSums<Dim>* sums, const SurfaceSums<Dim>* surface,
                        const std::int32_t* field, const double* friction, int groups,
                        double separability, double touch_volume, NodeHold hold,
                        const Velocity<Dim>* held, double dt, double mass_tol, NodeKinematics<Dim>* k,
                        double* acc)
{
  using U = GridUpdate<Dim>;
  constexpr int F = max_node_fields;
  // The fields that act: a separable side on its own, the two sides of a
  // group that are not separable summed into one.
  NodeSums<Dim> unit[F];
  SurfaceSums<Dim> usurf[F];
  std::int32_t group[F], of[F];
  int units = 0;
  for (int j = 0; j < n; ++j)
  {
    const bool side_b = field[j] % 2 == 1;
    if (side_b && j > 0 && field[j - 1] == field[j] - 1)
    {
      // Sides A (slot j - 1) and B (slot j) of one group: H&H eq. 21.
      acc[U::contact + count_split] += 1.0;
      const NodeSums<Dim> &a = sums[j - 1], &b = sums[j];
      const SurfaceSums<Dim> &sa = surface[j - 1], &sb = surface[j];
      const bool apart = a.m > mass_tol && b.m > mass_tol && std::max(sa.full, sb.full) > 0.0
                         && std::min(sa.md / a.m, sb.md / b.m) > separability;
      if (apart)
        acc[U::contact + count_separable] += 1.0;
      else
      {
        NodeSums<Dim>& u = unit[units - 1];
        u.m += b.m;
        for (int d = 0; d < Dim; ++d)
          u.p[d] += b.p[d];
        for (int d = 0; d < Dim; ++d)
          u.f[d] += b.f[d];
        for (int d = 0; d < Dim; ++d)
          u.e[d] += b.e[d];
        SurfaceSums<Dim>& v = usurf[units - 1];
        for (int d = 0; d < Dim; ++d)
          v.g[d] += sb.g[d];
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
  NodeKinematics<Dim> kin[F];
  if (units == 1)
    update_free_slot<Dim>(unit[0], hold, held, dt, mass_tol, kin[0], acc);
  else
    update_contact_node<Dim>(units, unit, usurf, group, friction, groups, touch_volume, hold, held, dt,
                        mass_tol, kin, acc);
  for (int j = 0; j < n; ++j)
    k[j] = kin[of[j]];
}

template void update_contact_node<2>(int, const NodeSums<2>*, const SurfaceSums<2>*, const std::int32_t*,
                                  const double*, int, double, NodeHold, const Velocity<2>*, double,
                                  double, NodeKinematics<2>*, double*);
template void update_contact_node<3>(int, const NodeSums<3>*, const SurfaceSums<3>*, const std::int32_t*,
                                  const double*, int, double, NodeHold, const Velocity<3>*, double,
                                  double, NodeKinematics<3>*, double*);

template void update_damage_node<2>(int, const NodeSums<2>*, const SurfaceSums<2>*, const std::int32_t*,
                                    const double*, int, double, double, NodeHold, const Velocity<2>*,
                                    double, double, NodeKinematics<2>*, double*);
template void update_damage_node<3>(int, const NodeSums<3>*, const SurfaceSums<3>*, const std::int32_t*,
                                    const double*, int, double, double, NodeHold, const Velocity<3>*,
                                    double, double, NodeKinematics<3>*, double*);

} // namespace pfmpm
