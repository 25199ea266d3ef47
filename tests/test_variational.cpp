// The variational rule (sis/scattered.h, ScatteredRule::Variational) and its
// smoothness functional (sis/smoothness.h) against slow direct references:
// Gauss-Legendre integration of the derivative products, a dense solve of
// (G + lambda R) c = b.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "sis/generator.h"
#include "sis/scattered.h"
#include "sis/smoothness.h"
#include "scattered_samples.h"
#include "support.h"

namespace sis {
namespace {

using test::dense_solve;
using test::random_samples;
using test::uniform;
using test::target;

ScatteredOptions variational(std::optional<double> lambda, int order = 2) {
  ScatteredOptions o;
  o.rule = ScatteredRule::Variational;
  o.lambda = lambda;
  o.smoothness = order;
  o.variational_iterations = 2000;
  o.variational_tolerance = 1e-14;
  return o;
}

// The m-th derivative of beta_n at x, from the difference identity
// beta_n' (x) = beta_{n-1}(x + 1/2) - beta_{n-1}(x - 1/2).
double bspline_derivative(int n, int m, double x) {
  if (m == 0) return bspline(n, x);
  return bspline_derivative(n - 1, m - 1, x + 0.5) - bspline_derivative(n - 1, m - 1, x - 0.5);
}

// The m-th derivative along one axis of coefficient k's basis function on
// [0, L] with the boundary rule's images (mirror: x + 2 L j and -x + 2 L j).
double axis(int n, int m, double x, long k, double L, Boundary b) {
  double s = 0;
  const double p = k + 0.5;
  for (int j = -3; j <= 3; ++j) {
    if (b == Boundary::Mirror) {
      s += bspline_derivative(n, m, x + 2 * L * j - p);
      s += ((m % 2) ? -1.0 : 1.0) * bspline_derivative(n, m, -x + 2 * L * j - p);
    } else {
      s += bspline_derivative(n, m, x + L * j - p);
    }
  }
  return s;
}

// 5-point Gauss-Legendre on [-1, 1]: exact for polynomials of degree 9.
const double kNodes[5] = {0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                          0.9061798459386640};
const double kWeights[5] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                            0.2369268850561891, 0.2369268850561891};

// J of the coefficients (unit steps, frame nx x ny), integrated cell by
// half-pixel cell, where the integrand is one polynomial of degree <= 2n.
double direct_energy(const std::vector<double>& c, long nx, long ny, int n, int order,
                     Boundary b) {
  auto deriv = [&](int mx, int my, double x, double y) {
    double s = 0;
    for (long ky = 0; ky < ny; ++ky) {
      const double ay = axis(n, my, y, ky, double(ny), b);
      if (ay == 0) continue;
      for (long kx = 0; kx < nx; ++kx) s += c[ky * nx + kx] * axis(n, mx, x, kx, double(nx), b) * ay;
    }
    return s;
  };
  double J = 0;
  for (long cy = 0; cy < 2 * ny; ++cy)
    for (long cx = 0; cx < 2 * nx; ++cx)
      for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j) {
          const double x = 0.5 * cx + 0.25 * (1 + kNodes[i]), y = 0.5 * cy + 0.25 * (1 + kNodes[j]);
          const double w = kWeights[i] * kWeights[j] * 0.0625;
          if (order == 1) {
            const double fx = deriv(1, 0, x, y), fy = deriv(0, 1, x, y);
            J += w * (fx * fx + fy * fy);
          } else {
            const double fxx = deriv(2, 0, x, y), fxy = deriv(1, 1, x, y), fyy = deriv(0, 2, x, y);
            J += w * (fxx * fxx + 2 * fxy * fxy + fyy * fyy);
          }
        }
  return J;
}

TEST(Smoothness, AutocorrelationsEqualGaussLegendreIntegrals) {
  for (int n = 0; n <= 4; ++n)  // products of degree <= 8: 5 nodes are exact
    for (int d = 0; d <= std::min(n, 2); ++d) {
      const std::vector<double> a = bspline_derivative_autocorrelation(n, d);
      ASSERT_EQ(a.size(), std::size_t(2 * n + 1));
      for (int k = -n; k <= n; ++k) {
        double s = 0;  // half-unit cells over beta_n's support [-(n+1)/2, (n+1)/2]
        for (int cell = -2 * n - 2; cell < 2 * n + 2; ++cell)
          for (int i = 0; i < 5; ++i) {
            const double u = 0.5 * cell + 0.25 * (1 + kNodes[i]);
            s += 0.25 * kWeights[i] * bspline_derivative(n, d, u) * bspline_derivative(n, d, u - k);
          }
        // Exact quadrature of a piecewise polynomial: only rounding remains.
        EXPECT_NEAR(a[k + n], s, 1e-13) << "degree " << n << " d " << d << " k " << k;
      }
    }
  EXPECT_THROW(bspline_derivative_autocorrelation(1, 2), std::invalid_argument);
}

