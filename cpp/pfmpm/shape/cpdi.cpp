/// @file cpdi.cpp
/// @brief The particle domains of CPDI: convection by F, the scaling of
/// failed particles' domains (H&H §2.6) and the checks of their size.
#include "pfmpm/shape/cpdi.h"

#include <cmath>
#include <sstream>

namespace pfmpm
{

template <int Dim>
std::vector<ColumnSpec> ParticleDomains<Dim>::columns()
{
  const char* const components = Dim == 2 ? "x,y" : "x,y,z";
  std::vector<ColumnSpec> specs;
  for (int k = 1; k <= Dim; ++k)
  {
    const std::string r = "r_" + std::to_string(k);
    specs.push_back({"convected_r" + std::to_string(k), Dim, DType::f64, {0.0},
                     "CPDI half-edge " + r + " = F " + r + "^0, advanced as F (H&H eq. 8)",
                     components, ""});
  }
  for (int k = 1; k <= Dim; ++k)
  {
    const std::string name = "domain_r" + std::to_string(k);
    specs.push_back({name, Dim, DType::f64, {0.0},
                     "half-edge r_" + std::to_string(k)
                         + " of the CPDI integration domain (scaled when failed, H&H §2.6)",
                     components, name});
  }
  return specs;
}

template <int Dim>
void ParticleDomains<Dim>::bind(Particles& P)
{
  for (int k = 0; k < Dim; ++k)
  {
    _r[k] = P.f64("convected_r" + std::to_string(k + 1)).data();
    _d[k] = P.f64("domain_r" + std::to_string(k + 1)).data();
  }
  const Column* damage = P.find("damage");
  _damage = damage ? damage->f64.data() : nullptr;
  const Column* c = P.find("c");
  _c = c && _scaling.c_failed > 0.0 ? c->f64.data() : nullptr;
}

template <int Dim>
void ParticleDomains<Dim>::integration_domain(std::size_t p) const
{
  const bool failed = _scaling.enabled && ((_damage && _damage[p] >= 1.0)
                                           || (_c && _c[p] < _scaling.c_failed));
  if (!failed)
  {
    for (int k = 0; k < Dim; ++k)
      for (int d = 0; d < Dim; ++d)
        _d[k][Dim * p + d] = _r[k][Dim * p + d];
    return;
  }
  const double* r1 = &_r[0][Dim * p];
  const double* r2 = &_r[1][Dim * p];
  // The half-diagonals l of the domain (card §1.3), each shortened to at
  // most h / 2; then the half-edges rebuilt from them.
  constexpr int diagonals = Dim == 2 ? 2 : 4;
  double l[diagonals][Dim];
  if constexpr (Dim == 2)
    // l_a = r_1 + r_2, l_b = r_1 - r_2.
    for (int d = 0; d < 2; ++d)
    {
      l[0][d] = r1[d] + r2[d];
      l[1][d] = r1[d] - r2[d];
    }
  else
  {
    // l_a = r_1 + r_2 + r_3, l_b = r_1 - r_2 + r_3, l_c = -r_1 + r_2 + r_3,
    // l_d = -r_1 - r_2 + r_3.
    const double* r3 = &_r[2][Dim * p];
    for (int d = 0; d < 3; ++d)
    {
      l[0][d] = r1[d] + r2[d] + r3[d];
      l[1][d] = r1[d] - r2[d] + r3[d];
      l[2][d] = -r1[d] + r2[d] + r3[d];
      l[3][d] = -r1[d] - r2[d] + r3[d];
    }
  }
  const double half = 0.5 * _h;
  for (double(&v)[Dim] : l)
  {
    double length;
    if constexpr (Dim == 2)
      length = std::hypot(v[0], v[1]);
    else
      length = std::hypot(v[0], v[1], v[2]);
    if (length > half)
      for (double& vd : v)
        vd *= half / length;
  }
  double* d1 = &_d[0][Dim * p];
  double* d2 = &_d[1][Dim * p];
  if constexpr (Dim == 2)
    // r_1 = (l_a + l_b) / 2, r_2 = (l_a - l_b) / 2.
    for (int d = 0; d < 2; ++d)
    {
      d1[d] = 0.5 * (l[0][d] + l[1][d]);
      d2[d] = 0.5 * (l[0][d] - l[1][d]);
    }
  else
  {
    // r_1 = (l_a + l_b - l_c - l_d) / 4, r_2 = (l_a - l_b + l_c - l_d) / 4,
    // r_3 = (l_a + l_b + l_c + l_d) / 4: the parallelepiped nearest to the
    // shortened diagonals (they need not be a parallelepiped's).
    double* d3 = &_d[2][Dim * p];
    for (int d = 0; d < 3; ++d)
    {
      d1[d] = 0.25 * (l[0][d] + l[1][d] - l[2][d] - l[3][d]);
      d2[d] = 0.25 * (l[0][d] - l[1][d] + l[2][d] - l[3][d]);
      d3[d] = 0.25 * (l[0][d] + l[1][d] + l[2][d] + l[3][d]);
    }
  }
}

template <int Dim>
void ParticleDomains<Dim>::convect(const std::int32_t* index, std::size_t n, const double* L,
                                   double dt) const
{
  for (std::size_t k = 0; k < n; ++k, L += Dim * Dim)
  {
    const std::size_t p = static_cast<std::size_t>(index[k]);
    // r_k <- (I + dt L) r_k: H&H eq. 8 on r_k = F r_k^0.
    for (double* const edge : _r)
    {
      double* r = &edge[Dim * p];
      double old[Dim];
      for (int d = 0; d < Dim; ++d)
        old[d] = r[d];
      for (int i = 0; i < Dim; ++i)
      {
        double Lr = L[Dim * i] * old[0];
        for (int j = 1; j < Dim; ++j)
          Lr += L[Dim * i + j] * old[j];
        r[i] = old[i] + dt * Lr;
      }
    }
  }
}

template <int Dim>
std::size_t ParticleDomains<Dim>::update(const Grid<Dim>& grid, const double* x,
                                         std::size_t n) const
{
  using Stencil = CpdiStencil<Dim>;
  const std::array<const BSpline1D*, Dim> basis = grid.bases();
  const auto count = static_cast<std::ptrdiff_t>(n);
  std::ptrdiff_t first_bad = count;
#pragma omp parallel for schedule(static) reduction(min : first_bad)
  for (std::ptrdiff_t p = 0; p < count; ++p)
  {
    integration_domain(static_cast<std::size_t>(p));
    const double* r[Dim];
    for (int k = 0; k < Dim; ++k)
      r[k] = &_d[k][Dim * p];
    bool bad = false;
    for (int d = 0; d < Dim; ++d)
    {
      // Each corner, computed as the stencil computes it, in a cell of the
      // particle's node block, and at most one cell beyond the grid's edge
      // (where the edge cell's functions extend).
      const BSpline1D& b = *basis[d];
      const int first = Stencil::first(b.cell(x[Dim * p + d]), b.size());
      for (int c = 0; c < Stencil::corners; ++c)
      {
        const double xc = Stencil::corner(&x[Dim * p], r, c, d);
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

template <int Dim>
std::size_t ParticleDomains<Dim>::oversized(std::size_t n) const
{
  for (std::size_t p = 0; p < n; ++p)
  {
    const double* r[Dim];
    for (int k = 0; k < Dim; ++k)
      r[k] = &_d[k][Dim * p];
    // The domain's extent along direction d is 2 sum_k |r_k,d|.
    double wide = 0.0;
    for (int d = 0; d < Dim; ++d)
    {
      double extent = std::abs(r[0][d]);
      for (int k = 1; k < Dim; ++k)
        extent += std::abs(r[k][d]);
      wide = std::max(wide, 2.0 * extent);
    }
    if (!(CpdiStencil<Dim>::determinant(r) > 0.0) || wide > _h * (1.0 + 1e-12))
      return p;
  }
  return n;
}

template <int Dim>
std::string ParticleDomains<Dim>::describe(std::size_t p) const
{
  std::ostringstream text;
  for (int k = 0; k < Dim; ++k)
  {
    text << (k ? ", r" : "r") << k + 1 << " = (";
    for (int d = 0; d < Dim; ++d)
      text << (d ? ", " : "") << _d[k][Dim * p + d];
    text << ")";
  }
  return text.str();
}

template class ParticleDomains<2>;
template class ParticleDomains<3>;

} // namespace pfmpm
