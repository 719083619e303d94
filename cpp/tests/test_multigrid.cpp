/// @file test_multigrid.cpp
/// @brief The multigrid preconditioner of the phase-field CG: the B-spline two-scale relation,
/// Galerkin coarse operators equal to the matrices assembled on the coarse grids, few iterations
/// to the tight solution, and the same bits on any number of threads.
#include "helpers.h"
#include "pfmpm/fracture/multigrid.h"
#include "pfmpm/fracture/phasefield.h"
#include "pfmpm/grid/bspline.h"
#include "pfmpm/grid/grid.h"
#include "pfmpm/solver/solver.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <optional>
#include <vector>

using namespace pfmpm;

namespace
{
constexpr double pi = 3.14159265358979323846;

/// A crackable plate [0, 8] x [0, 4] of n x n particles per cell of size d,
/// with an initial crack from its left edge to its centre along y = 2 as a
/// history band of width l0 / 2 (as pfmpm.crack does), the material turned
/// 30 degrees.
Particles make_plate(double d, int n, double l0)
{
  const double s = d / n, Lx = 8.0, Ly = 4.0;
  const int nx = static_cast<int>(std::lround(Lx / s)), ny = static_cast<int>(std::lround(Ly / s));
  Particles P(static_cast<std::size_t>(nx) * ny);
  test::add_model_columns(P, true);
  std::vector<double>&phi = P.f64("phi"), &history = P.f64("history");
  const double H0 = 1000.0 / (4.0 * l0), w = 0.5 * l0; // B G_c / (4 l0), G_c = 1
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
    {
      const std::size_t p = static_cast<std::size_t>(i) * ny + j;
      const double x = (i + 0.5) * s, y = (j + 0.5) * s;
      // A slight waviness keeps the particles off a lattice aligned with the grid.
      P.x[2 * p] = x + 0.05 * s * std::sin(1.7 * y);
      P.x[2 * p + 1] = y + 0.05 * s * std::cos(1.3 * x);
      P.volume[p] = s * s;
      P.mass[p] = s * s;
      phi[p] = pi / 6.0;
      const double dist = x <= 4.0 ? std::abs(y - 2.0) : std::hypot(x - 4.0, y - 2.0);
      history[p] = dist < w ? H0 * (1.0 - dist / w) : 0.0;
    }
  return P;
}

/// The Borden plate's orthotropic gamma (g1111 = 1, g2222 = 80, g1212 = 74),
/// or zero; without the bound, so that the second-order model is solved by
/// the preconditioned CG (the bounded solve refuses the multigrid).
Fracture fracture(double l0, bool fourth)
{
  Fracture f{1.0, l0, 0.0, {}, Model::AT2, false};
  if (fourth)
    f.gamma = {1.0, 0.0, 0.0, 0.0, 80.0, 0.0, 0.0, 0.0, 74.0};
  return f;
}

/// A solver for the plate on a grid of `cells` of size h from `origin`, by
/// default two empty cells around the plate; prepare() solves the phase field
/// of the initial crack cold.
struct PlateRun
{
  Grid<2> grid;
  Particles particles;
  Solver<2> solver;
  PlateRun(int degree, double h, Particles P, const Fracture& f, Preconditioner preconditioner,
           double tol)
      : PlateRun(degree, h,
                 {static_cast<int>(std::lround(8.0 / h)) + 4,
                  static_cast<int>(std::lround(4.0 / h)) + 4},
                 {-2.0 * h, -2.0 * h}, std::move(P), f, preconditioner, tol)
  {
  }
  PlateRun(int degree, double h, std::array<int, 2> cells, std::array<double, 2> origin,
           Particles P, const Fracture& f, Preconditioner preconditioner, double tol)
      : grid(degree, cells, h, origin),
        particles(std::move(P)),
        solver(grid, particles, test::elastic(100.0, 0.2, 1.0), step(f, tol))
  {
    solver.set_phase_field_preconditioner(preconditioner);
    solver.prepare();
  }
  PhaseFieldStats stats() const { return solver.phase_field_stats(); }
  static StepConfig step(const Fracture& f, double tol)
  {
    StepConfig step(1e-3);
    step.fracture = {f};
    step.tol = tol;
    step.max_iterations = 100000;
    return step;
  }
};

/// splitmix64: a fixed stream of pseudo-random numbers, the same on every
/// platform (unlike std::uniform_real_distribution).
struct Random
{
  std::uint64_t state;
  explicit Random(std::uint64_t seed) : state(seed) {}
  /// Uniform in [0, 1).
  double operator()()
  {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return double((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  }
};

/// FNV-1a over the bits of the doubles.
std::uint64_t bit_hash(const std::vector<double>& v, std::uint64_t h = 0xcbf29ce484222325ULL)
{
  const auto* bytes = reinterpret_cast<const unsigned char*>(v.data());
  for (std::size_t k = 0; k < v.size() * sizeof(double); ++k)
    h = (h ^ bytes[k]) * 0x100000001b3ULL;
  return h;
}

/// @brief A phase-field-like system on a Dim-dimensional grid of unit
/// cells, in the stencil storage that PhaseField hands the multigrid: K&T
/// eq. 57 (second order) with G_c = 1, K = sum_q V_q [(1 / l0 + 2 H_q) N N^T
/// + l0 grad N grad N^T] over 2^Dim particles per cell at random places with
/// random volumes, the history H large in a band across y = cells_y / 2 over
/// the first half in x (the crack). Cells of the corner x > 3/4, y < 1/4 have
/// no particle (their nodes are not unknowns unless another cell touches
/// them); the cells of the first two columns hold uncrackable particles only
/// (their nodes that no crackable particle touches get an identity row).
template <int Dim, int P>
struct TestSystem
{
  using S = SymmetricStencil<Dim, P>;
  static constexpr int H = S::size, K = [] { int k = 1; for (int a = 0; a < Dim; ++a) k *= P + 1; return k; }();
  std::array<int, Dim> cells, nodes;
  std::array<std::size_t, Dim> stride; // of the padded layout
  std::vector<double> rows;
  std::vector<std::size_t> position;

  TestSystem(std::array<int, Dim> cells_, double l0, std::uint64_t seed) : cells(cells_)
  {
    std::size_t size = 1;
    for (int a = Dim - 1; a >= 0; --a)
    {
      nodes[a] = cells[a] + P;
      stride[a] = size;
      size *= static_cast<std::size_t>(nodes[a] + 2 * P);
    }
    rows.assign(size * H, 0.0);
    std::vector<std::uint8_t> active(size, 0), crackable(size, 0);
    std::vector<BSpline1D> basis;
    for (int a = 0; a < Dim; ++a)
      basis.emplace_back(P, cells[a], 1.0, 0.0);
    Random random(seed);
    std::array<int, Dim> c{};
    for (;;)
    {
      const bool empty = c[0] >= 3 * cells[0] / 4 && c[1] < cells[1] / 4;
      const bool cracks = c[0] >= 2;
      if (!empty)
        for (int q = 0; q < (1 << Dim); ++q)
        {
          double N[Dim][P + 1], dN[Dim][P + 1], x[Dim];
          for (int a = 0; a < Dim; ++a)
          {
            x[a] = c[a] + 0.5 * ((q >> a) & 1) + 0.5 * random();
            basis[a].evaluate(c[a], x[a], N[a], dN[a], nullptr);
          }
          const double volume = (0.5 + random()) / (1 << Dim);
          const double band = std::abs(x[1] - 0.5 * cells[1]);
          const double history = x[0] < 0.5 * cells[0] && band < l0 ? 50.0 * (1.0 - band / l0) : 0.0;
          // The cell's nodes, lexicographic: value, gradient, padded index.
          double value[K], gradient[K][Dim];
          std::size_t index[K];
          for (int n = 0; n < K; ++n)
          {
            index[n] = 0;
            value[n] = 1.0;
            for (int a = Dim - 1, r = n; a >= 0; --a, r /= P + 1)
            {
              const int k = r % (P + 1);
              index[n] += static_cast<std::size_t>(c[a] + k + P) * stride[a];
              value[n] *= N[a][k];
              for (int b = 0; b < Dim; ++b)
                gradient[n][b] = (a == Dim - 1 ? 1.0 : gradient[n][b]) * (b == a ? dN[a][k] : N[a][k]);
            }
            active[index[n]] = 1;
            crackable[index[n]] |= cracks;
          }
          if (!cracks)
            continue;
          const double reaction = volume * (1.0 / l0 + 2.0 * history), diffusion = volume * l0;
          for (int n = 0; n < K; ++n)
            for (int m = 0; m < K; ++m)
            {
              int offset[Dim];
              for (int a = Dim - 1, rn = n, rm = m; a >= 0; --a, rn /= P + 1, rm /= P + 1)
                offset[a] = rm % (P + 1) - rn % (P + 1);
              int slot;
              if constexpr (Dim == 2)
                slot = S::slot(offset[0], offset[1]);
              else
                slot = S::slot(offset[0], offset[1], offset[2]);
              if (slot < 0)
                continue;
              double g = 0.0;
              for (int b = 0; b < Dim; ++b)
                g += gradient[n][b] * gradient[m][b];
              rows[index[n] * H + slot] += reaction * value[n] * value[m] + diffusion * g;
            }
        }
      int a = Dim - 1;
      while (a >= 0 && ++c[a] == cells[a])
        c[a--] = 0;
      if (a < 0)
        break;
    }
    for (std::size_t i = 0; i < size; ++i)
      if (active[i])
      {
        position.push_back(i);
        if (!crackable[i])
          rows[i * H] = 1.0;
      }
  }
};

/// Max |a - b| over two particle arrays of the same size.
double max_difference(const std::vector<double>& a, const std::vector<double>& b)
{
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}
} // namespace

class RefinementDegree : public ::testing::TestWithParam<int>
{
};

TEST_P(RefinementDegree, CoarseFunctionsAreCombinationsOfFineOnes)
{
  // N^2h_J(x) = sum_i R_iJ N^h_i(x) at points all over the fine grid, also
  // when an odd number of fine cells leaves the last coarse cell half outside.
  const int p = GetParam();
  for (int cells : {2 * p + 2, 2 * p + 3, 13})
  {
    const Refinement R(cells, p);
    const BSpline1D fine(p, cells, 1.0, 0.0), coarse(p, (cells + 1) / 2, 2.0, 0.0);
    ASSERT_EQ(R.fine, fine.size());
    ASSERT_EQ(R.coarse, coarse.size());
    for (int k = 0; k < 200; ++k)
    {
      const double x = (k + 0.37) * cells / 200.0;
      double nf[4], nc[4];
      const int cf = fine.cell(x), cc = coarse.cell(x);
      fine.evaluate(cf, x, nf, nullptr, nullptr);
      coarse.evaluate(cc, x, nc, nullptr, nullptr);
      for (int J = 0; J < R.coarse; ++J)
      {
        const double value = J >= cc && J <= cc + p ? nc[J - cc] : 0.0;
        double sum = 0.0;
        for (int a = 0; a < R.count[J]; ++a)
        {
          const int i = R.first[J] + a;
          if (i >= cf && i <= cf + p)
            sum += R.weight[std::size_t(J) * R.width() + a] * nf[i - cf];
        }
        EXPECT_NEAR(sum, value, 1e-14) << "p = " << p << ", cells = " << cells << ", J = " << J;
      }
    }
    // The transposed runs hold the same weights.
    for (int i = 0; i < R.fine; ++i)
      for (int a = 0; a < R.count_t[i]; ++a)
      {
        const int J = R.first_coarse[i] + a;
        const int b = i - R.first[J];
        ASSERT_TRUE(b >= 0 && b < R.count[J]);
        EXPECT_EQ(R.weight_t[std::size_t(i) * R.width() + a],
                  R.weight[std::size_t(J) * R.width() + b]);
      }
  }
}

INSTANTIATE_TEST_SUITE_P(Degrees, RefinementDegree, ::testing::Values(1, 2, 3));

TEST(Refinement, InteriorWeightsAreBinomial)
{
  // 2^-p C(p + 1, k) on fine functions 2J - p + k (knot insertion at the midpoints).
  const Refinement q(20, 2), c(20, 3);
  const double wq[] = {0.25, 0.75, 0.75, 0.25}, wc[] = {0.125, 0.5, 0.75, 0.5, 0.125};
  ASSERT_EQ(q.first[5], 2 * 5 - 2);
  ASSERT_EQ(q.count[5], 4);
  for (int k = 0; k < 4; ++k)
    EXPECT_EQ(q.weight[5 * q.width() + k], wq[k]);
  ASSERT_EQ(c.first[5], 2 * 5 - 3);
  ASSERT_EQ(c.count[5], 5);
  for (int k = 0; k < 5; ++k)
    EXPECT_EQ(c.weight[5 * c.width() + k], wc[k]);
}

TEST(Multigrid, GalerkinOperatorIsTheMatrixOfTheCoarseGrid)
{
  // The coarse spaces are nested in the fine one and the particles are the
  // quadrature of both, so P^T K_h P is K assembled on the grid of cells 2h,
  // entry by entry (fourth order, so second derivatives are in it too).
  const double h = 0.25, l0 = 0.5;
  const Fracture f = fracture(l0, true);
  PlateRun fine(2, h, {36, 20}, {-0.5, -0.5}, make_plate(h, 2, l0), f, Preconditioner::jacobi,
               1e-6);
  PlateRun coarse(2, 2 * h, {18, 10}, {-0.5, -0.5}, make_plate(h, 2, l0), f,
                  Preconditioner::jacobi, 1e-6);

  // K_h in the stencil storage, then the multigrid levels built from it.
  const int p = 2, H = SymmetricStencil<2, 2>::size;
  const PhaseFieldSystem k = fine.solver.phase_field_system();
  const int nny = fine.grid.nodes()[1];
  const std::size_t pny = nny + 2 * p, pnx = fine.grid.nodes()[0] + 2 * p;
  auto padded = [&](int ix, int iy) { return std::size_t(ix + p) * pny + (iy + p); };
  std::vector<double> rows(pnx * pny * H, 0.0);
  std::vector<std::size_t> position;
  for (std::size_t a = 0; a < k.nodes.size(); ++a)
  {
    const int ix = k.nodes[a] / nny, iy = k.nodes[a] % nny;
    position.push_back(padded(ix, iy));
    for (auto e = k.row_start[a]; e < k.row_start[a + 1]; ++e)
    {
      const int jx = k.nodes[k.column[e]] / nny, jy = k.nodes[k.column[e]] % nny;
      if (const int s = SymmetricStencil<2, 2>::slot(jx - ix, jy - iy); s >= 0)
        rows[padded(ix, iy) * H + s] = k.value[e];
    }
  }
  Multigrid mg(fine.grid.cells(), p, 1);
  mg.setup<2>(rows, position);
  ASSERT_GE(mg.unknowns().size(), 2u);

  const PhaseFieldSystem k2 = coarse.solver.phase_field_system();
  const int cny = coarse.grid.nodes()[1];
  EXPECT_EQ(mg.unknowns()[1], static_cast<std::int64_t>(k2.nodes.size()));
  double largest = 0.0, worst = 0.0;
  for (std::size_t a = 0; a < k2.nodes.size(); ++a)
  {
    const int ix = k2.nodes[a] / cny, iy = k2.nodes[a] % cny;
    for (auto e = k2.row_start[a]; e < k2.row_start[a + 1]; ++e)
    {
      const int jx = k2.nodes[k2.column[e]] / cny, jy = k2.nodes[k2.column[e]] % cny;
      largest = std::max(largest, std::abs(k2.value[e]));
      worst = std::max(worst, std::abs(mg.entry(1, ix, iy, jx - ix, jy - iy) - k2.value[e]));
    }
  }
  EXPECT_GT(largest, 0.0);
  EXPECT_LT(worst, 1e-12 * largest);
}

class MultigridOrder : public ::testing::TestWithParam<bool>
{
};

TEST_P(MultigridOrder, FewIterationsToTheTightSolution)
{
  // The cold solve of the initial crack: the V-cycle takes a few iterations
  // where Jacobi (second order) or symmetric Gauss-Seidel (fourth) take
  // many more, and its c at tol = 1e-6 agrees with a 1e-12 solve.
  const bool fourth = GetParam();
  const double h = 0.125, l0 = 0.25;
  const Fracture f = fracture(l0, fourth);
  PlateRun mg(2, h, make_plate(h, 2, l0), f, Preconditioner::multigrid, 1e-6);
  PlateRun plain(2, h, make_plate(h, 2, l0), f,
                 fourth ? Preconditioner::ssor : Preconditioner::jacobi, 1e-6);
  PlateRun tight(2, h, make_plate(h, 2, l0), f, Preconditioner::multigrid, 1e-12);
  // Measured: 13 against 42 Jacobi iterations (second order), 23 against
  // 548 Gauss-Seidel ones (fourth).
  EXPECT_LE(mg.stats().last_iterations, fourth ? 30 : 15);
  EXPECT_GE(plain.stats().last_iterations, (fourth ? 15 : 3) * mg.stats().last_iterations);
  EXPECT_LE(mg.stats().last_residual, 1e-6);
  EXPECT_LT(max_difference(mg.particles.f64("c"), tight.particles.f64("c")), 1e-6);
  EXPECT_LT(max_difference(plain.particles.f64("c"), tight.particles.f64("c")), 1e-6);
}

INSTANTIATE_TEST_SUITE_P(SecondAndFourth, MultigridOrder, ::testing::Values(false, true));

TEST(Multigrid, EveryPreconditionerReachesTheSameSolution)
{
  // Gauss-Seidel for the second-order model and Jacobi for the fourth-order
  // one, the non-default pairings, converge to the same c.
  const double h = 0.25, l0 = 0.5;
  for (bool fourth : {false, true})
  {
    const Fracture f = fracture(l0, fourth);
    PlateRun tight(2, h, make_plate(h, 2, l0), f, Preconditioner::multigrid, 1e-12);
    for (Preconditioner pc : {Preconditioner::jacobi, Preconditioner::ssor})
    {
      PlateRun s(2, h, make_plate(h, 2, l0), f, pc, 1e-8);
      EXPECT_EQ(s.solver.phase_field_preconditioner(), pc);
      EXPECT_LT(max_difference(s.particles.f64("c"), tight.particles.f64("c")), 1e-7) << "fourth = " << fourth;
    }
  }
}

class MultigridDegree : public ::testing::TestWithParam<int>
{
};

TEST_P(MultigridDegree, ConvergesForEveryDegree)
{
  // Linear, quadratic and cubic B-splines (second order for the linear ones,
  // which have no second derivatives): few iterations to the tight solution.
  const int p = GetParam();
  const double h = 0.25, l0 = 0.5;
  const Fracture f = fracture(l0, p >= 2);
  PlateRun mg(p, h, make_plate(h, 2, l0), f, Preconditioner::multigrid, 1e-6);
  PlateRun tight(p, h, make_plate(h, 2, l0), f, Preconditioner::multigrid, 1e-12);
  EXPECT_LE(mg.stats().last_iterations, 30);
  EXPECT_LT(max_difference(mg.particles.f64("c"), tight.particles.f64("c")), 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Degrees, MultigridDegree, ::testing::Values(1, 2, 3));

TEST(Multigrid, ASmallSystemIsSolvedDirectly)
{
  // 10 x 6 active nodes, fewer than the 400 of the coarsest level: the
  // V-cycle is the Cholesky solve, and CG converges in one iteration.
  const double h = 1.0, l0 = 2.0;
  PlateRun mg(2, h, make_plate(h, 2, l0), fracture(l0, true), Preconditioner::multigrid, 1e-10);
  EXPECT_EQ(mg.stats().unknowns, 60);
  EXPECT_EQ(mg.stats().last_iterations, 1);
  EXPECT_LE(mg.stats().last_residual, 1e-10);
}

TEST(Multigrid, ThreadCountDoesNotChangeBits)
{
  // Enough nodes (164 x 84 cells) that the sweeps, the transfers and the
  // Galerkin products run in parallel strips; a few steps of the phase field
  // with moving particles.
  const int max_threads = omp_get_max_threads();
  const double h = 0.05, l0 = 0.1;
  std::vector<Particles> out;
  std::vector<std::int64_t> iterations;
  for (int threads : {1, 2})
  {
    omp_set_num_threads(threads);
    Particles P = make_plate(h, 1, l0);
    for (std::size_t p = 0; p < P.size(); ++p)
      P.v[2 * p + 1] = 0.5 * (P.x[2 * p + 1] - 2.0); // opens the crack
    PlateRun s(2, h, std::move(P), fracture(l0, true), Preconditioner::multigrid, 1e-6);
    s.solver.advance(3);
    iterations.push_back(s.solver.phase_field_stats().iterations);
    out.push_back(s.particles);
  }
  omp_set_num_threads(max_threads);
  EXPECT_EQ(iterations[0], iterations[1]);
  EXPECT_GT(iterations[0], 0);
  ASSERT_EQ(out[0].size(), out[1].size());
  EXPECT_TRUE(test::same_bits(out[0].f64("c"), out[1].f64("c")));
  EXPECT_EQ(0, std::memcmp(out[0].stress.data(), out[1].stress.data(),
                           out[0].stress.size() * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(out[0].x.data(), out[1].x.data(), out[0].x.size() * sizeof(double)));
}

TEST(Multigrid, TwoDimensionalVCycleKeepsItsBits)
{
  // z = B r and K z of two V-cycles on a fixed system (three levels and the
  // direct solve, parallel sweeps on the finest), on 1 and 2 threads, against
  // the bits of the 2D-only multigrid of commit 3894336 (g++ 12.2,
  // -O3 -march=native on x86-64 with FMA).
  const std::uint64_t expected[3] = {0x8a88472eea21e8b0ULL, 0xe5374dbcd10b800fULL, 0x33ac84d451e5b615ULL};
  const int max_threads = omp_get_max_threads();
  for (int p = 1; p <= 3; ++p)
    for (int threads : {1, 2})
    {
      omp_set_num_threads(threads);
      std::uint64_t h = 0xcbf29ce484222325ULL;
      auto run = [&](auto system)
      {
        using System = decltype(system);
        constexpr int P = System::S::size == 5 ? 1 : System::S::size == 13 ? 2 : 3;
        Multigrid mg(system.cells, P);
        mg.template setup<P>(system.rows, system.position);
        const std::size_t n = system.position.size();
        EXPECT_GE(mg.unknowns().size(), 3u);
        Random random(7);
        std::vector<double> r(n), z(n), kz(n);
        for (int pass = 0; pass < 2; ++pass)
        {
          for (double& v : r)
            v = 2.0 * random() - 1.0;
          mg.template apply<P>(r.data(), z.data(), kz.data());
          h = bit_hash(kz, bit_hash(z, h));
        }
      };
      if (p == 1)
        run(TestSystem<2, 1>({100, 90}, 2.0, 11));
      else if (p == 2)
        run(TestSystem<2, 2>({100, 90}, 2.0, 11));
      else
        run(TestSystem<2, 3>({100, 90}, 2.0, 11));
      std::printf("p = %d, %d threads: hash %016llx\n", p, threads, static_cast<unsigned long long>(h));
      EXPECT_EQ(h, expected[p - 1]) << "p = " << p << ", " << threads << " threads";
    }
  omp_set_num_threads(max_threads);
}

namespace
{
/// The stencil of a TestSystem's padded layout.
template <int Dim, int P>
SymmetricStencil<Dim, P> stencil_of(const TestSystem<Dim, P>& system)
{
  if constexpr (Dim == 2)
    return SymmetricStencil<2, P>(system.stride[0]);
  else
    return SymmetricStencil<3, P>(system.stride[0] / system.stride[1], system.stride[1]);
}

/// out = K v over the unknowns (the order of `position`), by rows of the stencil.
template <int Dim, int P>
void product(const TestSystem<Dim, P>& system, const std::vector<double>& v, std::vector<double>& out)
{
  const SymmetricStencil<Dim, P> s = stencil_of(system);
  std::vector<double> padded(system.rows.size() / SymmetricStencil<Dim, P>::size, 0.0);
  for (std::size_t u = 0; u < v.size(); ++u)
    padded[system.position[u]] = v[u];
  out.resize(v.size());
  for (std::size_t u = 0; u < v.size(); ++u)
    out[u] = row_product(s, system.rows.data(), system.position[u], padded.data());
}

double dot(const std::vector<double>& a, const std::vector<double>& b)
{
  double sum = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k)
    sum += a[k] * b[k];
  return sum;
}

/// Iterations of preconditioned CG (z = B r by `precondition`) from zero to
/// |F - K c| <= tol |F|, or -1 past 2000.
template <int Dim, int P, class B>
int cg_iterations(const TestSystem<Dim, P>& system, const std::vector<double>& f, B&& precondition,
                  double tol)
{
  const std::size_t n = f.size();
  std::vector<double> r = f, z(n), p(n, 0.0), q(n);
  const double stop = tol * std::sqrt(dot(f, f));
  double rz = 0.0;
  for (int it = 1; it <= 2000; ++it)
  {
    precondition(r, z);
    const double rz_next = dot(r, z), beta = it == 1 ? 0.0 : rz_next / rz;
    rz = rz_next;
    for (std::size_t k = 0; k < n; ++k)
      p[k] = z[k] + beta * p[k];
    product(system, p, q);
    const double alpha = rz / dot(p, q);
    for (std::size_t k = 0; k < n; ++k)
      r[k] -= alpha * q[k];
    if (std::sqrt(dot(r, r)) <= stop)
      return it;
  }
  return -1;
}

/// CG iterations to 1e-6 with the V-cycle (`sweeps` Gauss-Seidel sweeps each
/// way) and with Jacobi on a TestSystem of `cells` unit cells each way, l0 in
/// cells; F = K 1 less a random part (an intact field, pulled towards
/// breaking in places). Also checks that the V-cycle's K z is K times its z.
template <int P>
std::array<int, 2> iterations_3d(int cells, double l0, int sweeps = 1)
{
  const TestSystem<3, P> system({cells, cells, cells}, l0, 5);
  const std::size_t n = system.position.size();
  std::vector<double> f, ones(n, 1.0);
  product(system, ones, f);
  Random random(3);
  for (double& v : f)
    v -= 0.5 * random() * v;
  Multigrid<3> mg(system.cells, P, 400, sweeps);
  mg.setup<P>(system.rows, system.position);
  double worst = 0.0;
  std::vector<double> kz, kz_product;
  const int multigrid = cg_iterations(
      system, f,
      [&](const std::vector<double>& r, std::vector<double>& z)
      {
        kz.resize(n);
        mg.apply<P>(r.data(), z.data(), kz.data());
        product(system, z, kz_product);
        for (std::size_t u = 0; u < n; ++u)
          worst = std::max(worst, std::abs(kz[u] - kz_product[u]) / std::abs(f[u]));
      },
      1e-6);
  EXPECT_LT(worst, 1e-10) << "K z from the V-cycle, relative to F";
  const int jacobi = cg_iterations(
      system, f,
      [&](const std::vector<double>& r, std::vector<double>& z)
      {
        for (std::size_t u = 0; u < n; ++u)
          z[u] = r[u] / system.rows[system.position[u] * SymmetricStencil<3, P>::size];
      },
      1e-6);
  std::printf("3D, p = %d, %d^3 cells, l0 = %g h: %zu unknowns on %zu levels; CG iterations: "
              "multigrid (%d sweeps) %d, Jacobi %d\n",
              P, cells, l0, n, mg.unknowns().size(), sweeps, multigrid, jacobi);
  return {multigrid, jacobi};
}

/// K_l of every multigrid level as a dense matrix over that level's grid
/// nodes (lexicographic, the last direction fastest), formed explicitly:
/// K_0 from the stencil rows, K_l+1 = P^T D K_l D P with P = R_x (x) R_y (x)
/// R_z from the Refinements and D the coupled nodes of level l (level 0: an
/// unknown with an off-diagonal entry; coarser: a nonzero diagonal).
template <int P>
void check_galerkin_3d(std::array<int, 3> cells)
{
  const TestSystem<3, P> system(cells, 1.5, 17);
  constexpr int H = SymmetricStencil<3, P>::size;
  const SymmetricStencil<3, P> s = stencil_of(system);
  Multigrid<3> mg(cells, P, 1);
  mg.setup<P>(system.rows, system.position);
  const std::vector<std::int64_t> unknowns = mg.unknowns();
  ASSERT_EQ(unknowns[0], static_cast<std::int64_t>(system.position.size()));

  std::array<int, 3> n;
  for (int a = 0; a < 3; ++a)
    n[a] = cells[a] + P;
  auto count = [](const std::array<int, 3>& m) { return std::size_t(m[0]) * m[1] * m[2]; };
  std::size_t N = count(n);
  std::vector<double> K(N * N, 0.0);
  std::vector<std::uint8_t> coupled(N, 0);
  for (std::size_t i : system.position)
  {
    // padded index -> node
    const int ix = int(i / system.stride[0]) - P, iy = int(i % system.stride[0] / system.stride[1]) - P,
              iz = int(i % system.stride[1]) - P;
    const std::size_t I = (std::size_t(ix) * n[1] + iy) * n[2] + iz;
    for (int k = 0; k < H; ++k)
    {
      const int jx = ix + s.d[k][0], jy = iy + s.d[k][1], jz = iz + s.d[k][2];
      if (jx >= n[0] || jy < 0 || jy >= n[1] || jz < 0 || jz >= n[2])
        continue;
      const std::size_t J = (std::size_t(jx) * n[1] + jy) * n[2] + jz;
      K[I * N + J] = K[J * N + I] = system.rows[i * H + k];
      if (k > 0 && system.rows[i * H + k] != 0.0)
        coupled[I] = coupled[J] = 1;
    }
  }
  for (std::size_t l = 1; l < unknowns.size(); ++l)
  {
    // P: fine node I = (ix, iy, iz), coarse node J, the product of the
    // directions' weights R_a(i_a, j_a).
    std::vector<Refinement> R;
    std::array<int, 3> m;
    for (int a = 0; a < 3; ++a)
    {
      R.emplace_back(cells[a], P);
      ASSERT_EQ(R[a].fine, n[a]);
      m[a] = R[a].coarse;
    }
    auto weight = [&](int a, int i, int j)
    {
      const int k = i - R[a].first[j];
      return k >= 0 && k < R[a].count[j] ? R[a].weight[std::size_t(j) * R[a].width() + k] : 0.0;
    };
    const std::size_t M = count(m);
    std::vector<double> Pm(N * M, 0.0);
    for (int ix = 0; ix < n[0]; ++ix)
      for (int iy = 0; iy < n[1]; ++iy)
        for (int iz = 0; iz < n[2]; ++iz)
        {
          const std::size_t I = (std::size_t(ix) * n[1] + iy) * n[2] + iz;
          if (!coupled[I])
            continue;
          for (int jx = 0; jx < m[0]; ++jx)
            for (int jy = 0; jy < m[1]; ++jy)
              for (int jz = 0; jz < m[2]; ++jz)
                Pm[I * M + (std::size_t(jx) * m[1] + jy) * m[2] + jz]
                    = weight(0, ix, jx) * weight(1, iy, jy) * weight(2, iz, jz);
        }
    std::vector<double> KP(N * M, 0.0), Kc(M * M, 0.0);
    for (std::size_t I = 0; I < N; ++I)
      for (std::size_t L = 0; L < N; ++L)
        if (const double k = K[I * N + L]; k != 0.0)
          for (std::size_t J = 0; J < M; ++J)
            KP[I * M + J] += k * Pm[L * M + J];
    for (std::size_t I = 0; I < N; ++I)
      for (std::size_t J = 0; J < M; ++J)
        if (const double p = Pm[I * M + J]; p != 0.0)
          for (std::size_t L = 0; L < M; ++L)
            Kc[J * M + L] += p * KP[I * M + L];
    // Every entry of the stencil against the dense product, and the
    // unknowns: the nodes of nonzero diagonal.
    double largest = 0.0, worst = 0.0;
    std::int64_t live = 0;
    for (std::size_t J = 0; J < M; ++J)
      live += Kc[J * M + J] > 0.0;
    for (std::size_t J = 0; J < M; ++J)
      largest = std::max(largest, std::abs(Kc[J * M + J]));
    for (int jx = 0; jx < m[0]; ++jx)
      for (int jy = 0; jy < m[1]; ++jy)
        for (int jz = 0; jz < m[2]; ++jz)
          for (int dx = -P; dx <= P; ++dx)
            for (int dy = -P; dy <= P; ++dy)
              for (int dz = -P; dz <= P; ++dz)
              {
                const int lx = jx + dx, ly = jy + dy, lz = jz + dz;
                const bool on = lx >= 0 && lx < m[0] && ly >= 0 && ly < m[1] && lz >= 0 && lz < m[2];
                const double expected
                    = on ? Kc[((std::size_t(jx) * m[1] + jy) * m[2] + jz) * M
                              + (std::size_t(lx) * m[1] + ly) * m[2] + lz]
                         : 0.0;
                worst = std::max(worst, std::abs(mg.entry(l, {jx, jy, jz}, {dx, dy, dz}) - expected));
              }
    // Beyond the stencil the Galerkin operator vanishes.
    for (int jx = 0; jx < m[0]; ++jx)
      for (int lx = 0; lx < m[0]; ++lx)
        if (std::abs(lx - jx) > P)
          for (std::size_t r = 0; r < std::size_t(m[1]) * m[2]; ++r)
            for (std::size_t q = 0; q < std::size_t(m[1]) * m[2]; ++q)
              worst = std::max(worst, std::abs(Kc[(jx * m[1] * m[2] + r) * M + lx * m[1] * m[2] + q]));
    EXPECT_GT(largest, 0.0);
    EXPECT_LT(worst, 1e-13 * largest) << "level " << l << ", p = " << P;
    EXPECT_EQ(unknowns[l], live) << "level " << l;
    // The next level's coupled nodes: the unknowns.
    K = std::move(Kc);
    coupled.assign(M, 0);
    for (std::size_t J = 0; J < M; ++J)
      coupled[J] = K[J * M + J] > 0.0;
    N = M;
    n = m;
    for (int a = 0; a < 3; ++a)
      cells[a] = (cells[a] + 1) / 2;
  }
}
} // namespace

class Multigrid3DDegree : public ::testing::TestWithParam<int>
{
};

TEST_P(Multigrid3DDegree, GalerkinOperatorIsPTransposeKP)
{
  // Every level of a 5 x 6 x 7-cell grid (odd and even halvings, a corner
  // without particles, identity rows) against the dense product, down to
  // one cell each way.
  const int p = GetParam();
  if (p == 1)
    check_galerkin_3d<1>({5, 6, 7});
  else if (p == 2)
    check_galerkin_3d<2>({5, 6, 7});
  else
    check_galerkin_3d<3>({5, 6, 7});
}

INSTANTIATE_TEST_SUITE_P(Degrees, Multigrid3DDegree, ::testing::Values(1, 2, 3));

TEST(Multigrid3D, FewIterationsIndependentOfTheResolution)
{
  // The same phase-field problem (quadratic B-splines, a broken band) at h
  // and h / 2, l0 = 2h and 4h: the V-cycle's CG iterations stay put, a few
  // times fewer than Jacobi's. Measured: 22 and 20 against 81 and 79.
  const std::array<int, 2> coarse = iterations_3d<2>(16, 2.0), fine = iterations_3d<2>(32, 4.0);
  EXPECT_LE(coarse[0], 25);
  EXPECT_LE(fine[0], 25);
  EXPECT_LE(std::abs(fine[0] - coarse[0]), 3);
  EXPECT_GE(coarse[1], 3 * coarse[0]);
  EXPECT_GE(fine[1], 3 * fine[0]);
  // Two sweeps each way: fewer iterations (measured 15), still a symmetric
  // preconditioner that CG converges with.
  const std::array<int, 2> two = iterations_3d<2>(16, 2.0, 2);
  EXPECT_GT(two[0], 0);
  EXPECT_LE(two[0], coarse[0] - 5);
}

TEST(Multigrid3D, ConvergesForEveryDegree)
{
  // Linear: 8 iterations against Jacobi's 31. Cubic: 73 against 352, the
  // Gauss-Seidel smoother's known weakness on high-degree splines.
  const std::array<int, 2> linear = iterations_3d<1>(16, 2.0), cubic = iterations_3d<3>(16, 2.0);
  EXPECT_GT(linear[0], 0);
  EXPECT_LE(linear[0], 10);
  EXPECT_GE(linear[1], 3 * linear[0]);
  EXPECT_GT(cubic[0], 0);
  EXPECT_LE(cubic[0], 80);
  EXPECT_GE(cubic[1], 4 * cubic[0]);
}

TEST(Multigrid3D, ThreadCountDoesNotChangeBits)
{
  // 34^3 unknowns: the finest level's sweeps, transfers and Galerkin
  // products run in parallel strips of x-planes.
  const int max_threads = omp_get_max_threads();
  const TestSystem<3, 2> system({32, 32, 32}, 4.0, 23);
  const std::size_t n = system.position.size();
  ASSERT_GT(n, 30000u);
  std::vector<std::vector<double>> out;
  for (int threads : {1, 2})
  {
    omp_set_num_threads(threads);
    Multigrid<3> mg(system.cells, 2);
    mg.setup<2>(system.rows, system.position);
    Random random(9);
    std::vector<double> r(n), z(n), kz(n), all;
    for (int pass = 0; pass < 2; ++pass)
    {
      for (double& v : r)
        v = 2.0 * random() - 1.0;
      mg.apply<2>(r.data(), z.data(), kz.data());
      all.insert(all.end(), z.begin(), z.end());
      all.insert(all.end(), kz.begin(), kz.end());
    }
    out.push_back(std::move(all));
  }
  omp_set_num_threads(max_threads);
  EXPECT_TRUE(test::same_bits(out[0], out[1]));
}
