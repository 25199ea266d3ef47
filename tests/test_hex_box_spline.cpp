// Three-directional box splines (docs/design.md section 7): the piecewise
// polynomial form against the closed form of the hat, the slow exact integral
// and a direct convolution; partition of unity, support, symmetry; the
// autocorrelation on the lattice and its condition number.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "sis/box_spline.h"
#include "sis/generator.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {

double hex_norm(double u1, double u2) {
  return std::max({std::abs(u1), std::abs(u2), std::abs(u1 + u2)});
}

// The hexagonal hat: 1 at 0, 0 at the six neighbours, linear on each triangle.
double hat_closed_form(double u1, double u2) { return std::max(0.0, 1.0 - hex_norm(u1, u2)); }

// int_lo^hi g by 3-point Gauss-Legendre between the sorted breakpoints:
// exact when g is a polynomial of degree <= 5 between them.
template <typename F>
double piecewise_gauss(std::vector<double> b, double lo, double hi, F g) {
  static const double x[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
  static const double w[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  b.push_back(lo);
  b.push_back(hi);
  std::sort(b.begin(), b.end());
  double s = 0;
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double a = std::max(b[i], lo), c = std::min(b[i + 1], hi);
    if (!(c > a)) continue;
    for (int q = 0; q < 3; ++q) s += 0.5 * (c - a) * w[q] * g(0.5 * (a + c) + 0.5 * (c - a) * x[q]);
  }
  return s;
}

// (hat * hat)(u) = int hat(w) hat(u - w) dw, directly. Along w1 (w2 fixed)
// the integrand is quadratic between w1 in Z, Z - w2, u1 + Z, u1 + u2 - w2 + Z;
// the result is cubic in w2 between w2 in Z, u2 + Z, u1 + u2 + Z, -u1 + Z.
double hat_self_convolution(double u1, double u2) {
  std::vector<double> outer;
  for (int k = -3; k <= 3; ++k)
    for (double off : {0.0, u2, u1 + u2, -u1}) outer.push_back(k + off);
  return piecewise_gauss(outer, -1, 1, [&](double w2) {
    std::vector<double> inner;
    for (int k = -4; k <= 4; ++k)
      for (double off : {0.0, -w2, u1, u1 + u2 - w2}) inner.push_back(k + off);
    return piecewise_gauss(inner, -2, 2, [&](double w1) {
      return hat_closed_form(w1, w2) * hat_closed_form(u1 - w1, u2 - w2);
    });
  });
}

// Random points over the support, a third of them on knot lines.
std::vector<std::pair<double, double>> points(int n, unsigned seed, int count = 400) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-n - 0.5, n + 0.5);
  std::vector<std::pair<double, double>> p;
  for (int i = 0; i < count; ++i) {
    double a = u(rng), b = u(rng);
    if (i % 3 == 1) a = std::round(a);
    if (i % 6 == 2) b = std::round(a + b) - a;
    p.push_back({a, b});
  }
  return p;
}

}  // namespace

TEST(BoxSpline, HatIsTheClosedForm) {
  const BoxSpline& B = BoxSpline::hexagonal(1);
  EXPECT_EQ(B.name(), "hex-hat");
  EXPECT_EQ(B.degree(), 1);
  for (const auto& [a, b] : points(1, 1)) {
    EXPECT_NEAR(B.eval(a, b), hat_closed_form(a, b), 1e-15) << a << " " << b;
    EXPECT_NEAR(box_spline_exact(1, a, b), hat_closed_form(a, b), 1e-15) << a << " " << b;
  }
  for (int k1 = -2; k1 <= 2; ++k1)
    for (int k2 = -2; k2 <= 2; ++k2) EXPECT_EQ(B.eval(k1, k2), (k1 == 0 && k2 == 0) ? 1.0 : 0.0);
}

TEST(BoxSpline, QuarticIsTheHatConvolvedWithItself) {
  // Doubling every direction is convolving the hat with itself. The
  // reference is a direct convolution, exact by its piecewise Gauss rules;
  // the piecewise polynomial form is interpolated from box_spline_exact, so
  // both agree to the rounding of a 15 x 15 interpolation (about 1e-15).
  const BoxSpline& B = BoxSpline::hexagonal(2);
  EXPECT_EQ(B.name(), "hex-quartic");
  EXPECT_EQ(B.degree(), 4);
  for (const auto& [a, b] : points(2, 2, 300)) {
    const double ref = hat_self_convolution(a, b);
    EXPECT_NEAR(box_spline_exact(2, a, b), ref, 2e-15) << a << " " << b;
    EXPECT_NEAR(B.eval(a, b), ref, 4e-15) << a << " " << b;
  }
  // Its values on the lattice: 1/2 at 0, 1/12 at the six neighbours.
  EXPECT_NEAR(B.eval(0, 0), 0.5, 1e-15);
  for (auto [k1, k2] : {std::pair{1, 0}, {0, 1}, {-1, 1}, {-1, 0}, {0, -1}, {1, -1}})
    EXPECT_NEAR(B.eval(k1, k2), 1.0 / 12, 1e-15);
}

