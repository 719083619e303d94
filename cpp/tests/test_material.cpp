/// @file test_material.cpp
/// @brief A constitutive model added in the test tree: one class and one registration, with no
/// change to the step, the bindings or the checkpoints. Saint Venant-Kirchhoff on the deformation
/// gradient F, in plane strain, runs through a whole step and gives its closed-form stress under
/// uniaxial strain.
#include "helpers.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/materials/material.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace pfmpm;
using namespace pfmpm::test;

namespace
{
/// Saint Venant-Kirchhoff, S = lambda tr(E) I + 2 mu E with the Green strain
/// E = (F^T F - I) / 2, sigma = F S F^T / J; plane strain (F_33 = 1). Its
/// state is F, advanced by F <- (I + dt L) F (H&H eq. 8).
class SaintVenantKirchhoff final : public MaterialModel<SaintVenantKirchhoff>
{
public:
  static constexpr bool phase_field = true;
  static constexpr const char* description = "Saint Venant-Kirchhoff, for the tests";
  static std::vector<ParameterSpec> parameters()
  {
    return {ParameterSpec::number("E", "stress", "Young's modulus").above(0.0),
            ParameterSpec::number("nu", "1", "Poisson's ratio").above(-1.0).below(0.5),
            ParameterSpec::number("density", "density", "mass density").above(0.0)};
  }
  explicit SaintVenantKirchhoff(const Parameters& p)
      : _density(p.number("density")), _mu(p.number("E") / (2.0 * (1.0 + p.number("nu")))),
        _lambda(p.number("E") * p.number("nu") / ((1.0 + p.number("nu")) * (1.0 - 2.0 * p.number("nu"))))
  {
  }
  std::string model() const override { return "test_saint_venant_kirchhoff"; }
  std::vector<ColumnSpec> columns(int) const override
  {
    return {{"F", 4, DType::f64, {1.0, 0.0, 0.0, 1.0}, "deformation gradient", "xx,xy,yx,yy", ""}};
  }
  double density() const override { return _density; }
  double wave_speed() const override { return std::sqrt((_lambda + 2.0 * _mu) / _density); }
  double rayleigh_speed() const override { return 0.0; }
  using MaterialModel<SaintVenantKirchhoff>::wave_speed;

  struct View
  {
    double* F;
    double* stress;
  };
  View view(Particles& P) const { return {P.f64("F").data(), P.stress.data()}; }
  static constexpr bool constant_wave_speed = true;
  static constexpr bool solid = false; // plane strain
  template <int Dim>
  void advance(const View& v, std::size_t p, const double* L, double dt) const
  {
    double* F = &v.F[4 * p];
    const double A[4] = {1.0 + dt * L[0], dt * L[1], dt * L[2], 1.0 + dt * L[3]};
    const double G[4] = {A[0] * F[0] + A[1] * F[2], A[0] * F[1] + A[1] * F[3],
                         A[2] * F[0] + A[3] * F[2], A[2] * F[1] + A[3] * F[3]};
    std::copy(G, G + 4, F);
  }
  template <int Dim>
  void undegraded(const View& v, std::size_t p) const { stress(&v.F[4 * p], &v.stress[4 * p]); }
  template <int Dim>
  double degraded(const View& v, std::size_t p, double g) const
  {
    stress(&v.F[4 * p], &v.stress[4 * p]);
    for (int k = 0; k < 4; ++k)
      v.stress[4 * p + k] *= g;
    return energy<2>(v, p);
  }
  template <int Dim>
  double energy(const View& v, std::size_t p) const
  {
    const double* F = &v.F[4 * p];
    double E[3];
    green(F, E);
    const double tr = E[0] + E[1], J = F[0] * F[3] - F[1] * F[2];
    return (0.5 * _lambda * tr * tr + _mu * (E[0] * E[0] + E[1] * E[1] + 2.0 * E[2] * E[2])) / J;
  }
  template <int Dim>
  void split(const View& v, std::size_t p, double& plus, double& minus) const
  {
    plus = energy<2>(v, p);
    minus = 0.0;
  }

