/// @file test_momentum.cpp
/// @brief The momentum stages of the step in 3D, from the source 2D runs:
/// P2G conserves mass and momentum and its internal forces have the moments
/// of the stresses (the B-splines' linear precision), the grid update
/// advances free nodes and holds the nodes of a wall, and G2P moves
/// particles with a rigid motion's velocity and velocity gradient exactly.
#include "pfmpm/common/symmetric.h"
#include "pfmpm/solver/momentum.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

using namespace pfmpm;

namespace
{
constexpr int Dim = 3;
constexpr int T = symmetric_size(Dim);
using Shape = BSplineStencil<Dim, 2>;

/// Particles at random points of [0.3, 2.7)^3 with random masses, volumes,
/// velocities, stresses and (on a few) external forces.
struct Cloud
{
  std::vector<double> x, v, m, V, stress, fext;
};

Cloud cloud(std::size_t n, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> at(0.3, 2.7), unit(-1.0, 1.0), positive(0.5, 1.5);
  Cloud c;
  for (std::size_t p = 0; p < n; ++p)
  {
    for (int d = 0; d < Dim; ++d)
    {
      c.x.push_back(at(rng));
      c.v.push_back(unit(rng));
      c.fext.push_back(p % 7 == 0 ? unit(rng) : 0.0);
    }
    for (int k = 0; k < T; ++k)
      c.stress.push_back(unit(rng));
    c.m.push_back(positive(rng));
    c.V.push_back(0.01 * positive(rng));
  }
  return c;
}

/// P2G of `c` on `grid` (activated): the sums per active node.
std::vector<NodeSums<Dim>> p2g(const Grid<Dim>& grid, const CellSort& sort, const Cloud& c)
{
  std::vector<NodeSums<Dim>> sums(static_cast<std::size_t>(grid.num_active()), NodeSums<Dim>{});
  const SingleField one;
  P2GArrays arrays{c.v.data(), c.m.data(), c.V.data(), c.stress.data(), c.fext.data(), nullptr,
                   nullptr};
  particle_to_grid<Shape>(grid, sort, Points{c.x.data()},
                          MomentumP2G<Shape, true, SingleField, false>{grid, one, arrays, nullptr,
                                                                       sums.data(), nullptr});
  return sums;
}

/// Nodal kinematics of the linear velocity field v_I = b + M X_I (X_I the
/// Greville abscissae) at every active node of `grid`, at rest otherwise.
std::vector<NodeKinematics<Dim>> linear_kinematics(const Grid<Dim>& grid, const double (&b)[Dim],
                                                   const double (&M)[Dim][Dim])
{
  std::vector<NodeKinematics<Dim>> k(static_cast<std::size_t>(grid.num_active()), NodeKinematics<Dim>{});
  for (std::int32_t a = 0; a < grid.num_active(); ++a)
  {
    const std::array<int, Dim> i = lattice_indices<Dim>(grid.active_nodes()[a], grid.nodes());
    for (int r = 0; r < Dim; ++r)
    {
      k[a].v[r] = b[r];
      for (int s = 0; s < Dim; ++s)
        k[a].v[r] += M[r][s] * grid.basis(s).greville(i[s]);
    }
  }
  return k;
}

/// G2P of the nodal kinematics `k` by move_cell (with Affine, APIC), the
/// particles at `x0` (the sort's positions) moved in `arrays` by dt: the
/// velocity gradient of each particle, Dim x Dim by particle index.
template <bool Affine>
std::vector<double> move(const Grid<Dim>& grid, const CellSort& sort, const std::vector<double>& x0,
                         const std::vector<NodeKinematics<Dim>>& k, const G2PArrays& arrays, double dt)
{
  std::vector<double> L(Dim * Dim * (x0.size() / Dim), 0.0);
  grid_to_particle<Shape>(
      grid, sort, Points{x0.data()},
      unreduced(
          [&](const Cell<Dim>& cell, const detail::EachParticle<Shape>& each)
          {
            const CellNodes<Shape> active(grid, cell);
            G2PBlock<Dim, 1, Shape::size> block;
            for (int i = 0; i < Shape::size; ++i)
              std::copy(k[active[i]].v, k[active[i]].v + 2 * Dim, block.nodal[0][i]);
            const BlockPoints<Shape> points(grid, cell);
            std::vector<double> cell_L(Dim * Dim * static_cast<std::size_t>(cell.end - cell.begin));
            std::size_t bad = x0.size();
            double s2 = 0.0, d2 = 0.0;
            move_cell<Shape, 1, Affine>(each, arrays, OneField{}, block, &points, dt, cell_L.data(),
                                        bad, s2, d2);
            for (std::int64_t j = cell.begin; j < cell.end; ++j)
              std::copy_n(&cell_L[Dim * Dim * (j - cell.begin)], Dim * Dim,
                          &L[Dim * Dim * static_cast<std::size_t>(each.order[j])]);
          }));
  return L;
}
} // namespace