TEST(Smoothness, EnergyEqualsDirectIntegrationOverTheFrame) {
  struct Case { int degree, order; Boundary b; };
  for (const Case cs : {Case{3, 2, Boundary::Mirror}, Case{3, 2, Boundary::Periodic},
                        Case{3, 1, Boundary::Mirror}, Case{2, 2, Boundary::Mirror},
                        Case{2, 1, Boundary::Periodic}, Case{1, 1, Boundary::Mirror}}) {
    const long nx = 7, ny = 6;
    std::mt19937_64 g(5 + cs.degree);
    std::vector<double> c(nx * ny);
    for (double& v : c) v = uniform(g) - 0.5;
    Grid<double> k(nx, ny, 1);
    k.data.assign(c.begin(), c.end());
    const SmoothnessOperator R(cs.degree, cs.order, 1.0, 1.0, cs.b);
    const double got = R.energy(k)[0];
    const double want = direct_energy(c, nx, ny, cs.degree, cs.order, cs.b);
    // Exact quadrature (degree <= 6 pieces, 5 nodes); rounding of ~1e4 terms.
    EXPECT_NEAR(got, want, 1e-11 * std::abs(want))
        << "degree " << cs.degree << " order " << cs.order;
    EXPECT_GT(want, 0.1);
  }
}

TEST(Smoothness, StepsScaleTheFunctional) {
  // f(x, y) = g(x / hx, y / hy): order 2's three terms scale by hy / hx^3,
  // 1 / (hx hy) and hx / hy^3 (checked on a spline varying along x only,
  // where only the first is non-zero).
  Grid<double> c(6, 5, 1);
  for (long y = 0; y < 5; ++y)
    for (long x = 0; x < 6; ++x) c.at(x, y, 0) = (x == 2) ? 1.0 : 0.0;
  const double unit = SmoothnessOperator(3, 2, 1, 1, Boundary::Periodic).energy(c)[0];
  const double scaled = SmoothnessOperator(3, 2, 2, 0.5, Boundary::Periodic).energy(c)[0];
  EXPECT_NEAR(scaled, unit * 0.5 / 8, 1e-13 * unit);  // the taps summed in another order
  EXPECT_THROW(SmoothnessOperator(3, 3, 1, 1, Boundary::Mirror), std::invalid_argument);
  EXPECT_THROW(SmoothnessOperator(1, 2, 1, 1, Boundary::Mirror), std::invalid_argument);
}

// The dense design matrix Phi[i][n] (unit steps) of the target.
std::vector<std::vector<double>> design(const ScatteredSamples& s, const ScatteredTarget& t,
                                        int degree) {
  const long W = long(t.width), H = long(t.height);
  std::vector<std::vector<double>> Phi(s.count(), std::vector<double>(W * H));
  for (long i = 0; i < s.count(); ++i)
    for (long y = 0; y < H; ++y)
      for (long x = 0; x < W; ++x)
        Phi[i][y * W + x] = axis(degree, 0, s.positions[2 * i], x, t.width, t.boundary) *
                            axis(degree, 0, s.positions[2 * i + 1], y, t.height, t.boundary);
  return Phi;
}

