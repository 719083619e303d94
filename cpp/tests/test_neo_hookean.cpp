// The finite-strain models of Homel & Herbold (2017, §2.7) at a single
// material point, driven through the Material interface as G2P drives it:
// neo-Hookean stress against closed forms (eq. 22), objectivity of the
// deformation update (eq. 8), Rankine softening (eq. 23), time to failure
// (eq. 24), the tensile degradation (eqs. 26-27) and the refused inputs.
#include "pfmpm/materials/damage.h"
#include "pfmpm/materials/neo_hookean.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

using namespace pfmpm;

namespace
{
const double pi = std::acos(-1.0);

/// One material point of a registered model, stepped as G2P steps it: the
/// volume times det(I + dt L), then Material::Bound::update.
struct Point
{
  std::shared_ptr<Material> model;
  Particles P{1};
  std::unique_ptr<Material::Bound> bound;

  Point(std::map<std::string, double> numbers, std::map<std::string, std::string> words = {})
      : model(MaterialRegistry::make("neo_hookean", Parameters(numbers, words)))
  {
    for (const ColumnSpec& c : model->columns(2))
      P.add(c);
    P.volume[0] = 2.0;
    P.mass[0] = 2.0 * model->density();
    bound = model->bind(P);
  }
  void step(const double* L, double dt)
  {
    P.volume[0] *= (1.0 + dt * L[0]) * (1.0 + dt * L[3]) - dt * dt * L[1] * L[2];
    bound->update(Batch{nullptr, 0, 1}, L, dt, nullptr, true);
  }
  /// One step of eq. 8 that takes a diagonal F to diag(lx, ly).
  void stretch_to(double lx, double ly)
  {
    const double dt = 0.01;
    const double* F = P.f64("F").data();
    const double L[4] = {(lx / F[0] - 1.0) / dt, 0.0, 0.0, (ly / F[3] - 1.0) / dt};
    step(L, dt);
  }
  const double* F() { return P.f64("F").data(); }
  const double* stress() { return P.stress.data(); }
  double column(const char* name) { return P.f64(name)[0]; }
};

const double E = 100.0, nu = 0.3, rho = 2.0;
const double mu = E / (2.0 * (1.0 + nu)), lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
} // namespace

TEST(NeoHookean, EquibiaxialStretchGivesItsClosedFormStress)
{
  // F = diag(l, l): sigma_xx = sigma_yy = (mu (l^2 - 1) + 2 lambda ln l) / l^2,
  // sigma_zz = 2 lambda ln l / l^2 (eq. 22 with F_33 = 1).
  Point a({{"E", E}, {"nu", nu}, {"density", rho}});
  for (int k = 1; k <= 40; ++k)
  {
    const double l = 1.0 + 0.025 * k; // up to l = 2
    a.stretch_to(l, l);
    const double s = (mu * (l * l - 1.0) + 2.0 * lam * std::log(l)) / (l * l);
    const double szz = 2.0 * lam * std::log(l) / (l * l);
    EXPECT_NEAR(a.stress()[0], s, 1e-13 * mu);
    EXPECT_NEAR(a.stress()[1], s, 1e-13 * mu);
    EXPECT_NEAR(a.stress()[2], 0.0, 1e-13 * mu);
    EXPECT_NEAR(a.stress()[3], szz, 1e-13 * mu);
    EXPECT_NEAR(a.column("J"), l * l, 1e-13);
  }
}

