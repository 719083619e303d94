/// @file test_state.cpp
/// @brief The solver state: restored into a fresh solver, it continues bitwise as the original,
/// with one field or with discrete fields in contact; the stability check stops a step that
/// outruns the grid.
#include "disks.h"
#include "helpers.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// A square block of n x n particles in [2, 4]^2 with a notch of history
/// along y = 3 and a shearing velocity field.
Particles make_block(int n)
{
  Particles P(static_cast<std::size_t>(n) * n);
  add_model_columns(P, true);
  std::vector<double>& history = P.f64("history");
  const double d = 2.0 / n;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
    {
      const std::size_t p = static_cast<std::size_t>(i) * n + j;
      P.x[2 * p] = 2.0 + (i + 0.5) * d;
      P.x[2 * p + 1] = 2.0 + (j + 0.5) * d;
      P.v[2 * p] = 0.2 * (P.x[2 * p + 1] - 3.0);
      P.v[2 * p + 1] = 0.05 * std::sin(P.x[2 * p]);
      P.volume[p] = d * d;
      P.mass[p] = d * d;
      if (std::abs(P.x[2 * p + 1] - 3.0) < 0.1 && P.x[2 * p] < 3.0)
        history[p] = 50.0;
    }
  return P;
}

/// Disk 0 moving obliquely at disk 1, which alone can crack (material 1);
/// with `notch`, a band of history across disk 1's middle.
Particles crackable_disks(bool notch)
{
  Particles P = make_disks({{2.0, 2.0, 1.0, 0.5, 0.1}, {4.1, 2.6, 1.0, 0.0, 0.0}}, 0.125);
  add_model_columns(P, true);
  for (std::size_t p = 0; p < P.size(); ++p)
    if (P.body[p] == 1)
    {
      P.material[p] = 1;
      if (notch && std::abs(P.x[2 * p + 1] - 2.6) < 0.1)
        P.f64("history")[p] = 50.0;
    }
  return P;
}

/// Positions, velocities, phase field and stresses bit for bit.
void expect_same_particles(const Particles& P, const Particles& Q)
{
  EXPECT_TRUE(same_bits(P.x, Q.x));
  EXPECT_TRUE(same_bits(P.v, Q.v));
  EXPECT_TRUE(same_bits(P.f64("c"), Q.f64("c")));
  EXPECT_TRUE(same_bits(P.stress, Q.stress));
}

/// The step of these tests: `dt` with `fracture`, and with `friction` each
/// body its own field.
StepConfig step_with(double dt, std::vector<std::optional<Fracture>> fracture,
                     std::vector<double> friction = {})
{
  StepConfig step(dt);
  step.fracture = std::move(fracture);
  step.friction = std::move(friction);
  step.partition = step.friction.empty() ? Partition::single : Partition::bodies;
  return step;
}

} // namespace

class RestoredSolver : public ::testing::TestWithParam<Model>
{
};