TEST(Variational, EqualsDenseSolve) {
  for (Boundary b : {Boundary::Mirror, Boundary::Periodic})
    for (int order : {1, 2}) {
      const ScatteredTarget t = target(6, 5, 3, b);
      const ScatteredSamples s = random_samples(60, 1, 6, 5, 31 + order, true);  // 2 per pixel
      const auto Phi = design(s, t, 3);
      const std::size_t n = 30;
      const double lambda = 0.05;
      const SmoothnessOperator R(3, order, 1, 1, b);
      std::vector<std::vector<double>> M(n, std::vector<double>(n, 0.0));
      std::vector<double> rhs(n, 0.0);
      for (std::size_t m = 0; m < n; ++m) {  // lambda R, column by column
        Grid<double> e(6, 5, 1), Re(6, 5, 1);
        e.data[m] = 1;
        R.apply(e, Re);
        for (std::size_t a = 0; a < n; ++a) M[a][m] = lambda * Re.data[a];
      }
      for (long i = 0; i < s.count(); ++i)
        for (std::size_t a = 0; a < n; ++a) {
          rhs[a] += s.weights[i] * s.values[i] * Phi[i][a];
          for (std::size_t m = 0; m < n; ++m) M[a][m] += s.weights[i] * Phi[i][a] * Phi[i][m];
        }
      const std::vector<double> want = dense_solve(M, rhs);
      ScatteredReport rep;
      const Coefficients got = project_scattered(s, t, variational(lambda, order), &rep);
      double err = 0;
      for (std::size_t a = 0; a < n; ++a) err = std::max(err, std::abs(got.c.data[a] - want[a]));
      // CG to 1e-14 of ||b||, times the conditioning of the small system.
      EXPECT_LT(err, 1e-10) << "order " << order << " after " << rep.iterations << " iterations";
      EXPECT_EQ(rep.lambda, lambda);
    }
}

TEST(Variational, FlatImageExactForAnyLambda) {
  for (Boundary b : {Boundary::Mirror, Boundary::Periodic})
    for (std::optional<double> lambda : {std::optional<double>(0.01), std::optional<double>(1.0),
                                         std::optional<double>(100.0), std::optional<double>()}) {
      const ScatteredTarget t = target(9, 7, 3, b);
      ScatteredSamples s = random_samples(40, 3, 9, 7, 3, true);  // 0.6 per pixel
      for (std::size_t e = 0; e < s.values.size(); ++e) s.values[e] = 0.37 + 0.1 * (e % 3);
      const Coefficients k = project_scattered(s, t, variational(lambda));
      // J of a constant is 0 (the derivative taps sum to 0), so the
      // constant is the minimiser; CG to 1e-14 of ||b||.
      for (std::size_t e = 0; e < k.c.data.size(); ++e)
        ASSERT_NEAR(k.c.data[e], 0.37 + 0.1 * (e % 3), 1e-9)
            << "lambda " << (lambda ? *lambda : -1) << " element " << e;
    }
}

TEST(Variational, ReproducesASplineOfTheSpaceFromDenseSamples) {
  for (Boundary b : {Boundary::Mirror, Boundary::Periodic}) {
    const ScatteredTarget t = target(8, 6, 3, b);
    ScatteredSamples s = random_samples(600, 1, 8, 6, 17, true);
    std::mt19937_64 g(99);
    std::vector<double> c(48);
    for (double& v : c) v = uniform(g) - 0.5;
    const auto Phi = design(s, t, 3);
    for (long i = 0; i < s.count(); ++i) {
      double v = 0;
      for (long n = 0; n < 48; ++n) v += c[n] * Phi[i][n];
      s.values[i] = v;
    }
    const Coefficients k = project_scattered(s, t, variational(1e-9));
    // lambda's bias is about lambda |G^{-1} R c| (G ~ 12 a per coefficient,
    // R c ~ 10): below 1e-8.
    for (long n = 0; n < 48; ++n) EXPECT_NEAR(k.c.data[n], c[n], 1e-7) << " n " << n;
    // A large lambda does not reproduce it (a check that the test can fail).
    const Coefficients smooth = project_scattered(s, t, variational(10.0));
    double m = 0;
    for (long n = 0; n < 48; ++n) m = std::max(m, std::abs(smooth.c.data[n] - c[n]));
    EXPECT_GT(m, 1e-2);
  }
}

TEST(Variational, ConvergesToTheLeastSquaresFitAsLambdaFalls) {
  const ScatteredTarget t = target(10, 8, 3, Boundary::Mirror);
  const ScatteredSamples s = test::jittered(10, 8, 3, 7);
  ScatteredOptions fit;
  fit.rule = ScatteredRule::LeastSquares;
  fit.iterations = 500;
  fit.tolerance = 1e-15;
  const Coefficients ls = project_scattered(s, t, fit);
  double previous = std::numeric_limits<double>::infinity();
  for (double lambda : {1e-1, 1e-3, 1e-5, 1e-7}) {
    const Coefficients k = project_scattered(s, t, variational(lambda));
    double m = 0;
    for (std::size_t e = 0; e < k.c.data.size(); ++e)
      m = std::max(m, std::abs(k.c.data[e] - ls.c.data[e]));
    EXPECT_LT(m, previous) << "lambda " << lambda;
    previous = m;
  }
  // The bias is linear in lambda: ~1e-7 |G^{-1} R c|.
  EXPECT_LT(previous, 1e-6);
}

