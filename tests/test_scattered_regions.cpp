// Scattered samples from regions of the frame at their own densities: the
// left half sampled 16 times per pixel, the right half twice, each sample
// weighing its region's area over its region's count. Only the frame's edges
// fold; the inner edge between the regions is no edge for the rules.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "sis/hex_lattice.h"
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
  t.space = CartesianSpace{Kernel::bspline(degree)};
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
    spline.space = t.space;
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

// Regions of jittered samples (one uniform sample in each cell of a q x q
// grid per pixel), the left half at q = 4, the right at q = 2, each weighing
// its cell's area: every support of the hexagonal hat (3 pixels^2) holds
// samples, where the uniform ones above leave some empty at 2 a pixel.
ScatteredSamples two_jittered_regions(double W, double H, int channels, std::uint64_t seed,
                                      double (*f)(double, double) = nullptr) {
  std::mt19937_64 g(seed);
  ScatteredSamples s;
  s.channels = channels;
  for (int half = 0; half < 2; ++half) {
    const int q = half == 0 ? 4 : 2;
    for (long j = 0; j < long(H) * q; ++j)
      for (long i = long(W / 2) * q * half; i < long(W / 2) * q * (half + 1); ++i) {
        const double x = (i + uniform(g)) / q, y = (j + uniform(g)) / q;
        s.positions.push_back(x);
        s.positions.push_back(y);
        s.weights.push_back(1.0 / (q * q));
        for (int c = 0; c < channels; ++c) s.values.push_back(f ? f(x, y) : 0.0);
      }
  }
  return s;
}

// The two regions on the hexagonal lattice: flat exact for the normalised
// sum and the fit, both generators, both boundary rules.
ScatteredTarget hex_target(int order, Boundary boundary) {
  ScatteredTarget t;
  t.width = kW;
  t.height = kH;
  t.space = HexagonalSpace{order, 1.0};
  t.boundary = boundary;
  return t;
}

TEST(ScatteredRegions, FlatImageComesBackExactAcrossTheDensityBoundaryOnTheHexagonalLattice) {
  for (int order : {1, 2})
    for (Boundary b : {Boundary::Mirror, Boundary::Periodic})
      for (ScatteredRule rule : {ScatteredRule::NormalisedSum, ScatteredRule::LeastSquares}) {
        ScatteredSamples s = two_jittered_regions(kW, kH, 2, 7);
        for (std::size_t e = 0; e < s.values.size(); ++e) s.values[e] = e % 2 ? -0.4 : 0.63;
        ScatteredOptions o;
        o.rule = rule;
        const Coefficients k = project_scattered(s, hex_target(order, b), o);
        // Exact but for double rounding (as above; the hexagonal prefilter's
        // FFT, gain at most 52).
        for (std::size_t e = 0; e < k.c.data.size(); ++e)
          ASSERT_NEAR(k.c.data[e], e % 2 ? -0.4 : 0.63, 1e-12)
              << "order " << order << ' ' << boundary_name(b) << ' ' << scattered_rule_name(rule)
              << " element " << e;
        o.rule = ScatteredRule::PlainSum;
        const Coefficients plain = project_scattered(s, hex_target(order, b), o);
        double worst = 0;
        for (std::size_t e = 0; e < plain.c.data.size(); ++e)
          worst = std::max(worst, std::abs(plain.c.data[e] - (e % 2 ? -0.4 : 0.63)));
        EXPECT_GT(worst, 1e-2) << "order " << order << ' ' << boundary_name(b);
      }
}

// A ramp along x, f = 0.2 + 0.05 x, over a frame 64 x 8 whose left half is
// sampled 16 times per pixel and right half 4 times (jittered). The ramp is not a
// function of the extended image's space: mirror folds it into a kink at
// x = 0 and x = W (periodic into a jump), where no spline of either space
// follows it (a mirrored spline has slope 0 there; a periodic one is
// continuous), while along y it is constant, which both rules extend
// exactly. Away from the x edges both spaces reproduce linear functions
// (the Cartesian B-splines of degree >= 1, the box splines too), so the
// converged fit is the ramp up to the edges' effect, which decays
// geometrically into the frame (as G^{-1} does, like the prefilter's
// a^{-1}: rho per lattice step, the largest pole of b_{2d+1} for the
// B-splines, 0.268 for the tent and 0.535 for the cubic; about 0.2 and 0.48
// for the box splines, sis/hex_lattice.h). So the ramp is exact to rounding
// only where rho^d has fallen below it. Asserted: f_app at the samples
// within 8 pixels of the inner edge between the regions (x in [24, 40],
// d = 24 pixels from the frame's edges) equals the ramp within 10 rho^d
// times its error at the edges, or 1e-12 (double rounding through the
// prefilter's gain) where that is smaller: exact to rounding for the tent
// and the hat, within 3e-6 times the edge error for the cubic and 8e-7
// for the quartic (measured: at most 8e-7 and 5e-8 of it). An effect of the inner edge would show there. Within 2
// pixels of the frame's x edges the error is above 1e-4 (the test can
// fail).
struct RampCase {
  std::string name;
  ScatteredTarget target;
  double rho, step;  // the decay per lattice step, the step in pixels
};

TEST(ScatteredRegions, RampComesBackExactAcrossTheDensityBoundaryAwayFromTheFramesEdges) {
  const double W = 64, H = 8;
  std::vector<RampCase> cases;
  for (int degree : {1, 3})
    for (Boundary b : {Boundary::Mirror, Boundary::Periodic}) {
      ScatteredTarget t;
      t.width = W;
      t.height = H;
      t.space = CartesianSpace{Kernel::bspline(degree)};
      t.boundary = b;
      cases.push_back({"degree " + std::to_string(degree) + ' ' + boundary_name(b), t,
                       degree == 1 ? 0.268 : 0.535, 1.0});
    }
  for (int order : {1, 2})
    for (Boundary b : {Boundary::Mirror, Boundary::Periodic}) {
      ScatteredTarget t;
      t.width = W;
      t.height = H;
      t.space = HexagonalSpace{order, 1.0};
      t.boundary = b;
      cases.push_back({std::string(order == 1 ? "hex-hat " : "hex-quartic ") + boundary_name(b), t,
                       order == 1 ? 0.2 : 0.48, Lattice::hexagonal(1.0).matrix()[0]});
    }
  const ScatteredSamples s =
      two_jittered_regions(W, H, 1, 5, [](double x, double) { return 0.2 + 0.05 * x; });
  for (const RampCase& cs : cases) {
    ScatteredOptions o;
    o.rule = ScatteredRule::LeastSquares;
    o.iterations = 600;
    o.tolerance = 1e-15;
    ScatteredReport report;
    const Coefficients k = project_scattered(s, cs.target, o, &report);
    const std::vector<double> at = evaluate_at_samples(k, s);
    double inner = 0, edge = 0;
    for (long i = 0; i < s.count(); ++i) {
      const double x = s.positions[2 * i], e = std::abs(at[i] - s.values[i]);
      if (x >= 24 && x <= 40) inner = std::max(inner, e);
      if (x < 2 || x > W - 2) edge = std::max(edge, e);
    }
    const double tolerance = std::max(1e-12, 10 * std::pow(cs.rho, 24 / cs.step) * edge);
    EXPECT_LT(inner, tolerance) << cs.name << " after " << report.iterations
                                << " iterations; error at the edges " << edge;
    EXPECT_GT(edge, 1e-4) << cs.name;
    EXPECT_LT(report.residual[0], 1e-14) << cs.name;
  }
}

}  // namespace
}  // namespace sis