TEST_P(RestoredSolver, ContinuesBitwise)
{
  // AT1's bounded solve carries nothing besides AT2's nodal c and the one before.
  const auto mat = elastic(100.0, 0.3, 1.0);
  const std::vector<std::optional<Fracture>> fracture{Fracture{0.5, 0.5, 0.0, {}, GetParam()}};
  Grid<2> grid(2, {24, 24}, 0.25, {0.0, 0.0});
  Particles P = make_block(40);
  Solver original(grid, P, mat, step_with(1e-3, fracture));
  original.advance(30);

  // A copy of the particles and the solver state, in a solver that has
  // solved nothing yet.
  Grid<2> grid2(2, {24, 24}, 0.25, {0.0, 0.0});
  Particles Q = P;
  Solver resumed(grid2, Q, mat, step_with(1e-3, fracture));
  resumed.restore(original.state());
  EXPECT_EQ(resumed.step_count(), 30);
  EXPECT_EQ(resumed.energies().fracture, original.energies().fracture);

  original.advance(20);
  resumed.advance(20);
  expect_same_particles(P, Q);
  EXPECT_EQ(original.phase_field_stats().iterations, resumed.phase_field_stats().iterations);
  EXPECT_EQ(original.phase_field_stats().passes, resumed.phase_field_stats().passes);
  EXPECT_EQ(original.energies().external_work, resumed.energies().external_work);
  EXPECT_EQ(original.time(), resumed.time());
  EXPECT_GT(original.energies().fracture, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Models, RestoredSolver, ::testing::Values(Model::AT2, Model::AT1),
                         [](const auto& info) { return info.param == Model::AT1 ? "AT1" : "AT2"; });

TEST(SolverState, StateOfAnotherGridIsRefused)
{
  const std::vector<std::optional<Fracture>> fracture{Fracture{0.5, 0.5, 0.0}};
  const auto mat = elastic(100.0, 0.3, 1.0);
  Grid<2> small(2, {20, 20}, 0.25, {0.0, 0.0}), large(2, {24, 24}, 0.25, {0.0, 0.0});
  Particles P = make_block(10), Q = make_block(10);
  Solver a(small, P, mat, step_with(1e-3, fracture)), b(large, Q, mat, step_with(1e-3, fracture));
  EXPECT_THROW(b.restore(a.state()), std::invalid_argument);
}

TEST(SolverState, RestoredContactRunContinuesBitwise)
{
  // Disk 0 hits disk 1 obliquely; only disk 1 (material 1) can crack, from a
  // notch of history across its middle. Each field keeps its own phase field.
  const auto mat = elastic(100.0, 0.3, 1.0, 2);
  const std::vector<std::optional<Fracture>> fracture{std::nullopt, Fracture{0.5, 0.5, 0.0}};
  const std::vector<double> friction{0.0, 0.3, 0.3, 0.0};
  Grid<2> grid(2, {32, 24}, 0.25, {0.0, 0.0});
  Particles P = crackable_disks(true);
  Solver original(grid, P, mat, step_with(2e-3, fracture, friction));
  original.advance(100);
  ASSERT_GT(original.contact_stats()->nodes, 0) << "the disks should be in contact";
  ASSERT_GT(original.contact_stats()->active, 0);

  // The particles and the solver state, in a solver that has solved nothing.
  Grid<2> grid2(2, {32, 24}, 0.25, {0.0, 0.0});
  Particles Q = P;
  Solver resumed(grid2, Q, mat, step_with(2e-3, fracture, friction));
  SolverState state = original.state();
  // One phase field (of the crackable disk) and the contact record.
  EXPECT_EQ(state.arrays.size(), 4u);
  EXPECT_EQ(state.arrays.count("grid/slab_sums"), 1u);
  EXPECT_EQ(state.arrays.count("phase_field/0/c"), 1u);
  EXPECT_EQ(state.arrays.count("contact/pair_impulse"), 1u);
  EXPECT_EQ(state.scalars.count("contact/friction_work"), 1u);
  resumed.restore(state);
  EXPECT_EQ(resumed.energies().fracture_by_field, original.energies().fracture_by_field);
  EXPECT_EQ(resumed.energies().friction_work, original.energies().friction_work);
  EXPECT_EQ(resumed.energies().pair_impulse, original.energies().pair_impulse);

  original.advance(150);
  resumed.advance(150);
  expect_same_particles(P, Q);
  const Energies a = original.energies(), b = resumed.energies();
  EXPECT_LT(a.friction_work, 0.0);
  EXPECT_GT(a.fracture_by_field[1], 0.0);
  EXPECT_EQ(a.fracture_by_field, b.fracture_by_field);
  EXPECT_EQ(a.friction_work, b.friction_work);
  EXPECT_EQ(a.external_work, b.external_work);
  const ContactStats &s = *original.contact_stats(), &t = *resumed.contact_stats();
  EXPECT_EQ(s.nodes, t.nodes);
  EXPECT_EQ(s.pairs, t.pairs);
  EXPECT_EQ(s.active, t.active);
  EXPECT_EQ(s.sliding, t.sliding);
  EXPECT_EQ(s.violations, t.violations);
  EXPECT_EQ(s.friction_work, t.friction_work);
  const PhaseFieldStats p = original.phase_field_stats(), q = resumed.phase_field_stats();
  EXPECT_EQ(p.solves, q.solves);
  EXPECT_EQ(p.iterations, q.iterations);
  EXPECT_EQ(original.time(), resumed.time());
}

TEST(SolverState, SlabsOfTwoOwnersAddUpToTheWholeRun)
{
  // The contact run of RestoredContactRunContinuesBitwise in three solvers
  // on the same particles: one keeps every slab of nodes, two keep
  // complementary ones, as two ranks owning them would. The two's slab sums
  // in slab order, with the particles' tile sums, give the energies of the
  // first bit for bit.
  const auto mat = elastic(100.0, 0.3, 1.0, 2);
  const std::vector<std::optional<Fracture>> fracture{std::nullopt, Fracture{0.5, 0.5, 0.0}};
  const std::vector<double> friction{0.0, 0.3, 0.3, 0.0};
  Grid<2> g0(2, {32, 24}, 0.25, {0.0, 0.0}), g1 = g0, g2 = g0;
  Particles P = crackable_disks(true), Q = P, R = P;
  Solver whole(g0, P, mat, step_with(2e-3, fracture, friction));
  Solver left(g1, Q, mat, step_with(2e-3, fracture, friction));
  Solver right(g2, R, mat, step_with(2e-3, fracture, friction));
  ASSERT_EQ(whole.owned_slabs(), (std::array<std::int64_t, 2>{0, 5})); // 34 node columns
  left.set_owned_slabs(0, 2);
  right.set_owned_slabs(2, 5);
  EXPECT_THROW(right.set_owned_slabs(2, 6), std::invalid_argument);
  EXPECT_THROW(right.set_owned_slabs(3, 2), std::invalid_argument);
  for (Solver<2>* s : {&whole, &left, &right})
    s->advance(100);
  expect_same_particles(P, Q);
  std::vector<double> slabs = left.slab_sums();
  slabs.insert(slabs.end(), right.slab_sums().begin(), right.slab_sums().end());
  EXPECT_EQ(slabs, whole.slab_sums());
  const Energies<2> a = whole.energies(), b = right.energies_of(whole.tile_sums(), slabs);
  ASSERT_LT(a.friction_work, 0.0);
  EXPECT_EQ(a.friction_work, b.friction_work);
  EXPECT_EQ(a.pair_impulse, b.pair_impulse);
  EXPECT_EQ(a.external_work, b.external_work);
  EXPECT_EQ(a.kinetic, b.kinetic);
  EXPECT_EQ(a.fracture_by_field, b.fracture_by_field);
  // A state without the slab sums (a checkpoint before version 8) puts its
  // totals into the first slab: the same totals.
  SolverState old = whole.state();
  ASSERT_EQ(old.arrays.erase("grid/slab_sums"), 1u);
  Grid<2> g3 = g0;
  Particles S = P;
  Solver again(g3, S, mat, step_with(2e-3, fracture, friction));
  again.restore(old);
  const Energies<2> c = again.energies();
  EXPECT_EQ(c.friction_work, a.friction_work);
  EXPECT_EQ(c.pair_impulse, a.pair_impulse);
  EXPECT_EQ(c.wall_impulse, a.wall_impulse);
}

TEST(SolverState, StateWithOtherFieldsIsRefused)
{
  const auto mat = elastic(100.0, 0.3, 1.0);
  const std::vector<std::optional<Fracture>> fracture{Fracture{0.5, 0.5, 0.0}};
  Grid<2> grid(2, {32, 24}, 0.25, {0.0, 0.0});
  Particles P = make_disks({{2.0, 2.0, 1.0, 0.0, 0.0}, {5.0, 2.0, 1.0, 0.0, 0.0}}, 0.25);
  Particles Q = P;
  Solver one(grid, P, mat, step_with(1e-3, fracture));
  Solver two(grid, Q, mat, step_with(1e-3, fracture, {0.0, 0.3, 0.3, 0.0}));
  EXPECT_THROW(one.restore(two.state()), std::invalid_argument);
  EXPECT_THROW(two.restore(one.state()), std::invalid_argument);
  // Both disks crack: two phase fields, not one.
  SolverState short_one = two.state();
  ASSERT_EQ(short_one.arrays.erase("phase_field/1/c"), 1u);
  EXPECT_THROW(two.restore(short_one), std::invalid_argument);
}

TEST(SolverState, StepOutrunningTheGridIsUnstable)
{
  // c = sqrt((lambda + 2 mu) / rho) = 13.4 for E = 100, nu = 0.3: with
  // dt = 0.01, dt c = 0.134 h-lengths of 0.25 / 0.5 = 0.27 of kappa h = 0.5;
  // a speed of 40 adds 0.8.
  Grid<2> grid(2, {24, 24}, 0.25, {0.0, 0.0});
  Particles P = make_block(10);
  Solver solver(grid, P, elastic(100.0, 0.3, 1.0), StepConfig(0.01));
  solver.set_stability_length(0.5);
  solver.advance(2);
  for (std::size_t p = 0; p < P.size(); ++p)
    P.v[2 * p] += 40.0;
  try
  {
    solver.advance(1);
    FAIL() << "no error";
  }
  catch (const SimulationError& e)
  {
    EXPECT_NE(std::string(e.what()).find("became unstable"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("after step 2"), std::string::npos) << e.what();
  }
}

TEST(SolverState, ParticlesOutOfIdOrderAreRefused)
{
  const auto mat = elastic(100.0, 0.3, 1.0);
  const std::vector<std::optional<Fracture>> fracture{Fracture{0.5, 0.5, 0.0}};
  Grid<2> grid(2, {24, 24}, 0.25, {0.0, 0.0});
  Particles P = make_block(10);
  std::swap(P.id[20], P.id[21]);
  try
  {
    Solver solver(grid, P, mat, step_with(1e-3, fracture));
    FAIL() << "particles out of id order were taken";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_STREQ(e.what(), "particle 21: id 20 after id 21 (the particles must be in ascending id order)");
  }
  // Restored particles are checked with the state.
  std::swap(P.id[20], P.id[21]);
  Solver solver(grid, P, mat, step_with(1e-3, fracture));
  solver.advance(2);
  const SolverState state = solver.state();
  P.id[99] = P.id[98];
  EXPECT_THROW(solver.restore(state), std::invalid_argument);
}

TEST(SolverState, StepsDependOnTheOrderOfTheIdsNotOnTheirValues)
{
  // Contact and a phase field: the same particles with ids 0 to n - 1 and
  // with sparse ids (as the seeding gives where a shape leaves lattice
  // positions out) take bitwise the same steps.
  const auto mat = elastic(100.0, 0.3, 1.0, 2);
  const std::vector<std::optional<Fracture>> fracture{std::nullopt, Fracture{0.5, 0.5, 0.0}};
  const std::vector<double> friction{0.0, 0.3, 0.3, 0.0};
  Grid<2> grid(2, {32, 24}, 0.25, {0.0, 0.0}), grid2(2, {32, 24}, 0.25, {0.0, 0.0});
  Particles P = crackable_disks(false), Q = crackable_disks(false);
  for (std::size_t p = 0; p < Q.size(); ++p)
    Q.id[p] = (std::int64_t{1} << 33) + 7 * static_cast<std::int64_t>(p) + (p * p) % 5;
  Solver a(grid, P, mat, step_with(2e-3, fracture, friction));
  Solver b(grid2, Q, mat, step_with(2e-3, fracture, friction));
  a.advance(60);
  b.advance(60);
  ASSERT_GT(a.contact_stats()->active, 0);
  expect_same_particles(P, Q);
  EXPECT_EQ(a.energies().friction_work, b.energies().friction_work);
}
