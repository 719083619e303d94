/// @file test_drucker_prager.cpp
/// @brief The Drucker-Prager model through the registry alone: the stress
/// stays on its cone, returns to the apex past it, flows by its potential,
/// and its plastic work closes the work balance of a strain path to round-off.
#include "pfmpm/materials/material.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

using namespace pfmpm;

namespace
{
const double pi = std::acos(-1.0);
const double E = 100.0, nu = 0.25, c = 0.5;
const double mu = E / (2.0 * (1.0 + nu)), lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
const double K = lam + 2.0 * mu / 3.0;

/// alpha, k or beta of the plane-strain fit to Mohr-Coulomb: 3 x / sqrt(9 + 12 tan^2 phi).
double fit(double x, double degrees)
{
  const double t = std::tan(degrees * pi / 180.0);
  return 3.0 * x / std::sqrt(9.0 + 12.0 * t * t);
}

/// One material point of unit volume (fixed: a small-strain model), with
/// the work (sigma_n + sigma_{n+1}) : deps / 2 done on it summed.
struct Point
{
  std::shared_ptr<Material> model;
  Particles P{1};
  std::unique_ptr<Material::Bound> bound;
  double work = 0.0;

  Point(double phi, double psi)
      : model(MaterialRegistry::make("drucker_prager",
                                     Parameters({{"E", E}, {"nu", nu}, {"density", 1.0},
                                                 {"cohesion", c}, {"friction_angle", phi},
                                                 {"dilation_angle", psi}},
                                                {})))
  {
    for (const ColumnSpec& s : model->columns(2))
      P.add(s);
    P.volume[0] = 1.0;
    bound = model->bind(P);
  }
  void step(const double* L, double dt)
  {
    const double before[4] = {P.stress[0], P.stress[1], P.stress[2], P.stress[3]};
    bound->update(Batch{nullptr, 0, 1}, L, dt, nullptr, true);
    const double deps[3] = {dt * L[0], dt * L[3], dt * (L[1] + L[2])}; // engineering shear
    for (int i = 0; i < 3; ++i)
      work += 0.5 * (before[i] + P.stress[i]) * deps[i];
  }
  const double* sigma() const { return P.stress.data(); }
  double mean() const { return (P.stress[0] + P.stress[1] + P.stress[3]) / 3.0; }
  /// sqrt(J2) of the stress.
  double q() const
  {
    const double m = mean(), sx = P.stress[0] - m, sy = P.stress[1] - m, sz = P.stress[3] - m;
    return std::sqrt(0.5 * (sx * sx + sy * sy + sz * sz) + P.stress[2] * P.stress[2]);
  }
  double energy() const
  {
    double sum = 0.0;
    bound->add_energy(Batch{nullptr, 0, 1}, nullptr, sum);
    return sum;
  }
  double column(const char* name, int k = 0) const { return P.f64(name)[k]; }
};
} // namespace

TEST(DruckerPrager, WithoutFrictionSimpleShearSaturatesAtTheCohesion)
{
  Point p(0.0, 0.0);
  const double L[4] = {0.0, 1.0, 0.0, 0.0}, dt = 1e-3; // gamma = 1e-3 a step
  for (int n = 0; n < 40; ++n)
  {
    p.step(L, dt);
    const double gamma = (n + 1) * dt;
    if (mu * gamma <= c)
      EXPECT_NEAR(p.sigma()[2], mu * gamma, 1e-13); // elastic: sigma_xy = mu gamma
    else
      EXPECT_NEAR(p.sigma()[2], c, 1e-13); // von Mises in shear: k = c
    EXPECT_NEAR(p.sigma()[0], 0.0, 1e-13);
    EXPECT_NEAR(p.sigma()[3], 0.0, 1e-13);
  }
  ASSERT_GT(p.column("plastic_work"), 0.0);
  // The work done is the stored energy plus the plastic work, to round-off.
  EXPECT_NEAR(p.work, p.energy() + p.column("plastic_work"), 1e-14 * p.work);
}

TEST(DruckerPrager, CompressedThenShearedTheStressStaysOnTheConeAndFlowsByItsPotential)
{
  const double phi = 30.0;
  for (const double psi : {0.0, 10.0, 30.0})
  {
    Point p(phi, psi);
    const double alpha = fit(std::tan(phi * pi / 180.0), phi), k = fit(c, phi);
    const double beta = fit(std::tan(psi * pi / 180.0), psi);
    const double squeeze[4] = {-1.0, 0.0, 0.0, -1.0}, shear[4] = {0.0, 1.0, 0.0, 0.0}, dt = 1e-3;
    for (int n = 0; n < 5; ++n)
      p.step(squeeze, dt); // elastic: p = -2 K 5e-3 ...
    ASSERT_LT(p.q() + alpha * p.mean() - k, 0.0);
    int plastic = 0;
    for (int n = 0; n < 60; ++n)
    {
      double ep[4];
      for (int i = 0; i < 4; ++i)
        ep[i] = p.column("plastic_strain", i);
      p.step(shear, dt);
      double d[4];
      for (int i = 0; i < 4; ++i)
        d[i] = p.column("plastic_strain", i) - ep[i];
      const double vol = d[0] + d[1] + d[3];
      if (vol == 0.0 && d[2] == 0.0)
        continue;
      ++plastic;
      EXPECT_NEAR(p.q() + alpha * p.mean(), k, 1e-12 * k); // on the cone
      // deps_p = dgamma (s / (2 sqrt(J2)) + beta / 3 I): tr = beta dgamma and
      // sqrt(dev : dev / 2) = dgamma / 2, so their ratio is 2 beta.
      const double m = vol / 3.0;
      const double dev = std::sqrt(0.5 * ((d[0] - m) * (d[0] - m) + (d[1] - m) * (d[1] - m)
                                          + (d[3] - m) * (d[3] - m))
                                   + d[2] * d[2]);
      EXPECT_NEAR(vol / dev, 2.0 * beta, 1e-9);
    }
    EXPECT_GT(plastic, 30) << "psi " << psi;
    EXPECT_NEAR(p.work, p.energy() + p.column("plastic_work"), 1e-13 * p.work) << "psi " << psi;
    EXPECT_GE(p.column("plastic_work"), 0.0);
  }
}

TEST(DruckerPrager, PulledApartEquallyTheMeanStressStopsAtTheApex)
{
  const double phi = 30.0;
  Point p(phi, phi);
  const double alpha = fit(std::tan(phi * pi / 180.0), phi), k = fit(c, phi);
  const double L[4] = {1.0, 0.0, 0.0, 1.0}, dt = 1e-3;
  for (int n = 0; n < 50; ++n)
    p.step(L, dt);
  // In-plane biaxial tension in plane strain is not hydrostatic, so the
  // stress first meets the cone and slides along it to the apex.
  EXPECT_NEAR(p.mean(), k / alpha, 1e-12 * k / alpha);
  EXPECT_NEAR(p.q(), 0.0, 1e-12 * k);
  EXPECT_NEAR(p.work, p.energy() + p.column("plastic_work"), 1e-13 * p.work);
}

TEST(DruckerPrager, TheDeclarationRefusesADilationAngleAboveTheFrictionAngle)
{
  try
  {
    MaterialRegistry::make("drucker_prager",
                           Parameters({{"E", E}, {"nu", nu}, {"density", 1.0}, {"cohesion", c},
                                       {"friction_angle", 20.0}, {"dilation_angle", 25.0}},
                                      {}));
    FAIL() << "accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_EQ(std::string(e.what()).rfind("dilation_angle = 25: must be <= friction_angle", 0), 0u)
        << e.what();
  }
}
