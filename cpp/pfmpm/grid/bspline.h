/// @file bspline.h
/// @brief Univariate B-splines of degree 1-3 on a uniform open knot vector.
///
/// The knot vector is the paper's open (clamped) vector Xi = {0,..,0, h, 2h, ..,
/// L,..,L} with the end knots repeated degree+1 times (Kakouris & Triantafyllou
/// 2019, Section 4). On a grid of `cells` cells there are `cells + degree` basis
/// functions; on cell c the nonzero ones are c, c+1, .., c+degree.
///
/// Each basis function is a polynomial of degree `degree` on every cell. The
/// constructor builds these polynomials once with the Cox-de Boor recursion,
/// so evaluation at a particle is a table look-up plus Horner's rule and costs
/// the same on boundary and interior cells.
#pragma once

#include <algorithm>
#include <array>
#include <vector>

namespace pfmpm
{

/// Largest supported degree.
inline constexpr int max_degree = 3;

/// @brief B-spline basis on a uniform open knot vector over [origin, origin + cells*h].
class BSpline1D
{
public:
  /// @param degree Polynomial degree, 1, 2 or 3.
  /// @param cells Number of knot spans (cells), at least degree.
  /// @param h Cell size (> 0).
  /// @param origin Coordinate of the first knot.
  BSpline1D(int degree, int cells, double h, double origin);

  int degree() const { return _degree; }
  int cells() const { return _cells; }
  /// Number of basis functions (control points): cells + degree.
  int size() const { return _cells + _degree; }
  double h() const { return _h; }
  double origin() const { return _origin; }
  double length() const { return _cells * _h; }
  /// Integral of basis function i over the line: h (t_{i+p+1} - t_i) / (p + 1).
  double integral(int i) const
  {
    return _h * (std::clamp(i + 1, 0, _cells) - std::clamp(i - _degree, 0, _cells)) / (_degree + 1);
  }

  /// @brief The Greville abscissa of basis function i: the mean of its
  /// `degree` inner knots, the point x_i with sum_i N_i(x) x_i = x on the
  /// whole line (linear precision; open knots included). Away from the
  /// ends: grid line i for degree 1, the centre of cell i - 1 for degree 2,
  /// grid line i - 1 for degree 3 (the centre of the function's support).
  double greville(int i) const { return _origin + _h * greville_coordinate(i); }
  /// @brief greville(i) in cells from the origin, as coordinate() measures.
  double greville_coordinate(int i) const
  {
    int sum = 0;
    for (int j = 1; j <= _degree; ++j)
      sum += std::clamp(i + j - _degree, 0, _cells);
    return static_cast<double>(sum) / _degree;
  }

  /// @brief The cell holding x, or -1 if x is outside [origin, origin + length).
  int cell(double x) const
  {
    const double s = (x - _origin) * _inv_h;
    if (!(s >= 0.0) || s >= _cells) // also rejects NaN
      return -1;
    return static_cast<int>(s);
  }

  /// @brief x in cells from the origin, (x - origin) / h, as cell() computes it.
  double coordinate(double x) const { return (x - _origin) * _inv_h; }

  /// @brief The cell holding x, or the first or last cell for x before or
  /// after the grid (whose polynomials extend there); x must not be NaN.
  int clamped_cell(double x) const
  {
    const double s = coordinate(x);
    return s < 0.0 ? 0 : s >= _cells ? _cells - 1 : static_cast<int>(s);
  }

  /// @brief The coefficients of basis function cell + k on `cell` as a
  /// polynomial in xi = coordinate(x) - cell: entry j multiplies xi^j, j = 0
  /// .. max_degree (zero above the degree).
  const double* polynomial(int cell, int k) const
  {
    return &_coeffs[static_cast<std::size_t>(cell) * stride + k * (max_degree + 1)];
  }

  /// @brief Values and derivatives of the degree+1 functions nonzero on `cell`.
  ///
  /// Entry k of each output array belongs to basis function cell + k.
  /// @param cell Cell index, 0 <= cell < cells().
  /// @param x Coordinate (normally inside the cell).
  /// @param[out] N Values, degree+1 entries.
  /// @param[out] dN First derivatives d/dx, degree+1 entries (may be null).
  /// @param[out] d2N Second derivatives d2/dx2, degree+1 entries (may be null).
  void evaluate(int cell, double x, double* N, double* dN, double* d2N) const;

  /// @brief Fast values and first derivatives for a compile-time degree P.
  template <int P>
  void evaluate(int cell, double x, double* N, double* dN) const
  {
    const double xi = (x - _origin) * _inv_h - cell;
    const double* a = &_coeffs[static_cast<std::size_t>(cell) * stride];
    for (int k = 0; k <= P; ++k, a += max_degree + 1)
    {
      double v = a[P], d = P * a[P];
      for (int j = P - 1; j >= 1; --j)
      {
        v = v * xi + a[j];
        d = d * xi + j * a[j];
      }
      N[k] = v * xi + a[0];
      dN[k] = d * _inv_h;
    }
  }

  /// @brief Fast values, first and second derivatives for a compile-time degree P.
  template <int P>
  void evaluate(int cell, double x, double* N, double* dN, double* d2N) const
  {
    const double xi = (x - _origin) * _inv_h - cell;
    const double* a = &_coeffs[static_cast<std::size_t>(cell) * stride];
    for (int k = 0; k <= P; ++k, a += max_degree + 1)
    {
      double v = a[P], d = 0.0, dd = 0.0;
      for (int j = P - 1; j >= 0; --j)
      {
        dd = dd * xi + 2.0 * d;
        d = d * xi + v;
        v = v * xi + a[j];
      }
      N[k] = v;
      dN[k] = d * _inv_h;
      d2N[k] = dd * _inv_h * _inv_h;
    }
  }

private:
  static constexpr int stride = (max_degree + 1) * (max_degree + 1);

  int _degree;
  int _cells;
  double _h;
  double _inv_h;
  double _origin;
  // Polynomial coefficients in the local coordinate xi = (x - x_cell)/h:
  // _coeffs[(cell*(max_degree+1) + k)*(max_degree+1) + j] multiplies xi^j in
  // basis function cell + k.
  std::vector<double> _coeffs;
};

} // namespace pfmpm