TEST(Momentum3, P2GConservesMassMomentumAndTheStressMoments)
{
  Grid<Dim> grid(2, {6, 7, 8}, 0.5, {0.0, 0.0, 0.0});
  const Cloud c = cloud(2000, 7);
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, c.x), c.m.size());
  grid.activate(sort.cell_start());
  const std::vector<NodeSums<Dim>> sums = p2g(grid, sort, c);

  // Mass and momentum; the internal forces sum to zero (the gradients of a
  // partition of unity), so the net forces sum to the external ones; and
  // sum_I X_I,k f_I,d = -sum_p V_p sigma_dk + sum_p x_p,k fext_p,d, with
  // X_I the Greville abscissae (sum_I grad N_I X_I = I).
  double mass = 0.0, scale = 0.0;
  double momentum[Dim] = {}, force[Dim] = {}, moment[Dim][Dim] = {};
  for (std::size_t p = 0; p < c.m.size(); ++p)
  {
    mass += c.m[p];
    for (int d = 0; d < Dim; ++d)
    {
      momentum[d] += c.m[p] * c.v[Dim * p + d];
      force[d] += c.fext[Dim * p + d];
      for (int k = 0; k < Dim; ++k)
        moment[d][k] += -c.V[p] * c.stress[T * p + symmetric_entry(d, k)]
                        + c.x[Dim * p + k] * c.fext[Dim * p + d];
    }
    scale += c.V[p];
  }
  double nodal_mass = 0.0, nodal_momentum[Dim] = {}, nodal_force[Dim] = {},
         nodal_moment[Dim][Dim] = {};
  for (std::int32_t a = 0; a < grid.num_active(); ++a)
  {
    const std::array<int, Dim> i = lattice_indices<Dim>(grid.active_nodes()[a], grid.nodes());
    const NodeSums<Dim>& s = sums[a];
    nodal_mass += s.m;
    for (int d = 0; d < Dim; ++d)
    {
      nodal_momentum[d] += s.p[d];
      nodal_force[d] += s.f[d];
      for (int k = 0; k < Dim; ++k)
        nodal_moment[d][k] += grid.basis(k).greville(i[k]) * s.f[d];
    }
  }
  EXPECT_NEAR(nodal_mass, mass, 1e-13 * mass);
  for (int d = 0; d < Dim; ++d)
  {
    EXPECT_NEAR(nodal_momentum[d], momentum[d], 1e-13 * mass);
    EXPECT_NEAR(nodal_force[d], force[d], 1e-13 * c.m.size());
    for (int k = 0; k < Dim; ++k)
      EXPECT_NEAR(nodal_moment[d][k], moment[d][k], 1e-12 * c.m.size()) << d << k;
  }
}

TEST(Momentum3, GridUpdateAdvancesFreeNodesAndHoldsAWall)
{
  Grid<Dim> grid(2, {6, 6, 6}, 0.5, {0.0, 0.0, 0.0});
  grid.set_wall(Side::back, Wall::fixed); // z = 0: every component
  grid.set_wall(Side::top, Wall::slip);   // y = 3: y alone
  const Cloud c = cloud(3000, 9);
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, c.x), c.m.size());
  grid.activate(sort.cell_start());
  const std::vector<NodeSums<Dim>> sums = p2g(grid, sort, c);
  std::vector<NodeKinematics<Dim>> k;
  const double dt = 1e-3;
  const SingleField one;
  using U = GridUpdate<Dim>;
  std::array<double, U::size> acc{};
  for (const auto& slab : update_grid<Dim>(grid, one, sums, {}, k, dt, 1e-12, 0.0))
    for (int j = 0; j < U::size; ++j)
      acc[j] += slab[j];
  ASSERT_EQ(k.size(), sums.size());
  double wall_impulse[Dim] = {}; // of the back wall
  for (std::int32_t a = 0; a < grid.num_active(); ++a)
  {
    const std::array<int, Dim> i = lattice_indices<Dim>(grid.active_nodes()[a], grid.nodes());
    const NodeSums<Dim>& s = sums[a];
    const bool back = i[2] == 0, top = i[1] == grid.nodes()[1] - 1;
    for (int d = 0; d < Dim; ++d)
    {
      const double free = (s.p[d] + dt * s.f[d]) / s.m; // K&T eqs. 63-65
      const bool held = back || (top && d == 1);
      EXPECT_NEAR(k[a].v[d], held ? 0.0 : free, 1e-12 * std::abs(free)) << a << " " << d;
      EXPECT_NEAR(k[a].a[d], (k[a].v[d] - s.p[d] / s.m) / dt, 1e-9 * std::abs(free) / dt);
      if (back && !(top && d == 1)) // on the edge the top's normal hold comes first
        wall_impulse[d] -= s.m * free;
    }
  }
  for (int d = 0; d < Dim; ++d)
    EXPECT_NEAR(acc[U::hold_impulse + Dim * static_cast<int>(Side::back) + d], wall_impulse[d],
                1e-12 * c.m.size());
  EXPECT_EQ(acc[U::light], 0.0);
}

