// The anisotropy tensor of the fourth-order phase field in a turned material
// frame (Fracture::rotated, section 4.3.4 of the paper).
#include "pfmpm/fracture/phasefield.h"

#include <gtest/gtest.h>

#include <cmath>


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
  const Grid linear(1, {8, 8}, 1.0, {0.0, 0.0});
  const Voigt gamma{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0};
  EXPECT_THROW(PhaseField(linear, {Fracture{1.0, 2.0, 0.0, gamma}}, 1e-6, 100),
               std::invalid_argument);
  EXPECT_NO_THROW(PhaseField(linear, {Fracture{1.0, 2.0, 0.0}}, 1e-6, 100));
  const Grid quadratic(2, {8, 8}, 1.0, {0.0, 0.0});
  EXPECT_TRUE(PhaseField(quadratic, {Fracture{1.0, 2.0, 0.0, gamma}}, 1e-6, 100).fourth_order());
  EXPECT_FALSE(PhaseField(quadratic, {Fracture{1.0, 2.0, 0.0}}, 1e-6, 100).fourth_order());
}
