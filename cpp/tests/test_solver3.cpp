/// @file test_solver3.cpp
/// @brief The solver in 3D, with B-splines and with CPDI: a slab between slip
/// walls steps as the 2D plane-strain run; a free bar rings at its
/// longitudinal period; a body spinning about an oblique axis keeps its
/// angular momentum with APIC (and with CPDI its domains' volumes); two
/// spheres collide as Hertz's; 1 and 2 threads, and a resumed run, give the
/// same bits.
#include "helpers.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/materials/material.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>

#include <omp.h>

#include <array>
#include <cmath>
#include <functional>
#include <vector>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// One linear elastic material (3D, or plane strain in 2D).
std::vector<std::shared_ptr<const Material>> steel() { return elastic(100.0, 0.3, 1.0); }

/// The bar of the slab test: [0, 16] x [0, 2] with spacing 0.5, a
/// longitudinal and a transverse velocity wave.
void bar_velocity(const double* x, double* v)
{
  const double pi = std::acos(-1.0);
  v[0] = 0.1 * std::cos(pi * x[0] / 16.0);
  v[1] = 0.05 * std::sin(pi * x[0] / 16.0) + 0.01;
}

/// A step of `dt` with CPDI (on the degree-1 grid).
StepConfig cpdi(double dt)
{
  StepConfig step(dt);
  step.shape = ShapeFunctions::cpdi;
  return step;
}
} // namespace

/// The slab's thickness in cells: the fewest the B-splines of the degree take.
class SlabOfDegree : public ::testing::TestWithParam<int>
{
};

TEST_P(SlabOfDegree, BetweenSlipWallsIsThePlaneStrainRun)
{
  // The 2D bar, and its 3D slab between slip walls, as thin as the grid
  // allows: one cell (h = 1) with degree 1, two with degree 2. Each 2D
  // particle is two per cell across, at 1/4 and 3/4 of it; these quadrature
  // points integrate the derivative of a degree-2 basis function exactly, so
  // the z forces on the free nodes between the walls cancel and the slab
  // stays in plane strain to round-off.
  const int degree = GetParam();
  const double thickness = degree;
  Grid<2> grid2(degree, {20, 6}, 1.0, {-2.0, -2.0});
  Particles P = lattice<2>({0.0, 0.0}, {16.0, 2.0}, 0.5);
  for (std::size_t p = 0; p < P.size(); ++p)
    bar_velocity(&P.x[2 * p], &P.v[2 * p]);
  Grid<3> grid3(degree, {20, 6, degree}, 1.0, {-2.0, -2.0, 0.0});
  grid3.set_wall(Side::back, Wall::slip);
  grid3.set_wall(Side::front, Wall::slip);
  Particles Q = lattice<3>({0.0, 0.0, 0.0}, {16.0, 2.0, thickness}, 0.5);
  for (std::size_t q = 0; q < Q.size(); ++q)
    bar_velocity(&Q.x[3 * q], &Q.v[3 * q]);
  ASSERT_EQ(Q.size(), 2 * degree * P.size());
  Solver plane(grid2, P, steel(), StepConfig(0.02));
  Solver slab(grid3, Q, steel(), StepConfig(0.02));
  EXPECT_THROW(plane.restore(slab.state()), std::invalid_argument); // z components and sides

  const Energies<2> start = plane.energies();
  const double energy = start.kinetic, momentum = start.mass * 0.11, angular = 16.0 * momentum;
  // The slab's totals per unit thickness are the plane run's; no motion out of the plane.
  const double worst = step_alongside(plane, slab, thickness, 200, energy, momentum, angular);
  EXPECT_GT(plane.energies().elastic, 0.1 * energy) << "the bar should have deformed";
  std::cout << "slab of degree " << degree << " against plane strain, 200 steps: largest relative gap "
            << worst << "\n";
}

INSTANTIATE_TEST_SUITE_P(Solver3, SlabOfDegree, ::testing::Values(1, 2));