  /// Cauchy stress (xx, yy, xy, zz) of F (xx, xy, yx, yy).
  void stress(const double* F, double* sig) const
  {
    double E[3];
    green(F, E);
    const double tr = E[0] + E[1];
    const double S[3] = {_lambda * tr + 2.0 * _mu * E[0], _lambda * tr + 2.0 * _mu * E[1],
                         2.0 * _mu * E[2]}; // xx, yy, xy
    const double J = F[0] * F[3] - F[1] * F[2];
    // (F S F^T)_ij = F_ik S_kl F_jl
    const double FS[4] = {F[0] * S[0] + F[1] * S[2], F[0] * S[2] + F[1] * S[1],
                          F[2] * S[0] + F[3] * S[2], F[2] * S[2] + F[3] * S[1]};
    sig[0] = (FS[0] * F[0] + FS[1] * F[1]) / J;
    sig[1] = (FS[2] * F[2] + FS[3] * F[3]) / J;
    sig[2] = (FS[0] * F[2] + FS[1] * F[3]) / J;
    sig[3] = _lambda * tr / J; // S_33 = lambda tr(E), F_33 = 1
  }

private:
  static void green(const double* F, double* E)
  {
    E[0] = 0.5 * (F[0] * F[0] + F[2] * F[2] - 1.0);
    E[1] = 0.5 * (F[1] * F[1] + F[3] * F[3] - 1.0);
    E[2] = 0.5 * (F[0] * F[1] + F[2] * F[3]);
  }
  double _density, _mu, _lambda;
};
} // namespace

PFMPM_REGISTER_MATERIAL(SaintVenantKirchhoff, "test_saint_venant_kirchhoff")