TEST(NeoHookean, UniaxialStressGivesItsClosedFormStress)
{
  // Uniaxial stress in plane strain: sigma_yy = 0 fixes the lateral stretch
  // l2 by mu (l2^2 - 1) + lambda ln(l1 l2) = 0 (solved here by Newton); then
  // sigma_xx = mu (l1^2 - l2^2) / J and sigma_zz = -mu (l2^2 - 1) / J.
  Point a({{"E", E}, {"nu", nu}, {"density", rho}});
  double l2 = 1.0;
  for (int k = 1; k <= 20; ++k)
  {
    const double l1 = 1.0 + 0.05 * k; // up to 2
    for (int it = 0; it < 50; ++it)
      l2 -= (mu * (l2 * l2 - 1.0) + lam * std::log(l1 * l2)) / (2.0 * mu * l2 + lam / l2);
    a.stretch_to(l1, l2);
    const double J = l1 * l2;
    EXPECT_NEAR(a.stress()[0], mu * (l1 * l1 - l2 * l2) / J, 1e-13 * mu);
    EXPECT_NEAR(a.stress()[1], 0.0, 1e-13 * mu);
    EXPECT_NEAR(a.stress()[3], -mu * (l2 * l2 - 1.0) / J, 1e-13 * mu);
  }
  EXPECT_LT(l2, 0.8); // a finite contraction at l1 = 2
  // The stored energy: W = mu/2 (l1^2 + l2^2 - 2) - mu ln J + lambda/2 (ln J)^2
  // per unit reference volume (volume 2 at J = 1).
  const double J = 2.0 * l2, W = 0.5 * mu * (4.0 + l2 * l2 - 2.0) - mu * std::log(J)
                                   + 0.5 * lam * std::log(J) * std::log(J);
  double sum = 0.0;
  a.bound->add_energy(Batch{nullptr, 0, 1}, nullptr, sum);
  EXPECT_NEAR(sum, 2.0 * W, 1e-12 * sum);
}

TEST(NeoHookean, RigidRotationKeepsTheStressInvariantsAndTurnsTheStress)
{
  // A pre-stretched point spun through 90 degrees in 200 steps. The
  // exponential update rotates F exactly: the invariants stay to round-off
  // and the stress turns with the body. Eq. 8 (Euler) stretches it by
  // (1 + (w dt)^2)^(1/2) per step, a drift that sub-steps shrink only as
  // 1 / substeps.
  const double F0[4] = {1.3, 0.0, 0.0, 0.8};
  auto spin = [&](std::map<std::string, std::string> words, double substeps)
  {
    auto p = std::make_unique<Point>(
        std::map<std::string, double>{{"E", E}, {"nu", nu}, {"density", rho}, {"substeps", substeps}},
        words);
    const double zero[4] = {0.0, 0.0, 0.0, 0.0};
    std::copy(F0, F0 + 4, p->P.f64("F").data());
    p->P.f64("J")[0] = F0[0] * F0[3];
    p->step(zero, 1.0); // the stress of the pre-stretch
    const int n = 200;
    const double w = 0.5 * pi / n;
    const double L[4] = {0.0, -w, w, 0.0}; // spin at rate w, dt = 1
    double s0[4];
    std::copy(p->stress(), p->stress() + 4, s0);
    for (int k = 0; k < n; ++k)
      p->step(L, 1.0);
    return std::make_pair(std::move(p), std::array<double, 4>{s0[0], s0[1], s0[2], s0[3]});
  };
  auto invariants = [](const double* s)
  { return std::array<double, 3>{s[0] + s[1], s[0] * s[1] - s[2] * s[2], s[3]}; };
  auto drift = [&](const double* s, const std::array<double, 4>& s0)
  {
    const auto a = invariants(s), b = invariants(s0.data());
    double d = 0.0;
    for (int i = 0; i < 3; ++i)
      d = std::max(d, std::abs(a[i] - b[i]) / std::abs(b[i]));
    return d;
  };

  auto [exact, s0] = spin({{"integration", "exponential"}}, 1.0);
  EXPECT_LT(drift(exact->stress(), s0), 1e-10);
  // Turned by 90 degrees: xx and yy swap, xy changes sign.
  const double* s = exact->stress();
  const double scale = std::abs(s0[0]) + std::abs(s0[1]);
  EXPECT_NEAR(s[0], s0[1], 1e-12 * scale);
  EXPECT_NEAR(s[1], s0[0], 1e-12 * scale);
  EXPECT_NEAR(s[2], -s0[2], 1e-12 * scale);
  EXPECT_NEAR(exact->F()[0], 0.0, 1e-12);
  EXPECT_NEAR(exact->F()[2], 1.3, 1e-12);
  EXPECT_NEAR(exact->column("J"), 1.3 * 0.8, 1e-12);

  auto [euler1, e1] = spin({}, 1.0);
  auto [euler4, e4] = spin({}, 4.0);
  const double d1 = drift(euler1->stress(), e1), d4 = drift(euler4->stress(), e4);
  EXPECT_GT(d1, 1e-3);
  EXPECT_NEAR(d1 / d4, 4.0, 0.1);
}

