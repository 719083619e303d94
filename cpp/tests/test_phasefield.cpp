/// @file test_phasefield.cpp
/// @brief The anisotropy tensor of the fourth-order phase field in a turned material frame
/// (Fracture::rotated, section 4.3.4 of the paper); the AT1 and AT2 coefficients
/// (Fracture::reaction, source, crack_density) and the bounded solve of AT1.
#include "pfmpm/fracture/phasefield.h"
#include "pfmpm/solver/solver.h"

#include "disks.h"
#include "helpers.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <tuple>


using namespace pfmpm;

namespace
{
constexpr double tol = 1e-13;

double energy(const Voigt& G, const double k[3])
{
  double sum = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      sum += k[i] * G[3 * i + j] * k[j];
  return sum;
}
} // namespace

TEST(Anisotropy, AxisOneLiesAcrossThePrincipalDirection)
{
  const Fracture f{1.0, 1.0, 0.0, {2.0, 0.5, 0.0, 0.5, 80.0, 0.0, 0.0, 0.0, 74.0}};
  // phi = 0: principal direction +x, so gamma's axis 1 is +y and axis 2 is -x,
  // and a crack along x (c varying in y only) sees gamma_1111 = 2.
  const Voigt G = f.rotated(0.0);
  EXPECT_NEAR(G[4], 2.0, tol * 80);
  EXPECT_NEAR(G[0], 80.0, tol * 80);
  EXPECT_NEAR(G[1], 0.5, tol * 80);
  EXPECT_NEAR(G[8], 74.0, tol * 80);
  EXPECT_NEAR(G[2], 0.0, tol * 80);
  EXPECT_NEAR(G[5], 0.0, tol * 80);
  // A quarter turn clockwise: principal direction -y, axis 1 along +x.
  const Voigt Q = f.rotated(std::acos(0.0));
  for (int i = 0; i < 9; ++i)
    EXPECT_NEAR(Q[i], f.gamma[i], tol * 80) << "entry " << i;
}

TEST(Anisotropy, HessianNormIsInvariant)
{
  // gamma = diag(1, 1, 2): kappa^T gamma kappa = |Hessian|^2 in any frame.
  const Fracture f{1.0, 1.0, 0.0, {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0}};
  for (double phi : {0.1, 0.7, -2.0, 3.0})
  {
    const Voigt G = f.rotated(phi);
    for (int i = 0; i < 9; ++i)
      EXPECT_NEAR(G[i], f.gamma[i], tol) << "phi " << phi << " entry " << i;
  }
}

TEST(Anisotropy, EnergyOfAHessianIsFrameIndependent)
{
  // The energy of a Hessian H in the global frame with the turned gamma equals
  // the energy of the same H written in the material frame with gamma itself.
  const Fracture f{1.0, 1.0, 0.0, {1.0, 0.3, 0.1, 0.3, 80.0, 0.2, 0.1, 0.2, 74.0}};
  const double hxx = 0.7, hyy = -1.3, hxy = 0.4;
  for (double phi : {0.0, 0.4, 1.9, -0.8})
  {
    const double e1x = std::sin(phi), e1y = std::cos(phi), e2x = -std::cos(phi), e2y = std::sin(phi);
    const double global[3] = {hxx, hyy, hxy};
    const double material[3] = {
        e1x * e1x * hxx + e1y * e1y * hyy + 2 * e1x * e1y * hxy,
        e2x * e2x * hxx + e2y * e2y * hyy + 2 * e2x * e2y * hxy,
        e1x * e2x * hxx + e1y * e2y * hyy + (e1x * e2y + e1y * e2x) * hxy};
    EXPECT_NEAR(energy(f.rotated(phi), global), energy(f.gamma, material), 1e-12);
  }
}

TEST(Anisotropy, FourthOrderNeedsC1Splines)
{
  const Grid<2> linear(1, {8, 8}, 1.0, {0.0, 0.0});
  const Voigt gamma{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0};
  EXPECT_THROW(PhaseField<2>(linear, {Fracture{1.0, 2.0, 0.0, gamma}}, 1e-6, 100),
               std::invalid_argument);
  EXPECT_NO_THROW(PhaseField<2>(linear, {Fracture{1.0, 2.0, 0.0}}, 1e-6, 100));
  const Grid<2> quadratic(2, {8, 8}, 1.0, {0.0, 0.0});
  EXPECT_TRUE(PhaseField<2>(quadratic, {Fracture{1.0, 2.0, 0.0, gamma}}, 1e-6, 100).fourth_order());
  EXPECT_FALSE(PhaseField<2>(quadratic, {Fracture{1.0, 2.0, 0.0}}, 1e-6, 100).fourth_order());
}

namespace
{
/// Integral over x of Fracture::crack_density along the 1D profile d(x)
/// (d = 1 - c, d' its derivative), midpoint rule on [-L, L].
template <class D, class DD>
double crack_density_integral(const Fracture& f, double L, D d, DD dd)
{
  const int n = 200000;
  const double dx = 2.0 * L / n;
  double sum = 0.0;
  for (int k = 0; k < n; ++k)
  {
    const double x = -L + (k + 0.5) * dx;
    sum += f.crack_density(1.0 - d(x), dd(x) * dd(x)) * dx;
  }
  return sum;
}
} // namespace

