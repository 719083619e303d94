/// @file bspline.cpp
/// @brief Cox-de Boor polynomial tables of the open-knot B-spline basis.
#include "pfmpm/grid/bspline.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace pfmpm
{

namespace
{
using Poly = std::array<double, max_degree + 1>; // coefficients of xi^0..xi^3

/// (a + b*xi) * p, truncated to degree max_degree (never exceeded here).
Poly times_linear(const Poly& p, double a, double b)
{
  Poly r{};
  for (int j = 0; j <= max_degree; ++j)
  {
    r[j] += a * p[j];
    if (j + 1 <= max_degree)
      r[j + 1] += b * p[j];
  }
  return r;
}
} // namespace

BSpline1D::BSpline1D(int degree, int cells, double h, double origin)
    : _degree(degree), _cells(cells), _h(h), _inv_h(1.0 / h), _origin(origin),
      _coeffs(static_cast<std::size_t>(cells) * stride, 0.0)
{
  if (degree < 1 || degree > max_degree)
    throw std::invalid_argument("B-spline degree = " + std::to_string(degree)
                                + ": must be 1, 2 or 3");
  if (cells < degree)
    throw std::invalid_argument("B-spline cells = " + std::to_string(cells)
                                + ": need at least degree = " + std::to_string(degree));
  if (!(h > 0.0))
    throw std::invalid_argument("B-spline h = " + std::to_string(h) + ": must be > 0");

  // Open knot vector in units of h: t_j = clamp(j - p, 0, cells).
  const int p = degree;
  auto knot = [p, cells](int j) { return static_cast<double>(std::clamp(j - p, 0, cells)); };

  for (int c = 0; c < cells; ++c)
  {
    // Knot span s = c + p holds [c, c+1). Cox-de Boor recursion on polynomials
    // in xi, where x/h = c + xi: start from N_{s,0} = 1 and raise the degree.
    // basis[i - (s - q)] holds N_{i,q} for i = s-q .. s.
    const int s = c + p;
    std::vector<Poly> basis(1, Poly{1.0, 0.0, 0.0, 0.0});
    for (int q = 1; q <= p; ++q)
    {
      std::vector<Poly> next(q + 1, Poly{});
      for (int i = s - q; i <= s; ++i)
      {
        Poly& out = next[i - (s - q)];
        // Left term: (x - t_i)/(t_{i+q} - t_i) N_{i,q-1}
        if (i >= s - q + 1)
        {
          const double den = knot(i + q) - knot(i);
          if (den > 0.0)
          {
            const Poly t = times_linear(basis[i - (s - q + 1)], (c - knot(i)) / den, 1.0 / den);
            for (int j = 0; j <= max_degree; ++j)
              out[j] += t[j];
          }
        }
        // Right term: (t_{i+q+1} - x)/(t_{i+q+1} - t_{i+1}) N_{i+1,q-1}
        if (i + 1 <= s)
        {
          const double den = knot(i + q + 1) - knot(i + 1);
          if (den > 0.0)
          {
            const Poly t = times_linear(basis[i + 1 - (s - q + 1)],
                                        (knot(i + q + 1) - c) / den, -1.0 / den);
            for (int j = 0; j <= max_degree; ++j)
              out[j] += t[j];
          }
        }
      }
      basis = std::move(next);
    }
    for (int k = 0; k <= p; ++k)
      std::copy(basis[k].begin(), basis[k].end(),
                _coeffs.begin() + static_cast<std::ptrdiff_t>(c) * stride + k * (max_degree + 1));
  }
}

void BSpline1D::evaluate(int cell, double x, double* N, double* dN, double* d2N) const
{
  const double xi = (x - _origin) * _inv_h - cell;
  const double* a = &_coeffs[static_cast<std::size_t>(cell) * stride];
  for (int k = 0; k <= _degree; ++k, a += max_degree + 1)
  {
    double v = 0.0, d = 0.0, dd = 0.0;
    for (int j = max_degree; j >= 0; --j)
    {
      dd = dd * xi + 2.0 * d;
      d = d * xi + v;
      v = v * xi + a[j];
    }
    N[k] = v;
    if (dN)
      dN[k] = d * _inv_h;
    if (d2N)
      d2N[k] = dd * _inv_h * _inv_h;
  }
}

} // namespace pfmpm
