// Acquisition at factors that are not a whole number of samples per lattice
// step (docs/design.md section 10): the samples' cubic Lagrange model
// integrated exactly against the generator, against a brute-force
// quadrature of the model; flat images stay flat and ramps ramps for every
// generator on both lattices.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "sis/hex_projection.h"
#include "sis/projection.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {

// Every Cartesian generator the tools offer, with the method it takes.
std::vector<Kernel> every_kernel() {
  std::vector<Kernel> k;
  for (int d = 0; d <= 7; ++d) k.push_back(Kernel::bspline(d));
  for (const char* name : {"mitchell", "gaussian", "catmull-rom", "lanczos3"})
    k.push_back(Kernel::parse(name));
  return k;
}
Method method_of(const Kernel& k) { return k.is_bspline() ? Method::MinError : Method::Conventional; }

// Input sizes for the output sizes below: factors 1.5, 2.5 and 3.3 (the
// issue's), and different non-integer ratios per axis (a --size).
struct Case {
  long W, H, win, hin;
};
std::vector<Case> cases(long W, long H) {
  std::vector<Case> c;
  for (double f : {1.5, 2.5, 3.3}) c.push_back({W, H, std::lround(W * f), std::lround(H * f)});
  c.push_back({W, H, std::lround(W * 2.37), std::lround(H * 1.71)});
  return c;
}

// The 4-point cubic Lagrange cardinal function, written out: on [0, 1)
// the interpolation weight of the sample at distance |t| from the two
// nearer samples, on [1, 2) from the two farther ones.
double cardinal(double t) {
  const double a = std::abs(t);
  if (a < 1) return (1 - a * a) * (2 - a) / 2;
  if (a < 2) return (1 - a) * (2 - a) * (3 - a) / 6;
  return 0;
}

// One axis by brute force: A[n][m] = (1/h) int f_m(x) phi((x - p_n) / h) dx
// with f_m the model of the unit sample m (the cardinal functions of the
// extended samples folded onto m by the rule), h = 1, p_n = n + 1/2, by the
// midpoint rule on N points of phi's support (its ends, where the box
// jumps, on cell edges). Conventional: rows normalised to sum 1.
std::vector<std::vector<double>> model_axis_by_quadrature(long count, long samples, const Kernel& phi,
                                                          Boundary rule, Method method) {
  const double step = double(count) / samples, R = phi.radius();
  const int N = 60000;
  std::vector<std::vector<double>> A(count, std::vector<double>(samples, 0.0));
  for (long n = 0; n < count; ++n) {
    const double p = n + 0.5;
    for (int q = 0; q < N; ++q) {
      const double t = -R + (q + 0.5) * (2 * R / N);
      const double v = phi.eval(t) * (2 * R / N);
      const double u = (p + t) / step - 0.5;  // sample coordinate
      for (long j = long(std::floor(u)) - 1; j <= long(std::floor(u)) + 2; ++j)
        A[n][extend_index(j, samples, rule)] += v * cardinal(u - double(j));
    }
    if (method == Method::Conventional) {
      double s = 0;
      for (double w : A[n]) s += w;
      for (double& w : A[n]) w /= s;
    }
  }
  return A;
}

}  // namespace

TEST(Factor, AcquisitionIsTheModelsExactInnerProduct) {
  // Non-integer ratios on both axes (9 x 7 from 23 x 19, 13 x 11 from 20 x
  // 29), every generator, both rules, against model_axis_by_quadrature.
  // Tolerance: the midpoint rule's error on integrands with kinks (the
  // cardinal function's, the generator's) falls as the cell's square,
  // (2R / N)^2: below 1e-8 for every case here already at N = 20000, so
  // 1e-8 at N = 60000 leaves a margin of 9.
  for (auto [W, H, win, hin] : {std::array<long, 4>{9, 7, 23, 19}, {13, 11, 20, 29}})
    for (const Kernel& k : every_kernel())
      for (Boundary rule : {Boundary::Mirror, Boundary::Periodic}) {
        const Method m = method_of(k);
        const Image in = random_image(win, hin, 2, 42);
        const AcquisitionPlan plan(win, hin, 2, W, H, Lattice::cartesian(), k, rule, m);
        const Coefficients got = acquire(in, plan, 2);
        const auto ax = model_axis_by_quadrature(W, win, k, rule, m);
        const auto ay = model_axis_by_quadrature(H, hin, k, rule, m);
        for (long n2 = 0; n2 < H; ++n2)
          for (long n1 = 0; n1 < W; ++n1)
            for (int c = 0; c < 2; ++c) {
              double want = 0;
              for (long j = 0; j < hin; ++j)
                for (long i = 0; i < win; ++i) want += ay[n2][j] * ax[n1][i] * in.at(i, j, c);
              ASSERT_NEAR(got.c.at(n1, n2, c), want, 1e-8)
                  << k.name() << " " << boundary_name(rule) << " " << win << " x " << hin << " -> "
                  << W << " x " << H << " at " << n1 << ", " << n2;
            }
      }
}

TEST(Factor, WholeRatiosKeepThePointSum) {
  // A whole number of samples per pixel on an axis (here x: 3, y: 1.5) keeps
  // the plain point sum on that axis: its weights are step * phi(x_i - p_n).
  const AcquisitionPlan plan(27, 21, 1, 9, 14, Lattice::cartesian(), Kernel::bspline(3),
                             Boundary::Mirror, Method::MinError);
  const AxisWeights& wx = plan.weights_x();
  for (long n = 0; n < 9; ++n)
    for (long e = wx.begin(n); e < wx.end(n); ++e) {
      // interior coefficients only: the border folds several samples into one
      if (n < 2 || n > 6) continue;
      const long i = wx.index[e];
      EXPECT_EQ(wx.weight[e], (1.0 / 3.0) * bspline(3, ((i + 0.5) * (9.0 / 27.0) - (n + 0.5))))
          << n << " " << i;
    }
  // y is a Lagrange axis: each interior coefficient reaches 2 samples beyond
  // its support on each side (the cubic support 4 pixels holds 6 samples).
  const AxisWeights& wy = plan.weights_y();
  EXPECT_EQ(wy.end(7) - wy.begin(7), 6 + 4);
}

