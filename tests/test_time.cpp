// The temporal half of the space-time projection (sis/time.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numeric>

#include "sis/generator.h"
#include "sis/time.h"

namespace {

using namespace sis;

// K sub-frames at the centres of K equal parts of each of n intervals of
// length L starting at t0.
std::vector<double> centres(double t0, double L, int n, int K) {
  std::vector<double> t;
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < K; ++k) t.push_back(t0 + L * i + L * (k + 0.5) / K);
  return t;
}

double model(const TimeProjection& p, const std::vector<double>& c, double t) {
  double s = 0;
  for (int i = 0; i < p.count(); ++i)
    s += c[i] * bspline(p.degree(), (t - p.origin()) / p.step() - (p.first() + i));
  return s;
}

Shutter box(double angle, double phase) {
  Shutter s;
  s.angle = angle;
  s.phase = phase;
  return s;
}

// Degree 0, a 360-degree box shutter centred on the frame (phase -180, so the
// shutter of frame k is the B-spline cell of coefficient k) and K sub-frames at
// the centres of K equal parts of the frame interval: each weight is 1/K on
// the frame's own sub-frames and 0 elsewhere. Rounding: the cells q_k are
// differences of times of size ~1 (error ~1e-16 each), so 1e-13 is ample.
TEST(Time, DegreeZeroFullShutterIsTheSubFrameAverage) {
  const double fps = 24;
  const int K = 5, n = 6;
  const std::vector<double> t = centres(-0.5 / fps, 1 / fps, n, K);
  TimeProjection p(t, 0, 1 / fps, TimeModel::Hold);
  const Shutter s = box(360, -180);
  for (int f = 0; f < n; ++f) {
    const std::vector<double> u = frame_weights(p, s, f / fps, fps);
    const std::vector<double> v = conventional_frame_weights(t, s, f / fps, fps);
    for (int k = 0; k < n * K; ++k) {
      const double want = (k / K == f) ? 1.0 / K : 0.0;
      EXPECT_NEAR(u[k], want, 1e-13) << "frame " << f << " sub-frame " << k;
      EXPECT_NEAR(v[k], want, 1e-15) << "frame " << f << " sub-frame " << k;
    }
  }
}

// Display weights against a slow direct integration (midpoint rule with 2e6
// points across the open shutter; the integrand's kinks and the shutter's
// jumps cost at most ~1/N relative, hence 1e-5).
TEST(Time, DisplayWeightsMatchDirectIntegration) {
  const double fps = 30, S = 1 / 40.0;
  for (int curve = 0; curve < 4; ++curve) {
    for (int D = 0; D <= 3; ++D) {
      Shutter s = box(216, 30);
      s.curve = static_cast<ShutterCurve>(curve);
      if (s.curve == ShutterCurve::Table) {
        s.table_u = {0, 0.3, 1};
        s.table_weight = {0.5, 2, 1};
      }
      const double T = 7 / fps;
      const int first = -2, count = 20;
      const std::vector<double> w = display_weights(s, T, fps, D, S, first, count);
      const double o = s.open(T, fps), c = s.close(T, fps);
      const int N = 2000000;
      std::vector<double> ref(count, 0.0);
      double total = 0;
      for (int i = 0; i < N; ++i) {
        const double x = o + (c - o) * (i + 0.5) / N;
        const double sw = s.weight(x, T, fps);
        total += sw;
        for (int j = 0; j < count; ++j) ref[j] += sw * bspline(D, x / S - (first + j));
      }
      double sum = 0;
      for (int j = 0; j < count; ++j) {
        EXPECT_NEAR(w[j], ref[j] / total, 1e-5) << "curve " << curve << " D " << D << " m " << first + j;
        sum += w[j];
      }
      // partition of unity, exact to rounding
      EXPECT_NEAR(sum, 1.0, 1e-13) << "curve " << curve << " D " << D;
    }
  }
}

