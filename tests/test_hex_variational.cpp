// The variational rule on the hexagonal lattice (sis/scattered.h,
// ScatteredRule::Variational with a HexagonalSpace target) and its
// smoothness stencil (sis/smoothness.h, HexSmoothnessOperator) against slow
// direct references: the energy of coefficient patches by numerical
// integration of central differences of the evaluated spline, a dense
// solve of (G + lambda R) c = b on the periodic grid.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "sis/hex_lattice.h"
#include "sis/scattered.h"
#include "sis/smoothness.h"
#include "hex_scattered_reference.h"
#include "scattered_samples.h"
#include "support.h"

namespace sis {
namespace {

using test::all_images;
using test::dense_solve;
using test::layout_of;
using test::normal_equations;
using test::order_of;
using test::phi;
using test::jittered;
using test::random_samples;
using test::uniform;

ScatteredTarget target(double W, double H, int order, Boundary b, int margin = -1) {
  ScatteredTarget t;
  t.width = W;
  t.height = H;
  t.space = HexagonalSpace{order, 1.0};
  t.boundary = b;
  t.margin = margin;
  return t;
}

ScatteredOptions variational(std::optional<double> lambda, int smoothness = 2) {
  ScatteredOptions o;
  o.rule = ScatteredRule::Variational;
  o.lambda = lambda;
  o.smoothness = smoothness;
  o.variational_iterations = 3000;
  o.variational_tolerance = 1e-14;
  return o;
}

struct Generator {
  int order, smoothness;
};

// The stencil against numerical integration: a random patch of 3 x 3 stored
// coefficients in the middle of a 16 x 16 grid (no wrap reaches it), its
// energy c^T R c by the operator against the integral over a box holding
// the patch's support of the central-difference derivatives (step e) of the
// evaluated spline, by the midpoint rule on a grid of step d = h / 120.
// The integrand is piecewise polynomial: where it is smooth the midpoint
// rule errs by O(d^2) and the differences by O(e^2) (plus rounding
// eps / e^2 for the second ones); on the mesh's edges it has kinks
// (hex-quartic: |grad f|^2 is C1, the second derivatives C0) or jumps
// (hex-hat: its gradient is piecewise constant), where the midpoint rule
// errs by O(d^2) per unit length of edge (kinks) or O(d) (jumps, with
// signs that partly cancel). Measured relative errors: 4e-4 (hex-hat,
// order 1), 2e-8 (hex-quartic, order 1), 2e-5 (hex-quartic, order 2); the
// bounds leave a factor of about 5, while a wrong tap of R (R_0, or an
// offset misplaced on the offset-row grid) moves the energy by percents.
TEST(HexSmoothness, StencilEqualsNumericalIntegrationOfTheSpline) {
  for (const Generator& gen : {Generator{1, 1}, Generator{2, 1}, Generator{2, 2}}) {
    const double hstep = 1.3;  // a lattice step other than 1: the scaling
    const ScatteredTarget t = target(16 * hstep, 14 * hstep, gen.order, Boundary::Periodic, 0);
    HexLayout L = layout_of(t);
    L.lattice = Lattice::hexagonal(1.0 / (hstep * hstep * std::sqrt(3.0) / 2), L.lattice.origin());
    ASSERT_NEAR(L.step(), hstep, 1e-12);
    const BoxSpline& B = BoxSpline::hexagonal(gen.order);
    const HexSmoothnessOperator R(B, gen.smoothness, L.lattice.matrix());
    std::mt19937_64 g(5 + gen.order * 3 + gen.smoothness);
    Grid<double> c(L.columns, L.rows, 1);
    const long i0 = L.columns / 2 - 1, j0 = L.rows / 2 - 1;
    std::vector<Vec2> at;
    std::vector<double> cv;
    for (long j = j0; j < j0 + 3; ++j)
      for (long i = i0; i < i0 + 3; ++i) {
        const double v = uniform(g) - 0.5;
        c.data[std::size_t(j) * L.columns + i] = v;
        at.push_back(L.position(i, j));
        cv.push_back(v);
      }
    const double want = R.energy(c)[0];
    auto f = [&](double x, double y) {
      double s = 0;
      for (std::size_t k = 0; k < at.size(); ++k) s += cv[k] * phi(B, L, x, y, at[k]);
      return s;
    };
    const double d = hstep / 120;                             // the midpoint rule's step
    const double e = hstep * (gen.smoothness == 1 ? 1e-5 : 1e-3);  // the differences' step
    const double pad = (gen.order + 1) * hstep;
    const double x0 = L.position(i0, j0).x - pad, x1 = L.position(i0 + 3, j0 + 2).x + pad;
    const double y0 = L.position(i0, j0).y - pad, y1 = L.position(i0, j0 + 2).y + pad;
    double J = 0;
    for (double y = y0 + d / 2; y < y1; y += d)
      for (double x = x0 + d / 2; x < x1; x += d) {
        if (gen.smoothness == 1) {
          const double fx = (f(x + e, y) - f(x - e, y)) / (2 * e);
          const double fy = (f(x, y + e) - f(x, y - e)) / (2 * e);
          J += fx * fx + fy * fy;
        } else {
          const double f0 = f(x, y);
          const double fxx = (f(x + e, y) - 2 * f0 + f(x - e, y)) / (e * e);
          const double fyy = (f(x, y + e) - 2 * f0 + f(x, y - e)) / (e * e);
          const double fxy =
              (f(x + e, y + e) - f(x + e, y - e) - f(x - e, y + e) + f(x - e, y - e)) / (4 * e * e);
          J += fxx * fxx + 2 * fxy * fxy + fyy * fyy;
        }
      }
    J *= d * d;
    const double tol = gen.order == 1 ? 2e-3 : gen.smoothness == 1 ? 1e-6 : 1e-4;
    EXPECT_NEAR(J / want, 1.0, tol) << "order " << gen.order << " smoothness " << gen.smoothness
                                    << ": integral " << J << ", c^T R c " << want;
  }
}

// R's taps sum to 0 (a constant has no energy), and, symmetric, their first
// moments vanish, so R annihilates the coefficients of a linear function
// (c_k = a . x_k, which both box splines reproduce): order 2 gives linear
// functions no energy. On the periodic grid: a constant exactly.
TEST(HexSmoothness, ConstantsAndLinearFunctionsHaveNoEnergy) {
  for (const Generator& gen : {Generator{1, 1}, Generator{2, 1}, Generator{2, 2}}) {
    const HexLayout L = layout_of(target(12, 10, gen.order, Boundary::Periodic, 0));
    const HexSmoothnessOperator R(BoxSpline::hexagonal(gen.order), gen.smoothness,
                                  L.lattice.matrix());
    double sum = 0, m1 = 0, m2 = 0, big = 0, self = 0;
    for (const HexTap& t : R.taps()) {
      sum += t.value;
      m1 += t.value * t.k1;
      m2 += t.value * t.k2;
      big = std::max(big, std::abs(t.value));
      if (t.k1 == 0 && t.k2 == 0) self = t.value;
      EXPECT_LE(std::max({std::abs(t.k1), std::abs(t.k2), std::abs(t.k1 + t.k2)}),
                2 * gen.order - 1);
    }
    EXPECT_GT(self, 0);
    EXPECT_LT(std::abs(sum), 1e-14 * big);
    EXPECT_LT(std::abs(m1), 1e-13 * big);
    EXPECT_LT(std::abs(m2), 1e-13 * big);
    Grid<double> c(L.columns, L.rows, 2), out(L.columns, L.rows, 2);
    for (std::size_t e = 0; e < c.data.size(); ++e) c.data[e] = e % 2 ? -0.25 : 0.7;
    R.apply(c, out);
    for (double v : out.data) ASSERT_LT(std::abs(v), 1e-14 * big);
    // Linear: the interior (no wrap reaches the taps).
    Grid<double> lin(L.columns, L.rows, 1), rl(L.columns, L.rows, 1);
    for (long j = 0; j < L.rows; ++j)
      for (long i = 0; i < L.columns; ++i) {
        const Vec2 p = L.position(i, j);
        lin.data[std::size_t(j) * L.columns + i] = 0.3 * p.x - 0.7 * p.y + 1;
      }
    R.apply(lin, rl);
    const long r = 2 * gen.order;
    for (long j = r; j < L.rows - r; ++j)
      for (long i = r; i < L.columns - r; ++i)
        ASSERT_LT(std::abs(rl.data[std::size_t(j) * L.columns + i]), 1e-12 * big * L.columns)
            << i << ", " << j;
  }
}

// hex-hat's order 1 is the linear finite elements' stiffness on the
// equilateral mesh (the cotangent formula): -(cot 60 + cot 60) / 2 =
// -1/sqrt(3) to each of the six neighbours, 6/sqrt(3) on the diagonal, for
// any step (order 1 is scale free in 2-D).
TEST(HexSmoothness, HatGradientIsTheCotangentLaplacian) {
  for (double density : {1.0, 0.37}) {
    const HexSmoothnessOperator R(BoxSpline::hexagonal(1), 1, Lattice::hexagonal(density).matrix());
    ASSERT_EQ(R.taps().size(), 7u);
    for (const HexTap& t : R.taps())
      EXPECT_NEAR(t.value, (t.k1 == 0 && t.k2 == 0) ? 6 / std::sqrt(3.0) : -1 / std::sqrt(3.0),
                  1e-14)
          << t.k1 << ", " << t.k2;
  }
}

TEST(HexSmoothness, TheThinPlateRefusesTheHat) {
  const HexLayout L = layout_of(target(12, 10, 1, Boundary::Periodic, 0));
  test::expect_error([&] { HexSmoothnessOperator(BoxSpline::hexagonal(1), 2, L.lattice.matrix()); },
                     "--smoothness 2");
  const ScatteredSamples s = random_samples(50, 1, 6, 5, 1);
  test::expect_error([&] { project_scattered(s, target(6, 5, 1, Boundary::Mirror), variational(0.1)); },
                     "hex-hat");
  EXPECT_NO_THROW(project_scattered(s, target(6, 5, 1, Boundary::Mirror), variational(0.1, 1)));
}

TEST(HexVariational, EqualsDenseSolve) {
  for (Boundary bd : {Boundary::Mirror, Boundary::Periodic})
    for (const Generator& gen : {Generator{1, 1}, Generator{2, 1}, Generator{2, 2}}) {
      const ScatteredTarget t = target(3, 3, gen.order, bd, 1);
      const ScatteredSamples s = random_samples(60, 1, 3, 3, 7 + gen.order + gen.smoothness, true);
      std::vector<std::vector<double>> M;
      std::vector<double> rhs;
      normal_equations(s, t, M, rhs);
      const HexLayout L = layout_of(t);
      const long n = L.columns * L.rows;
      const double lambda = 0.05;
      const HexSmoothnessOperator R(BoxSpline::hexagonal(gen.order), gen.smoothness,
                                    L.lattice.matrix());
      for (long m = 0; m < n; ++m) {  // + lambda R, column by column
        Grid<double> e(L.columns, L.rows, 1), Re(L.columns, L.rows, 1);
        e.data[m] = 1;
        R.apply(e, Re);
        for (long a = 0; a < n; ++a) M[a][m] += lambda * Re.data[a];
      }
      const std::vector<double> want = dense_solve(M, rhs);
      ScatteredReport rep;
      const Coefficients got = project_scattered(s, t, variational(lambda, gen.smoothness), &rep);
      ASSERT_EQ(got.c.data.size(), want.size());
      double err = 0, scale = 0;
      for (long a = 0; a < n; ++a) {
        err = std::max(err, std::abs(got.c.data[a] - want[a]));
        scale = std::max(scale, std::abs(want[a]));
      }
      // CG to 1e-14 of ||b||, times the small system's conditioning.
      EXPECT_LT(err, 1e-10 * std::max(1.0, scale))
          << "order " << gen.order << " smoothness " << gen.smoothness << " after "
          << rep.iterations << " iterations";
      EXPECT_EQ(rep.lambda, lambda);
    }
}

TEST(HexVariational, FlatImageExactForAnyLambda) {
  for (Boundary bd : {Boundary::Mirror, Boundary::Periodic})
    for (const Generator& gen : {Generator{1, 1}, Generator{2, 2}})
      for (std::optional<double> lambda : {std::optional<double>(0.01), std::optional<double>(1.0),
                                           std::optional<double>(100.0), std::optional<double>()}) {
        const ScatteredTarget t = target(9, 7, gen.order, bd, 2);
        ScatteredSamples s = random_samples(60, 3, 9, 7, 3, true);
        for (std::size_t e = 0; e < s.values.size(); ++e) s.values[e] = 0.37 + 0.1 * (e % 3);
        const Coefficients k = project_scattered(s, t, variational(lambda, gen.smoothness));
        // A constant is in the space and has no energy (R's rows sum to 0),
        // so it is the exact solution; CG stops at a residual of 1e-9 ||b||,
        // and the small system's conditioning keeps the coefficients as near.
        for (std::size_t e = 0; e < k.c.data.size(); ++e)
          ASSERT_NEAR(k.c.data[e], 0.37 + 0.1 * (e % 3), 1e-9)
              << "lambda " << (lambda ? *lambda : -1) << " element " << e;
      }
}

// A spline of the space, sampled densely inside the frame away from its
// edges (no sample has an image in the grid's period but itself, so the
// data are the spline's values exactly): at a tiny lambda the rule gives
// it back wherever the samples determine it (the box splines are locally
// linearly independent), checked at points inside the sampled region.
TEST(HexVariational, ReproducesASplineOfTheSpaceFromDenseSamples) {
  for (const Generator& gen : {Generator{1, 1}, Generator{2, 2}}) {
    const ScatteredTarget t = target(12, 11, gen.order, Boundary::Mirror, 0);
    // The grid's period D (hex_scattered.h): mirror images -x and 2W - x
    // fall outside it for x in (-D.x0, 2W - D.x1), likewise in y.
    const HexLayout L = layout_of(t);
    const Vec2 o = L.lattice.origin();
    const double dx0 = o.x - L.step() / 4, dx1 = dx0 + L.columns * L.step();
    const double dy0 = o.y - L.row_step() / 2, dy1 = dy0 + L.rows * L.row_step();
    const double ax = -dx0 + 0.1, bx = 2 * t.width - dx1 - 0.1;
    const double ay = -dy0 + 0.1, by = 2 * t.height - dy1 - 0.1;
    ASSERT_GT(bx - ax, 2.5);
    ASSERT_GT(by - ay, 2.5);
    ScatteredSamples s;
    std::mt19937_64 g(4);
    for (int i = 0; i < 1500; ++i) {
      s.positions.push_back(ax + (bx - ax) * uniform(g));
      s.positions.push_back(ay + (by - ay) * uniform(g));
    }
    s.values.assign(1500, 0.0);
    ScatteredOptions fit;
    fit.rule = ScatteredRule::NormalisedSum;
    Coefficients truth = project_scattered(random_samples(4000, 1, 12, 11, 9), t, fit);  // its layout
    for (double& v : truth.c.data) v = uniform(g) - 0.5;
    s.values = evaluate_at_samples(truth, s);
    const Coefficients k = project_scattered(s, t, variational(1e-12, gen.smoothness));
    ScatteredSamples probe;
    for (int i = 0; i < 200; ++i) {
      probe.positions.push_back(ax + 0.5 + (bx - ax - 1) * uniform(g));
      probe.positions.push_back(ay + 0.5 + (by - ay - 1) * uniform(g));
    }
    probe.values.assign(200, 0.0);
    const std::vector<double> want = evaluate_at_samples(truth, probe),
                              got = evaluate_at_samples(k, probe);
    // lambda's bias is about lambda |G^{-1} R c|, larger near the sampled
    // region's edge where G is poorly conditioned (about 1e-6 at lambda
    // 1e-9 for hex-quartic): below 1e-6 at 1e-12.
    for (int i = 0; i < 200; ++i) EXPECT_NEAR(got[i], want[i], 1e-6) << "order " << gen.order;
    const Coefficients smooth = project_scattered(s, t, variational(10.0, gen.smoothness));
    const std::vector<double> far = evaluate_at_samples(smooth, probe);
    double m = 0;
    for (int i = 0; i < 200; ++i) m = std::max(m, std::abs(far[i] - want[i]));
    EXPECT_GT(m, 1e-2);  // a check that the test can fail
  }
}

TEST(HexVariational, ConvergesToTheHexLeastSquaresFitAsLambdaFalls) {
  for (const Generator& gen : {Generator{1, 1}, Generator{2, 2}}) {
    const ScatteredTarget t = target(10, 8, gen.order, Boundary::Mirror, 3);
    const ScatteredSamples s = jittered(10, 8, 3, 7);
    ScatteredOptions fit;
    fit.rule = ScatteredRule::LeastSquares;
    fit.iterations = 3000;
    fit.tolerance = 1e-15;
    const Coefficients ls = project_scattered(s, t, fit);
    double previous = std::numeric_limits<double>::infinity();
    for (double lambda : {1e-1, 1e-3, 1e-5, 1e-7}) {
      const Coefficients k = project_scattered(s, t, variational(lambda, gen.smoothness));
      double m = 0;
      for (std::size_t e = 0; e < k.c.data.size(); ++e)
        m = std::max(m, std::abs(k.c.data[e] - ls.c.data[e]));
      EXPECT_LT(m, previous) << "order " << gen.order << " lambda " << lambda;
      previous = m;
    }
    // The bias is linear in lambda: ~1e-7 |G^{-1} R c|.
    EXPECT_LT(previous, 1e-5) << "order " << gen.order;
  }
}

TEST(HexVariational, SameBitsForAnyThreadCount) {
  const ScatteredTarget t = target(30, 24, 2, Boundary::Mirror);
  test::expect_variational_same_bits_for_any_thread_count(random_samples(700, 3, 30, 24, 11), t, 40);
}

TEST(HexVariational, GcvPicksALargerLambdaForNoisierSamples) {
  const ScatteredTarget t = target(16, 12, 2, Boundary::Mirror);
  ScatteredSamples clean = jittered(16, 12, 1, 3);
  ScatteredSamples noisy = clean;
  std::mt19937_64 g(8);
  for (double& v : noisy.values) v += 0.3 * (uniform(g) - 0.5);
  ScatteredReport rc, rn;
  project_scattered(clean, t, variational({}), &rc);
  project_scattered(noisy, t, variational({}), &rn);
  EXPECT_GT(rn.lambda, rc.lambda);
  ASSERT_GE(rn.gcv.size(), 3u);
  for (std::size_t i = 1; i < rn.gcv.size(); ++i) EXPECT_LT(rn.gcv[i].first, rn.gcv[i - 1].first);
}

// The memory estimate counts the working set: more than the fit's, more
// with the GCV probes, and at least what the solve reports.
TEST(HexVariational, MemoryEstimateCountsTheWorkingSet) {
  const ScatteredTarget t = target(40, 30, 2, Boundary::Mirror);
  const ScatteredSamples s = random_samples(2000, 3, 40, 30, 2);
  ScatteredOptions fit;
  fit.rule = ScatteredRule::LeastSquares;
  ScatteredOptions given = variational(0.1), gcv = variational({});
  given.variational_iterations = gcv.variational_iterations = 3;
  const std::uint64_t fb = scattered_bytes(t, s, fit), vb = scattered_bytes(t, s, given),
                      gb = scattered_bytes(t, s, gcv);
  EXPECT_GT(vb, fb);
  EXPECT_GT(gb, vb);
  // At least what the GCV solve certainly holds: b and the CG's four grids
  // (A = 3 + 4 probe channels a coefficient) and, at each of the samples'
  // images (no fewer than the samples), the values and f_app.
  const auto [nx, ny] = scattered_grid(t);
  const std::uint64_t A = 7, n = std::uint64_t(nx) * std::uint64_t(ny);
  EXPECT_GE(gb, 8 * (5 * A * n + 2 * A * std::uint64_t(s.count())));
}

}  // namespace
}  // namespace sis
