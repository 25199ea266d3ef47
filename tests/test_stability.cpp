// Where the method fails, measured (docs/design.md section 6): noise gain against
// theory, the step response's overshoot, and the range remedies.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <random>
#include <thread>

#include "sis/metrics.h"
#include "sis/projection.h"
#include "sis/range.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {
// (1/pi) integral_0^pi g(w) dw by the midpoint rule (g smooth and periodic:
// spectrally accurate).
template <class G>
double mean_over_period(G g) {
  const int n = 4096;
  double s = 0;
  for (int i = 0; i < n; ++i) s += g((i + 0.5) * kPi / n);
  return s / n;
}
}  // namespace

TEST(HighlightCompression, IsOpenImageIOsCurveAndInvertible) {
  for (double x : {0.0, 0.05, -0.1, 0.18, -0.18}) EXPECT_EQ(highlight_compress(x), x);
  EXPECT_NEAR(highlight_compress(0.18 + 1e-9), 0.18, 1e-6);  // continuous at the knee
  double prev = -1e9;
  for (double x = -1000; x <= 1000; x += 0.37) {
    const double y = highlight_compress(x);
    EXPECT_GT(y, prev);  // monotone
    prev = y;
    EXPECT_EQ(highlight_compress(-x), -y);
    EXPECT_NEAR(highlight_expand(y), x, 1e-12 * std::max(1.0, std::abs(x)));
  }
  EXPECT_LT(highlight_compress(100.0), 2.0);  // 100 maps below 2
}

TEST(LocalRange, MatchesBruteForceAtAnyRatio) {
  // 3 and 4 channels take the vectorised path, the others the scalar ones
  for (int C : {1, 2, 3, 4, 5})
  for (auto [win, hin, W, H] : {std::array<long, 4>{37, 23, 10, 6}, {8, 8, 20, 13}, {40, 40, 10, 10}}) {
    std::mt19937 rng(win + C);
    std::uniform_real_distribution<float> u(-1, 1);
    Image in(win, hin, C);
    for (float& v : in.data) v = u(rng);
    LocalRange lr(win, hin, C, W, H);
    for (long y = 0; y < hin; y += 5) lr.add_rows(y, std::min(hin, y + 5), in.row(y));
    // the same in three steps, strips of 3 rows folded in pieces of 7
    // values (not whole samples), the pieces in decreasing order
    LocalRange split(win, hin, C, W, H);
    const long values = win * C;
    for (long y0 = 0; y0 < hin; y0 += 3) {
      const long y1 = std::min(hin, y0 + 3);
      split.open(y0, y1);
      for (long k0 = (values - 1) / 7 * 7; k0 >= 0; k0 -= 7)
        for (long y = y0; y < y1; ++y)
          split.fold(y, k0, std::min(values, k0 + 7), in.row(y) + k0);
      split.close(y1);
    }
    EXPECT_EQ(split.min().data, lr.min().data);
    EXPECT_EQ(split.max().data, lr.max().data);
    // in bands of 1 and 4 rows (an output row's input rows in several
    // bands): in order, and the bands at once on two threads in decreasing
    // order, in strips of 3
    for (long band_rows : {1L, 4L}) {
      LocalRange ordered(win, hin, C, W, H, band_rows);
      ordered.add_rows(0, hin, in.row(0));
      EXPECT_EQ(ordered.min().data, lr.min().data) << band_rows;
      EXPECT_EQ(ordered.max().data, lr.max().data) << band_rows;
      LocalRange banded(win, hin, C, W, H, band_rows);
      const BandPartition bands(hin, band_rows);
      std::atomic<long> next{bands.count() - 1};
      auto worker = [&] {
        LocalRange::Band band(banded);
        for (long b; (b = next--) >= 0;) {
          band.begin(b);
          for (long y0 = bands.begin(b); y0 < bands.end(b); y0 += 3) {
            const long y1 = std::min(bands.end(b), y0 + 3);
            band.open(y0, y1);
            for (long y = y0; y < y1; ++y) band.fold(y, 0, values, in.row(y));
            band.close(y1);
          }
          band.end();
        }
      };
      std::thread other(worker);
      worker();
      other.join();
      EXPECT_EQ(banded.min().data, lr.min().data) << band_rows;
      EXPECT_EQ(banded.max().data, lr.max().data) << band_rows;
    }
    // per axis: the samples inside the pixel's interval, or (upsampling) the
    // last at or before its centre and the first after it, those that exist
    auto inside = [](long i, long samples, long count, long p) {
      const double x = (i + 0.5) * count / samples;
      bool any = false;
      for (long k = 0; k < samples; ++k) {
        const double xk = (k + 0.5) * count / samples;
        any = any || (xk >= p && xk < p + 1);
      }
      if (any) return x >= p && x < p + 1;
      const double centre = p + 0.5;
      long before = -1, after = samples;
      for (long k = 0; k < samples; ++k) {
        const double xk = (k + 0.5) * count / samples;
        if (xk <= centre) before = k;
        if (xk > centre && after == samples) after = k;
      }
      if (before < 0) return i == after;  // left of the first sample
      if (after == samples) return i == before;
      return i == before || i == after;
    };
    for (long m = 0; m < H; ++m)
      for (long n = 0; n < W; ++n)
        for (int c = 0; c < C; ++c) {
          float lo = 1e9f, hi = -1e9f;
          for (long j = 0; j < hin; ++j)
            for (long i = 0; i < win; ++i)
              if (inside(i, win, W, n) && inside(j, hin, H, m)) {
                lo = std::min(lo, in.at(i, j, c));
                hi = std::max(hi, in.at(i, j, c));
              }
          EXPECT_EQ(lr.min().at(n, m, c), lo) << win << " " << W << " " << C;
          EXPECT_EQ(lr.max().at(n, m, c), hi) << win << " " << W << " " << C;
        }
  }
}