TEST(NeoHookean, WaveSpeedFollowsTheState)
{
  Point a({{"E", E}, {"nu", nu}, {"density", rho}});
  const double c0 = std::sqrt((lam + 2.0 * mu) / rho);
  a.stretch_to(1.0, 1.0);
  EXPECT_NEAR(a.bound->wave_speed(0), c0, 1e-14 * c0);
  EXPECT_NEAR(a.model->wave_speed(), c0, 1e-14 * c0);
  // Compressed: c^2 = (mu b_max + lambda + mu - lambda ln J) / rho, bounded
  // with -ln J <= 1/J - 1.
  a.stretch_to(0.9, 0.9);
  const double c = std::sqrt((mu * 0.81 + lam + mu - lam * std::log(0.81)) / rho);
  const double bound = std::sqrt((mu * 0.81 + lam + mu + lam * (1.0 / 0.81 - 1.0)) / rho);
  EXPECT_NEAR(a.bound->wave_speed(0), bound, 1e-14 * c);
  EXPECT_GT(c, c0);
  EXPECT_LT(bound / c, 1.02);
  // Stretched along x: b_max = 1.21 raises it, J = 1.1 lowers the exact speed,
  // which the bound drops (at most lambda ln J over c^2: a few per cent).
  a.stretch_to(1.1, 1.0);
  const double stretched = std::sqrt((mu * 1.21 + lam + mu - lam * std::log(1.1)) / rho);
  EXPECT_GE(a.bound->wave_speed(0), stretched);
  EXPECT_LT(a.bound->wave_speed(0) / stretched, 1.03);
}

TEST(Damage, WaveSpeedFallsWithDamageUnderTension)
{
  // Rankine material (nu = 0, E = 100, rho = 1) pulled equally both ways:
  // both in-plane trial stresses are tensile, all of the stiffness is
  // degraded, and c^2 (mu b + mu here, lambda = 0) scales by 1 - D.
  Point a({{"E", 100.0}, {"nu", 0.0}, {"density", 1.0}, {"sigma_f", 1.0}, {"Gf", 0.01}, {"l_ch", 1.0}},
          {{"damage", "rankine"}});
  a.stretch_to(1.015, 1.015); // trial 1.5 sigma_f in both directions: D = 2/3
  const double D = a.column("damage");
  EXPECT_NEAR(D, 2.0 * (1.0 - 1.0 / (50.0 * (1.015 * 1.015 - 1.0) / (1.015 * 1.015))), 1e-13);
  const double b = 1.015 * 1.015;
  const double elastic = std::sqrt(50.0 * b + 50.0);
  EXPECT_NEAR(a.bound->wave_speed(0), elastic * std::sqrt(1.0 - D), 1e-12 * elastic);
  a.stretch_to(1.0, 1.0); // unloaded: no tensile principal stress, the whole speed
  EXPECT_NEAR(a.bound->wave_speed(0), 10.0, 1e-12);
}