namespace {

// A flat image and a ramp a + b x + c y (output pixels) in double samples.
const double kFlat = 0.25;
const double kRamp[3] = {0.5, 0.004, 0.002};
double ramp(double x, double y) { return kRamp[0] + kRamp[1] * x + kRamp[2] * y; }

Grid<double> sampled(long win, long hin, double W, double H, bool flat) {
  Grid<double> g(win, hin, 1);
  for (long j = 0; j < hin; ++j)
    for (long i = 0; i < win; ++i)
      g.at(i, j, 0) = flat ? kFlat : ramp((i + 0.5) * W / win, (j + 0.5) * H / hin);
  return g;
}

// Pixels from the border where the mirror extension of a ramp (not a ramp)
// still shows: the prefilter's slowest pole decays as |z|^k per pixel, from
// a jump of at most the ramp's slope times the generator's support (0.03):
// |z|^k below 1e-7 of it. Conventional filters have no prefilter, only
// their support (3 for Lanczos-3) plus the model's 2 samples of up to 3.3
// pixels: 10.
long ramp_border(const Kernel& k) {
  if (!k.is_bspline() || k.degree() < 1) return 10;
  const double z = std::abs(bspline_prefilter_poles(k.degree()).front());
  return 10 + long(std::ceil(std::log(1e-7) / std::log(z)));
}

// Half an ulp of the float final image (2^-24 relative), with the double
// computation's rounding: weights and sums of about 100 terms each axis,
// through a prefilter of gain up to 1 / A_7(pi)^2 (about 1e5 for degree 7)
// on values below 2: 1e-16 * 100 * 1e5 * 2 = 2e-9.
double tolerance(double want) { return std::ldexp(std::abs(want), -24) + 2e-9; }

}  // namespace

TEST(Factor, FlatStaysFlatAndRampStaysRampOnTheCartesianLattice) {
  // At non-integer factors, every generator, the centred display (the
  // conventional filters' pixels themselves): a flat image is flat
  // everywhere (the model is a constant, the mirror and periodic extensions
  // of a constant too), a ramp a ramp away from the border. Every method
  // keeps a ramp at pixel centres: the projection onto a space of degree
  // >= 1 holds it, the box's pixel average of a ramp is its centre value,
  // and a symmetric normalised filter's average too.
  for (const Case& s : cases(150, 130))
    for (const Kernel& k : every_kernel())
      for (bool flat : {true, false}) {
        const Method m = method_of(k);
        const Grid<double> in = sampled(s.win, s.hin, double(s.W), double(s.H), flat);
        for (Boundary rule : {Boundary::Mirror, Boundary::Periodic}) {
          if (!flat && rule == Boundary::Periodic) continue;  // a wrapped ramp jumps
          const AcquisitionPlan plan(s.win, s.hin, 1, double(s.W), double(s.H),
                                     Lattice::cartesian(), k, rule, m);
          Coefficients c = acquire(in, plan, 2);
          if (m == Method::MinError) prefilter(c, 2);
          const Image out = final_image(c, Display::centred(), s.W, s.H, 2);
          const long border = flat ? 0 : ramp_border(k);
          ASSERT_LT(2 * border, std::min(s.W, s.H)) << k.name();
          double worst = 0;
          for (long y = border; y < s.H - border; ++y)
            for (long x = border; x < s.W - border; ++x) {
              const double want = flat ? kFlat : ramp(x + 0.5, y + 0.5);
              const double e = std::abs(out.at(x, y, 0) - want);
              worst = std::max(worst, e);
              ASSERT_LE(e, tolerance(want))
                  << k.name() << " " << boundary_name(rule) << " " << s.win << " x " << s.hin
                  << " -> " << s.W << " x " << s.H << (flat ? " flat" : " ramp") << " at " << x
                  << ", " << y;
            }
        }
      }
}

TEST(Factor, FlatStaysFlatAndRampStaysRampOnTheHexagonalLattice) {
  // The hexagonal aligned rule at the same factors, hat and quartic (both
  // reproduce degree 1): flat everywhere, a ramp away from the border (the
  // quartic's slowest decay 0.48 per step: 1e-7 after 25 steps, 27 pixels),
  // through the centred display.
  for (const Case& s : cases(100, 90))
    for (int order : {1, 2})
      for (bool flat : {true, false}) {
        HexProjectionOptions o;
        o.order = order;
        const Grid<double> in = sampled(s.win, s.hin, double(s.W), double(s.H), flat);
        const Coefficients c = project_hexagonal(in, double(s.W), double(s.H), o);
        const Image out = final_image(c, Display::centred(), s.W, s.H, 2);
        const long border = flat ? 0 : 30;
        for (long y = border; y < s.H - border; ++y)
          for (long x = border; x < s.W - border; ++x) {
            const double want = flat ? kFlat : ramp(x + 0.5, y + 0.5);
            ASSERT_LE(std::abs(out.at(x, y, 0) - want), tolerance(want))
                << "order " << order << " " << s.win << " x " << s.hin << " -> " << s.W << " x "
                << s.H << (flat ? " flat" : " ramp") << " at " << x << ", " << y;
          }
      }
}
