/// @file test_material3.cpp
/// @brief The materials on 3 x 3 tensors, through the Material interface as
/// G2P drives them: neo-Hookean stress (H&H eq. 22) under uniaxial stretch,
/// simple shear and volumetric compression against the closed forms, reached
/// by the deformation update (H&H eq. 8) with a constant velocity gradient;
/// objectivity of the exponential update under a rotation; linear elasticity
/// in 3D; the 2D-only models refuse 3D particles.
#include "pfmpm/common/symmetric.h"
#include "pfmpm/materials/deformation.h"
#include "pfmpm/materials/linear_elastic.h"
#include "pfmpm/materials/material.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
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
  const auto damaged = MaterialRegistry::make(
      "neo_hookean", Parameters({{"E", E}, {"nu", nu}, {"density", rho}, {"sigma_f", 1.0}, {"Gf", 1.0}, {"l_ch", 0.1}},
                                {{"damage", "rankine"}}));
  EXPECT_THROW(damaged->columns(3), std::invalid_argument);
  EXPECT_THROW(Particles(3, 4), std::invalid_argument);
}
