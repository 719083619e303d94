/// @file test_transfer.cpp
/// @brief Particle-grid transfers: P2G conserves mass and momentum to round-off, free motion
/// conserves momentum exactly, and results do not depend on the number of OpenMP threads
/// (bitwise).
#include "helpers.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// A disk of particles with a swirling, stretching velocity field and a
/// non-uniform pre-stress, on a grid with origin (-1, -2) and h = 0.25.
Particles make_disk(int n_per_side)
{
  std::vector<double> xs, ys;
  const double r = 2.0, d = 2 * r / n_per_side;
  for (int i = 0; i < n_per_side; ++i)
    for (int j = 0; j < n_per_side; ++j)
    {
      const double x = -r + (i + 0.5) * d, y = -r + (j + 0.5) * d;
      if (x * x + y * y < r * r)
      {
        xs.push_back(x + 3.0);
        ys.push_back(y + 2.5);
      }
    }
  Particles P(xs.size());
  add_model_columns(P, true);
  std::vector<double>& strain = P.f64("strain");
  for (std::size_t i = 0; i < xs.size(); ++i)
  {
    P.x[2 * i] = xs[i];
    P.x[2 * i + 1] = ys[i];
    P.v[2 * i] = 0.3 - 0.2 * (ys[i] - 2.5) + 0.05 * std::sin(3 * xs[i]);
    P.v[2 * i + 1] = -0.1 + 0.2 * (xs[i] - 3.0);
    P.volume[i] = d * d;
    P.mass[i] = d * d * (1.0 + 0.1 * std::cos(xs[i]));
    strain[3 * i] = 1e-3 * std::sin(ys[i]);
    strain[3 * i + 2] = 5e-4 * xs[i];
  }
  return P;
}
} // namespace

class TransferDegree : public ::testing::TestWithParam<int>
{
};

TEST_P(TransferDegree, P2GConservesMassAndMomentum)
{
  Grid<2> grid(GetParam(), {40, 40}, 0.25, {-1.0, -2.0});
  Particles P = make_disk(60);
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), StepConfig(1e-3));
  const Energies e = solver.energies();
  double m = 0, px = 0, py = 0;
  for (const auto& row : solver.nodal_mass_momentum())
  {
    m += row[1];
    px += row[2];
    py += row[3];
  }
  EXPECT_NEAR(m, e.mass, 1e-14 * e.mass * 20);
  EXPECT_NEAR(px, e.momentum[0], 1e-13 * e.mass);
  EXPECT_NEAR(py, e.momentum[1], 1e-13 * e.mass);
}

TEST_P(TransferDegree, FreeMotionConservesMomentum)
{
  // No external force and no walls: the internal forces sum to zero at the
  // nodes (gradients of a partition of unity), so momentum is exact.
  Grid<2> grid(GetParam(), {40, 40}, 0.25, {-1.0, -2.0});
  Particles P = make_disk(60);
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), StepConfig(1e-3));
  const Energies before = solver.energies();
  solver.advance(200);
  const Energies after = solver.energies();
  EXPECT_NEAR(after.mass, before.mass, 1e-14 * before.mass * 20);
  EXPECT_NEAR(after.momentum[0], before.momentum[0], 1e-12 * before.mass);
  EXPECT_NEAR(after.momentum[1], before.momentum[1], 1e-12 * before.mass);
}

