// Adaptive rays (sis/refinement.h): nothing refined is the uniform render,
// a refined pixel's rays are the uniform sobol render's of that density,
// the estimators find a busy quadrant, and bad refinements are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "sis/pattern.h"
#include "sis/refinement.h"
#include "sis/scattered.h"

namespace sis {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A frame of 64 x 64 pixels, flat 0.5 but in its top-right quadrant
// (x >= 32, y < 32), which holds a zone plate centred on the frame's
// bottom-left corner: its local frequency K r / pi runs from 0.6 to 1.2
// cycles a pixel there (r from 45 to 90 pixels), past the space's Nyquist
// frequency everywhere in the quadrant, and its mean is the flat part's (so
// the quadrant's edge is no jump that would ring into the flat tiles).
double busy_quadrant(double x, double y) {
  if (x < 32 || y >= 32) return 0.5;
  const double K = 0.6 * kPi / 45, dx = x, dy = 64 - y;
  return 0.5 + 0.5 * std::cos(K * (dx * dx + dy * dy));
}

ScatteredSamples samples_of(const SamplePattern& p, double (*f)(double, double)) {
  ScatteredSamples s;
  s.channels = 1;
  s.positions.resize(std::size_t(2 * p.count()));
  sample_positions(p, 0, p.count(), s.positions.data());
  for (long i = 0; i < p.count(); ++i) s.values.push_back(f(s.positions[2 * i], s.positions[2 * i + 1]));
  return s;
}

std::vector<double> values_at(const std::vector<double>& xy, double (*f)(double, double)) {
  std::vector<double> v;
  for (std::size_t i = 0; i < xy.size(); i += 2) v.push_back(f(xy[i], xy[i + 1]));
  return v;
}

ScatteredTarget frame(double W, double H) {
  ScatteredTarget t;
  t.width = W;
  t.height = H;
  return t;
}

TEST(Refinement, NothingRefinedIsTheUniformRenderBitForBit) {
  const SamplePattern base = make_pattern(PatternKind::Sobol, 3, 40, 24, 2);
  const ScatteredSamples s = samples_of(base, busy_quadrant);
  const ScatteredTarget t = frame(40, 24);
  const Coefficients uniform = project_scattered(s, t);
  const std::vector<double> est = estimate_tile_error(s, uniform, t, {}, Estimator::Halves, 8);
  // a budget of the base's own 4 rays per pixel buys no tile
  const Refinement r = plan_refinement(base, est, 8, 4.0);
  EXPECT_TRUE(r.tiles.empty());
  EXPECT_EQ(r.extra_count(), 0);
  EXPECT_EQ(r.rays_per_pixel(), 4.0);
  const Coefficients adaptive = project_scattered(adaptive_samples(s, r, {}), t);
  ASSERT_EQ(adaptive.c.data.size(), uniform.c.data.size());
  EXPECT_EQ(std::memcmp(adaptive.c.data.data(), uniform.c.data.data(),
                        uniform.c.data.size() * sizeof(double)), 0);
  // and through the text a second pass's render carries
  const Refinement back = parse_refinement(refinement_text(r), "text");
  EXPECT_TRUE(back.tiles.empty());
  const Coefficients again = project_scattered(adaptive_samples(s, back, {}), t);
  EXPECT_EQ(std::memcmp(again.c.data.data(), uniform.c.data.data(), uniform.c.data.size() * sizeof(double)), 0);
}

TEST(Refinement, ARefinedPixelHoldsTheUniformSobolRaysOfItsDensity) {
  // base 4 rays a pixel, tiles of 3 pixels refined to 16 (edge tiles cut by
  // the 10 x 7 frame): every refined pixel's rays are exactly the uniform
  // sobol render's at 16 rays per pixel, each weighing 1/16; elsewhere the
  // base's, each 1/4.
  const SamplePattern base = make_pattern(PatternKind::Sobol, 9, 10, 7, 2);
  const SamplePattern fine = make_pattern(PatternKind::Sobol, 9, 10, 7, 4);
  const Refinement r = make_refinement(base, 3, 16, {0, 3, 11});  // 4 x 3 tiles; 11 the corner's (1 x 1 pixels)
  EXPECT_EQ(r.extra_count(), (9 + 3 + 1) * 12);
  ScatteredSamples s = samples_of(base, busy_quadrant);
  std::vector<double> xy(std::size_t(2 * r.extra_count()));
  extra_positions(r, 0, r.extra_count(), xy.data());
  const ScatteredSamples a = adaptive_samples(s, r, values_at(xy, busy_quadrant));
  ASSERT_EQ(a.count(), base.count() + r.extra_count());
  std::map<long, std::vector<std::pair<double, double>>> got, want;
  std::map<long, double> weight;
  for (long i = 0; i < a.count(); ++i) {
    const long p = long(a.positions[2 * i + 1]) * 10 + long(a.positions[2 * i]);
    got[p].push_back({a.positions[2 * i], a.positions[2 * i + 1]});
    if (weight.count(p)) {
      EXPECT_EQ(weight[p], a.weights[std::size_t(i)]);
    }
    weight[p] = a.weights[std::size_t(i)];
  }
  auto refined = [&](long p) {
    const long t = (p / 10) / 3 * 4 + (p % 10) / 3;
    return t == 0 || t == 3 || t == 11;
  };
  for (long k = 0; k < fine.count(); ++k) {
    const Vec2 q = sample_position(fine, k);
    const long p = long(q.y) * 10 + long(q.x);
    if (refined(p)) want[p].push_back({q.x, q.y});
  }
  for (long k = 0; k < base.count(); ++k) {
    const Vec2 q = sample_position(base, k);
    const long p = long(q.y) * 10 + long(q.x);
    if (!refined(p)) want[p].push_back({q.x, q.y});
  }
  for (long p = 0; p < 70; ++p) {
    std::sort(got[p].begin(), got[p].end());
    std::sort(want[p].begin(), want[p].end());
    EXPECT_EQ(got[p], want[p]) << "pixel " << p;
    EXPECT_EQ(weight[p], refined(p) ? 1.0 / 16 : 1.0 / 4) << "pixel " << p;
  }
}

TEST(Refinement, EstimatorsFindTheBusyQuadrant) {
  // 8 x 8 tiles of 8 pixels; the busy quadrant is tiles (4..7, 0..3). A
  // budget of 4 + 16 x 64 x 60 / 4096 = 19 rays per pixel buys exactly 16
  // tiles refined to 64 rays per pixel.
  const SamplePattern base = make_pattern(PatternKind::Sobol, 0, 64, 64, 2);
  const ScatteredSamples s = samples_of(base, busy_quadrant);
  const ScatteredTarget t = frame(64, 64);
  const Coefficients k = project_scattered(s, t);
  std::vector<long> quadrant;
  for (long ty = 0; ty < 4; ++ty)
    for (long tx = 4; tx < 8; ++tx) quadrant.push_back(ty * 8 + tx);
  // the oracle: the approximation's squared error against the closed form
  // per tile (4 x 4 points a pixel); its 16 worst tiles are the quadrant
  ScatteredSamples pts;
  pts.channels = 1;
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) {
      pts.positions.push_back((x + 0.5) / 4);
      pts.positions.push_back((y + 0.5) / 4);
      pts.values.push_back(0);
    }
  const std::vector<double> f = evaluate_at_samples(k, pts);
  std::vector<double> truth(64, 0.0);
  for (long i = 0; i < pts.count(); ++i) {
    const double x = pts.positions[2 * i], y = pts.positions[2 * i + 1];
    truth[std::size_t(long(y / 8) * 8 + long(x / 8))] += std::pow(f[std::size_t(i)] - busy_quadrant(x, y), 2) / 16;
  }
  EXPECT_EQ(plan_refinement(base, truth, 8, 19.0, 64).tiles, quadrant);
  // halves, contrast and residual find it; highpass does not (measured: two
  // tiles just outside the quadrant, at its inner corner, rank above its
  // weakest tile, the coefficients' aliased chirp spilling over its edge)
  for (Estimator e : {Estimator::Halves, Estimator::Contrast, Estimator::Residual}) {
    const std::vector<double> est = estimate_tile_error(s, k, t, {}, e, 8);
    ASSERT_EQ(est.size(), 64u);
    const Refinement r = plan_refinement(base, est, 8, 19.0, 64);
    EXPECT_EQ(r.tiles, quadrant) << estimator_name(e);
    EXPECT_EQ(r.rays_per_pixel(), 19.0);
    // the flat tiles two tiles or more from the quadrant: next to nothing
    // (the fit leaves the flat part exact but for what its residual
    // spreads from the quadrant: measured below 1e-5 of the quadrant's
    // weakest tile)
    double least = HUGE_VAL;
    for (long q : quadrant) least = std::min(least, est[std::size_t(q)]);
    for (long q = 0; q < 64; ++q)
      if (q % 8 < 2 || q / 8 > 5) {
        EXPECT_LT(est[std::size_t(q)], 1e-5 * least) << estimator_name(e) << " tile " << q;
      }
  }
}

