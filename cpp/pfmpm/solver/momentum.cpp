/// @file momentum.cpp
/// @brief The grid update of one slot (K&T eqs. 63-65), out of line so that
/// every velocity-field partition runs the same arithmetic.
#include "pfmpm/solver/momentum.h"

namespace pfmpm
{

void update_free_slot(const NodeSums& s, std::uint8_t walls, double dt, double mass_tol,
                      NodeKinematics& k, double* acc)
{
  if (s.m <= mass_tol)
  {
    k = NodeKinematics{};
    if (s.m > 0.0)
      acc[sum_light] += 1.0; // a light slot, counted
    return;
  }
  // Trial momentum (eq. 63) and velocity (eq. 64); with no contact force,
  // these are final (eq. 65).
  const double vo[2] = {s.px / s.m, s.py / s.m};
  double vn[2] = {vo[0] + dt * s.fx / s.m, vo[1] + dt * s.fy / s.m};
  finish_slot(s, vo, vn, walls, nullptr, dt, k, acc);
}

void finish_slot(const NodeSums& s, const double* vo, double* vn, std::uint8_t walls,
                 const double* friction, double dt, NodeKinematics& k, double* acc)
{
  double vw[2] = {vo[0], vo[1]}; // old velocity as the wall allows it
  if (walls)
    for (int d = 0; d < 2; ++d)
      if (walls & (1 << d))
      {
        // The wall's work: the kinetic energy it stops along d.
        acc[sum_wall_work] -= 0.5 * s.m * vo[d] * vo[d];
        vn[d] = vw[d] = 0.0;
      }
  k = NodeKinematics{vn[0], vn[1], (vn[0] - vo[0]) / dt, (vn[1] - vo[1]) / dt};
  acc[sum_external_work] += 0.5 * dt * (s.ex * (vw[0] + vn[0]) + s.ey * (vw[1] + vn[1]));
  if (friction)
    acc[sum_friction_work] +=
        0.5 * dt * (friction[0] * (vw[0] + vn[0]) + friction[1] * (vw[1] + vn[1]));
}

} // namespace pfmpm
