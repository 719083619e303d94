/// @file moments.cpp
/// @brief The product polynomials of CellProducts.
#include "pfmpm/fracture/moments.h"

#include <algorithm>

namespace pfmpm
{

CellProducts::CellProducts(const BSpline1D& basis)
    : _degree(basis.degree()), _cells(basis.cells())
{
  const int p = _degree, W = p + 1, Q = 2 * p + 1, D = derivatives, R = row(p);
  _values = static_cast<std::size_t>((D + 1) * (D + 1) * Q * R);
  _stride = _values + static_cast<std::size_t>((p + 1) * W);
  const int kinds = std::min(_cells, 2 * p + 1);
  _table.assign(static_cast<std::size_t>(kinds) * _stride, 0.0);
  const double inv_h = 1.0 / basis.h();
  for (int k = 0; k < kinds; ++k)
  {
    // A cell with this table: the ends' own, and cell p for the interior.
    const int cell = _cells <= 2 * p + 1 || k <= p ? k : k + _cells - (2 * p + 1);
    double* table = &_table[kind(cell) * _stride];
    // poly[d][a][j]: coefficient of xi^j in d^d N_a / dx^d on the cell.
    double poly[derivatives + 1][max_degree + 1][max_degree + 1] = {};
    for (int a = 0; a < W; ++a)
    {
      const double* c = basis.polynomial(cell, a);
      for (int m = 0; m <= p; ++m)
        table[_values + static_cast<std::size_t>(m * W + a)] = c[m];
      double scale = 1.0;
      for (int d = 0; d <= D; ++d, scale *= inv_h)
        for (int j = 0; j + d <= p; ++j)
        {
          double falling = 1.0; // (j + d)! / j!
          for (int f = j + 1; f <= j + d; ++f)
            falling *= f;
          poly[d][a][j] = falling * c[j + d] * scale;
        }
    }
    for (int d1 = 0; d1 <= D; ++d1)
      for (int d2 = 0; d2 <= D; ++d2)
        for (int a = 0; a < W; ++a)
          for (int b = 0; b < W; ++b)
            for (int j1 = 0; j1 + d1 <= p; ++j1)
              for (int j2 = 0; j2 + d2 <= p; ++j2)
                table[static_cast<std::size_t>(((d1 * (D + 1) + d2) * Q + j1 + j2) * R + a * W + b)]
                    += poly[d1][a][j1] * poly[d2][b][j2];
  }
}

} // namespace pfmpm