TEST(Models, ProfilesCarryOneUnitOfCrackDensity)
{
  // The 1D optimal profiles in K&T's l0 (l = 2 l0 in the standard form):
  // AT2 d = exp(-|x| / (2 l0)); AT1 d = (1 - |x| / (4 l0))^2 on |x| <= 4 l0.
  // Both integrate to one unit of crack (eq. 3: G_c per unit area).
  const double l0 = 0.7;
  const Fracture at2{1.0, l0, 0.0};
  const Fracture at1{1.0, l0, 0.0, {}, Model::AT1};
  const double e2 = crack_density_integral(
      at2, 60.0 * l0, [&](double x) { return std::exp(-std::abs(x) / (2 * l0)); },
      [&](double x) { return -std::copysign(1.0, x) * std::exp(-std::abs(x) / (2 * l0)) / (2 * l0); });
  const double e1 = crack_density_integral(
      at1, 4.0 * l0,
      [&](double x) { return std::pow(1.0 - std::abs(x) / (4 * l0), 2); },
      [&](double x) { return -std::copysign(1.0, x) * (1.0 - std::abs(x) / (4 * l0)) / (2 * l0); });
  EXPECT_NEAR(e2, 1.0, 1e-7); // the midpoint rule's error
  EXPECT_NEAR(e1, 1.0, 1e-7);
}

TEST(Models, AT1ThresholdAndCoefficients)
{
  // A homogeneous AT1 state solves reaction(H) c = source(): c = 1 exactly at
  // H_c = 3 G_c / (32 l0), i.e. sigma_c^2 / (2 E) with
  // sigma_c = sqrt(3 E G_c / (8 l)), l = 2 l0.
  const double Gc = 2.5, l0 = 0.4, E = 30.0;
  const Fracture at1{Gc, l0, 0.0, {}, Model::AT1};
  const double sigma_c = std::sqrt(3.0 * E * Gc / (8.0 * 2.0 * l0));
  const double Hc = sigma_c * sigma_c / (2.0 * E);
  EXPECT_NEAR(at1.reaction(Hc), at1.source(), 1e-15);
  EXPECT_EQ(at1.source(), 0.5);
  EXPECT_EQ(at1.diffusion(), 4.0 * l0 * l0);
  // AT2 keeps eq. 49 and F = 1.
  const Fracture at2{Gc, l0, 0.2};
  EXPECT_EQ(at2.reaction(3.0), 4.0 * l0 * 0.8 * 3.0 / Gc + 1.0);
  EXPECT_EQ(at2.source(), 1.0);
  // k_f scales the history term of both models.
  const Fracture at1k{Gc, l0, 0.2, {}, Model::AT1};
  EXPECT_NEAR(at1k.reaction(Hc), 0.8 * at1.reaction(Hc), 1e-15);
}

TEST(Models, AT1IsSecondOrderOnly)
{
  const Grid<2> quadratic(2, {8, 8}, 1.0, {0.0, 0.0});
  const Voigt gamma{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0};
  EXPECT_THROW(PhaseField<2>(quadratic, {Fracture{1.0, 2.0, 0.0, gamma, Model::AT1}}, 1e-6, 100),
               std::invalid_argument);
  // Nor in one phase field with a fourth-order AT2 material.
  EXPECT_THROW(PhaseField<2>(quadratic,
                          {Fracture{1.0, 2.0, 0.0, {}, Model::AT1}, Fracture{1.0, 2.0, 0.0, gamma}},
                          1e-6, 100),
               std::invalid_argument);
  EXPECT_THROW(PhaseField<2>(quadratic, {Fracture{1.0, 2.0, 0.0, {}, Model::AT1, false}}, 1e-6, 100),
               std::invalid_argument);
  EXPECT_TRUE(PhaseField<2>(quadratic, {Fracture{1.0, 2.0, 0.0, {}, Model::AT1}}, 1e-6, 100).bounded());
}

TEST(Models, WhichSolvesAreBounded)
{
  // Second order: bounded unless every material asks for no bound; fourth
  // order: never (its own profile leaves [0, 1] when gamma_n > 1).
  const Grid<2> quadratic(2, {8, 8}, 1.0, {0.0, 0.0});
  const Voigt gamma{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0};
  const Fracture at2{1.0, 2.0, 0.0}, free{1.0, 2.0, 0.0, {}, Model::AT2, false};
  EXPECT_TRUE(at2.bound);
  EXPECT_TRUE(PhaseField<2>(quadratic, {at2}, 1e-6, 100).bounded());
  EXPECT_FALSE(PhaseField<2>(quadratic, {free}, 1e-6, 100).bounded());
  EXPECT_TRUE(PhaseField<2>(quadratic, {free, at2}, 1e-6, 100).bounded());
  EXPECT_FALSE(PhaseField<2>(quadratic, {Fracture{1.0, 2.0, 0.0, gamma}}, 1e-6, 100).bounded());
}