TEST(Noise, MeasuredGainIsTheDiscreteOperatorsExactGain) {
  // The seeded measurement (variance over one noise image) against each
  // method's exact discrete gain, within 4 standard deviations of the
  // measurement; and that exact gain against the continuous theory of
  // docs/design.md section 6, which models the sampling as continuous: the
  // min-error tent's coefficients have exact gain 2.815 at factor 4 against a
  // continuous 3 (within 7 %).
  const long N = 160, s = 4;
  const double sigma = 0.1;
  std::mt19937 rng(2026);
  std::normal_distribution<float> noise(0, float(sigma));
  Image in(N * s, N * s, 1);
  for (float& v : in.data) v = 0.5f + noise(rng);
  auto variance = [](const std::vector<double>& v) {
    double m = 0, q = 0;
    for (double x : v) m += x;
    m /= v.size();
    for (double x : v) q += (x - m) * (x - m);
    return q / (v.size() - 1);
  };
  const double unit = sigma * sigma / (s * s);
  // The continuous theory per axis, squared for 2-D: min-error coefficients
  // a^{-1}[0] = mean(1/A_d); the centred display mean(B_d^2 / A_d), B_d the
  // display taps' transform; conventional tent (integral tent^2) /
  // (integral tent)^2 = 2/3.
  auto coefficients_theory = [](int d) {
    return std::pow(mean_over_period([&](double w) { return 1 / bspline_autocorrelation_spectrum(d, w); }), 2);
  };
  auto centred_theory = [](int d) {
    return std::pow(mean_over_period([&](double w) {
      double B = bspline(d, 0);
      for (int t = 1; t <= d; ++t) B += 2 * bspline(d, t) * std::cos(t * w);
      return B * B / bspline_autocorrelation_spectrum(d, w);
    }), 2);
  };
  EXPECT_NEAR(coefficients_theory(1), 3.0, 1e-6);
  EXPECT_NEAR(coefficients_theory(3), 24.6, 0.05);
  EXPECT_NEAR(centred_theory(3), 1.45, 0.01);
  struct Case {
    const char* name;
    int degree;
    Method method;
    bool display;  // the centred display, else the coefficients
    double continuous;
  };
  const Case cases[] = {
      {"min-error tent coefficients", 1, Method::MinError, false, coefficients_theory(1)},
      {"min-error tent centred", 1, Method::MinError, true, centred_theory(1)},
      {"min-error cubic coefficients", 3, Method::MinError, false, coefficients_theory(3)},
      {"min-error cubic centred", 3, Method::MinError, true, centred_theory(3)},
      {"conventional tent coefficients", 1, Method::Conventional, false, 4.0 / 9.0}};
  for (const Case& t : cases) {
    auto apply = [&](const Image& image) {
      ProjectionOptions o;
      o.generator = Kernel::bspline(t.degree);
      o.method = t.method;
      o.boundary = Boundary::Periodic;
      const Coefficients k = project(image, N, N, o);
      if (!t.display) return std::vector<double>(k.c.data.begin(), k.c.data.end());
      const Image p = resample(k, Display::centred(), N, N);
      return std::vector<double>(p.data.begin(), p.data.end());
    };
    const DiscreteNoiseGain exact = discrete_noise_gain(apply, N, s);
    const double measured = variance(apply(in)) / unit;
    EXPECT_NEAR(measured / exact.gain, 1.0, 4 * exact.relative_sd)
        << t.name << ": measured " << measured << ", exact " << exact.gain << ", sd "
        << exact.relative_sd;
    EXPECT_NEAR(exact.gain / t.continuous, 1.0, 0.07) << t.name << ": exact " << exact.gain;
    if (t.degree == 1 && t.method == Method::MinError && !t.display) {
      EXPECT_NEAR(exact.gain, 2.815, 0.001);
    }
  }
}