TEST(Solver3, CpdiSlabBetweenSlipWallsIsThePlaneStrainRun)
{
  // The bar of SlabOfDegree with CPDI, in 2D and as a slab three cells thick (CPDI's block is
  // four nodes a direction) filled by the body, between slip walls: each particle's domain
  // spans [z - 1/4, z + 1/4], so the z derivatives of the averaged shape functions of a column
  // of particles telescope to zero at the free nodes between the walls, and the averages
  // factor into the plane run's times the same weights along z.
  const double thickness = 3.0, dt = 0.02;
  Grid<2> grid2(1, {20, 6}, 1.0, {-2.0, -2.0});
  Particles P = lattice<2>({0.0, 0.0}, {16.0, 2.0}, 0.5);
  for (std::size_t p = 0; p < P.size(); ++p)
    bar_velocity(&P.x[2 * p], &P.v[2 * p]);
  Grid<3> grid3(1, {20, 6, 3}, 1.0, {-2.0, -2.0, 0.0});
  grid3.set_wall(Side::back, Wall::slip);
  grid3.set_wall(Side::front, Wall::slip);
  Particles Q = lattice<3>({0.0, 0.0, 0.0}, {16.0, 2.0, thickness}, 0.5);
  for (std::size_t q = 0; q < Q.size(); ++q)
    bar_velocity(&Q.x[3 * q], &Q.v[3 * q]);
  ASSERT_EQ(Q.size(), 6 * P.size());
  Solver plane(grid2, P, steel(), cpdi(dt));
  Solver slab(grid3, Q, steel(), cpdi(dt));
  lattice_domains<2>(P, 0.5);
  lattice_domains<3>(Q, 0.5);

  const Energies<2> start = plane.energies();
  const double energy = start.kinetic, momentum = start.mass * 0.11, angular = 16.0 * momentum;
  const double worst = step_alongside(plane, slab, thickness, 200, energy, momentum, angular);
  EXPECT_GT(plane.energies().elastic, 0.1 * energy) << "the bar should have deformed";
  // The domains stay in their planes: r3 along z, r1 and r2 without a z component.
  double out_of_plane = 0.0;
  for (std::size_t q = 0; q < Q.size(); ++q)
    for (int k : {0, 1})
    {
      const std::vector<double>& r = Q.f64("domain_r" + std::to_string(k + 1));
      out_of_plane = std::max(out_of_plane, std::abs(r[3 * q + 2]));
    }
  EXPECT_LT(out_of_plane, 1e-14);
  std::cout << "CPDI slab against plane strain, 200 steps: largest relative gap " << worst << "\n";
}

namespace
{
/// A free bar L x 2 x 2 (h = 1, 8 particles a cell) in its first
/// longitudinal mode, v_x = v0 cos(pi x / L), v0 = 0.01.
Particles longitudinal_bar(double L)
{
  const double pi = std::acos(-1.0);
  Particles P = lattice<3>({0.0, 0.0, 0.0}, {L, 2.0, 2.0}, 0.5);
  for (std::size_t p = 0; p < P.size(); ++p)
    P.v[3 * p] = 0.01 * std::cos(pi * P.x[3 * p] / L);
  return P;
}

/// The period of that bar's mode, stepped by `solver` at dt: twice the time
/// between two sign changes of the momentum of its left half (at the start) (each linear between
/// the steps); 0 if there are not two within 640 steps.
double ringing_period(Solver<3>& solver, const Particles& P, double L, double dt)
{
  std::vector<char> left(P.size()); // the left half at the start
  for (std::size_t p = 0; p < P.size(); ++p)
    left[p] = P.x[3 * p] < 0.5 * L;
  auto left_momentum = [&]
  {
    double sum = 0.0;
    for (std::size_t p = 0; p < P.size(); ++p)
      sum += left[p] ? P.mass[p] * P.v[3 * p] : 0.0;
    return sum;
  };
  std::vector<double> crossings;
  double before = left_momentum();
  for (int step = 1; step <= 640 && crossings.size() < 2; ++step)
  {
    solver.advance(1);
    const double now = left_momentum();
    if ((before > 0.0) != (now > 0.0))
      crossings.push_back(dt * (step - now / (now - before)));
    before = now;
  }
  return crossings.size() == 2 ? 2.0 * (crossings[1] - crossings[0]) : 0.0;
}
} // namespace