namespace
{
/// Whether 1 and 3 threads give the same bits, with the phase field on: a
/// notch of history along y = 2.5 makes the solve and the degraded stresses
/// take part; a nonzero gamma adds the fourth-order term, with orientations
/// that vary from particle to particle; AT2 with and without the bound, AT1.
void expect_thread_independent_bits(int degree, const Voigt& gamma, Model model = Model::AT2,
                                    bool bound = true)
{
  auto run = [&](int threads)
  {
    omp_set_num_threads(threads);
    Grid<2> grid(degree, {40, 40}, 0.25, {-1.0, -2.0});
    Particles P = make_disk(60);
    std::vector<double>&history = P.f64("history"), &phi = P.f64("phi");
    for (std::size_t i = 0; i < P.size(); ++i)
    {
      if (std::abs(P.x[2 * i + 1] - 2.5) < 0.1 && P.x[2 * i] < 3.0)
        history[i] = 50.0;
      phi[i] = 0.3 * P.x[2 * i];
    }
    StepConfig step(1e-3);
    step.fracture = {Fracture{0.5, 0.5, 0.0, gamma, model, bound}};
    step.max_iterations = 20000;
    Solver solver(grid, P, elastic(100.0, 0.3, 1.0), step);
    solver.advance(50);
    return std::make_pair(P, solver.energies());
  };
  const int max_threads = omp_get_max_threads();
  const auto [p1, e1] = run(1);
  const auto [p3, e3] = run(3);
  omp_set_num_threads(max_threads);
  ASSERT_EQ(p1.size(), p3.size());
  EXPECT_TRUE(same_bits(p1.x, p3.x));
  EXPECT_TRUE(same_bits(p1.v, p3.v));
  EXPECT_TRUE(same_bits(p1.stress, p3.stress));
  EXPECT_TRUE(same_bits(p1.f64("c"), p3.f64("c")));
  EXPECT_TRUE(same_bits(p1.f64("history"), p3.f64("history")));
  EXPECT_EQ(e1.kinetic, e3.kinetic);
  EXPECT_EQ(e1.elastic, e3.elastic);
  EXPECT_EQ(e1.fracture, e3.fracture);
  EXPECT_GT(e1.fracture, 0.0);
}
} // namespace

TEST_P(TransferDegree, ThreadCountDoesNotChangeBits)
{
  expect_thread_independent_bits(GetParam(), Voigt{});              // AT2, bounded
  expect_thread_independent_bits(GetParam(), Voigt{}, Model::AT2, false); // unbounded CG
  expect_thread_independent_bits(GetParam(), Voigt{}, Model::AT1);
  if (GetParam() >= 2)
    expect_thread_independent_bits(GetParam(), Voigt{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 74.0});
}

INSTANTIATE_TEST_SUITE_P(Degrees, TransferDegree, ::testing::Values(1, 2, 3));