TEST(Stability, StepOvershootMatchesTheGeneratorsPrediction) {
  // A vertical step edge on a pixel boundary, densely sampled (s = 16, the
  // edge on a sample-cell boundary): the displayed overshoot equals the exact
  // 1-D step response to the quadrature's accuracy.
  const long N = 64, s = 16;
  Image in(N * s, 8 * s, 1);
  for (long j = 0; j < in.height; ++j)
    for (long i = 0; i < in.width; ++i) in.at(i, j, 0) = i >= N * s / 2 ? 1.0f : 0.0f;
  for (int d : {1, 2, 3})
    for (const Display& disp : {Display::centred(), Display::antialiased_2x2()}) {
      ProjectionOptions o;
      o.generator = Kernel::bspline(d);
      const Image p = final_image(project(in, N, 8, o), disp, N, 8);
      double over = 0, under = 0;
      for (long x = 0; x < N; ++x) {
        over = std::max(over, double(p.at(x, 4, 0)) - 1);
        under = std::max(under, -double(p.at(x, 4, 0)));
      }
      const StepResponse theory = step_response(d, disp);
      EXPECT_GT(theory.overshoot, 1e-3) << d;  // min-error rings: Gibbs
      EXPECT_NEAR(over, theory.overshoot, 2e-3) << d << " " << disp.name();
      EXPECT_NEAR(under, theory.undershoot, 2e-3) << d << " " << disp.name();
    }
}

TEST(Stability, ClampsBoundTheDisplayedSamples) {
  Image img(3, 1, 1);
  img.data = {-0.5f, 0.5f, 2.0f};
  LocalRange lr(3, 1, 1, 3, 1);
  const Buffer<float> row = {0.0f, 0.25f, 1.0f};
  lr.add_rows(0, 1, row.data());
  const RangeReport r = report_range(img, &lr);
  EXPECT_EQ(r.negative, 1);
  EXPECT_EQ(r.out_of_range, 3);
  EXPECT_EQ(r.min, -0.5);
  EXPECT_EQ(r.max, 2.0);
  Image z = img;
  apply_clamp(z, Clamp::Zero, nullptr);
  EXPECT_EQ(z.data, (Buffer<float>{0.0f, 0.5f, 2.0f}));
  Image l = img;
  apply_clamp(l, Clamp::Local, &lr);
  EXPECT_EQ(l.data, row);
  EXPECT_THROW(apply_clamp(l, Clamp::Local, nullptr), std::invalid_argument);
  EXPECT_THROW(parse_clamp("soft"), std::invalid_argument);
}