TEST(Solver3, FreeBarRingsAtItsLongitudinalPeriod)
{
  // A free bar 40 x 2 x 2 (h = 1, 8 particles a cell) in its first
  // longitudinal mode, v_x = v0 cos(pi x / L): its left half's momentum is
  // cos(2 pi t / T), T = 2 L / c with c = sqrt(E / rho) (a thin bar; the
  // lateral inertia's correction is nu^2 pi^2 r^2 / (2 L^2) ~ 2e-4).
  const double L = 40.0, dt = 0.02;
  Grid<3> grid(2, {44, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  Particles P = longitudinal_bar(L);
  Solver solver(grid, P, steel(), StepConfig(dt));
  const double period = ringing_period(solver, P, L, dt), exact = 2.0 * L / 10.0;
  std::cout << "free bar period " << period << " against 2 L / c = " << exact << " (relative "
            << period / exact - 1.0 << ")\n";
  EXPECT_NEAR(period / exact, 1.0, 0.01);
  // The momentum of the whole bar stays zero.
  EXPECT_LT(std::abs(solver.energies().momentum[0]), 1e-12 * solver.energies().mass * 0.01);
}

TEST(Solver3, CpdiFreeBarRingsAtItsLongitudinalPeriod)
{
  // The free bar of FreeBarRingsAtItsLongitudinalPeriod with CPDI on the degree-1 grid.
  const double L = 40.0, dt = 0.02;
  Grid<3> grid(1, {44, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  Particles P = longitudinal_bar(L);
  Solver solver(grid, P, steel(), cpdi(dt));
  lattice_domains<3>(P, 0.5);
  const double period = ringing_period(solver, P, L, dt), exact = 2.0 * L / 10.0;
  std::cout << "CPDI free bar period " << period << " against 2 L / c = " << exact
            << " (relative " << period / exact - 1.0 << ")\n";
  EXPECT_NEAR(period / exact, 1.0, 0.01);
  EXPECT_LT(std::abs(solver.energies().momentum[0]), 1e-12 * solver.energies().mass * 0.01);
  // The domains were convected: stretched and shortened along x, as the bar.
  double longest = 0.0, shortest = 1.0;
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    longest = std::max(longest, P.f64("convected_r1")[3 * p]);
    shortest = std::min(shortest, P.f64("convected_r1")[3 * p]);
  }
  EXPECT_GT(longest - shortest, 1e-5);
}

namespace
{
/// A ball of radius 3 about (5, 5, 5), 2 particles a cell a side (h = 1),
/// spinning at 1/3 about the axis (1, 2, 2) / 3 through its centre: its
/// particles with the rigid velocities v = omega x (x - centre), and the
/// velocity gradients G_ij = dv_i/dx_j = eps_ikj omega_k of the affine
/// matrices (9 per particle).
struct SpinningBall
{
  struct Shape
  {
    std::array<double, 3> centre{5.0, 5.0, 5.0};
    double R = 3.0, rate = 1.0 / 3.0;
    std::array<double, 3> omega{rate / 3.0, 2.0 * rate / 3.0, 2.0 * rate / 3.0};
  } shape;
  Particles P = lattice<3>({2.0, 2.0, 2.0}, {8.0, 8.0, 8.0}, 0.5,
                           [this](const double* x)
                           {
                             double r2 = 0.0;
                             for (int k = 0; k < 3; ++k)
                               r2 += (x[k] - shape.centre[k]) * (x[k] - shape.centre[k]);
                             return r2 < shape.R * shape.R;
                           });
  std::vector<double> G = std::vector<double>(9 * P.size());

  SpinningBall()
  {
    const auto& [centre, R, rate, omega] = shape;
    for (std::size_t p = 0; p < P.size(); ++p)
    {
      double r[3];
      for (int k = 0; k < 3; ++k)
        r[k] = P.x[3 * p + k] - centre[k];
      for (int i = 0; i < 3; ++i)
      {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        P.v[3 * p + i] = omega[j] * r[k] - omega[k] * r[j];
        G[9 * p + 3 * i + k] = omega[j];
        G[9 * p + 3 * i + j] = -omega[k];
      }
    }
  }
};
} // namespace

TEST(Solver3, ObliqueSpinKeepsItsAngularMomentumWithApic)
{
  // A neo-Hookean ball of radius 3 spinning at omega about the axis (1, 2, 2) / 3
  // through its centre, seeded with the affine matrices of the rigid field
  // v = omega x (x - centre), for one turn.
  SpinningBall spin;
  const auto& [centre, R, rate, omega] = spin.shape;
  const double pi = std::acos(-1.0);
  Grid<3> grid(2, {10, 10, 10}, 1.0, {0.0, 0.0, 0.0});
  Particles& P = spin.P;
  const std::vector<double>& G = spin.G;
  const std::size_t n = P.size();
  const auto ball = MaterialRegistry::make(
      "neo_hookean", Parameters({{"E", 100.0}, {"nu", 0.3}, {"density", 1.0}}, {}));
  StepConfig step(0.03);
  step.transfer = TransferScheme::apic;
  Solver solver(grid, P, {ball}, step);
  solver.set_velocity_gradients(G);
  const Energies<3> start = solver.energies();
  // The angular momentum about the origin: the particles' own, sum m r x v
  // about the centre (their momentum is zero), plus with APIC that of their
  // affine velocities, eps_abc (B_p)_cb m_p = 2 m_p D omega_a with the
  // quadratic B-splines' D_p = h^2 / 4 (Jiang et al. 2015).
  double length = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    double expected = 2.0 * 0.25 * start.mass * omega[a];
    for (std::size_t p = 0; p < n; ++p)
      expected += P.mass[p] * ((P.x[3 * p + b] - centre[b]) * P.v[3 * p + c]
                               - (P.x[3 * p + c] - centre[c]) * P.v[3 * p + b]);
    EXPECT_NEAR(start.angular_momentum[a], expected, 1e-12 * std::abs(expected));
    length += expected * expected;
  }
  length = std::sqrt(length);
  const double turn = 2.0 * pi / rate;
  const int steps = static_cast<int>(std::lround(turn / 0.03));
  double drift = 0.0;
  solver.advance(steps);
  const Energies<3> end = solver.energies();
  for (int d = 0; d < 3; ++d)
    drift = std::max(drift, std::abs(end.angular_momentum[d] - start.angular_momentum[d]) / length);
  std::cout << "oblique spin, " << steps << " steps (one turn): angular momentum drifts " << drift
            << " of |L|, kinetic energy " << end.kinetic / start.kinetic << " of its start\n";
  EXPECT_LT(drift, 1e-10);
  for (int d = 0; d < 3; ++d)
    EXPECT_LT(std::abs(end.momentum[d]), 1e-12 * start.mass * rate * R);
  EXPECT_NEAR(end.kinetic / start.kinetic, 1.0, 0.01);
}

TEST(Solver3, CpdiObliqueSpinKeepsItsAngularMomentumAndVolume)
{
  // The spinning ball of ObliqueSpinKeepsItsAngularMomentumWithApic with CPDI and APIC, its
  // domains the lattice's cubes, for one turn. The domains are convected as F is (H&H eq. 8),
  // so a domain's volume 8 det R is J times the lattice cube's: a rotation's own step
  // det(I + dt W) = 1 + dt^2 |omega|^2 would add 2 pi |omega| dt = 6 % a turn, which the
  // neo-Hookean bulk stiffness holds back.
  SpinningBall spin;
  const double R = spin.shape.R, rate = spin.shape.rate, pi = std::acos(-1.0), dt = 0.03;
  Grid<3> grid(1, {10, 10, 10}, 1.0, {0.0, 0.0, 0.0});
  Particles& P = spin.P;
  const std::vector<double>& G = spin.G;
  const std::size_t n = P.size();
  const auto ball = MaterialRegistry::make(
      "neo_hookean", Parameters({{"E", 100.0}, {"nu", 0.3}, {"density", 1.0}}, {}));
  StepConfig step = cpdi(dt);
  step.transfer = TransferScheme::apic;
  Solver solver(grid, P, {ball}, step);
  lattice_domains<3>(P, 0.5);
  solver.set_velocity_gradients(G);
  const Energies<3> start = solver.energies();
  double length = 0.0;
  for (int a = 0; a < 3; ++a)
    length += start.angular_momentum[a] * start.angular_momentum[a];
  length = std::sqrt(length);
  const int steps = static_cast<int>(std::lround(2.0 * pi / rate / dt));
  solver.advance(steps);
  const Energies<3> end = solver.energies();
  double drift = 0.0;
  for (int d = 0; d < 3; ++d)
    drift = std::max(drift, std::abs(end.angular_momentum[d] - start.angular_momentum[d]) / length);
  // The domains' volumes 8 det R against the lattice's cubes, 0.5^3.
  double worst = 0.0;
  for (std::size_t p = 0; p < n; ++p)
  {
    const double* r[3] = {&P.f64("domain_r1")[3 * p], &P.f64("domain_r2")[3 * p],
                          &P.f64("domain_r3")[3 * p]};
    worst = std::max(worst, std::abs(8.0 * CpdiStencil<3>::determinant(r) / 0.125 - 1.0));
  }
  // The kinetic energy is printed, not checked: APIC with CPDI loses some in a rigid spin (B_p
  // is formed with D_p of the position and domain before the move, P2G divides by the D_p
  // after it), as in 2D.
  std::cout << "CPDI oblique spin, " << n << " particles, " << steps
            << " steps (one turn): angular momentum drifts " << drift
            << " of |L|, domain volumes off by at most " << worst << ", kinetic energy "
            << end.kinetic / start.kinetic << " of its start\n";
  EXPECT_LT(drift, 1e-10); // the issue asks for 1 %
  EXPECT_LT(worst, 0.01);
  for (int d = 0; d < 3; ++d)
    EXPECT_LT(std::abs(end.momentum[d]), 1e-12 * start.mass * rate * R);
}

namespace
{
/// The free bar of FreeBarRingsAtItsLongitudinalPeriod, shorter and with a
/// shear wave too, for the bitwise checks.
Particles ringing_bar()
{
  Particles P = lattice<3>({0.0, 0.0, 0.0}, {8.0, 2.0, 2.0}, 0.5);
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    P.v[3 * p] = 0.05 * std::cos(0.4 * P.x[3 * p]);
    P.v[3 * p + 2] = 0.02 * std::sin(0.4 * P.x[3 * p] + P.x[3 * p + 1]);
  }
  return P;
}
} // namespace

TEST(Solver3, OneAndTwoThreadsGiveTheSameBits)
{
  const int threads = omp_get_max_threads();
  std::vector<Particles> runs;
  for (int t : {1, 2})
  {
    omp_set_num_threads(t);
    Grid<3> grid(2, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
    runs.push_back(ringing_bar());
    Solver solver(grid, runs.back(), steel(), StepConfig(0.02));
    solver.set_adaptive_threads(false);
    solver.advance(60);
  }
  omp_set_num_threads(threads);
  EXPECT_TRUE(same_bits(runs[0].x, runs[1].x));
  EXPECT_TRUE(same_bits(runs[0].v, runs[1].v));
  EXPECT_TRUE(same_bits(runs[0].stress, runs[1].stress));
}

TEST(Solver3, ResumedRunContinuesBitwise)
{
  Grid<3> grid(2, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  grid.set_wall(Side::bottom, Wall::slip);
  Particles P = ringing_bar();
  Solver original(grid, P, steel(), StepConfig(0.02));
  original.advance(40);
  Grid<3> grid2(2, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  grid2.set_wall(Side::bottom, Wall::slip);
  Particles Q = P;
  Solver resumed(grid2, Q, steel(), StepConfig(0.02));
  const SolverState state = original.state();
  EXPECT_EQ(state.scalars.count("wall_impulse/front/z"), 1u);
  EXPECT_EQ(state.scalars.count("region/0/displacement/z"), 1u);
  resumed.restore(state);
  original.advance(40);
  resumed.advance(40);
  EXPECT_TRUE(same_bits(P.x, Q.x));
  EXPECT_TRUE(same_bits(P.v, Q.v));
  EXPECT_TRUE(same_bits(P.stress, Q.stress));
  const Energies<3> a = original.energies(), b = resumed.energies();
  EXPECT_EQ(a.wall_impulse, b.wall_impulse);
  EXPECT_EQ(a.wall_work, b.wall_work);
  EXPECT_EQ(original.time(), resumed.time());
}

TEST(Solver3, CpdiOneAndTwoThreadsGiveTheSameBits)
{
  // The ringing bar with CPDI: one field with APIC, and cut at x = 4 into two bodies, each its
  // own field, in frictional contact.
  const int threads = omp_get_max_threads();
  for (const Partition partition : {Partition::single, Partition::bodies})
  {
    std::vector<Particles> runs;
    double drift = 0.0;
    for (int t : {1, 2})
    {
      omp_set_num_threads(t);
      Grid<3> grid(1, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
      runs.push_back(ringing_bar());
      Particles& P = runs.back();
      StepConfig step = cpdi(0.02);
      if (partition == Partition::bodies)
      {
        for (std::size_t p = 0; p < P.size(); ++p)
          P.body[p] = P.x[3 * p] < 4.0 ? 0 : 1;
        step.partition = partition;
        step.friction = {0.3, 0.3, 0.3, 0.3};
      }
      else
        step.transfer = TransferScheme::apic;
      Solver solver(grid, P, steel(), step);
      lattice_domains<3>(P, 0.5);
      solver.set_adaptive_threads(false);
      const Energies<3> start = solver.energies();
      solver.advance(60);
      const Energies<3> end = solver.energies();
      for (int d = 0; d < 3; ++d)
        drift = std::max(drift,
                         std::abs(end.momentum[d] - start.momentum[d]) / (start.mass * 0.05));
    }
    const char* name = partition == Partition::bodies ? "bodies" : "single";
    EXPECT_TRUE(same_bits(runs[0].x, runs[1].x)) << name;
    EXPECT_TRUE(same_bits(runs[0].v, runs[1].v)) << name;
    EXPECT_TRUE(same_bits(runs[0].stress, runs[1].stress)) << name;
    for (const char* column : {"convected_r1", "convected_r2", "convected_r3"})
      EXPECT_TRUE(same_bits(runs[0].f64(column), runs[1].f64(column))) << name << " " << column;
    // No walls: the momentum stays, contact or not.
    EXPECT_LT(drift, 1e-12) << name;
  }
  omp_set_num_threads(threads);
}

TEST(Solver3, CpdiResumedRunContinuesBitwise)
{
  // CPDI with APIC against a slip wall: the domains and B_p travel in the particles' columns.
  auto make = [](Grid<3>& grid, Particles& P)
  {
    grid.set_wall(Side::bottom, Wall::slip);
    StepConfig step = cpdi(0.02);
    step.transfer = TransferScheme::apic;
    return std::make_unique<Solver<3>>(grid, P, steel(), step);
  };
  Grid<3> grid(1, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  Particles P = ringing_bar();
  auto original = make(grid, P);
  lattice_domains<3>(P, 0.5);
  original->advance(40);
  Grid<3> grid2(1, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  Particles Q = P;
  auto resumed = make(grid2, Q);
  resumed->restore(original->state());
  original->advance(40);
  resumed->advance(40);
  EXPECT_TRUE(same_bits(P.x, Q.x));
  EXPECT_TRUE(same_bits(P.v, Q.v));
  EXPECT_TRUE(same_bits(P.stress, Q.stress));
  for (const char* column : {"convected_r1", "convected_r2", "convected_r3", "affine"})
    EXPECT_TRUE(same_bits(P.f64(column), Q.f64(column))) << column;
  const Energies<3> a = original->energies(), b = resumed->energies();
  EXPECT_EQ(a.wall_impulse, b.wall_impulse);
  EXPECT_EQ(original->time(), resumed->time());
}

TEST(Solver3, TwoDimensionalFeaturesAreRefused)
{
  Grid<3> grid(2, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  Particles P = ringing_bar();
  StepConfig cracks(0.02);
  cracks.fracture = {Fracture{1.0, 2.0, 0.0}};
  EXPECT_NO_THROW(Solver(grid, P, steel(), cracks)); // the second-order phase field runs in 3D
  Voigt gamma{};
  gamma[0] = 1.0;
  cracks.fracture = {Fracture{1.0, 2.0, 0.0, gamma}}; // the fourth-order one does not
  EXPECT_THROW(Solver(grid, P, steel(), cracks), std::invalid_argument);
  Particles flat(4, 2);
  EXPECT_THROW(Solver(grid, flat, steel(), StepConfig(0.02)), std::invalid_argument);
}

TEST(Solver3, CpdiBadInputIsRefused)
{
  Particles P = ringing_bar();
  // Degree 2, and fewer than 3 cells along z.
  Grid<3> quadratic(2, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  EXPECT_THROW(Solver(quadratic, P, steel(), cpdi(0.02)), std::invalid_argument);
  Grid<3> thin(1, {12, 6, 2}, 1.0, {-2.0, -2.0, -2.0});
  EXPECT_THROW(Solver(thin, P, steel(), cpdi(0.02)), std::invalid_argument);
  // A domain wider than a cell along z, and a left-handed one, at t = 0.
  Grid<3> grid(1, {12, 6, 6}, 1.0, {-2.0, -2.0, -2.0});
  Solver solver(grid, P, steel(), cpdi(0.02));
  lattice_domains<3>(P, 0.5);
  P.f64("convected_r3")[3 * 7 + 2] = P.f64("domain_r3")[3 * 7 + 2] = 0.6;
  try
  {
    solver.advance(1);
    ADD_FAILURE() << "a domain 1.2 cells wide was taken";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("particle 7: CPDI domain with half-edges r1 = (0.25, 0, 0), "
                                         "r2 = (0, 0.25, 0), r3 = (0, 0, 0.6)"),
              std::string::npos)
        << e.what();
  }
  P.f64("convected_r3")[3 * 7 + 2] = P.f64("domain_r3")[3 * 7 + 2] = -0.25;
  EXPECT_THROW(solver.advance(1), std::invalid_argument);
}

TEST(Solver3, SpheresCollideAsHertzs)
{
  // Two elastic spheres of radius 10 h (20 cells per diameter, 8 particles a
  // cell), each its own field with frictionless contact, meeting head-on at
  // a relative speed of 0.3 (0.026 of the P-wave speed) after a gap of one
  // cell. Hertz's quasi-static impact of identical spheres: E* = E / (2 (1 -
  // nu^2)), R* = R / 2, m* = M / 2, the duration 2.868 (m*^2 / (R* E*^2 v))^(1/5)
  // and the peak force (4/3) E* R*^(1/2) d^(3/2) at the largest approach d =
  // (15 m* v^2 / (16 E* R*^(1/2)))^(2/5). The force is the contact impulse's
  // change per step (Energies::pair_impulse).
  const double R = 10.0, speed = 0.3, E = 100.0, nu = 0.3, pi = std::acos(-1.0);
  const std::array<double, 3> centre[2] = {{14.0, 14.0, 14.0}, {35.0, 14.0, 14.0}};
  Grid<3> grid(2, {49, 28, 28}, 1.0, {0.0, 0.0, 0.0});
  std::vector<Particles> balls;
  for (int b = 0; b < 2; ++b)
    balls.push_back(lattice<3>({centre[b][0] - R, 4.0, 4.0}, {centre[b][0] + R, 24.0, 24.0}, 0.5,
                               [&](const double* x)
                               {
                                 double r2 = 0.0;
                                 for (int k = 0; k < 3; ++k)
                                   r2 += (x[k] - centre[b][k]) * (x[k] - centre[b][k]);
                                 return r2 <= R * R;
                               }));
  const std::size_t n0 = balls[0].size();
  Particles P(n0 + balls[1].size(), 3);
  for (int b = 0; b < 2; ++b)
    for (std::size_t q = 0; q < balls[b].size(); ++q)
    {
      const std::size_t p = b == 0 ? q : n0 + q;
      std::copy_n(&balls[b].x[3 * q], 3, &P.x[3 * p]);
      P.v[3 * p] = b == 0 ? 0.5 * speed : -0.5 * speed;
      P.volume[p] = P.mass[p] = 0.125;
      P.body[p] = b;
    }
  ASSERT_EQ(balls[1].size(), n0);
  const double c = plane_strain_wave_speed(E, nu, 1.0), dt = 0.3 / (c + speed);
  StepConfig step(dt);
  step.partition = Partition::bodies;
  step.friction = {0.0, 0.0, 0.0, 0.0};
  Solver solver(grid, P, elastic(E, nu, 1.0), step);

  const double M = 0.125 * static_cast<double>(n0), Es = E / (2.0 * (1.0 - nu * nu)), Rs = 0.5 * R,
               ms = 0.5 * M;
  const double duration = 2.868 * std::pow(ms * ms / (Rs * Es * Es * speed), 0.2);
  const double approach = std::pow(15.0 * ms * speed * speed / (16.0 * Es * std::sqrt(Rs)), 0.4);
  const double peak = 4.0 / 3.0 * Es * std::sqrt(Rs) * std::pow(approach, 1.5);
  EXPECT_NEAR(M, 4.0 / 3.0 * pi * R * R * R, 0.01 * M);
  // The gap closes in 1 / speed; run on to 1.6 contact durations after.
  const int steps = static_cast<int>((1.0 / speed + 1.6 * duration) / dt);
  double impulse = 0.0, largest = 0.0, momentum = 0.0;
  int first = -1, last = -1;
  std::vector<double> force(steps);
  for (int k = 0; k < steps; ++k)
  {
    solver.advance(1);
    const Energies<3> e = solver.energies();
    force[k] = -(e.pair_impulse[0][0] - impulse) / dt; // the push of sphere 1 on sphere 0
    impulse = e.pair_impulse[0][0];
    largest = std::max(largest, force[k]);
    for (int d = 0; d < 3; ++d)
      momentum = std::max(momentum, std::abs(e.momentum[d]));
  }
  for (int k = 0; k < steps; ++k)
    if (force[k] > 1e-3 * largest)
      last = k, first = first < 0 ? k : first;
  ASSERT_GE(first, 0);
  ASSERT_LT(last, steps - 1) << "the spheres should have parted";
  const double measured = (last - first + 1) * dt;
  std::cout << "Hertz spheres, " << P.size() << " particles: duration " << measured << " against "
            << duration << " (" << measured / duration - 1.0 << "), peak force " << largest
            << " against " << peak << " (" << largest / peak - 1.0 << "), momentum "
            << momentum / (M * speed) << " of M v\n";
  EXPECT_NEAR(measured / duration, 1.0, 0.05);
  EXPECT_NEAR(largest / peak, 1.0, 0.05);
  EXPECT_LT(momentum, 1e-10 * M * speed);
  EXPECT_EQ(solver.contact_stats()->violations, (std::array<std::int64_t, 4>{}));
}
