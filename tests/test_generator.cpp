// Generators: B-spline identities against a slow direct formula, the values
// of docs/design.md section 3, and the conventional filters' definitions.
#include <gtest/gtest.h>

#include <cmath>

#include "sis/generator.h"

using namespace sis;

namespace {

// Direct truncated-power formula, long double (independent of the recurrence),
// evaluated on the left half (b_d is even) where its terms cancel least.
long double truncated_power_bspline(int d, long double x) {
  x = -std::abs(x);
  long double s = 0, binom = 1, fact = 1;
  for (int k = 1; k <= d; ++k) fact *= k;
  for (int k = 0; k <= d + 1; ++k) {
    const long double t = x + (d + 1) / 2.0L - k;
    if (t > 0) s += ((k % 2) ? -1 : 1) * binom * std::pow(t, (long double)d);
    binom = binom * (d + 1 - k) / (k + 1);
  }
  return s / fact;
}

// Integral of f over [a, b], 8-point Gauss-Legendre on `pieces` equal pieces.
template <class F>
double gauss_legendre(F f, double a, double b, int pieces) {
  static const double X[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                              -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                              0.7966664774136267,  0.9602898564975363};
  static const double W[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                              0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                              0.2223810344533745, 0.1012285362903763};
  double s = 0, h = (b - a) / pieces;
  for (int p = 0; p < pieces; ++p) {
    const double m = a + (p + 0.5) * h;
    for (int i = 0; i < 8; ++i) s += 0.5 * h * W[i] * f(m + 0.5 * h * X[i]);
  }
  return s;
}

}  // namespace

TEST(BSpline, ValuesFromDesign) {
  for (double x : {-0.9, -0.3, 0.0, 0.25, 0.7}) EXPECT_NEAR(bspline(1, x), 1 - std::abs(x), 1e-15);
  EXPECT_NEAR(bspline(2, 0), 0.75, 1e-15);
  EXPECT_NEAR(bspline(2, 1), 0.125, 1e-15);
  EXPECT_NEAR(bspline(3, 0), 2.0 / 3, 1e-15);
  EXPECT_NEAR(bspline(3, 1), 1.0 / 6, 1e-15);
  EXPECT_NEAR(bspline(3, 0.5), 23.0 / 48, 1e-15);
  EXPECT_NEAR(bspline(3, 1.5), 1.0 / 48, 1e-15);
  const double b7[4] = {2416, 1191, 120, 1};
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(bspline(7, k), b7[k] / 5040, 1e-15) << k;
}

TEST(BSpline, MatchesTruncatedPowerFormula) {
  for (int d = 0; d <= 15; ++d)
    for (double x = -9.0; x <= 9.0; x += 0.0625 + 1e-3)
      EXPECT_NEAR(bspline(d, x), (double)truncated_power_bspline(d, x), 1e-13) << d << " " << x;
}

TEST(BSpline, PartitionOfUnitySymmetryAndSupport) {
  for (int d = 0; d <= kMaxDegree; ++d) {
    const double r = 0.5 * (d + 1);
    for (double x = -0.5; x < 0.5; x += 0.01) {
      double s = 0;
      for (int k = -10; k <= 10; ++k) s += bspline(d, x - k);
      EXPECT_NEAR(s, 1.0, 1e-14) << "degree " << d << " x " << x;
      if (d > 0) {
        EXPECT_DOUBLE_EQ(bspline(d, x), bspline(d, -x)) << d;
      }
    }
    for (double x : {r, r + 1e-9, r + 0.5, r + 3.0}) {
      EXPECT_EQ(bspline(d, x), 0.0) << d;
      EXPECT_EQ(bspline(d, -x - 1e-12), 0.0) << d;
    }
    const Kernel k = Kernel::bspline(d);
    EXPECT_EQ(k.radius(), r);
    EXPECT_NEAR(k.integral(), 1.0, 1e-14) << d;
    // integral by quadrature, independent of the cumulative formula
    EXPECT_NEAR(gauss_legendre([&](double x) { return bspline(d, x); }, -r, r, 2 * (d + 1)), 1.0,
                1e-13)
        << d;
  }
}

TEST(BSpline, CumulativeIsTheIntegral) {
  for (int d = 0; d <= kMaxDegree; ++d) {
    const double r = 0.5 * (d + 1);
    for (double x = -r - 0.5; x <= r + 0.5; x += 0.37) {  // derivative is b_d
      const double e = 1e-6;
      EXPECT_NEAR((bspline_cumulative(d, x + e) - bspline_cumulative(d, x - e)) / (2 * e),
                  bspline(d, x), 1e-6)
          << d << " " << x;
    }
    // exact where knots do not cut the quadrature pieces: half-integers
    for (int j = 0; j <= 2 * (d + 1); ++j) {
      const double x = -r + 0.5 * j;
      const double ref = gauss_legendre([&](double t) { return bspline(d, t); }, -r, x,
                                        std::max(1, j));
      EXPECT_NEAR(bspline_cumulative(d, x), ref, 1e-13) << d << " " << x;
    }
  }
}

