/// @file disks.h
/// @brief Disks of particles for the contact tests: test_contact.cpp, test_state.cpp.
#pragma once

#include "pfmpm/particles/particles.h"

#include <cmath>
#include <cstdint>
#include <vector>

namespace pfmpm::test
{
struct Disk
{
  double cx, cy, r, vx, vy;
};

/// Disks of particles on a lattice of spacing d, body i for disk i.
inline Particles make_disks(const std::vector<Disk>& disks, double d)
{
  std::vector<double> xs, ys, vx, vy;
  std::vector<std::int32_t> body;
  for (std::size_t b = 0; b < disks.size(); ++b)
  {
    const Disk& k = disks[b];
    const int n = static_cast<int>(std::ceil(2 * k.r / d));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
      {
        const double x = -k.r + (i + 0.5) * d, y = -k.r + (j + 0.5) * d;
        if (x * x + y * y < k.r * k.r)
        {
          xs.push_back(k.cx + x);
          ys.push_back(k.cy + y);
          vx.push_back(k.vx);
          vy.push_back(k.vy);
          body.push_back(static_cast<std::int32_t>(b));
        }
      }
  }
  Particles P(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i)
  {
    P.x[2 * i] = xs[i];
    P.x[2 * i + 1] = ys[i];
    P.v[2 * i] = vx[i];
    P.v[2 * i + 1] = vy[i];
    P.volume[i] = d * d;
    P.mass[i] = d * d;
    P.body[i] = body[i];
  }
  return P;
}

} // namespace pfmpm::test
