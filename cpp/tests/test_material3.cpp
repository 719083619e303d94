/// @file test_material3.cpp
/// @brief The materials on 3 x 3 tensors, through the Material interface as
/// G2P drives them: neo-Hookean stress (H&H eq. 22) under uniaxial stretch,
/// simple shear and volumetric compression against the closed forms, reached
/// by the deformation update (H&H eq. 8) with a constant velocity gradient;
/// objectivity of the exponential update under a rotation; the tensile
/// degradation and Rankine damage in 3D (H&H eqs. 23, 26-27), and a
/// plane-strain state giving the 2D model's numbers; linear elasticity in 3D;
/// the 2D-only models refuse 3D particles.
#include "pfmpm/common/symmetric.h"
#include "pfmpm/materials/damage.h"
#include "pfmpm/materials/deformation.h"
#include "pfmpm/materials/linear_elastic.h"
#include "pfmpm/materials/material.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <string>

using namespace pfmpm;

namespace
{
const double E = 100.0, nu = 0.3, rho = 2.0;
const double mu = E / (2.0 * (1.0 + nu)), lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));

/// One 3D material point of a registered model, stepped as G2P steps it:
/// the volume times det(I + dt L), then Material::Bound::update.
struct Point3
{
  std::shared_ptr<Material> model;
  Particles P{1, 3};
  std::unique_ptr<Material::Bound> bound;

  Point3(const std::string& name, std::map<std::string, double> numbers,
         std::map<std::string, std::string> words = {})
      : model(MaterialRegistry::make(name, Parameters(numbers, words)))
  {
    for (const ColumnSpec& c : model->columns(3))
      P.add(c);
    P.volume[0] = 2.0;
    P.mass[0] = 2.0 * model->density();
    bound = model->bind(P);
  }
  /// n steps of dt with the constant velocity gradient L (row-major 3 x 3).
  void steps(const double (&L)[9], double dt, int n)
  {
    for (int k = 0; k < n; ++k)
    {
      P.volume[0] *= volume_ratio<3>(L, dt);
      bound->update(Batch{nullptr, 0, 1}, L, dt, nullptr, true);
    }
  }
  /// The stress entry (i, j).
  double sigma(int i, int j) const { return P.stress[symmetric_entry(i, j)]; }
  double energy() const
  {
    double sum = 0.0;
    bound->add_energy(Batch{nullptr, 0, 1}, nullptr, sum);
    return sum;
  }
};

/// H&H eq. 22 for F, the expected stress of each entry.
void expect_neo_hookean_stress(const Point3& point, const double (&F)[3][3], double tol)
{
  double B[3][3] = {}, J = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        B[i][j] += F[i][k] * F[j][k];
  J = F[0][0] * (F[1][1] * F[2][2] - F[1][2] * F[2][1]) - F[0][1] * (F[1][0] * F[2][2] - F[1][2] * F[2][0])
      + F[0][2] * (F[1][0] * F[2][1] - F[1][1] * F[2][0]);
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
    {
      const double expected = mu / J * (B[i][j] - (i == j ? 1.0 : 0.0)) + (i == j ? lam * std::log(J) / J : 0.0);
      EXPECT_NEAR(point.sigma(i, j), expected, tol * (std::abs(expected) + mu)) << i << j;
    }
  EXPECT_NEAR(point.P.f64("J")[0], J, 1e-13 * J);
}
} // namespace