TEST(BSpline, AutocorrelationIsTheGramOfShifts) {
  for (int d = 0; d <= kMaxDegree; ++d) {
    const auto a = bspline_autocorrelation(d);
    const double r = 0.5 * (d + 1);
    for (int k = 0; k <= d + 1; ++k) {
      // knots of both factors lie on the half-integer grid: exact quadrature
      const double g = gauss_legendre([&](double x) { return bspline(d, x) * bspline(d, x - k); },
                                      -r, r, 2 * (d + 1));
      EXPECT_NEAR(k <= d ? a[k] : 0.0, g, 1e-14) << d << " " << k;
    }
  }
}

TEST(BSpline, SpectrumClosedFormsAndConditionNumbers) {
  for (double w = 0; w <= 3.2; w += 0.05) {
    EXPECT_NEAR(bspline_autocorrelation_spectrum(1, w), (2 + std::cos(w)) / 3, 1e-15);
    EXPECT_NEAR(bspline_autocorrelation_spectrum(2, w), (33 + 26 * std::cos(w) + std::cos(2 * w)) / 60,
                1e-15);
    EXPECT_NEAR(bspline_autocorrelation_spectrum(3, w),
                (1208 + 1191 * std::cos(w) + 120 * std::cos(2 * w) + std::cos(3 * w)) / 2520, 1e-15);
    for (int d = 0; d <= kMaxDegree; ++d) EXPECT_GT(bspline_autocorrelation_spectrum(d, w), 0.0);
  }
  const double pi = std::acos(-1.0);
  EXPECT_NEAR(1 / bspline_autocorrelation_spectrum(1, pi), 3.0, 1e-12);
  EXPECT_NEAR(1 / bspline_autocorrelation_spectrum(2, pi), 7.5, 1e-12);
  EXPECT_NEAR(1 / bspline_autocorrelation_spectrum(3, pi), 2520.0 / 136, 1e-12);  // 18.53
}

TEST(BSpline, PrefilterPolesFromDesign) {
  EXPECT_TRUE(bspline_prefilter_poles(0).empty());
  const auto p1 = bspline_prefilter_poles(1);
  ASSERT_EQ(p1.size(), 1u);
  EXPECT_NEAR(p1[0], std::sqrt(3.0) - 2, 1e-14);
  const auto p3 = bspline_prefilter_poles(3);
  ASSERT_EQ(p3.size(), 3u);
  EXPECT_NEAR(p3[0], -0.5352804, 1e-7);
  EXPECT_NEAR(p3[1], -0.1225546, 1e-7);
  EXPECT_NEAR(p3[2], -0.0091487, 1e-7);
  // Every degree: each pole is a root of the autocorrelation's transform.
  for (int d = 1; d <= kMaxDegree; ++d) {
    const auto a = bspline_autocorrelation(d);
    for (double z : bspline_prefilter_poles(d)) {
      double s = a[0];
      for (int k = 1; k <= d; ++k) s += a[k] * (std::pow(z, k) + std::pow(z, -k));
      EXPECT_NEAR(s * std::pow(std::abs(z), d), 0.0, 1e-13) << d << " " << z;
      EXPECT_GT(z, -1.0);
      EXPECT_LT(z, 0.0);
    }
  }
}

TEST(Kernel, ConventionalFilters) {
  const Kernel m = Kernel::mitchell();
  EXPECT_EQ(m.radius(), 2.0);
  for (double x : {0.0, 0.3, 0.99}) {
    const double ax = std::abs(x);
    EXPECT_NEAR(m.eval(x), 7.0 / 6 * ax * ax * ax - 2 * x * x + 8.0 / 9, 1e-15);
  }
  for (double x : {1.0, 1.4, -1.8}) {
    const double ax = std::abs(x);
    EXPECT_NEAR(m.eval(x), -7.0 / 18 * ax * ax * ax + 2 * x * x - 10.0 / 3 * ax + 16.0 / 9, 1e-15);
  }
  EXPECT_NEAR(m.integral(), 1.0, 1e-14);
  const Kernel cr = Kernel::catmull_rom();
  EXPECT_NEAR(cr.eval(0), 1.0, 1e-15);
  EXPECT_NEAR(cr.eval(1), 0.0, 1e-15);
  EXPECT_NEAR(cr.integral(), 1.0, 1e-14);
  const Kernel l = Kernel::lanczos(3);
  EXPECT_EQ(l.radius(), 3.0);
  EXPECT_NEAR(l.eval(0), 1.0, 1e-15);
  for (int k = 1; k < 3; ++k) EXPECT_NEAR(l.eval(k), 0.0, 1e-15);
  EXPECT_EQ(l.eval(3.0), 0.0);
  const Kernel g = Kernel::gaussian();
  EXPECT_NEAR(g.eval(0), 1 - std::exp(-4.5), 1e-15);
  EXPECT_EQ(g.eval(1.5), 0.0);
  EXPECT_NEAR(g.eval(0.7), g.eval(-0.7), 1e-16);
}

TEST(Kernel, ParseAndName) {
  for (const char* s : {"box", "tent", "quadratic", "cubic", "bspline:5", "mitchell", "gaussian",
                        "catmull-rom", "lanczos3"})
    EXPECT_EQ(Kernel::parse(s).name(), s);
  EXPECT_EQ(Kernel::parse("bspline:3").name(), "cubic");
  EXPECT_EQ(Kernel::parse("bspline:0").degree(), 0);
  EXPECT_THROW(Kernel::parse("bspline:8"), std::invalid_argument);
  EXPECT_THROW(Kernel::parse("sinc"), std::invalid_argument);
  EXPECT_THROW(Kernel::bspline(-1), std::invalid_argument);
}
