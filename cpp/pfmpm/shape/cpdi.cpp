/// @file cpdi.cpp
/// @brief The particle domains of CPDI: convection by F, the scaling of
/// failed particles' domains (H&H §2.6) and the checks of their size.
#include "pfmpm/shape/cpdi.h"

#include <cmath>

namespace pfmpm
{

std::vector<ColumnSpec> ParticleDomains::columns()
{
  return {{"convected_r1", 2, DType::f64, {0.0},
           "CPDI half-edge r_1 = F r_1^0, advanced as F (H&H eq. 8)", "x,y", ""},
          {"convected_r2", 2, DType::f64, {0.0},
           "CPDI half-edge r_2 = F r_2^0, advanced as F (H&H eq. 8)", "x,y", ""},
          {"domain_r1", 2, DType::f64, {0.0},
           "half-edge r_1 of the CPDI integration domain (scaled when failed, H&H §2.6)", "x,y",
           "domain_r1"},
          {"domain_r2", 2, DType::f64, {0.0},
           "half-edge r_2 of the CPDI integration domain (scaled when failed, H&H §2.6)", "x,y",
           "domain_r2"}};
}

void ParticleDomains::bind(Particles& P)
{
  _r1 = P.f64("convected_r1").data();
  _r2 = P.f64("convected_r2").data();
  _d1 = P.f64("domain_r1").data();
  _d2 = P.f64("domain_r2").data();
  const Column* damage = P.find("damage");
  _damage = damage ? damage->f64.data() : nullptr;
  const Column* c = P.find("c");
  _c = c && _scaling.c_failed > 0.0 ? c->f64.data() : nullptr;
}

void ParticleDomains::integration_domain(std::size_t p) const
{
  const double* r1 = &_r1[2 * p];
  const double* r2 = &_r2[2 * p];
  double* d1 = &_d1[2 * p];
  double* d2 = &_d2[2 * p];
  const bool failed = _scaling.enabled && ((_damage && _damage[p] >= 1.0)
                                           || (_c && _c[p] < _scaling.c_failed));
  if (!failed)
  {
    d1[0] = r1[0];
    d1[1] = r1[1];
    d2[0] = r2[0];
    d2[1] = r2[1];
    return;
  }
  // Half-diagonals l_a = r_1 + r_2, l_b = r_1 - r_2, each shortened to at
  // most h / 2; then r_1 = (l_a + l_b) / 2, r_2 = (l_a - l_b) / 2 (card §1.3).
  double la[2] = {r1[0] + r2[0], r1[1] + r2[1]};
  double lb[2] = {r1[0] - r2[0], r1[1] - r2[1]};
  const double half = 0.5 * _h;
  for (double* l : {la, lb})
  {
    const double length = std::hypot(l[0], l[1]);
    if (length > half)
    {
      l[0] *= half / length;
      l[1] *= half / length;
    }
  }
  d1[0] = 0.5 * (la[0] + lb[0]);
  d1[1] = 0.5 * (la[1] + lb[1]);
  d2[0] = 0.5 * (la[0] - lb[0]);
  d2[1] = 0.5 * (la[1] - lb[1]);
}

void ParticleDomains::convect(const std::int32_t* index, std::size_t n, const double* L,
                              double dt) const
{
  for (std::size_t k = 0; k < n; ++k, L += 4)
  {
    const std::size_t p = static_cast<std::size_t>(index[k]);
    // r_k <- (I + dt L) r_k: H&H eq. 8 on r_k = F r_k^0.
    for (double* r : {&_r1[2 * p], &_r2[2 * p]})
    {
      const double rx = r[0], ry = r[1];
      r[0] = rx + dt * (L[0] * rx + L[1] * ry);
      r[1] = ry + dt * (L[2] * rx + L[3] * ry);
    }
  }
}

std::size_t ParticleDomains::update(const Grid<2>& grid, const double* x, std::size_t n) const
{
  const BSpline1D* basis[2] = {&grid.basis(0), &grid.basis(1)};
  const auto count = static_cast<std::ptrdiff_t>(n);
  std::ptrdiff_t first_bad = count;
#pragma omp parallel for schedule(static) reduction(min : first_bad)
  for (std::ptrdiff_t p = 0; p < count; ++p)
  {
    integration_domain(static_cast<std::size_t>(p));
    const double *r1 = &_d1[2 * p], *r2 = &_d2[2 * p];
    bool bad = false;
    for (int d = 0; d < 2; ++d)
    {
      // Each corner, computed as the stencil computes it, in a cell of the
      // particle's node block, and at most one cell beyond the grid's edge
      // (where the edge cell's functions extend).
      const BSpline1D& b = *basis[d];
      const int first = CpdiStencil::first(b.cell(x[2 * p + d]), b.size());
      for (int c = 0; c < 4; ++c)
      {
        const double xc = CpdiStencil::corner(&x[2 * p], r1, r2, c, d);
        const double s = b.coordinate(xc);
        if (!(s >= -1.0 && s < b.cells() + 1.0)) // also NaN
          bad = true;
        else if (const int local = b.clamped_cell(xc) - first; local < 0 || local > 2)
          bad = true;
      }
    }
    if (bad)
      first_bad = std::min(first_bad, p);
  }
  return static_cast<std::size_t>(first_bad);
}

std::size_t ParticleDomains::oversized(std::size_t n) const
{
  for (std::size_t p = 0; p < n; ++p)
  {
    const double *r1 = &_d1[2 * p], *r2 = &_d2[2 * p];
    const double wide = 2.0 * std::max(std::abs(r1[0]) + std::abs(r2[0]),
                                       std::abs(r1[1]) + std::abs(r2[1]));
    if (!(r1[0] * r2[1] - r2[0] * r1[1] > 0.0) || wide > _h * (1.0 + 1e-12))
      return p;
  }
  return n;
}

} // namespace pfmpm
