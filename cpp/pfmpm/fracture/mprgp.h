/// @file mprgp.h
/// @brief The bounded phase-field system (K&T eq. 50 with 0 <= c <= 1), as
/// the quadratic program min c.K c / 2 - F.c over the box, by MPRGP: the
/// solve that PhaseField::bounded_solve hands over to when its active-set
/// passes do not settle.
#pragma once

#include "pfmpm/common/reduce.h"
#include "pfmpm/fracture/symmetric_stencil.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace pfmpm
{

/// @brief K c = F on the active nodes of a padded node layout, K symmetric
/// positive semi-definite and stored as SymmetricStencil<Dim, P> rows (zero at
/// the padded nodes that are not active).
template <int Dim, int P>
struct StencilSystem
{
  SymmetricStencil<Dim, P> stencil;
  const double* rows;          ///< K: SymmetricStencil<Dim, P>::size entries per padded node
  const std::size_t* position; ///< per active node: its padded index
  const double* diagonal;      ///< per active node: K_aa > 0
  const double* rhs;           ///< per active node: F
  std::size_t size;            ///< active nodes

  /// (K v)_a for a padded vector v.
  double product(std::size_t a, const double* v) const
  {
    return row_product(stencil, rows, position[a], v);
  }
};

/// What one mprgp call did.
struct MprgpResult
{
  int iterations = 0;    ///< conjugate-gradient, expansion and proportioning steps
  int expansions = 0;    ///< of them, expansion steps
  int proportionings = 0; ///< and proportioning steps
  double residual = 0.0; ///< ||F - K c|| on the free nodes at the end
  bool converged = false;
};

/// @brief Minimise c.K c / 2 - F.c over 0 <= c <= 1 by MPRGP, modified
/// proportioning with reduced gradient projections (Dostál & Schöberl 2005,
/// Comput. Optim. Appl. 30:23-43; its two-sided form in Dostál 2009,
/// "Optimal quadratic programming algorithms", ch. 8), on the problem scaled
/// by the diagonal, y = D^1/2 c: a Jacobi preconditioner that leaves the
/// constraints a box.
///
/// With the gradient g = K c - F, a node is free inside the box and held on
/// a bound; phi is g on the free nodes (the free gradient) and beta, on the
/// held ones, the part of g that would move c into the box (the chopped
/// gradient). Each iteration is one of:
/// - a conjugate-gradient step on the free nodes, when c stays in the box
///   and the chopped gradient is small against the reduced free gradient
///   (||beta||^2 <= Gamma^2 phi~.phi, Gamma = 1, norms of the scaled problem);
/// - an expansion step, when the CG step would leave the box: the largest
///   feasible step along it, then a projected gradient step of fixed length
///   alpha = 1.9 / ||D^-1/2 K D^-1/2|| (Gershgorin's bound), which may add
///   many nodes to the held set at once;
/// - a proportioning step along beta, when the chopped gradient dominates,
///   which frees nodes (limited to the box on the far side).
/// Every step lowers the energy. For K positive definite the iterates
/// converge R-linearly, at a rate bounded by K's spectrum (the theorem of
/// the paper), so the loop ends by the stopping test, not by a cycle, which
/// the primal-dual active-set method can enter when K is not an M-matrix
/// (B-spline mass terms have positive off-diagonal entries).
///
/// Stops by the test of the active-set passes (PhaseField::bounded_solve):
/// ||F - K c|| <= `stop` on the free nodes, and no held node whose
/// multiplier would move it into the box by more than `step` (a Jacobi step,
/// |beta_a| / K_aa); or after `max_iterations`. Sums are deterministic_sum,
/// so the result has the same bits on any number of threads.
/// @param K The system.
/// @param[in,out] c The padded phase field: the start (projected onto the
///        box), then the solution.
/// @param p A padded work vector, zero at the nodes that are not active; left so.
/// @param g, q Work vectors (resized to K.size).
template <int Dim, int P>
MprgpResult mprgp(const StencilSystem<Dim, P>& K, double* c, double* p, std::vector<double>& g,
                  std::vector<double>& q, double stop, double step, int max_iterations)
{
  const std::size_t n = K.size;
  const auto ns = static_cast<std::ptrdiff_t>(n);
  const std::size_t* pos = K.position;
  const double* D = K.diagonal;
  g.resize(n);
  q.resize(n);

  // alpha-bar from Gershgorin's bound of D^-1/2 K D^-1/2 (>= its norm; >= 1).
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < ns; ++a)
    p[pos[a]] = 1.0 / std::sqrt(D[a]);
  double gershgorin = 1.0;
#pragma omp parallel for schedule(static) reduction(max : gershgorin)
  for (std::ptrdiff_t a = 0; a < ns; ++a)
    gershgorin = std::max(gershgorin, p[pos[a]] * row_magnitude_product(K.stencil, K.rows, pos[a], p));
  const double alpha = 1.9 / gershgorin;

  // Free gradient, chopped gradient and reduced free gradient of node a.
  auto free = [&](std::size_t a) { return c[pos[a]] > 0.0 && c[pos[a]] < 1.0; };
  auto phi = [&](std::size_t a) { return free(a) ? g[a] : 0.0; };
  auto beta = [&](std::size_t a)
  { return c[pos[a]] <= 0.0 ? std::min(g[a], 0.0) : c[pos[a]] >= 1.0 ? std::max(g[a], 0.0) : 0.0; };
  auto reduced = [&](std::size_t a)
  {
    const double f = phi(a), x = c[pos[a]];
    return f > 0.0 ? std::min(D[a] * x / alpha, f) : std::max(D[a] * (x - 1.0) / alpha, f);
  };
  // The gradient g = K c - F and the direction p = D^-1 phi, from c.
  auto restart = [&]()
  {
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t a = 0; a < ns; ++a)
      g[a] = K.product(a, c) - K.rhs[a];
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t a = 0; a < ns; ++a)
      p[pos[a]] = phi(a) / D[a];
  };
  // The largest step s >= 0 with c - s p in the box.
  auto feasible = [&]()
  {
    double s = std::numeric_limits<double>::infinity();
#pragma omp parallel for schedule(static) reduction(min : s)
    for (std::ptrdiff_t a = 0; a < ns; ++a)
    {
      const double d = p[pos[a]], x = c[pos[a]];
      if (d > 0.0)
        s = std::min(s, x / d);
      else if (d < 0.0)
        s = std::min(s, (x - 1.0) / d);
    }
    return s;
  };
  // c -= s p, kept in the box against round-off, g -= s K p (K p in q).
  auto move = [&](double s)
  {
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t a = 0; a < ns; ++a)
    {
      double& x = c[pos[a]];
      x = std::clamp(x - s * p[pos[a]], 0.0, 1.0);
      g[a] -= s * q[a];
    }
  };
  // q = K p, and p.K p and g.p.
  auto multiply = [&]()
  {
    return deterministic_sum<2>(n,
                                [&](std::size_t a, std::array<double, 2>& acc)
                                {
                                  q[a] = K.product(a, p);
                                  acc[0] += p[pos[a]] * q[a];
                                  acc[1] += g[a] * p[pos[a]];
                                });
  };

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < ns; ++a)
    c[pos[a]] = std::clamp(c[pos[a]], 0.0, 1.0);
  restart();
  MprgpResult result;
  for (;;)
  {
    // ||phi||^2, ||beta||^2 and phi~.phi in the scaled problem, and the
    // held nodes that the stopping test would free.
    const auto m = deterministic_sum<4>(n,
                                        [&](std::size_t a, std::array<double, 4>& acc)
                                        {
                                          const double f = phi(a), b = beta(a);
                                          acc[0] += f * f;
                                          acc[1] += b * b / D[a];
                                          acc[2] += reduced(a) * f / D[a];
                                          acc[3] += std::abs(b) > step * D[a] ? 1.0 : 0.0;
                                        });
    result.residual = std::sqrt(m[0]);
    if (result.residual <= stop && m[3] == 0.0)
    {
      result.converged = true;
      return result;
    }
    if (result.iterations >= max_iterations)
      return result;
    ++result.iterations;
    if (m[1] <= m[2]) // proportional: Gamma = 1
    {
      const auto [pKp, gp] = multiply();
      const double s = gp / pKp, s_max = feasible();
      if (s <= s_max) // conjugate gradient step
      {
        move(s);
        // p = D^-1 phi - gamma p, conjugate to the last p.
        const double gamma =
            deterministic_sum<1>(n, [&](std::size_t a, std::array<double, 1>& acc)
                                 { acc[0] += phi(a) / D[a] * q[a]; })[0]
            / pKp;
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t a = 0; a < ns; ++a)
          p[pos[a]] = phi(a) / D[a] - gamma * p[pos[a]];
      }
      else // expansion step: to the box, then a projected gradient step
      {
        ++result.expansions;
        move(s_max);
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t a = 0; a < ns; ++a)
          q[a] = phi(a) / D[a]; // read before any c changes
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t a = 0; a < ns; ++a)
          c[pos[a]] = std::clamp(c[pos[a]] - alpha * q[a], 0.0, 1.0);
        restart();
      }
    }
    else // proportioning step along D^-1 beta, within the box
    {
      ++result.proportionings;
#pragma omp parallel for schedule(static)
      for (std::ptrdiff_t a = 0; a < ns; ++a)
        p[pos[a]] = beta(a) / D[a];
      const auto [dKd, gd] = multiply();
      move(std::min(gd / dKd, feasible()));
#pragma omp parallel for schedule(static)
      for (std::ptrdiff_t a = 0; a < ns; ++a)
        p[pos[a]] = phi(a) / D[a];
    }
  }
}

} // namespace pfmpm