TEST(BoxSpline, PartitionOfUnitySupportAndSymmetry) {
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    const BoxSpline& B = BoxSpline::hexagonal(n);
    for (const auto& [a, b] : points(n, 10 + n)) {
      double sum = 0;
      for (int k1 = -n - 2; k1 <= n + 2; ++k1)
        for (int k2 = -n - 2; k2 <= n + 2; ++k2) sum += B.eval(a - k1, b - k2);
      EXPECT_NEAR(sum, 1.0, 4e-15) << n << " at " << a << " " << b;
      const double v = B.eval(a, b);
      if (hex_norm(a, b) >= n) {
        EXPECT_EQ(v, 0.0);
      }
      EXPECT_GE(v, 0.0);
      // 60 degree rotation e1 -> e2 -> e3: (u1, u2) -> (-u2, u1 + u2);
      // mirror x -> -x: (u1, u2) -> (-u1 - u2, u2).
      EXPECT_NEAR(B.eval(-b, a + b), v, 4e-15) << n;
      EXPECT_NEAR(B.eval(-a - b, b), v, 4e-15) << n;
    }
  }
}

TEST(BoxSpline, SlicesAreExactAndProjectToBSplines) {
  // The slice at height v, integrated over t, is the X-ray of M_n along e1:
  // the box spline of the directions' projections, the B-spline b_{2n-1}(v).
  // Integrated over v it gives int M_n = 1.
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    const BoxSpline& B = BoxSpline::hexagonal(n);
    BoxSplineSlice s;
    std::mt19937 rng(n);
    std::uniform_real_distribution<double> u(-n - 0.2, n + 0.2);
    for (int i = 0; i < 200; ++i) {
      const double v = i % 10 == 0 ? std::round(u(rng)) : u(rng);
      B.slice(v, s);
      EXPECT_NEAR(s.integrate(-10, 10), bspline(2 * n - 1, v), 4e-15) << n << " " << v;
      for (int j = 0; j < 20; ++j) {
        const double t = u(rng);
        EXPECT_NEAR(s.eval(t), B.eval(t - 0.5 * v, v), 1e-15) << n << " " << v << " " << t;
        EXPECT_NEAR(s.eval(-t), s.eval(t), 4e-15);
      }
      // partial integrals against Gauss on the knots (degree 3n - 2 <= 5)
      const double a = u(rng), b = u(rng);
      std::vector<double> knots;
      for (int k = -n - 1; k <= n + 1; ++k) {
        knots.push_back(k + 0.5 * v);
        knots.push_back(k - 0.5 * v);
      }
      EXPECT_NEAR(s.integrate(a, b),
                  (a < b ? 1 : -1) * piecewise_gauss(knots, std::min(a, b), std::max(a, b),
                                                     [&](double t) { return s.eval(t); }),
                  1e-15);
    }
  }
}

