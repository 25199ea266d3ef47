// Projection from scattered samples (sis/scattered.h) against slow direct
// references: double sums over the samples' boundary images, a dense solve
// of the fit's normal equations, and the grid acquisition.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "sis/generator.h"
#include "sis/prefilter.h"
#include "sis/projection.h"
#include "sis/scattered.h"
#include "scattered_samples.h"
#include "support.h"

namespace sis {
namespace {

using test::dense_solve;
using test::jittered;
using test::random_samples;
using test::expect_error;
using test::target;
using test::smooth;
using test::uniform;

const Kernel& generator_of(const ScatteredTarget& t) {
  return std::get<CartesianSpace>(t.space).generator;
}

// sum over the images of x (mirror: x + 2 L k and -x + 2 L k; periodic:
// x + L k) of phi(image - (n + 1/2)): coefficient n's weight on one axis.
double axis_reference(const Kernel& phi, double x, long n, double L, Boundary b) {
  double s = 0;
  const double p = n + 0.5;
  for (int k = -3; k <= 3; ++k) {
    if (b == Boundary::Mirror) {
      s += phi.eval(x + 2 * L * k - p);
      s += phi.eval(-x + 2 * L * k - p);
    } else {
      s += phi.eval(x + L * k - p);
    }
  }
  return s;
}

// Phi[i][n]: the weight of sample i for coefficient n = (nx, ny), row-major.
std::vector<std::vector<double>> design(const ScatteredSamples& s, const ScatteredTarget& t) {
  const long W = long(t.width), H = long(t.height);
  std::vector<std::vector<double>> Phi(s.count(), std::vector<double>(W * H));
  for (long i = 0; i < s.count(); ++i)
    for (long y = 0; y < H; ++y)
      for (long x = 0; x < W; ++x)
        Phi[i][y * W + x] =
            axis_reference(generator_of(t), s.positions[2 * i], x, t.width, t.boundary) *
            axis_reference(generator_of(t), s.positions[2 * i + 1], y, t.height, t.boundary);
  return Phi;
}

double weight_of(const ScatteredSamples& s, const ScatteredTarget& t, long i) {
  return s.weights.empty() ? t.width * t.height / s.count() : s.weights[i];
}

// The normalised rule by direct double sums, then the existing prefilter.
Coefficients normalised_reference(const ScatteredSamples& s, const ScatteredTarget& t) {
  const auto Phi = design(s, t);
  const long W = long(t.width), H = long(t.height);
  Coefficients k;
  k.c = Grid<double>(W, H, s.channels);
  k.space = t.space;
  k.boundary = t.boundary;
  k.image_width = t.width;
  k.image_height = t.height;
  for (long n = 0; n < W * H; ++n) {
    double den = 0;
    std::vector<double> num(s.channels, 0.0);
    for (long i = 0; i < s.count(); ++i) {
      const double w = weight_of(s, t, i) * Phi[i][n];
      den += w;
      for (int c = 0; c < s.channels; ++c) num[c] += w * s.values[i * s.channels + c];
    }
    for (int c = 0; c < s.channels; ++c) k.c.at(n % W, n / W, c) = num[c] / den;
  }
  prefilter(k);
  return k;
}

ScatteredOptions normalised() {
  ScatteredOptions o;
  o.rule = ScatteredRule::NormalisedSum;
  return o;
}

double max_abs_diff(const Grid<double>& a, const Grid<double>& b) {
  EXPECT_EQ(a.data.size(), b.data.size());
  double m = 0;
  for (std::size_t e = 0; e < a.data.size(); ++e) m = std::max(m, std::abs(a.data[e] - b.data[e]));
  return m;
}

struct Case {
  int degree;
  Boundary boundary;
};
std::vector<Case> cases() {
  std::vector<Case> v;
  for (int d = 0; d <= 3; ++d)
    for (Boundary b : {Boundary::Mirror, Boundary::Periodic}) v.push_back({d, b});
  return v;
}
std::string name(const Case& c) {
  return "degree " + std::to_string(c.degree) + " " + boundary_name(c.boundary);
}

TEST(Scattered, NormalisedSumEqualsDirectDoubleSums) {
  for (const Case& cs : cases()) {
    for (bool weighted : {false, true}) {
      const ScatteredTarget t = target(7, 5, cs.degree, cs.boundary);
      const ScatteredSamples s = random_samples(400, 2, 7, 5, 11 + cs.degree, weighted);
      const Coefficients got = project_scattered(s, t, normalised());
      const Coefficients want = normalised_reference(s, t);
      // Both are the same sums in another order and through another
      // evaluation of phi (closed forms against bspline()), then the same
      // prefilter, whose gain is at most 1/A_3(pi)^2 = 342 in 2-D.
      EXPECT_LT(max_abs_diff(got.c, want.c), 1e-12) << name(cs) << (weighted ? " weighted" : "");
    }
  }
}

// The passes' other tap rules (Cox-de Boor above degree 3, the kernel's own
// values for the conventional Gaussian and Lanczos) and widths of 4 + 1 and
// 6 + 1 values a coefficient (the vector path's widest and the general one).
TEST(Scattered, OtherTapRulesAndWidthsEqualDirectDoubleSums) {
  for (Boundary b : {Boundary::Mirror, Boundary::Periodic}) {
    for (int channels : {1, 4, 6}) {
      const ScatteredTarget t = target(8, 7, 5, b);
      const ScatteredSamples s = random_samples(700, channels, 8, 7, 31 + channels, true);
      // The degree-5 prefilter's gain is 1/A_5(pi)^2 ~ 1.5e4 in 2-D: the
      // sums' rounding (1e-16 each) reaches a few 1e-12 after it.
      EXPECT_LT(max_abs_diff(project_scattered(s, t, normalised()).c, normalised_reference(s, t).c),
                1e-10)
          << boundary_name(b) << ' ' << channels << " channels";
    }
    for (const Kernel& k : {Kernel::gaussian(), Kernel::lanczos(3)}) {
      ScatteredTarget t = target(6, 4, 3, b);
      t.space = CartesianSpace{k};
      t.method = Method::Conventional;
      const ScatteredSamples s = random_samples(400, 2, 6, 4, 13);
      const auto Phi = design(s, t);
      const Coefficients got = project_scattered(s, t, normalised());
      for (long n = 0; n < 24; ++n)
        for (int c = 0; c < 2; ++c) {
          double num = 0, den = 0;
          for (long i = 0; i < s.count(); ++i) {
            num += Phi[i][n] * s.values[i * 2 + c];
            den += Phi[i][n];
          }
          EXPECT_NEAR(got.c.at(n % 6, n / 6, c), num / den, 1e-13) << k.name() << ' ' << boundary_name(b);
        }
    }
  }
}

TEST(Scattered, PlainSumAndConventionalEqualDirectDoubleSums) {
  for (const Case& cs : cases()) {
    const ScatteredTarget t = target(6, 4, cs.degree, cs.boundary);
    const ScatteredSamples s = random_samples(300, 1, 6, 4, 5, true);
    const auto Phi = design(s, t);
    Coefficients want;
    want.c = Grid<double>(6, 4, 1);
    want.space = t.space;
    want.boundary = t.boundary;
    for (long n = 0; n < 24; ++n) {
      double num = 0;
      for (long i = 0; i < s.count(); ++i) num += s.weights[i] * Phi[i][n] * s.values[i];
      want.c.at(n % 6, n / 6, 0) = num;
    }
    prefilter(want);
    ScatteredOptions o;
    o.rule = ScatteredRule::PlainSum;
    EXPECT_LT(max_abs_diff(project_scattered(s, t, o).c, want.c), 1e-12) << name(cs);
  }
  // Conventional Mitchell: the normalised weighted average itself.
  for (Boundary b : {Boundary::Mirror, Boundary::Periodic}) {
    ScatteredTarget t = target(6, 4, 3, b);
    t.space = CartesianSpace{Kernel::mitchell()};
    t.method = Method::Conventional;
    const ScatteredSamples s = random_samples(300, 1, 6, 4, 9);
    const auto Phi = design(s, t);
    const Coefficients got = project_scattered(s, t, normalised());
    EXPECT_FALSE(got.min_error);
    for (long n = 0; n < 24; ++n) {
      double num = 0, den = 0;
      for (long i = 0; i < s.count(); ++i) {
        num += Phi[i][n] * s.values[i];
        den += Phi[i][n];
      }
      EXPECT_NEAR(got.c.at(n % 6, n / 6, 0), num / den, 1e-13) << boundary_name(b);
    }
  }
}

TEST(Scattered, FitEqualsDenseSolve) {
  for (const Case& cs : cases()) {
    const ScatteredTarget t = target(6, 5, cs.degree, cs.boundary);
    const ScatteredSamples s = random_samples(500, 1, 6, 5, 21 + cs.degree, true);
    const auto Phi = design(s, t);
    const std::size_t n = 30;
    std::vector<std::vector<double>> G(n, std::vector<double>(n, 0.0));
    std::vector<double> b(n, 0.0);
    for (long i = 0; i < s.count(); ++i)
      for (std::size_t a = 0; a < n; ++a) {
        if (Phi[i][a] == 0) continue;
        b[a] += s.weights[i] * s.values[i] * Phi[i][a];
        for (std::size_t m = 0; m < n; ++m) G[a][m] += s.weights[i] * Phi[i][a] * Phi[i][m];
      }
    const std::vector<double> want = dense_solve(G, b);
    ScatteredOptions o;
    o.rule = ScatteredRule::LeastSquares;
    o.iterations = 200;
    o.tolerance = 1e-15;
    ScatteredReport rep;
    const Coefficients got = project_scattered(s, t, o, &rep);
    double m = 0;
    for (std::size_t a = 0; a < n; ++a) m = std::max(m, std::abs(got.c.data[a] - want[a]));
    // The solve's rounding is about cond(G) eps (cond(G) <= 342 for the
    // cubic times the irregularity of the samples); the CG stops at 1e-15 of
    // ||b||.
    EXPECT_LT(m, 1e-10) << name(cs) << " after " << rep.iterations << " iterations";
    EXPECT_LT(rep.residual[0], 1e-14) << name(cs);
  }
}

TEST(Scattered, FlatImageExactFromRandomPositions) {
  for (const Case& cs : cases()) {
    for (ScatteredRule rule : {ScatteredRule::NormalisedSum, ScatteredRule::LeastSquares}) {
      const ScatteredTarget t = target(9, 7, cs.degree, cs.boundary);
      ScatteredSamples s = random_samples(800, 3, 9, 7, 3, true);  // about 13 per pixel
      for (std::size_t e = 0; e < s.values.size(); ++e) s.values[e] = 0.37 + 0.1 * (e % 3);
      ScatteredOptions o;
      o.rule = rule;
      o.iterations = 5;
      const Coefficients k = project_scattered(s, t, o);
      for (std::size_t e = 0; e < k.c.data.size(); ++e)
        ASSERT_NEAR(k.c.data[e], 0.37 + 0.1 * (e % 3), 1e-12)
            << name(cs) << ' ' << scattered_rule_name(rule) << " element " << e;
    }
  }
}

TEST(Scattered, FitReproducesASplineOfTheSpace) {
  for (const Case& cs : cases()) {
    const ScatteredTarget t = target(8, 6, cs.degree, cs.boundary);
    ScatteredSamples s = random_samples(300, 1, 8, 6, 17, true);
    std::mt19937_64 g(99);
    std::vector<double> c(48);
    for (double& v : c) v = uniform(g) - 0.5;
    const auto Phi = design(s, t);
    for (long i = 0; i < s.count(); ++i) {
      double v = 0;
      for (long n = 0; n < 48; ++n) v += c[n] * Phi[i][n];
      s.values[i] = v;
    }
    ScatteredOptions o;
    o.rule = ScatteredRule::LeastSquares;
    o.iterations = 300;
    o.tolerance = 1e-15;
    const Coefficients k = project_scattered(s, t, o);
    for (long n = 0; n < 48; ++n) EXPECT_NEAR(k.c.data[n], c[n], 1e-10) << name(cs) << " n " << n;
    // The normalised rule is not exact for it (a check that the test can fail).
    if (cs.degree > 0) {
      EXPECT_GT(max_abs_diff(project_scattered(s, t, normalised()).c, k.c), 1e-3) << name(cs);
    }
  }
}

TEST(Scattered, GridPositionsGiveTheGridResult) {
  for (const Case& cs : cases()) {
    const long W = 10, H = 8;
    for (int s : {1, 2, 3, 4}) {
      Image input(W * s, H * s, 1);
      ScatteredSamples smp;
      for (long j = 0; j < H * s; ++j)
        for (long i = 0; i < W * s; ++i) {
          const double x = (i + 0.5) / s, y = (j + 0.5) / s;
          input.at(i, j, 0) = float(smooth(x, y));
          smp.positions.push_back(x);
          smp.positions.push_back(y);
          smp.values.push_back(input.at(i, j, 0));
          smp.weights.push_back(1.0 / (s * s));
        }
      ProjectionOptions po;
      po.generator = Kernel::bspline(cs.degree);
      po.boundary = cs.boundary;
      const Coefficients grid = project(input, W, H, po);
      const Coefficients got = project_scattered(smp, target(W, H, cs.degree, cs.boundary), normalised());
      // At an integer factor the denominator sum_i phi_i,n / s^2 is a
      // quadrature of int phi = 1 that is exact (section 3), so it is 1 to
      // rounding and the normalised sum is the grid's plain sum in another
      // order: a few ulps of each r, times the prefilter's gain (<= 342).
      EXPECT_LT(max_abs_diff(got.c, grid.c), 1e-13) << name(cs) << " factor " << s;
    }
  }
}

TEST(Scattered, ConvergesToTheGridProjectionAsDensityGrows) {
  const long W = 16, H = 12;
  Image fine(W * 32, H * 32, 1);
  for (long j = 0; j < H * 32; ++j)
    for (long i = 0; i < W * 32; ++i) fine.at(i, j, 0) = float(smooth((i + 0.5) / 32, (j + 0.5) / 32));
  for (int degree : {1, 3}) {
    ProjectionOptions po;
    po.generator = Kernel::bspline(degree);
    const Coefficients grid = project(fine, W, H, po);
    for (ScatteredRule rule : {ScatteredRule::NormalisedSum, ScatteredRule::LeastSquares}) {
      std::vector<double> err;
      for (int s : {2, 4, 8, 16}) {
        ScatteredOptions o;
        o.rule = rule;
        const Coefficients k = project_scattered(jittered(W, H, s, 7), target(W, H, degree, Boundary::Mirror), o);
        double e2 = 0;
        for (std::size_t e = 0; e < k.c.data.size(); ++e)
          e2 += (k.c.data[e] - grid.c.data[e]) * (k.c.data[e] - grid.c.data[e]);
        err.push_back(std::sqrt(e2 / k.c.data.size()));
      }
      // Jittered quadrature of a smooth integrand with M = s^2 samples per
      // pixel errs like M^{-1/2 - 1/2} = s^{-2} in 2-D: 4 times less per
      // doubling of s. Asserted on the RMS over the coefficients: at least
      // 2.5 times (measured 2.9 to 5.5 with these seeds).
      for (std::size_t e = 1; e < err.size(); ++e)
        EXPECT_GT(err[e - 1] / err[e], 2.5)
            << "degree " << degree << ' ' << scattered_rule_name(rule) << " step " << e << ": "
            << err[e - 1] << " -> " << err[e];
    }
  }
}

// The threads split the coefficient rows, each coefficient's terms in the
// samples' order: the same bits for any count, jittered samples in rows (so
// that the blocks of samples reach different rows) and shuffled ones, every
// rule, three channels and one.
TEST(Scattered, SameBitsForAnyThreadCount) {
  ScatteredSamples rows = jittered(64, 48, 3, 5);
  ScatteredSamples shuffled = rows;
  std::mt19937_64 g(3);
  for (long i = shuffled.count() - 1; i > 0; --i) {
    const long j = long(g() % std::uint64_t(i + 1));
    std::swap(shuffled.positions[2 * i], shuffled.positions[2 * j]);
    std::swap(shuffled.positions[2 * i + 1], shuffled.positions[2 * j + 1]);
    std::swap(shuffled.values[i], shuffled.values[j]);
  }
  ScatteredSamples colour = rows;
  colour.channels = 3;
  colour.values.clear();
  for (long i = 0; i < rows.count(); ++i)
    for (int c = 0; c < 3; ++c) colour.values.push_back(rows.values[i] + 0.1 * c);
  for (const ScatteredSamples* s : {&rows, &shuffled, &colour})
    for (Boundary b : {Boundary::Mirror, Boundary::Periodic})
      for (ScatteredRule rule :
           {ScatteredRule::NormalisedSum, ScatteredRule::PlainSum, ScatteredRule::LeastSquares}) {
        const ScatteredTarget t = target(64, 48, 3, b);
        ScatteredOptions o;
        o.rule = rule;
        o.threads = 1;
        const Coefficients one = project_scattered(*s, t, o);
        const std::vector<double> at_one = evaluate_at_samples(one, *s, 1);
        for (int threads : {2, 3, 7}) {
          o.threads = threads;
          const Coefficients k = project_scattered(*s, t, o);
          ASSERT_EQ(k.c.data.size(), one.c.data.size());
          EXPECT_TRUE(std::equal(k.c.data.begin(), k.c.data.end(), one.c.data.begin()))
              << scattered_rule_name(rule) << ' ' << boundary_name(b) << ' ' << threads << " threads";
          EXPECT_EQ(evaluate_at_samples(one, *s, threads), at_one) << threads << " threads";
        }
      }
}

TEST(Scattered, BadInputIsRefusedWithAClearMessage) {
  const ScatteredTarget t = target(4, 3, 3, Boundary::Mirror);
  const ScatteredSamples good = random_samples(100, 1, 4, 3, 1);
  auto with = [&](auto change) {
    ScatteredSamples s = good;
    change(s);
    return s;
  };
  expect_error([&] { project_scattered(with([](auto& s) { s.positions[10] = 4.5; }), t); },
               "sample 5 at (4.5");
  expect_error([&] { project_scattered(with([](auto& s) { s.positions[3] = -0.01; }), t); },
               "outside the frame");
  expect_error([&] { project_scattered(with([](auto& s) { s.positions[0] = NAN; }), t); },
               "sample 0 has a non-finite position");
  expect_error([&] { project_scattered(with([](auto& s) { s.values[7] = INFINITY; }), t); },
               "sample 7 has a non-finite value in channel 0");
  expect_error([&] { project_scattered(with([](auto& s) { s.values.pop_back(); }), t); },
               "values hold 99 numbers, expected 100");
  expect_error([&] { project_scattered(with([](auto& s) { s.positions.pop_back(); }), t); },
               "not two (x, y) per sample");
  expect_error([&] { project_scattered(with([](auto& s) { s.weights.assign(99, 1.0); }), t); },
               "weights hold 99 numbers, expected 100");
  expect_error([&] { project_scattered(with([](auto& s) { s.weights.assign(100, 1.0); s.weights[4] = 0; }), t); },
               "sample 4 has weight");
  // A coefficient whose support holds no sample.
  ScatteredSamples corner;
  corner.positions = {0.1, 0.1};
  corner.values = {1.0};
  expect_error([&] { project_scattered(corner, target(8, 8, 1, Boundary::Mirror)); },
               "no sample in its generator's support");
  ScatteredTarget conv = t;
  conv.method = Method::Conventional;
  conv.space = CartesianSpace{Kernel::mitchell()};
  ScatteredOptions fit;
  fit.rule = ScatteredRule::LeastSquares;
  expect_error([&] { project_scattered(good, conv, fit); }, "conventional method takes the normalised");
  ScatteredTarget mitchell = t;
  mitchell.space = CartesianSpace{Kernel::mitchell()};
  expect_error([&] { project_scattered(good, mitchell); }, "min-error needs a B-spline");
  expect_error([] { parse_scattered_rule("exact"); }, "unknown scattered rule 'exact'");
  // A bad sample past the first blocks: named as in one pass; the
  // acquisition, holding part of the call, refuses more.
  for (int threads : {1, 2}) {
    const ScatteredTarget big = target(64, 48, 3, Boundary::Mirror);
    ScatteredSamples late = jittered(64, 48, 2, 9);
    late.values[10000] = NAN;
    ScatteredAcquisition acq(big, 1, threads);
    expect_error([&] { acq.add(late); }, "sample 10000 has a non-finite value in channel 0");
    EXPECT_THROW(acq.finish(ScatteredRule::NormalisedSum), std::logic_error) << threads;
    EXPECT_THROW(acq.add(jittered(64, 48, 2, 9)), std::logic_error) << threads;
  }
  // Counts that do not match leave it as it was.
  ScatteredAcquisition acq(t, 1);
  expect_error([&] { acq.add(with([](auto& s) { s.values.pop_back(); })); }, "values hold 99");
  acq.add(good);
  EXPECT_NO_THROW(acq.finish(ScatteredRule::NormalisedSum));
}

}  // namespace
}  // namespace sis