TEST(Damage, WaveSpeedOfADamagedParticleInShearIsTheCompressiveDirectionsWhereStiffer)
{
  // Simple shear F = [[1, g], [0, 1]] (J = 1 exactly under eq. 8): the larger
  // principal stress is tensile, the smaller compressive. Eq. 26 scales the
  // stress, and so the longitudinal stiffness, along the tensile direction by
  // 1 - D and keeps it along the compressive one: c^2 rho = the larger of
  // (1 - D)(mu b1 + lambda + mu) and mu b2 + lambda + mu.
  Point a({{"E", E}, {"nu", nu}, {"density", rho}, {"sigma_f", 1.0}, {"c_f", 2.0}, {"l_ch", 0.5}},
          {{"damage", "time_to_failure"}});
  const double dt = 0.01;
  auto shear = [&](double dg)
  {
    const double L[4] = {0.0, dg / dt, 0.0, 0.0};
    a.step(L, dt);
  };
  auto principal = [&](double& b1, double& b2)
  {
    const double g = a.F()[1];
    const double m = 1.0 + 0.5 * g * g, r = std::sqrt(0.25 * g * g * g * g + g * g);
    b1 = m + r;
    b2 = m - r;
  };
  for (int k = 0; k < 10; ++k)
    shear(0.05); // g = 0.5; the trial stress exceeds sigma_f from the first step on
  double b1, b2;
  principal(b1, b2);
  const double D = a.column("damage");
  EXPECT_NEAR(D, 0.4, 1e-12);
  EXPECT_NEAR(a.column("J"), 1.0, 1e-14);
  const double along = (1.0 - D) * (mu * b1 + lam + mu), across = mu * b2 + lam + mu;
  EXPECT_GT(across, along); // here the compressive direction is the stiffer
  EXPECT_NEAR(a.bound->wave_speed(0), std::sqrt(across / rho), 1e-12);
  EXPECT_LT(a.bound->wave_speed(0), std::sqrt((mu * b1 + lam + mu) / rho)); // the undamaged bound
  // Drawn out to g = 30 (b1 = 901, as between two sliding fragments), failed:
  // no stiffness along the stretch, the speed is the compressive direction's,
  // a fifth of what mu b1 would give.
  for (int k = 0; k < 59; ++k)
    shear(0.5);
  principal(b1, b2);
  EXPECT_EQ(a.column("damage"), 1.0);
  EXPECT_NEAR(b1, 901.0, 1.0);
  EXPECT_NEAR(a.bound->wave_speed(0), std::sqrt((mu * b2 + lam + mu) / rho), 1e-12);
  EXPECT_LT(a.bound->wave_speed(0), 0.2 * std::sqrt((mu * b1 + lam + mu) / rho));
}

namespace
{
/// Rankine softening, nu = 0 and uniaxial strain F = diag(l, 1): a 1D bar.
/// E = 100, sigma_f = 1, G_f = 0.01, l_ch = 1 give Hbar l_ch = 1/2, H_s = 1.
std::map<std::string, double> rankine_bar()
{
  return {{"E", 100.0}, {"nu", 0.0}, {"density", 1.0}, {"sigma_f", 1.0},
          {"Gf", 0.01},  {"l_ch", 1.0}};
}
} // namespace