TEST(NeoHookean3, UniaxialStretchGivesItsClosedFormStress)
{
  // L = diag(r, 0, 0) over t: F = diag(e^{rt}, 1, 1) with the exponential,
  // exactly up to round-off.
  Point3 point("neo_hookean", {{"E", E}, {"nu", nu}, {"density", rho}}, {{"integration", "exponential"}});
  const double r = 0.2, dt = 0.01;
  const double L[9] = {r, 0, 0, 0, 0, 0, 0, 0, 0};
  point.steps(L, dt, 50);
  const double s = std::exp(r * dt * 50);
  const double F[3][3] = {{s, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  expect_neo_hookean_stress(point, F, 1e-10);
  // The energy V W / J = V0 W.
  const double lnJ = std::log(s);
  const double W = 0.5 * mu * (s * s + 2.0 - 3.0) - mu * lnJ + 0.5 * lam * lnJ * lnJ;
  EXPECT_NEAR(point.energy(), 2.0 * W, 1e-10 * 2.0 * W);
}

TEST(NeoHookean3, SimpleShearGivesItsClosedFormStress)
{
  // L = g e_x (x) e_y is nilpotent: (I + dt L)^n = I + n dt L, so H&H eq. 8
  // gives F = I + gamma e_x (x) e_y exactly; J = 1, sigma = mu (B - I).
  Point3 point("neo_hookean", {{"E", E}, {"nu", nu}, {"density", rho}});
  const double g = 0.5, dt = 0.01;
  const double L[9] = {0, g, 0, 0, 0, 0, 0, 0, 0};
  point.steps(L, dt, 60);
  const double gamma = g * dt * 60;
  const double F[3][3] = {{1, gamma, 0}, {0, 1, 0}, {0, 0, 1}};
  expect_neo_hookean_stress(point, F, 1e-10);
  EXPECT_NEAR(point.sigma(0, 0), mu * gamma * gamma, 1e-10 * mu);
  EXPECT_NEAR(point.sigma(0, 1), mu * gamma, 1e-10 * mu);
  EXPECT_NEAR(point.sigma(1, 1), 0.0, 1e-10 * mu);
  EXPECT_NEAR(point.sigma(2, 2), 0.0, 1e-10 * mu);
}

TEST(NeoHookean3, VolumetricCompressionGivesItsClosedFormStress)
{
  // L = -r I: F = e^{-rt} I, a pressure (mu (s^2 - 1) + lambda ln J) / J with J = s^3.
  Point3 point("neo_hookean", {{"E", E}, {"nu", nu}, {"density", rho}}, {{"integration", "exponential"}});
  const double r = 0.3, dt = 0.01;
  const double L[9] = {-r, 0, 0, 0, -r, 0, 0, 0, -r};
  point.steps(L, dt, 40);
  const double s = std::exp(-r * dt * 40), J = s * s * s;
  const double F[3][3] = {{s, 0, 0}, {0, s, 0}, {0, 0, s}};
  expect_neo_hookean_stress(point, F, 1e-10);
  EXPECT_NEAR(point.sigma(1, 1), (mu * (s * s - 1.0) + lam * std::log(J)) / J, 1e-10 * mu);
  // The volume follows J: V = J V0.
  EXPECT_NEAR(point.P.volume[0], 2.0 * J, 1e-12);
}

TEST(NeoHookean3, ARotationLeavesTheStretchAndItsStress)
{
  // Stretch, then spin about an oblique axis with the exponential update:
  // B rotates, sigma = R sigma_0 R^T, so its invariants stay.
  Point3 point("neo_hookean", {{"E", E}, {"nu", nu}, {"density", rho}}, {{"integration", "exponential"}});
  const double L0[9] = {0.1, 0, 0, 0, -0.05, 0, 0, 0, 0.02};
  point.steps(L0, 0.1, 10);
  auto invariants = [&]()
  {
    double s[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        s[i][j] = point.sigma(i, j);
    const double I1 = s[0][0] + s[1][1] + s[2][2];
    double ss = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        ss += s[i][j] * s[j][i];
    const double I3 = s[0][0] * (s[1][1] * s[2][2] - s[1][2] * s[2][1])
                      - s[0][1] * (s[1][0] * s[2][2] - s[1][2] * s[2][0])
                      + s[0][2] * (s[1][0] * s[2][1] - s[1][1] * s[2][0]);
    return std::array<double, 3>{I1, ss, I3};
  };
  const auto before = invariants();
  const double w[3] = {0.3, -0.4, 0.5};
  const double W[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0};
  point.steps(W, 0.05, 40);
  const auto after = invariants();
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(after[k], before[k], 1e-11 * std::abs(before[k])) << k;
  EXPECT_GT(std::abs(point.sigma(0, 1)), 1e-3); // it did rotate
}

TEST(LinearElastic3, UniaxialStrainGivesLambdaAndMu)
{
  Point3 point("linear_elastic", {{"E", E}, {"nu", nu}, {"density", rho}},
               {{"plane", "strain"}, {"split", "none"}});
  // Small strain from one step of a symmetric L plus a spin, which it ignores.
  const double e = 1e-3, dt = 1.0;
  const double L[9] = {e, 0.2e-3, 0, -0.2e-3, 0, 0.5e-3, 0, 0.5e-3, 0};
  point.steps(L, dt, 1);
  EXPECT_NEAR(point.sigma(0, 0), (lam + 2.0 * mu) * e, 1e-15 * E);
  EXPECT_NEAR(point.sigma(1, 1), lam * e, 1e-15 * E);
  EXPECT_NEAR(point.sigma(2, 2), lam * e, 1e-15 * E);
  EXPECT_NEAR(point.sigma(0, 1), 0.0, 1e-15 * E);
  EXPECT_NEAR(point.sigma(1, 2), 2.0 * mu * 0.5e-3, 1e-15 * E);
  EXPECT_NEAR(point.sigma(0, 2), 0.0, 1e-15 * E);
  // V psi with psi = sigma : eps / 2.
  const double psi = 0.5 * ((lam + 2.0 * mu) * e * e + 2.0 * (2.0 * mu * 0.5e-3) * 0.5e-3);
  EXPECT_NEAR(point.energy(), point.P.volume[0] * psi, 1e-12 * psi);
  EXPECT_NEAR(point.model->wave_speed(), std::sqrt((lam + 2.0 * mu) / rho), 1e-12);
}

TEST(Material3, TwoDimensionalModelsRefuseThreeDimensionalParticles)
{
  const auto dp = MaterialRegistry::make(
      "drucker_prager",
      Parameters({{"E", E}, {"nu", nu}, {"density", rho}, {"friction_angle", 30.0}, {"cohesion", 1.0}}, {}));
  Particles P(4, 3);
  EXPECT_FALSE(dp->solid());
  EXPECT_THROW(dp->columns(3), std::invalid_argument);
  EXPECT_THROW(dp->bind(P), std::invalid_argument);
  const auto stress = MaterialRegistry::make(
      "linear_elastic", Parameters({{"E", E}, {"nu", nu}, {"density", rho}}, {{"plane", "stress"}}));
  EXPECT_THROW(stress->columns(3), std::invalid_argument);
  EXPECT_THROW(Particles(3, 4), std::invalid_argument);
}

TEST(Damage3, TensileDegradationOfAPlaneStressIsThePlaneFormula)
{
  // A stress with no yz and xz is degraded in 3D as by the 2D formula (its
  // zz a principal value); a general one keeps its principal directions,
  // each tensile value scaled by 1 - D.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 200; ++k)
  {
    const double D = 0.5 * (1.0 + u(rng));
    double plane[4] = {u(rng), u(rng), u(rng), u(rng)};
    double solid[6] = {plane[0], plane[1], plane[2], plane[3], 0.0, 0.0};
    degrade_tensile<2>(plane, D);
    degrade_tensile<3>(solid, D);
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(solid[c], plane[c], 1e-14) << k << " " << c;
    EXPECT_EQ(solid[4], 0.0);
    EXPECT_EQ(solid[5], 0.0);

    double sig[6];
    for (double& s : sig)
      s = u(rng);
    Eigen::Matrix3d S, Sd;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        S(i, j) = sig[symmetric_entry(i, j)];
    degrade_tensile<3>(sig, D);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        Sd(i, j) = sig[symmetric_entry(i, j)];
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> before(S);
    for (int i = 0; i < 3; ++i)
    {
      const Eigen::Vector3d v = before.eigenvectors().col(i);
      const double l = before.eigenvalues()(i);
      const Eigen::Vector3d expected = (l > 0.0 ? 1.0 - D : 1.0) * l * v;
      EXPECT_LT((Sd * v - expected).norm(), 1e-13) << k << " " << i;
    }
  }
}

TEST(NeoHookean3, RankineDamageOfAUniaxialStretch)
{
  // F = diag(s, 1, 1) past the strength: D of H&H eq. 23 from the largest
  // trial principal stress, and every tensile principal stress scaled by 1 - D.
  const double sigma_f = 2.0, Gf = 0.05, l_ch = 0.1;
  Point3 point("neo_hookean", {{"E", E}, {"nu", nu}, {"density", rho}, {"sigma_f", sigma_f}, {"Gf", Gf}, {"l_ch", l_ch}},
               {{"integration", "exponential"}, {"damage", "rankine"}});
  const double r = 0.5, dt = 0.01;
  const double L[9] = {r, 0, 0, 0, 0, 0, 0, 0, 0};
  point.steps(L, dt, 10);
  const double s = std::exp(r * dt * 10), J = s, lnJ = std::log(J);
  const double trial_xx = (mu * (s * s - 1.0) + lam * lnJ) / J, trial_yy = lam * lnJ / J;
  ASSERT_GT(trial_xx, sigma_f);
  const double a = l_ch / (2.0 * E * Gf);
  const double D = (1.0 - sigma_f / trial_xx) / (1.0 - a * sigma_f * sigma_f);
  EXPECT_NEAR(point.P.f64("damage")[0], D, 1e-12);
  EXPECT_NEAR(point.sigma(0, 0), (1.0 - D) * trial_xx, 1e-10 * mu);
  EXPECT_NEAR(point.sigma(1, 1), (1.0 - D) * trial_yy, 1e-10 * mu);
  EXPECT_NEAR(point.sigma(2, 2), (1.0 - D) * trial_yy, 1e-10 * mu);
  EXPECT_GT(point.P.f64("dissipated")[0], 0.0);
}

TEST(NeoHookean3, APlaneStrainStateIsThe2DModelsToRoundOff)
{
  // A 3D point with F = [[F_2D, 0], [0, 1]], driven by L = [[L_2D, 0], [0, 0]],
  // against the 2D (plane-strain) point: the same stress, damage, dissipated
  // work and wave speed, through softening (Rankine) and time to failure.
  for (const std::string damage : {"rankine", "time_to_failure"})
  {
    std::map<std::string, double> numbers{{"E", E}, {"nu", nu}, {"density", rho}, {"sigma_f", 1.5}, {"l_ch", 0.1}};
    numbers[damage == "rankine" ? "Gf" : "c_f"] = damage == "rankine" ? 0.05 : 2.0;
    const std::map<std::string, std::string> words{{"damage", damage}};
    Point3 solid("neo_hookean", numbers, words);
    const auto model = MaterialRegistry::make("neo_hookean", Parameters(numbers, words));
    Particles P(1, 2);
    for (const ColumnSpec& c : model->columns(2))
      P.add(c);
    P.volume[0] = 2.0;
    const auto plane = model->bind(P);
    const double dt = 0.01;
    int partial = 0; // steps with 0 < D < 1: softening, not yet failed
    for (int k = 0; k < 60; ++k)
    {
      const double t = k * dt;
      const double L2[4] = {0.4 + 0.1 * std::sin(7 * t), 0.3 * std::cos(3 * t), -0.2, -0.1 + 0.05 * t};
      const double L3[9] = {L2[0], L2[1], 0, L2[2], L2[3], 0, 0, 0, 0};
      P.volume[0] *= volume_ratio<2>(L2, dt);
      plane->update(Batch{nullptr, 0, 1}, L2, dt, nullptr, true);
      solid.steps(L3, dt, 1);
      const double D = P.f64("damage")[0];
      partial += D > 0.0 && D < 1.0;
      ASSERT_NEAR(solid.P.f64("damage")[0], D, 1e-12) << damage << " step " << k;
      ASSERT_NEAR(solid.P.f64("dissipated")[0], P.f64("dissipated")[0], 1e-12 * (1.0 + P.f64("dissipated")[0]))
          << damage << " step " << k;
      for (int c = 0; c < 4; ++c)
        ASSERT_NEAR(solid.P.stress[c], P.stress[c], 1e-11 * mu) << damage << " step " << k << " " << c;
      ASSERT_NEAR(solid.P.stress[4], 0.0, 1e-14 * mu);
      ASSERT_NEAR(solid.P.stress[5], 0.0, 1e-14 * mu);
      // The 3D speed weighs the out-of-plane direction too (b_zz = 1), where
      // 2D takes the in-plane ones alone.
      ASSERT_GE(solid.bound->wave_speed(0), plane->wave_speed(0) * (1.0 - 1e-12)) << damage << " step " << k;
      double e = 0.0;
      plane->add_energy(Batch{nullptr, 0, 1}, nullptr, e);
      ASSERT_NEAR(solid.energy(), e, 1e-12 * mu * P.volume[0]) << damage << " step " << k;
    }
    EXPECT_GE(partial, 5) << damage;
  }
}