TEST(BoxSpline, BandIntegralsAreRectangleIntegrals) {
  // Y(t1) - Y(t0) of the band [v0, v1] against int_{v0}^{v1} of the slice's
  // exact integral over [t0, t1], by 3-point Gauss in v between the heights
  // where the rectangle's sides cross knot lines (the integrand has degree
  // 3n - 1 <= 5 there). The band's total is the X-ray identity integrated:
  // int_{v0}^{v1} b_{2n-1}(v) dv. Tolerance: Y sums up to ~25 pieces, each
  // interpolated at 3n Chebyshev nodes on [-1, 1] (measured: below 1e-15).
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    const BoxSpline& B = BoxSpline::hexagonal(n);
    std::mt19937 rng(20 + n);
    std::uniform_real_distribution<double> u(-n - 0.3, n + 0.3);
    BoxSplineBand band;
    BoxSplineSlice s;
    for (int i = 0; i < 60; ++i) {
      double v0 = u(rng), v1 = u(rng);
      if (i % 7 == 0) v0 = std::round(v0);
      if (v1 < v0) std::swap(v0, v1);
      band.build(B, v0, v1);
      EXPECT_NEAR(band.total(),
                  bspline_cumulative(2 * n - 1, v1) - bspline_cumulative(2 * n - 1, v0), 3e-15);
      for (int r = 0; r < 10; ++r) {
        double t0 = u(rng), t1 = u(rng);
        if (t1 < t0) std::swap(t0, t1);
        std::vector<double> heights;
        for (int k = -2 * n - 2; k <= 2 * n + 2; ++k)
          for (double e : {0.0, 2 * t0, -2 * t0, 2 * t1, -2 * t1}) heights.push_back(k + e);
        const double ref = piecewise_gauss(heights, v0, v1, [&](double v) {
          B.slice(v, s);
          return s.integrate(t0, t1);
        });
        std::size_t h0 = 0, h1 = 0;
        EXPECT_NEAR(band.antiderivative(t1, h1) - band.antiderivative(t0, h0), ref, 3e-15)
            << n << " band " << v0 << " " << v1 << " t " << t0 << " " << t1;
      }
    }
  }
}

TEST(BoxSpline, AutocorrelationOnTheLattice) {
  // a[k] = int M(u) M(u - k) du = M_2n(k): the autocorrelation of a centred
  // box spline is the box spline with every direction doubled, sampled on the
  // lattice; box_spline_exact(2n) is an independent route to it.
  const BoxSpline& hat = BoxSpline::hexagonal(1);
  ASSERT_EQ(hat.autocorrelation().size(), 7u);
  for (const HexTap& t : hat.autocorrelation())
    EXPECT_NEAR(t.value, (t.k1 == 0 && t.k2 == 0) ? 0.5 : 1.0 / 12, 1e-15);
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    const BoxSpline& B = BoxSpline::hexagonal(n);
    double sum = 0;
    for (const HexTap& t : B.autocorrelation()) {
      EXPECT_NEAR(t.value, box_spline_exact(2 * n, t.k1, t.k2), 1e-15) << n;
      EXPECT_LT(hex_norm(t.k1, t.k2), 2 * n);
      sum += t.value;
    }
    EXPECT_NEAR(sum, 1.0, 2e-15);  // partition of unity: sum_k a[k] = int M = 1
    EXPECT_NEAR(B.autocorrelation_spectrum(0, 0), 1.0, 2e-15);
  }
  EXPECT_EQ(BoxSpline::hexagonal(2).autocorrelation().size(), 37u);  // hexagon of radius 3
}

TEST(BoxSpline, ConditionNumbers) {
  // docs/design.md: 4 for the hat (A = 1/2 + (cos w1 + cos w2 + cos(w2 - w1))/6,
  // from 1 at 0 down to 1/4 at the K points); about 52 for the quartic.
  // Both extremes sit at 0 and K = (2 pi/3, -2 pi/3).
  const BoxSpline& hat = BoxSpline::hexagonal(1);
  EXPECT_NEAR(hat.condition_number(), 4.0, 1e-12);
  EXPECT_NEAR(hat.autocorrelation_spectrum(2 * kPi / 3, -2 * kPi / 3), 0.25, 1e-15);
  const BoxSpline& quartic = BoxSpline::hexagonal(2);
  const double kappa = quartic.condition_number();
  EXPECT_GT(kappa, 51.5);
  EXPECT_LT(kappa, 52.5);
  EXPECT_NEAR(kappa, 1.0 / quartic.autocorrelation_spectrum(2 * kPi / 3, -2 * kPi / 3), 1e-9);
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n)  // positive everywhere: a Riesz basis
    for (int i = 0; i < 60; ++i)
      for (int j = 0; j < 60; ++j) {
        const double w1 = 2 * kPi * i / 60, w2 = 2 * kPi * j / 60;
        EXPECT_GT(BoxSpline::hexagonal(n).autocorrelation_spectrum(w1, w2), 0.0);
      }
}

TEST(BoxSpline, Errors) {
  EXPECT_THROW(BoxSpline::hexagonal(0), std::invalid_argument);
  EXPECT_THROW(BoxSpline::hexagonal(3), std::invalid_argument);
  EXPECT_THROW(BoxSpline::parse("hex-cubic"), std::invalid_argument);
  EXPECT_EQ(&BoxSpline::parse("hex-quartic"), &BoxSpline::hexagonal(2));
  EXPECT_THROW(box_spline_exact(9, 0, 0), std::invalid_argument);
}