// A static scene (the same sub-frame K times): every frame's weights sum to
// one, so the frame is the spatial result, on uneven times and every degree:
// the cells tile the span and their integrals of the B-splines are exact, so
// the only error is rounding in the Gram solve (condition number < 3 for
// degree 3; 1e-12 is ample).
TEST(Time, StaticSceneGivesTheSpatialResult) {
  const double fps = 24;
  std::vector<double> t = centres(0, 1 / fps, 8, 4);
  for (size_t k = 0; k < t.size(); ++k) t[k] += (k % 2 ? 0.2 : -0.1) / fps / 4;  // uneven
  for (int D = 0; D <= 3; ++D) {
    TimeProjection p(t, D, 1 / fps, TimeModel::Hold);
    const Shutter s = box(180, 0);
    int a, b;
    default_frames(t, s, fps, a, b);
    ASSERT_LE(a, b);
    for (int f = a; f <= b; ++f) {
      const std::vector<double> u = frame_weights(p, s, f / fps, fps);
      const double sum = std::accumulate(u.begin(), u.end(), 0.0);
      EXPECT_NEAR(sum, 1.0, 1e-12) << "D " << D << " frame " << f;
    }
  }
}

// Polynomials of degree <= D are reproduced in the interior: constants
// exactly (to rounding), higher degrees up to the hold of each sub-frame over
// its cell (16 uniform sub-frames per step; measured at most 8.6e-5 for
// D = 3 on values of size 1, 4.7e-7 for D = 1; 2e-4 leaves room for rounding
// of the platform's libm only, the hold's error itself being deterministic).
TEST(Time, PolynomialsReproducedInTheInterior) {
  const double S = 0.1;
  const std::vector<double> t = centres(0, S, 24, 16);
  for (int D = 0; D <= 3; ++D) {
    TimeProjection p(t, D, S, TimeModel::Hold);
    for (int n = 0; n <= D; ++n) {
      std::vector<double> f(t.size());
      for (size_t k = 0; k < t.size(); ++k) f[k] = std::pow(t[k] / 2.4 - 0.5, n) * 2;
      const std::vector<double> c = p.coefficients(f);
      double worst = 0;
      for (double x = 0.8; x <= 1.6; x += 0.0137)
        worst = std::max(worst, std::abs(model(p, c, x) - std::pow(x / 2.4 - 0.5, n) * 2));
      EXPECT_LT(worst, n == 0 ? 1e-13 : 2e-4) << "D " << D << " n " << n;
    }
  }
}

// The weights of a frame decay away from its shutter by the largest
// prefilter pole per step: the share of sum |u_k| beyond J steps is below
// |z|^J (the window a streaming front end keeps, docs/design.md section 16).
TEST(Time, WeightsDecayAwayFromTheShutter) {
  std::vector<double> t;
  for (int k = 0; k < 400; ++k) t.push_back((k + 0.5) / 100.0);
  const double fps = 25;
  for (int D = 1; D <= 3; ++D) {
    TimeProjection p(t, D, 1 / fps, TimeModel::Hold);
    const Shutter s = box(180, 0);
    const std::vector<double> u = frame_weights(p, s, 2.0, fps);
    const double z = std::abs(bspline_prefilter_poles(D)[0]);
    for (int J : {10, 14}) {
      double tail = 0, total = 0;
      for (size_t k = 0; k < t.size(); ++k) {
        const double d = std::max(s.open(2.0, fps) - t[k], t[k] - s.close(2.0, fps)) * fps;
        total += std::abs(u[k]);
        if (d >= J) tail += std::abs(u[k]);
      }
      EXPECT_LT(tail / total, std::pow(z, J)) << "D " << D << " J " << J;
      EXPECT_GT(tail, 0) << "D " << D << " J " << J;
    }
  }
}