TEST(Refinement, TheBudgetChoosesTheTiles) {
  const SamplePattern base = make_pattern(PatternKind::Sobol, 0, 20, 20, 1);
  std::vector<double> est(9);
  for (int q = 0; q < 9; ++q) est[std::size_t(q)] = q == 4 ? 5 : q == 8 ? 3 : q == 0 ? 3 : 0;
  // 3 x 3 tiles of 8 (the last column and row 4 pixels wide); refined to 9
  // rays: tile 4 costs 64 x 8, tile 0 too, tile 8 16 x 8; ties by index
  const Refinement r = plan_refinement(base, est, 8, 1 + (64 * 8 + 64 * 8 + 16 * 8) / 400.0, 9);
  EXPECT_EQ(r.tiles, (std::vector<long>{0, 4, 8}));
  const Refinement r2 = plan_refinement(base, est, 8, 1 + (64 * 8 + 64 * 8) / 400.0, 9);
  EXPECT_EQ(r2.tiles, (std::vector<long>{0, 4}));
  // the share sets the refined rays: 1 + (3 - 1) / 0.25 = 9
  EXPECT_EQ(plan_refinement(base, est, 8, 3, std::nullopt, 0.25).rays, 9);
  // by default the rays r whose tiles remove the most estimate, sum e (1 - 1/r):
  // all three tiles fit while 144 (r - 1) <= 800, r = 6 removes 11 x 5/6;
  // r = 7 fits tiles 0 and 4 only (8 x 6/7), r >= 13 tile 4 alone (< 5)
  const Refinement d = plan_refinement(base, est, 8, 3);
  EXPECT_EQ(d.rays, 6);
  EXPECT_EQ(d.tiles, (std::vector<long>{0, 4, 8}));
  // a budget past 64 may refine to the budget itself (every tile at 100)
  EXPECT_EQ(plan_refinement(base, est, 8, 100).rays, 100);
}