TEST(Rankine, StressPathFollowsTheSofteningLineAndDamageNeverDecreases)
{
  Point a(rankine_bar(), {{"damage", "rankine"}});
  const double m = 50.0, sigma_f = 1.0, Hs = 1.0;
  // Load past the peak, unload, reload to failure and beyond.
  std::vector<double> path;
  for (int k = 1; k <= 150; ++k)
    path.push_back(1.0 + 1e-4 * k); // trial stress up to 1.5 sigma_f
  for (int k = 1; k <= 100; ++k)
    path.push_back(1.015 - 1.4e-4 * k); // back to l = 1.001
  for (int k = 1; k <= 300; ++k)
    path.push_back(1.001 + 1e-4 * k); // to l = 1.031, past full damage
  double r = sigma_f, D_before = 0.0;
  int softening = 0, unloading = 0;
  for (double l : path)
  {
    a.stretch_to(l, 1.0);
    const double trial = m * (l * l - 1.0) / l; // eq. 22, 1D
    r = std::max(r, trial);
    const double D = std::min(1.0, (1.0 + Hs) * (1.0 - sigma_f / r)); // eq. 23
    EXPECT_NEAR(a.column("damage"), D, 1e-13);
    EXPECT_NEAR(a.stress()[0], (1.0 - D) * trial, 1e-13 * sigma_f);
    EXPECT_NEAR(a.stress()[1], 0.0, 1e-13 * sigma_f);
    EXPECT_GE(a.column("damage"), D_before);
    if (trial >= r && D < 1.0 && D > 0.0)
    {
      // On the softening line: sigma = sigma_f (1 + H_s) - H_s sigma^E.
      EXPECT_NEAR(a.stress()[0], sigma_f * (1.0 + Hs) - Hs * trial, 1e-13 * sigma_f);
      ++softening;
    }
    if (trial < r)
      ++unloading; // secant: (1 - D) sigma^E with D held
    D_before = a.column("damage");
  }
  EXPECT_GT(softening, 100);
  EXPECT_GT(unloading, 100);
  EXPECT_EQ(a.column("damage"), 1.0);
  EXPECT_EQ(a.stress()[0], 0.0);
}

TEST(Rankine, APointDissipatesGfOverLchPerUnitVolume)
{
  // Loaded to failure in fine steps, the point dissipates sum V_0 W dD,
  // which tends to V_0 int W dD: in small strain V_0 sigma_f^2 (1 + H_s) /
  // (2 E H_s) = V_0 G_f / l_ch (here 2 x 0.01). The failure strain is 2 %,
  // so the finite-strain W differs from E eps^2 / 2 by about that much.
  Point a(rankine_bar(), {{"damage", "rankine"}});
  for (int k = 1; k <= 20000; ++k)
    a.stretch_to(1.0 + 1.6e-6 * k, 1.0);
  ASSERT_EQ(a.column("damage"), 1.0);
  const double dissipated = a.column("dissipated");
  EXPECT_NEAR(dissipated, 2.0 * 0.01, 0.02 * 2.0 * 0.01);
  // The stored energy is gone: W - D W+ = 0 at D = 1 in 1D.
  double stored = 0.0;
  a.bound->add_energy(Batch{nullptr, 0, 1}, nullptr, stored);
  EXPECT_NEAR(stored, 0.0, 1e-12);
  // And the work done on the point equals what it dissipated: the
  // trapezoidal sum of V_0 P dl along the path (P = J sigma / l, V_0 = 2).
  Point b(rankine_bar(), {{"damage", "rankine"}});
  double work = 0.0, P_before = 0.0;
  for (int k = 1; k <= 20000; ++k)
  {
    const double l = 1.0 + 1.6e-6 * k;
    b.stretch_to(l, 1.0);
    const double P = b.stress()[0]; // J sigma / l = sigma in 1D (J = l)
    work += 2.0 * 0.5 * (P + P_before) * 1.6e-6;
    P_before = P;
  }
  EXPECT_NEAR(b.column("dissipated"), work, 1e-6 * work);
}

TEST(TimeToFailure, DamageGrowsAtOneOverTauWhileTheStrengthIsExceeded)
{
  // tau = l / c_f = 0.5 / 2: D grows by dt / tau = 0.04 per step of dt = 0.01.
  Point a({{"E", 100.0}, {"nu", 0.0}, {"density", 1.0}, {"sigma_f", 1.0}, {"c_f", 2.0}, {"l_ch", 0.5}},
          {{"damage", "time_to_failure"}});
  a.stretch_to(1.005, 1.0); // trial 0.9975 < sigma_f
  EXPECT_EQ(a.column("damage"), 0.0);
  for (int k = 1; k <= 10; ++k)
  {
    a.stretch_to(1.02, 1.0); // above sigma_f
    EXPECT_NEAR(a.column("damage"), 0.04 * k, 1e-14);
  }
  const double held = a.column("damage");
  a.stretch_to(1.005, 1.0); // below: D holds
  EXPECT_EQ(a.column("damage"), held);
  const double trial = 50.0 * (1.005 * 1.005 - 1.0) / 1.005;
  EXPECT_NEAR(a.stress()[0], (1.0 - held) * trial, 1e-14);
  for (int k = 0; k < 20; ++k)
    a.stretch_to(1.02, 1.0);
  EXPECT_EQ(a.column("damage"), 1.0);
  // Compression keeps its whole stress (eq. 26).
  a.stretch_to(0.99, 1.0);
  EXPECT_NEAR(a.stress()[0], 50.0 * (0.99 * 0.99 - 1.0) / 0.99, 1e-14);
}