TEST(Solver, ParticleLeavingTheGridIsReported)
{
  Grid<2> grid(2, {8, 8}, 1.0, {0.0, 0.0});
  Particles P(1);
  P.x = {7.9, 4.0};
  P.v = {10.0, 0.0};
  P.mass = {1.0};
  P.volume = {1.0};
  Solver solver(grid, P, elastic(1.0, 0.0, 1.0), StepConfig(0.05));
  try
  {
    solver.advance(10);
    FAIL() << "expected SimulationError";
  }
  catch (const SimulationError& e)
  {
    EXPECT_NE(std::string(e.what()).find("outside the grid"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("step 1"), std::string::npos) << e.what();
  }
}

namespace
{
/// One particle of unit volume at x with velocity v and mass m.
Particles lone_particle(std::array<double, 2> x, std::array<double, 2> v, double m)
{
  Particles P(1);
  P.x = {x[0], x[1]};
  P.v = {v[0], v[1]};
  P.mass = {m};
  P.volume = {1.0};
  return P;
}
} // namespace

TEST(Solver, FixedWallStopsAParticleOnIt)
{
  // Open knot vectors interpolate at the ends: a particle on the left edge
  // sees only the wall node, so a fixed wall stops it and a slip wall removes
  // only the normal component.
  for (Wall wall : {Wall::fixed, Wall::slip})
  {
    Grid<2> grid(2, {8, 8}, 1.0, {0.0, 0.0});
    grid.set_wall(Side::left, wall);
    Particles P = lone_particle({0.0, 4.0}, {-1.0, 0.5}, 1.0);
    Solver solver(grid, P, elastic(1.0, 0.0, 1.0), StepConfig(1e-3));
    solver.advance(1);
    EXPECT_NEAR(P.v[0], 0.0, 1e-15); // -1 + dt * (1 / dt)
    EXPECT_NEAR(P.v[1], wall == Wall::fixed ? 0.0 : 0.5, 1e-15);
    EXPECT_DOUBLE_EQ(P.x[0], 0.0);
    // The wall's impulse is the momentum it stopped.
    const auto impulse = solver.energies().wall_impulse[static_cast<int>(Side::left)];
    EXPECT_NEAR(impulse[0], 1.0, 1e-15);
    EXPECT_NEAR(impulse[1], wall == Wall::fixed ? -0.5 : 0.0, 1e-15);
  }
}

TEST(Solver, AtACornerEachDirectionCountsOnTheWallNormalToIt)
{
  // A particle at the corner sees only the corner node, which the left wall
  // holds along x and the bottom wall along y, whatever else they hold.
  for (Wall left : {Wall::fixed, Wall::slip})
    for (Wall bottom : {Wall::fixed, Wall::slip})
    {
      Grid<2> grid(2, {8, 8}, 1.0, {0.0, 0.0});
      grid.set_wall(Side::left, left);
      grid.set_wall(Side::bottom, bottom);
      Particles P = lone_particle({0.0, 0.0}, {-1.0, -2.0}, 1.0);
      Solver solver(grid, P, elastic(1.0, 0.0, 1.0), StepConfig(1e-3));
      solver.advance(1);
      const NodeHold hold = grid.constraints()[0];
      EXPECT_EQ(hold.held, 3);
      EXPECT_EQ(hold.by[0], static_cast<int>(Side::left));
      EXPECT_EQ(hold.by[1], static_cast<int>(Side::bottom));
      const auto impulse = solver.energies().wall_impulse;
      EXPECT_NEAR(impulse[static_cast<int>(Side::left)][0], 1.0, 1e-15);
      EXPECT_NEAR(impulse[static_cast<int>(Side::bottom)][1], 2.0, 1e-15);
      EXPECT_EQ(impulse[static_cast<int>(Side::left)][1], 0.0);
      EXPECT_EQ(impulse[static_cast<int>(Side::bottom)][0], 0.0);
    }
}

TEST(Solver, ARegionSetsItsNodesVelocityAndCountsWhatItAdds)
{
  // A particle at a node's control point under a region that holds x at
  // u = 0.3: after one step it moves at u along x and keeps its y velocity;
  // the region's impulse is m (u - v) and its work the kinetic energy it
  // added, (u^2 - v^2) m / 2 (no force acts on a lone particle at rest
  // stress).
  Grid<2> grid(2, {8, 8}, 1.0, {0.0, 0.0});
  const int k = grid.add_region({3.0, 3.0}, {6.0, 6.0}, 1);
  grid.set_region_velocity(k, {0.3, -7.0});
  Particles P = lone_particle({4.5, 4.5}, {-1.0, 0.5}, 2.0);
  Solver solver(grid, P, elastic(1.0, 0.0, 1.0), StepConfig(1e-3));
  solver.advance(1);
  EXPECT_NEAR(P.v[0], 0.3, 1e-14);
  EXPECT_NEAR(P.v[1], 0.5, 1e-14);
  const Energies e = solver.energies();
  EXPECT_NEAR(e.region_impulse[k][0], 2.0 * 1.3, 1e-14);
  EXPECT_EQ(e.region_impulse[k][1], 0.0);
  EXPECT_NEAR(e.region_work[k], 0.5 * 2.0 * (0.09 - 1.0), 1e-14);
  EXPECT_THROW(grid.add_region({3.0, 3.0}, {2.0, 6.0}, 1), std::invalid_argument);
  EXPECT_THROW(grid.add_region({3.0, 3.0}, {6.0, 6.0}, 0), std::invalid_argument);
  EXPECT_THROW(grid.add_region({3.1, 3.1}, {3.2, 3.2}, 1), std::invalid_argument);
}