void expect_error(const std::function<void()>& f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one containing '" << part << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(Refinement, BadRefinementsAreRefused) {
  const SamplePattern base = make_pattern(PatternKind::Sobol, 0, 16, 16, 2);
  const std::vector<double> est(4, 1.0);
  expect_error([&] { plan_refinement(base, est, 8, 3.5); }, "below the base pattern's 4");
  expect_error([&] { plan_refinement(base, est, 8, NAN); }, "below the base pattern's 4");
  expect_error([&] { plan_refinement(base, est, 8, 8, 16, 0.5); }, "not both");
  expect_error([&] { plan_refinement(base, est, 8, 8, std::nullopt, 1.5); }, "(0, 1]");
  expect_error([&] { plan_refinement(base, {1.0}, 8, 8); }, "1 tile estimates for 4 tiles");
  expect_error([&] { make_refinement(base, 8, 16, {4}); }, "tile 4 lies outside the frame");
  expect_error([&] { make_refinement(base, 8, 16, {-1}); }, "outside the frame");
  expect_error([&] { make_refinement(base, 8, 16, {2, 1}); }, "must increase");
  expect_error([&] { make_refinement(base, 0, 16, {}); }, "a tile of 0 pixels");
  expect_error([&] { make_refinement(base, 8, 4, {0}); }, "more than the base's 4");
  expect_error([&] { make_refinement(make_pattern(PatternKind::Jitter, 0, 16, 16, 2), 8, 16, {0}); },
               "base pattern is jitter");
  expect_error([&] { make_refinement(make_pattern(PatternKind::Sobol, 0, 16, 16, 1.5), 8, 16, {0}); },
               "same whole number of rays in every pixel");
  const Refinement r = make_refinement(base, 8, 16, {1, 2});
  std::string text = refinement_text(r);
  EXPECT_EQ(parse_refinement(text, "t").tiles, (std::vector<long>{1, 2}));
  expect_error([&] { parse_refinement(text.substr(0, text.size() - 2), "t.txt"); },
               "t.txt: 1 tile indices; its 'tiles' line says 2");
  std::string outside = text;
  outside.replace(outside.rfind("1 2"), 3, "1 9");
  expect_error([&] { parse_refinement(outside, "t.txt"); }, "tile 9 lies outside the frame");
  expect_error([&] { parse_refinement("sis-refinement 1\npattern sobol\nseed x\n", "t.txt"); },
               "t.txt: line 3: seed 'x'");
  expect_error([&] { adaptive_samples(samples_of(base, busy_quadrant), r, {}); }, "extra rays' values");
}

}  // namespace
}  // namespace sis