TEST(Time, BadTimesAndShuttersAreRefused) {
  EXPECT_THROW(check_times({1.0}), std::invalid_argument);
  EXPECT_THROW(check_times({0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(check_times({0.0, -1.0}), std::invalid_argument);
  EXPECT_THROW(check_times({0.0, NAN}), std::invalid_argument);
  EXPECT_THROW(parse_shutter("0", "box"), std::invalid_argument);
  EXPECT_THROW(parse_shutter("361", "box"), std::invalid_argument);
  EXPECT_THROW(parse_shutter("x", "box"), std::invalid_argument);
  EXPECT_THROW(parse_shutter("180", "/nonexistent/curve.txt"), std::invalid_argument);
  EXPECT_EQ(parse_shutter("360", "tent").angle, 360);
  EXPECT_EQ(parse_shutter("90:-45", "cubic").phase, -45);
  EXPECT_THROW(TimeProjection({0, 1}, 4, 1, TimeModel::Hold), std::invalid_argument);
  EXPECT_THROW(TimeProjection({0, 1}, 1, 0, TimeModel::Hold), std::invalid_argument);
  // a frame whose shutter falls outside the span
  TimeProjection p({0.0, 0.1, 0.2}, 1, 0.1, TimeModel::Hold);
  EXPECT_THROW(frame_weights(p, box(180, 0), 0.3, 10), std::invalid_argument);
  EXPECT_NO_THROW(frame_weights(p, box(180, 0), 0.0, 10));
}

TEST(Time, ShutterTableFile) {
  const std::string path = ::testing::TempDir() + "/shutter_table.txt";
  {
    std::ofstream o(path);
    o << "# u weight\n0 1\n0.5 2\n1 1\n";
  }
  const Shutter s = parse_shutter("180:0", path);
  EXPECT_EQ(s.curve, ShutterCurve::Table);
  EXPECT_DOUBLE_EQ(s.weight(0.025, 0, 10), 2.0);
  {
    std::ofstream o(path);
    o << "0 1\n0.5\n";
  }
  EXPECT_THROW(parse_shutter("180", path), std::invalid_argument);
  std::remove(path.c_str());
}

}  // namespace

// The interpolating models reproduce polynomials of their degree (and of the
// B-spline's, whichever is lower) at uneven times over the whole span, ends
// included (their projection is on the span, not mirrored), where the hold
// does so only up to O(h^2). Rounding: sums of ~250 terms of size ~1 through
// a Gram solve of condition ~1e2: 1e-11 is ample.
TEST(Time, InterpolatingModelsReproduceTheirPolynomials) {
  const double S = 0.1;
  const int steps = 30, per = 4;
  std::vector<double> t;
  for (int k = 0; k < steps * per; ++k)  // uneven: each inside its own cell
    t.push_back(S * (k + 0.5 + 0.35 * std::sin(1.7 * k)) / per);
  double a, b;
  time_span(t, a, b);
  for (TimeModel tm : {TimeModel::Linear, TimeModel::Cubic}) {
    const int q = tm == TimeModel::Linear ? 1 : 3;
    for (int D = 0; D <= 3; ++D) {
      for (double step : {S, S / per, 0.37 * S}) {
        TimeProjection p(t, D, step, tm);
        for (int n = 0; n <= std::min(q, D); ++n) {
          auto f = [&](double x) { return std::pow(x / (steps * S) - 0.5, n) * 2; };
          std::vector<double> v(t.size());
          for (size_t k = 0; k < t.size(); ++k) v[k] = f(t[k]);
          const std::vector<double> c = p.coefficients(v);
          double worst = 0;
          for (double x = a; x <= b; x += 0.00731)
            worst = std::max(worst, std::abs(model(p, c, x) - f(x)));
          EXPECT_LT(worst, 1e-11) << time_model_name(tm) << " D " << D << " n " << n << " step "
                                  << step;
        }
      }
    }
  }
}

// A degree above the model's is not reproduced: on a quadratic (D = 3, 4
// sub-frames per step) the hold and the linear model both leave an O(h^2)
// error, which the cubic model removes.
TEST(Time, HigherModelsReduceTheHoldsError) {
  const double S = 0.1;
  const std::vector<double> t = centres(0, S, 60, 4);
  auto f = [](double x) { return std::pow(x / 6 - 0.5, 2) * 2; };
  std::vector<double> v(t.size());
  for (size_t k = 0; k < t.size(); ++k) v[k] = f(t[k]);
  double err[3];
  int i = 0;
  for (TimeModel tm : {TimeModel::Hold, TimeModel::Linear, TimeModel::Cubic}) {
    TimeProjection p(t, 3, S, tm);
    const std::vector<double> c = p.coefficients(v);
    double worst = 0;
    for (double x = 2.5; x <= 3.5; x += 0.00731)
      worst = std::max(worst, std::abs(model(p, c, x) - f(x)));
    err[i++] = worst;
  }
  EXPECT_GT(err[0], 1e-6);
  EXPECT_GT(err[1], 1e-6);
  EXPECT_LT(err[2], 1e-9);
}

TEST(Time, ModelSpellings) {
  EXPECT_EQ(parse_time_model("hold"), TimeModel::Hold);
  EXPECT_EQ(parse_time_model("linear"), TimeModel::Linear);
  EXPECT_EQ(parse_time_model("cubic"), TimeModel::Cubic);
  EXPECT_THROW(parse_time_model("spline"), std::invalid_argument);
  for (TimeModel m : {TimeModel::Hold, TimeModel::Linear, TimeModel::Cubic})
    EXPECT_EQ(parse_time_model(time_model_name(m)), m);
}

// The same on the smallest sequences (2, 3 and 5 sub-frames, where the cubic
// model falls to the line and the quadratic), with one lattice step across
// the whole span (N = 1) and steps that do not divide it, at times near 0
// and near 1e4 s (the lattice's origin is the span's start). Rounding: the
// times near 1e4 s carry 1e4 x 2^-52 ~ 2e-12 s against spans of ~0.1 s,
// scaled by the basis' slopes: 1e-8 is ample.
TEST(Time, SmallSequencesReproduceTheirPolynomials) {
  for (int K : {2, 3, 5}) {
    for (double offset : {0.0, 1e4}) {
      std::vector<double> t;
      for (int k = 0; k < K; ++k) t.push_back(offset + 0.04 * (k + 0.3 * std::sin(2.3 * k)));
      double a, b;
      time_span(t, a, b);
      for (TimeModel tm : {TimeModel::Linear, TimeModel::Cubic}) {
        const int q = tm == TimeModel::Linear ? 1 : std::min(3, K - 1);
        for (int D = 0; D <= 3; ++D) {
          for (double step : {0.04, 3 * (b - a), (b - a) / 2.6}) {
            TimeProjection p(t, D, step, tm);
            EXPECT_NEAR(p.origin(), a + p.step() * (0.5 * (D + 1) - std::floor(0.5 * (D + 1))), 1e-12);
            for (int n = 0; n <= std::min(q, D); ++n) {
              auto f = [&](double x) { return std::pow((x - a) / (b - a) - 0.3, n); };
              std::vector<double> v;
              for (double x : t) v.push_back(f(x));
              const std::vector<double> c = p.coefficients(v);
              double worst = 0;
              // inside the span (a box B-spline is half-open; near 1e4 s the ends round)
              for (int i = 0; i <= 97; ++i) {
                const double x = a + (b - a) * std::clamp(i / 97.0, 1e-9, 1 - 1e-9);
                worst = std::max(worst, std::abs(model(p, c, x) - f(x)));
              }
              EXPECT_LT(worst, 1e-8) << "K " << K << " offset " << offset << " "
                                     << time_model_name(tm) << " D " << D << " step " << step
                                     << " n " << n;
            }
          }
        }
      }
    }
  }
}

// The hold's single mirror needs a span longer than a B-spline's support;
// shorter spans are refused rather than giving weights that do not sum to 1,
// and so are lattices of more than 1e7 steps.
TEST(Time, HoldNeedsASpanLongerThanTheSupport) {
  EXPECT_THROW(TimeProjection({0.0, 0.1}, 3, 0.1, TimeModel::Hold), std::invalid_argument);
  EXPECT_NO_THROW(TimeProjection({0.0, 0.1}, 1, 0.1, TimeModel::Hold));
  EXPECT_NO_THROW(TimeProjection({0.0, 0.1}, 3, 0.1, TimeModel::Cubic));
  EXPECT_THROW(TimeProjection({0.0, 0.1}, 1, 1e-12, TimeModel::Cubic), std::invalid_argument);
}