TEST(Variational, SameBitsForAnyThreadCount) {
  const ScatteredTarget t = target(40, 30, 3, Boundary::Mirror);
  test::expect_variational_same_bits_for_any_thread_count(random_samples(700, 3, 40, 30, 11), t, 50);
}

TEST(Variational, GcvPicksALargerLambdaForNoisierSamples) {
  const ScatteredTarget t = target(16, 12, 3, Boundary::Mirror);
  ScatteredSamples clean = test::jittered(16, 12, 1, 3);
  ScatteredSamples noisy = clean;
  std::mt19937_64 g(8);
  for (double& v : noisy.values) v += 0.3 * (uniform(g) - 0.5);
  ScatteredReport rc, rn;
  project_scattered(clean, t, variational({}), &rc);
  project_scattered(noisy, t, variational({}), &rn);
  EXPECT_EQ(rc.gcv.size(), 15u);
  EXPECT_GT(rn.lambda, rc.lambda);
}

// GCV's search runs from the largest lambda down and stops after two rises
// of the score past its lowest; its warm-started solve at the chosen lambda
// equals a solve from zero at that lambda given.
TEST(Variational, GcvStopsPastTheMinimumAndItsFitEqualsTheGivenLambdas) {
  const ScatteredTarget t = target(16, 12, 3, Boundary::Mirror);
  ScatteredSamples noisy = test::jittered(16, 12, 1, 3);
  std::mt19937_64 g(8);
  for (double& v : noisy.values) v += 0.3 * (uniform(g) - 0.5);
  ScatteredReport r;
  const Coefficients chosen = project_scattered(noisy, t, variational({}), &r);
  ASSERT_GE(r.gcv.size(), 3u);
  ASSERT_LT(r.gcv.size(), 15u);  // stopped before the smallest lambda
  for (std::size_t i = 1; i < r.gcv.size(); ++i) EXPECT_LT(r.gcv[i].first, r.gcv[i - 1].first);
  const std::size_t n = r.gcv.size();
  std::size_t best = 0;
  for (std::size_t i = 1; i < n; ++i)
    if (r.gcv[i].second < r.gcv[best].second) best = i;
  EXPECT_EQ(best, n - 3);
  EXPECT_EQ(r.lambda, r.gcv[best].first);
  EXPECT_GE(r.gcv[n - 2].second, r.gcv[best].second);
  EXPECT_GE(r.gcv[n - 1].second, r.gcv[best].second);
  const Coefficients given = project_scattered(noisy, t, variational(r.lambda));
  double m = 0, scale = 0;
  for (std::size_t e = 0; e < given.c.data.size(); ++e) {
    m = std::max(m, std::abs(chosen.c.data[e] - given.c.data[e]));
    scale = std::max(scale, std::abs(given.c.data[e]));
  }
  // Both stop at a residual of 1e-9 ||b||; the warm start only changes
  // where inside that ball.
  EXPECT_LT(m, 1e-7 * scale);
}

void expect_error(const ScatteredSamples& s, const ScatteredTarget& t, const ScatteredOptions& o,
                  const std::string& needle) {
  test::expect_error([&] { project_scattered(s, t, o); }, needle);
}

TEST(Variational, BadInputIsRefusedWithAClearMessage) {
  const ScatteredTarget t = target(6, 5, 3, Boundary::Mirror);
  const ScatteredSamples s = random_samples(50, 1, 6, 5, 1);
  expect_error(s, t, variational(-1.0), "lambda must be a finite number >= 0");
  expect_error(s, t, variational(std::nan("")), "lambda must be a finite number >= 0");
  expect_error(s, t, variational(0.1, 3), "smoothness order must be 1 or 2");
  expect_error(random_samples(2, 1, 6, 5, 1), t, variational(0.1), "at least 3 samples, got 2");
  expect_error(s, target(6, 5, 1, Boundary::Mirror), variational(0.1, 2),
               "order 2 needs a B-spline of degree 2 or more");
  ScatteredTarget hex = t;
  hex.space = HexagonalSpace{1, 1.0};  // hex-hat: C0, no thin plate
  expect_error(s, hex, variational(0.1), "--smoothness 2 (the thin plate) needs");
  expect_error(s, hex, variational(0.1), "hex-hat");
  EXPECT_EQ(parse_scattered_rule("variational"), ScatteredRule::Variational);
  EXPECT_STREQ(scattered_rule_name(ScatteredRule::Variational), "variational");
}

}  // namespace
}  // namespace sis