TEST(BoundedSolve, BelowTheThresholdNothingIsDamaged)
{
  // An AT1 block with a history just below and then just above H_c: below,
  // every node is held at c = 1 without a CG iteration, the particles have
  // c = 1 to round-off and no fracture energy; above, the bound lets go.
  const double Gc = 1.0, l0 = 0.5, Hc = 3.0 * Gc / (32.0 * l0);
  auto run = [&](double H)
  {
    Grid<2> grid(2, {24, 24}, 0.25, {0.0, 0.0});
    Particles P = test::make_disks({{3.0, 3.0, 2.0, 0.0, 0.0}}, 0.125);
    test::add_model_columns(P, true);
    for (double& h : P.f64("history"))
      h = H;
    StepConfig step(1e-3);
    step.fracture = {Fracture{Gc, l0, 0.0, {}, Model::AT1}};
    step.tol = 1e-8;
    Solver solver(grid, P, test::elastic(100.0, 0.3, 1.0), step);
    solver.prepare();
    double lo = 1.0, hi = 0.0;
    for (double c : P.f64("c"))
    {
      lo = std::min(lo, c);
      hi = std::max(hi, c);
    }
    return std::make_tuple(lo, hi, solver.energies().fracture, solver.phase_field_stats());
  };
  const auto [lo, hi, fracture, stats] = run(0.999 * Hc);
  EXPECT_NEAR(lo, 1.0, 1e-14);
  EXPECT_NEAR(hi, 1.0, 1e-14);
  EXPECT_NEAR(fracture, 0.0, 1e-14);
  EXPECT_EQ(stats.at_bound, stats.unknowns);
  EXPECT_EQ(stats.last_iterations, 0);
  EXPECT_EQ(stats.last_passes, 1);
  // Above H_c the solution is homogeneous, c = H_c / H (a constant has no
  // gradient, so the free boundary does not disturb it).
  const auto [lo2, hi2, fracture2, stats2] = run(2.0 * Hc);
  EXPECT_NEAR(lo2, 0.5, 1e-6);
  EXPECT_NEAR(hi2, 0.5, 1e-6);
  EXPECT_GT(fracture2, 0.0);
  EXPECT_LT(stats2.at_bound, stats2.unknowns);
}

TEST(BoundedSolve, NodesWithinTheRoundOffOfTheMomentsAreUncoupled)
{
  // A block of intact particles and one of huge history, 1e-6 cells from
  // the end of node (J, .)'s support: that node's entries are of order
  // 1e-25 of its neighbours', below the round-off of the moments (which
  // gave such a node K_II = -5e-11 beside 3e5 in a two-body impact). It is
  // uncoupled, an identity row, and K stays positive semi-definite.
  const int J = 3;
  Grid<2> grid(2, {12, 12}, 1.0, {0.0, 0.0});
  Particles P = test::make_disks({{8.0, 6.0, 1.5, 0.0, 0.0}, {0.0, 0.0, 0.1, 0.0, 0.0}}, 0.5);
  test::add_model_columns(P, true);
  const std::size_t last = P.size() - 1;
  P.x[2 * last] = J + 1 - 1e-6; // in cell J, whose nodes are J, J + 1, J + 2 along x
  P.x[2 * last + 1] = 6.25;
  std::vector<double>& history = P.f64("history");
  std::fill(history.begin(), history.end(), 1.0);
  history[last] = 1e12;
  StepConfig step(1e-3);
  step.fracture = {Fracture{1.0, 0.5, 0.0}};
  step.tol = 1e-8;
  Solver solver(grid, P, test::elastic(100.0, 0.3, 1.0), step);
  solver.prepare();
  const PhaseFieldSystem k = solver.phase_field_system();
  const auto n = static_cast<int>(k.rhs.size());
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n);
  for (int a = 0; a < n; ++a)
    for (std::int64_t e = k.row_start[a]; e < k.row_start[a + 1]; ++e)
      K(a, k.column[e]) = k.value[e];
  const int nny = grid.nodes()[1];
  int uncoupled = 0;
  for (int a = 0; a < n; ++a)
    if (k.nodes[a] / nny == J)
    {
      ++uncoupled;
      EXPECT_EQ(K(a, a), 1.0);
      EXPECT_EQ(k.rhs[a], 1.0);
      EXPECT_EQ(k.solution[a], 1.0);
      EXPECT_EQ(K.row(a).cwiseAbs().sum(), 1.0) << "node " << k.nodes[a];
    }
  EXPECT_EQ(uncoupled, 3); // (J, 5), (J, 6), (J, 7): the particle's support along y
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(K, Eigen::EigenvaluesOnly);
  EXPECT_GT(eigen.eigenvalues().minCoeff(), -1e-12 * eigen.eigenvalues().maxCoeff());
}