TEST(Material, ATestModelRunsThroughAStepWithItsClosedFormStress)
{
  // A block of 24 x 24 cells, 2 x 2 particles per cell, moving with
  // v = (a x, 0): uniaxial strain. Its stress is zero at t = 0, so the nodes
  // carry the linear field exactly (interior nodes) and one step of dt
  // stretches the interior particles to F = diag(1 + a dt, 1): lambda = 1.25.
  const double E = 100.0, nu = 0.3, a = 2.5, dt = 0.1;
  auto model = MaterialRegistry::make("test_saint_venant_kirchhoff",
                                      Parameters({{"E", E}, {"nu", nu}, {"density", 1.0}}, {}));
  EXPECT_EQ(model->columns(2).front().name, "F");
  Grid<2> grid(2, {40, 40}, 1.0, {-10.0, -10.0});
  const int n = 48;
  Particles P(static_cast<std::size_t>(n) * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
    {
      const std::size_t p = static_cast<std::size_t>(i) * n + j;
      P.x[2 * p] = -6.0 + 0.5 * (i + 0.5);
      P.x[2 * p + 1] = -6.0 + 0.5 * (j + 0.5);
      P.v[2 * p] = a * P.x[2 * p];
      P.mass[p] = P.volume[p] = 0.25;
    }
  Solver solver(grid, P, {model}, StepConfig(dt));
  solver.advance(1);

  const double l = 1.0 + a * dt;
  const double mu = E / (2 * (1 + nu)), lam = E * nu / ((1 + nu) * (1 - 2 * nu));
  const double Exx = 0.5 * (l * l - 1.0);
  const double sxx = l * (lam + 2 * mu) * Exx, syy = lam * Exx / l; // sigma = F S F^T / J
  const std::vector<double>& F = P.f64("F");
  int interior = 0;
  for (std::size_t p = 0; p < P.size(); ++p)
  {
    // Particles 3 cells inside the block: their nodes see only its inside.
    const double x0 = P.x[2 * p] / l, y0 = P.x[2 * p + 1]; // where it started
    if (std::abs(x0) > 2.9 || std::abs(y0) > 2.9)
      continue;
    ++interior;
    EXPECT_NEAR(F[4 * p], l, 1e-13);
    EXPECT_NEAR(F[4 * p + 3], 1.0, 1e-13);
    EXPECT_NEAR(P.stress[4 * p], sxx, 1e-11 * sxx);
    EXPECT_NEAR(P.stress[4 * p + 1], syy, 1e-11 * sxx);
    EXPECT_NEAR(P.stress[4 * p + 2], 0.0, 1e-11 * sxx);
    EXPECT_NEAR(P.stress[4 * p + 3], syy, 1e-11 * sxx); // sigma_zz = sigma_yy here
  }
  EXPECT_EQ(interior, 144);
  // The finite-strain stress, not the small-strain one ((lambda + 2 mu) 0.25).
  EXPECT_GT(sxx, 1.3 * (lam + 2 * mu) * (l - 1.0));
}

TEST(Material, UnknownModelAndParameterAreRefused)
{
  EXPECT_THROW(MaterialRegistry::make("no_such_model", Parameters()), std::invalid_argument);
  EXPECT_THROW(MaterialRegistry::make("linear_elastic",
                                      Parameters({{"E", 1.0}, {"nu", 0.2}, {"density", 1.0}, {"G", 1.0}}, {})),
               std::invalid_argument);
  EXPECT_THROW(MaterialRegistry::make("linear_elastic", Parameters({{"E", 1.0}, {"density", 1.0}}, {})),
               std::invalid_argument);
  const auto m = MaterialRegistry::make(
      "linear_elastic", Parameters({{"E", 1.0}, {"nu", 0.2}, {"density", 1.0}}, {{"plane", "stress"}}));
  EXPECT_EQ(m->model(), "linear_elastic");
}

/// The message of the invalid_argument that make() throws, or "".
std::string refused(const std::string& model, const Parameters& p)
{
  try
  {
    MaterialRegistry::make(model, p);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}

TEST(Material, DeclaredParametersStateTheirRuleInTheRefusal)
{
  const Parameters ok({{"E", 1.0}, {"nu", 0.2}, {"density", 1.0}}, {});
  EXPECT_EQ(refused("linear_elastic", Parameters({{"E", -1.0}, {"nu", 0.2}, {"density", 1.0}}, {})),
            "E = -1: must be > 0");
  EXPECT_EQ(refused("linear_elastic", Parameters({{"E", 1.0}, {"nu", 0.5}, {"density", 1.0}}, {})),
            "nu = 0.5: must be > -1 and < 0.5");
  EXPECT_EQ(refused("linear_elastic", Parameters({{"E", 1.0}, {"nu", 0.2}, {"density", 1.0}},
                                                 {{"plane", "shell"}})),
            "plane = shell: must be one of strain, stress");
  EXPECT_EQ(refused("linear_elastic", Parameters({{"E", 1.0}, {"density", 1.0}}, {})),
            "nu: missing (the linear_elastic model needs it)");
  EXPECT_EQ(refused("neo_hookean", Parameters({{"E", 1.0}, {"nu", 0.2}, {"density", 1.0},
                                               {"substeps", 2.5}}, {})),
            "substeps = 2.5: must be a whole number and >= 1 and <= 1000");
  EXPECT_EQ(refused("neo_hookean", Parameters({{"E", 1.0}, {"nu", 0.2}, {"density", 1.0},
                                               {"sigma_f", 1.0}, {"l_ch", 1.0}},
                                              {{"damage", "rankine"}})),
            "Gf: missing (damage = rankine needs it)");
  EXPECT_EQ(refused("neo_hookean", Parameters({{"E", 1.0}, {"nu", 0.2}, {"density", 1.0},
                                               {"integration", 1.0}}, {})),
            "integration = 1: must be one of euler, exponential");
  EXPECT_EQ(refused("linear_elastic", ok), "");
  // The declaration's defaults fill what is not given.
  const Parameters full = ok.checked("linear_elastic", MaterialRegistry::declaration("linear_elastic").parameters);
  EXPECT_EQ(full.word("plane"), "strain");
  EXPECT_EQ(full.word("split"), "spectral");
  EXPECT_EQ(full.number("E"), 1.0);
}