TEST(Damage, TensilePrincipalStressesAreDegradedAndCompressiveOnesKept)
{
  // Principal values 3 and -2 along axes turned by 0.3 rad, zz = 1 (eqs. 26-27).
  const double c = std::cos(0.3), s = std::sin(0.3), D = 0.25;
  auto tensor = [&](double a, double b)
  {
    return std::array<double, 3>{a * c * c + b * s * s, a * s * s + b * c * c, (a - b) * c * s};
  };
  const auto trial = tensor(3.0, -2.0), expected = tensor((1.0 - D) * 3.0, -2.0);
  double sig[4] = {trial[0], trial[1], trial[2], 1.0};
  degrade_tensile<2>(sig, D);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(sig[k], expected[k], 1e-14);
  EXPECT_NEAR(sig[3], 0.75, 1e-15);
  // Equal principal values: the whole tensor scales, in any basis.
  double iso[4] = {2.0, 2.0, 0.0, -1.0};
  degrade_tensile<2>(iso, D);
  EXPECT_DOUBLE_EQ(iso[0], 1.5);
  EXPECT_DOUBLE_EQ(iso[1], 1.5);
  EXPECT_DOUBLE_EQ(iso[3], -1.0);
}

TEST(NeoHookean, BadParametersAreRefusedNamingTheKey)
{
  auto refused = [](std::map<std::string, double> numbers, std::map<std::string, std::string> words)
  {
    std::map<std::string, double> base{{"E", 100.0}, {"nu", 0.3}, {"density", 1.0}};
    for (const auto& [k, v] : numbers)
      base[k] = v;
    try
    {
      MaterialRegistry::make("neo_hookean", Parameters(base, words));
    }
    catch (const std::invalid_argument& e)
    {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::map<std::string, std::string> rankine{{"damage", "rankine"}};
  const std::map<std::string, std::string> ttf{{"damage", "time_to_failure"}};
  EXPECT_EQ(refused({{"sigma_f", 0.0}, {"Gf", 1.0}, {"l_ch", 1.0}}, rankine).rfind("sigma_f = 0", 0), 0u);
  EXPECT_EQ(refused({{"sigma_f", 1.0}, {"Gf", -1.0}, {"l_ch", 1.0}}, rankine).rfind("Gf = -1", 0), 0u);
  EXPECT_EQ(refused({{"sigma_f", 1.0}, {"c_f", 0.0}, {"l_ch", 1.0}}, ttf).rfind("c_f = 0", 0), 0u);
  // l_ch >= 2 E G_f / sigma_f^2 = 2 would snap back.
  EXPECT_EQ(refused({{"sigma_f", 1.0}, {"Gf", 0.01}, {"l_ch", 2.0}}, rankine).rfind("l_ch = 2: must be < 2", 0), 0u);
  EXPECT_EQ(refused({}, {{"damage", "plastic"}}).rfind("damage = plastic", 0), 0u);
  EXPECT_EQ(refused({{"substeps", 2.0}}, {{"integration", "exponential"}}).rfind("substeps = 2", 0), 0u);
  EXPECT_EQ(refused({{"sigma_f", 1.0}}, {}).rfind("sigma_f: not a parameter", 0), 0u);
  EXPECT_EQ(refused({}, {}), "");
}
