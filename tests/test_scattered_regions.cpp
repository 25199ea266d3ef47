// Scattered samples from regions of the frame at their own densities: the
// left half sampled 16 times per pixel, the right half twice, each sample
// weighing its region's area over its region's count. Only the frame's edges
// fold; the inner edge between the regions is no edge for the rules.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "sis/scattered.h"

namespace sis {
namespace {

double uniform(std::mt19937_64& g) { return double(g() >> 11) * 0x1p-53; }

constexpr double kW = 24, kH = 16;

// Uniform samples in [x0, x1) x [0, kH) at `per_pixel` a pixel, weighing
// the region's area / its count.
void add_region(ScatteredSamples& s, double x0, double x1, int per_pixel, std::mt19937_64& g) {
  const long n = long((x1 - x0) * kH) * per_pixel;
  const double w = (x1 - x0) * kH / double(n);
  for (long i = 0; i < n; ++i) {
    s.positions.push_back(x0 + (x1 - x0) * uniform(g));
    s.positions.push_back(kH * uniform(g));
    s.weights.push_back(w);
    for (int c = 0; c < s.channels; ++c) s.values.push_back(0);
  }
}

ScatteredSamples two_regions(int channels, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  ScatteredSamples s;
  s.channels = channels;
  add_region(s, 0, kW / 2, 16, g);
  add_region(s, kW / 2, kW, 2, g);
  return s;
}

ScatteredTarget target(int degree, Boundary boundary) {
  ScatteredTarget t;
  t.width = kW;
  t.height = kH;
  t.generator = Kernel::bspline(degree);
  t.boundary = boundary;
  return t;
}

struct Case {
  int degree;
  Boundary boundary;
};
std::vector<Case> cases() {
  return {{1, Boundary::Mirror}, {3, Boundary::Mirror}, {3, Boundary::Periodic}, {2, Boundary::Periodic}};
}
std::string name(const Case& c) {
  return "degree " + std::to_string(c.degree) +
         (c.boundary == Boundary::Mirror ? " mirror" : " periodic");
}

TEST(ScatteredRegions, WeightsAreEachRegionsAreaOverItsCount) {
  const ScatteredSamples s = two_regions(1, 1);
  double left = 0, right = 0;
  long n_left = 0;
  for (long i = 0; i < s.count(); ++i) {
    (s.positions[2 * i] < kW / 2 ? left : right) += s.weights[i];
    n_left += s.positions[2 * i] < kW / 2;
  }
  EXPECT_EQ(n_left, 12 * 16 * 16);
  EXPECT_EQ(s.count() - n_left, 12 * 16 * 2);
  EXPECT_NEAR(left, kW / 2 * kH, 1e-9);
  EXPECT_NEAR(right, kW / 2 * kH, 1e-9);
}

TEST(ScatteredRegions, FlatImageComesBackExactAcrossTheDensityBoundary) {
  for (const Case& cs : cases()) {
    for (ScatteredRule rule : {ScatteredRule::NormalisedSum, ScatteredRule::LeastSquares}) {
      ScatteredSamples s = two_regions(2, 7);
      for (std::size_t e = 0; e < s.values.size(); ++e) s.values[e] = e % 2 ? -0.4 : 0.63;
      ScatteredOptions o;
      o.rule = rule;
      const Coefficients k = project_scattered(s, target(cs.degree, cs.boundary), o);
      // Exact but for double rounding: the weight sums of some 256 samples
      // per coefficient on the dense side, a quotient, and the prefilter's
      // FFT (relative errors of order 1e-15).
      for (std::size_t e = 0; e < k.c.data.size(); ++e)
        ASSERT_NEAR(k.c.data[e], e % 2 ? -0.4 : 0.63, 1e-12)
            << name(cs) << ' ' << scattered_rule_name(rule) << " element " << e;
      // The plain sum is not exact here (a check that the test can fail):
      // the right half's samples are 8 times sparser than the left's.
      o.rule = ScatteredRule::PlainSum;
      const Coefficients plain = project_scattered(s, target(cs.degree, cs.boundary), o);
      double worst = 0;
      for (std::size_t e = 0; e < plain.c.data.size(); ++e)
        worst = std::max(worst, std::abs(plain.c.data[e] - (e % 2 ? -0.4 : 0.63)));
      EXPECT_GT(worst, 1e-2) << name(cs);
    }
  }
}

TEST(ScatteredRegions, FitReproducesASplineOfTheSpaceAcrossTheDensityBoundary) {
  for (const Case& cs : cases()) {
    const ScatteredTarget t = target(cs.degree, cs.boundary);
    ScatteredSamples s = two_regions(1, 11);
    // a spline of the space: random coefficients, evaluated at the samples
    Coefficients spline;
    spline.c = Grid<double>(long(kW), long(kH), 1);
    spline.lattice = t.lattice;
    spline.space = CartesianSpace{t.generator};
    spline.boundary = t.boundary;
    spline.image_width = kW;
    spline.image_height = kH;
    std::mt19937_64 g(23);
    for (double& v : spline.c.data) v = uniform(g) - 0.5;
    s.values = evaluate_at_samples(spline, s);
    ScatteredOptions o;
    o.rule = ScatteredRule::LeastSquares;
    o.iterations = 400;
    o.tolerance = 1e-14;
    ScatteredReport report;
    const Coefficients k = project_scattered(s, t, o, &report);
    EXPECT_LT(report.iterations, 400) << name(cs) << ": the fit did not reach its tolerance";
    EXPECT_LE(report.residual[0], 1e-14) << name(cs);
    // The error is at most cond(G) times the relative residual (1e-14);
    // measured, the fit stops after 101 to 147 iterations with the
    // coefficients within 7e-13 of the spline's in these four cases: 1e-9
    // leaves room for another machine's rounding, not for a wrong fit.
    double worst = 0;
    for (std::size_t e = 0; e < k.c.data.size(); ++e)
      worst = std::max(worst, std::abs(k.c.data[e] - spline.c.data[e]));
    EXPECT_LT(worst, 1e-9) << name(cs);
    // The normalised rule does not reproduce it (a check that the test can fail).
    o.rule = ScatteredRule::NormalisedSum;
    const Coefficients n = project_scattered(s, t, o);
    double off = 0;
    for (std::size_t e = 0; e < n.c.data.size(); ++e)
      off = std::max(off, std::abs(n.c.data[e] - spline.c.data[e]));
    EXPECT_GT(off, 1e-3) << name(cs);
  }
}

}  // namespace
}  // namespace sis