TEST(Momentum3, G2PMovesParticlesWithARigidMotion)
{
  // Nodal velocity v_I = b + W X_I with W skew (a rotation about an oblique
  // axis) and zero acceleration: each particle gets L_p = W, moves by
  // dt (b + W x_p) and changes its volume by det(I + dt W).
  Grid<Dim> grid(2, {6, 6, 6}, 0.5, {0.0, 0.0, 0.0});
  Cloud c = cloud(500, 13);
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, c.x), c.m.size());
  grid.activate(sort.cell_start());
  const double b[Dim] = {0.2, -0.1, 0.4};
  const double w[Dim] = {0.3, -0.5, 0.7}; // the angular velocity
  const double W[Dim][Dim] = {{0.0, -w[2], w[1]}, {w[2], 0.0, -w[0]}, {-w[1], w[0], 0.0}};
  const std::vector<NodeKinematics<Dim>> k = linear_kinematics(grid, b, W);
  const std::vector<double> x0 = c.x, v0 = c.v, V0 = c.V;
  const double dt = 1e-2;
  const std::vector<double> L =
      move<false>(grid, sort, x0, k, G2PArrays{c.x.data(), c.v.data(), c.V.data()}, dt);
  // det(I + dt W) = 1 + dt^2 |w|^2 for a skew W.
  const double ratio = 1.0 + dt * dt * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  for (std::size_t p = 0; p < c.m.size(); ++p)
  {
    for (int r = 0; r < Dim; ++r)
    {
      double u = b[r];
      for (int s = 0; s < Dim; ++s)
      {
        u += W[r][s] * x0[Dim * p + s];
        EXPECT_NEAR(L[Dim * Dim * p + Dim * r + s], W[r][s], 1e-13);
      }
      EXPECT_NEAR(c.x[Dim * p + r], x0[Dim * p + r] + dt * u, 1e-14);
      EXPECT_EQ(c.v[Dim * p + r], v0[Dim * p + r]); // zero acceleration (FLIP)
    }
    EXPECT_NEAR(c.V[p], V0[p] * ratio, 1e-15 * V0[p]);
  }
}

TEST(Momentum3, ApicCarriesAnAffineVelocityFieldExactly)
{
  // Nodal velocities v_I = b + A X_I. APIC's G2P (Jiang et al. 2015, eq. 10)
  // gives v_p = b + A x_p and B_p = A D_p; its P2G (eq. 8) gives node I the
  // momentum sum_p m_p N_I (v_p + B_p D_p^-1 (X_I - x_p)) = m_I (b + A X_I):
  // the field comes back to round-off.
  Grid<Dim> grid(2, {6, 6, 6}, 0.5, {0.0, 0.0, 0.0});
  Cloud c = cloud(2000, 21);
  CellSort sort;
  ASSERT_EQ(sort.sort(grid, c.x), c.m.size());
  grid.activate(sort.cell_start());
  const double b[Dim] = {0.2, -0.1, 0.4};
  const double A[Dim][Dim] = {{0.3, -0.2, 0.1}, {0.05, -0.4, 0.25}, {-0.15, 0.2, 0.35}};
  const std::vector<NodeKinematics<Dim>> k = linear_kinematics(grid, b, A);
  std::vector<double> affine(Dim * Dim * c.m.size(), 0.0);
  const std::vector<double> x0 = c.x;
  move<true>(grid, sort, x0, k, G2PArrays{c.x.data(), c.v.data(), c.V.data(), affine.data()}, 0.0);
  for (std::size_t p = 0; p < c.m.size(); ++p)
    for (int r = 0; r < Dim; ++r)
    {
      double u = b[r];
      for (int s = 0; s < Dim; ++s)
        u += A[r][s] * c.x[Dim * p + s];
      EXPECT_NEAR(c.v[Dim * p + r], u, 1e-13) << p;
    }
  // The diagonal D_p of quadratic B-splines is h^2 / 4 inside: B_p = A h^2 / 4
  // for a particle two cells or more from every end.
  for (std::size_t p = 0; p < c.m.size(); ++p)
  {
    bool inside = true;
    for (int d = 0; d < Dim; ++d)
      inside = inside && c.x[Dim * p + d] >= 1.0 && c.x[Dim * p + d] < 2.0;
    if (inside)
      for (int r = 0; r < Dim; ++r)
        for (int s = 0; s < Dim; ++s)
          EXPECT_NEAR(affine[Dim * Dim * p + Dim * r + s], A[r][s] * 0.0625, 1e-14) << p;
  }
  std::vector<NodeSums<Dim>> sums(static_cast<std::size_t>(grid.num_active()), NodeSums<Dim>{});
  const SingleField one;
  P2GArrays arrays{c.v.data(), c.m.data(), c.V.data(), c.stress.data(), c.fext.data(), nullptr, nullptr,
                   affine.data()};
  particle_to_grid<Shape>(grid, sort, Points{c.x.data()},
                          MomentumP2G<Shape, false, SingleField, true>{grid, one, arrays, nullptr,
                                                                      sums.data(), nullptr});
  double worst = 0.0;
  for (std::int32_t a = 0; a < grid.num_active(); ++a)
    if (sums[a].m > 1e-6)
      for (int r = 0; r < Dim; ++r)
        worst = std::max(worst, std::abs(sums[a].p[r] / sums[a].m - k[a].v[r]));
  EXPECT_LT(worst, 1e-12);
}
