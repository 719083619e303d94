/// @file test_contact.cpp
/// @brief Discrete fields with frictional contact (eqs. 63-77): momentum is conserved to round-off
/// through a collision, the checks C.1-C.4 hold at every contact node, results do not depend on
/// the thread count, and bodies that never meet run with the same bits as one field.
#include "disks.h"
#include "helpers.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <vector>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// Sum of M_p |v_p|: the scale of the momentum error.
double momentum_scale(const Particles& P)
{
  double s = 0;
  for (std::size_t i = 0; i < P.size(); ++i)
    s += P.mass[i] * std::hypot(P.v[2 * i], P.v[2 * i + 1]);
  return s;
}

// Two disks, the second at rest and off the first's path: an oblique impact.
const std::vector<Disk> oblique = {{2.0, 2.0, 1.0, 0.5, 0.1}, {4.1, 2.6, 1.0, 0.0, 0.0}};
} // namespace

class ContactDegree : public ::testing::TestWithParam<int>
{
};

TEST_P(ContactDegree, CollisionConservesMomentumAndPassesChecks)
{
  Grid grid(GetParam(), {32, 24}, 0.25, {0.0, 0.0});
  Particles P = make_disks(oblique, 0.125);
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), 2e-3, {}, 1e-6, 1000,
                {0.0, 0.3, 0.3, 0.0});
  const Energies before = solver.energies();
  const double scale = momentum_scale(P);
  std::int64_t max_nodes = 0;
  for (int k = 0; k < 60; ++k)
  {
    solver.advance(25);
    max_nodes = std::max<std::int64_t>(max_nodes, solver.contact_stats()->nodes);
    const Energies e = solver.energies();
    EXPECT_NEAR(e.momentum[0], before.momentum[0], 1e-10 * scale);
    EXPECT_NEAR(e.momentum[1], before.momentum[1], 1e-10 * scale);
  }
  const ContactStats& s = *solver.contact_stats();
  EXPECT_GT(max_nodes, 0);
  EXPECT_GT(s.active, 0);   // the disks did push on each other
  EXPECT_LT(s.friction_work, 0.0); // friction dissipated energy
  for (int c = 0; c < 4; ++c)
    EXPECT_EQ(s.violations[c], 0) << "C." << c + 1;
}

TEST_P(ContactDegree, ThreadCountDoesNotChangeBits)
{
  auto run = [](int threads)
  {
    omp_set_num_threads(threads);
    Grid grid(GetParam(), {32, 24}, 0.25, {0.0, 0.0});
    Particles P = make_disks(oblique, 0.125);
    add_model_columns(P, true);
    for (std::size_t i = 0; i < P.size(); ++i)
      if (std::abs(P.x[2 * i + 1] - 2.0) < 0.1 && P.body[i] == 0)
        P.f64("history")[i] = 50.0;
    Solver solver(grid, P, elastic(100.0, 0.3, 1.0), 2e-3,
                  {Fracture{0.5, 0.5, 0.0}}, 1e-6, 1000, {0.0, 0.3, 0.3, 0.0});
    solver.advance(300);
    return std::make_pair(P, solver.energies());
  };
  const int max_threads = omp_get_max_threads();
  const auto [p1, e1] = run(1);
  const auto [p3, e3] = run(3);
  omp_set_num_threads(max_threads);
  EXPECT_TRUE(same_bits(p1.x, p3.x));
  EXPECT_TRUE(same_bits(p1.v, p3.v));
  EXPECT_TRUE(same_bits(p1.f64("c"), p3.f64("c")));
  EXPECT_EQ(e1.friction_work, e3.friction_work);
  EXPECT_EQ(e1.fracture, e3.fracture);
  EXPECT_LT(e1.friction_work, 0.0);
}

TEST_P(ContactDegree, BodiesThatNeverMeetRunAsOneField)
{
  // Far apart and moving apart: no contact node, so the same bits as one field.
  const std::vector<Disk> apart = {{2.0, 3.0, 1.0, -0.2, 0.1}, {6.0, 3.0, 1.0, 0.3, 0.0}};
  auto run = [&](std::vector<double> friction)
  {
    Grid grid(GetParam(), {32, 24}, 0.25, {0.0, 0.0});
    Particles P = make_disks(apart, 0.125);
    add_model_columns(P, false);
    for (std::size_t i = 0; i < P.size(); ++i)
      P.f64("strain")[3 * i] = 1e-3 * std::sin(P.x[2 * i + 1]);
    Solver solver(grid, P, elastic(100.0, 0.3, 1.0), 2e-3, {}, 1e-6, 1000,
                  std::move(friction));
    solver.advance(300);
    return P;
  };
  const Particles one = run({});
  const Particles two = run({0.5, 0.5, 0.5, 0.5});
  EXPECT_TRUE(same_bits(one.x, two.x));
  EXPECT_TRUE(same_bits(one.v, two.v));
  EXPECT_TRUE(same_bits(one.stress, two.stress));
}

// Quadratic and cubic B-splines; the scene refuses contact on linear ones
// (a tiny-mass node of one field at the edge of a linear cell blows up).
INSTANTIATE_TEST_SUITE_P(Degrees, ContactDegree, ::testing::Values(2, 3));

TEST(Contact, BadFrictionIsRefused)
{
  Grid grid(2, {8, 8}, 1.0, {0.0, 0.0});
  Particles P(1);
  P.x = {4.0, 4.0};
  P.mass = {1.0};
  P.volume = {1.0};
  const auto m = elastic(1.0, 0.0, 1.0);
  EXPECT_THROW(Solver(grid, P, m, 0.1, {}, 1e-6, 10, {0.0, -0.1, -0.1, 0.0}), std::invalid_argument);
  EXPECT_THROW(Solver(grid, P, m, 0.1, {}, 1e-6, 10, {0.0, 0.1, 0.2, 0.0}), std::invalid_argument);
  EXPECT_THROW(Solver(grid, P, m, 0.1, {}, 1e-6, 10, {0.0, 0.1, 0.2}), std::invalid_argument);
  P.body = {2};
  EXPECT_THROW(Solver(grid, P, m, 0.1, {}, 1e-6, 10, {0.0, 0.1, 0.1, 0.0}), std::invalid_argument);
}