TEST(Stability, RangeReportEqualsADirectCount) {
  // A size that is not a whole number of vector lanes (and large enough to
  // be split among threads), NaN samples among the values, the local range
  // of a random input at factor 2; report_range at 1, 2 and 3 threads
  // against a plain loop with the same tolerance.
  const long W = 401, H = 173, C = 3;
  Image img = random_image(W, H, C, 3, -0.2f, 1.2f);
  for (std::size_t q = 0; q < img.data.size(); q += 997) img.data[q] = NAN;
  const Image in = random_image(2 * W, 2 * H, C, 4);
  LocalRange lr(2 * W, 2 * H, C, W, H);
  lr.add_rows(0, 2 * H, in.data.data());
  double lo = INFINITY, hi = -INFINITY;
  long negative = 0, out = 0;
  for (std::size_t q = 0; q < img.data.size(); ++q) {
    const float v = img.data[q];
    if (std::isnan(v)) continue;
    lo = std::min<double>(lo, v);
    hi = std::max<double>(hi, v);
    negative += v < 0;
    const float a = lr.min().data[q], b = lr.max().data[q];
    const float tol = 1e-5f * std::max({1.0f, std::abs(a), std::abs(b)});
    out += v < a - tol || v > b + tol;
  }
  EXPECT_GT(negative, 0);
  EXPECT_GT(out, 0);
  for (int threads : {1, 2, 3}) {
    const RangeReport r = report_range(img, &lr, threads);
    EXPECT_EQ(r.min, lo) << threads;
    EXPECT_EQ(r.max, hi) << threads;
    EXPECT_EQ(r.negative, negative) << threads;
    EXPECT_EQ(r.out_of_range, out) << threads;
    EXPECT_EQ(r.samples, long(img.data.size())) << threads;
    EXPECT_EQ(report_range(img, nullptr, threads).out_of_range, 0) << threads;
  }
  // A zero minimum met as -0 in one lane and +0 in another: reported as +0
  // at any thread count.
  Image z(W, H, C);
  std::fill(z.data.begin(), z.data.end(), 0.5f);
  z.data[1] = -0.0f;
  z.data[z.data.size() / 2 + 7] = 0.0f;
  for (int threads : {1, 2, 3}) {
    const RangeReport r = report_range(z, nullptr, threads);
    EXPECT_EQ(r.min, 0.0) << threads;
    EXPECT_FALSE(std::signbit(r.min)) << threads;
  }
}

TEST(Numerics, PrefilterErrorStaysNearRoundingForEveryDegree) {
  // Zero-mean random r excites every frequency (the worst case for the
  // conditioning). Prefiltering r rounded to float against r in double: the
  // difference, relative to the largest coefficient, stays at float rounding
  // (2^-24 = 6e-8) for every degree, though the 2-D condition number reaches
  // 4.7e5 at degree 7: the amplified frequencies are amplified alike in c.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int d = 0; d <= kMaxDegree; ++d) {
    const long n = 128;
    Grid<double> r(n, n, 1);
    for (double& v : r.data) v = u(rng);
    Grid<double> rf = r, c = r;
    for (double& v : rf.data) v = static_cast<float>(v);
    const PrefilterPlan plan(d, n, n, Boundary::Mirror);
    plan.execute(c);
    plan.execute(rf);
    double peak = 0, err = 0;
    for (std::size_t q = 0; q < c.data.size(); ++q) {
      peak = std::max(peak, std::abs(c.data[q]));
      err = std::max(err, std::abs(rf.data[q] - c.data[q]));
    }
    EXPECT_LT(err / peak, 2 * std::ldexp(1.0, -24)) << "degree " << d;
  }
}
