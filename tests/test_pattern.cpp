// Sample patterns (sis/pattern.h): the regular grid's positions exactly,
// every pattern reproducible from its seed and different between seeds,
// jitter one sample in each cell, the Sobol' pattern's elementary intervals
// each holding exactly its count, the bulk call equal to the single one.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "sis/pattern.h"

namespace sis {
namespace {

const PatternKind kAll[] = {PatternKind::Regular, PatternKind::Jitter, PatternKind::Sobol};

std::vector<double> positions(const SamplePattern& p, int threads = 1) {
  std::vector<double> xy(2 * std::size_t(p.count()));
  sample_positions(p, 0, p.count(), xy.data(), threads);
  return xy;
}

TEST(Pattern, Names) {
  for (PatternKind k : kAll) EXPECT_EQ(parse_pattern(pattern_name(k)), k);
  EXPECT_THROW(parse_pattern("halton"), std::invalid_argument);
}

TEST(Pattern, GridIsTheRenderOfTheFactor) {
  // the Makefile's render size: printf "%d", RES * FACTOR + 0.5
  const SamplePattern p = make_pattern(PatternKind::Regular, 0, 100, 60, 1.5);
  EXPECT_EQ(p.grid_width(), 150);
  EXPECT_EQ(p.grid_height(), 90);
  const SamplePattern q = make_pattern(PatternKind::Jitter, 0, 101, 33, 3.3);
  EXPECT_EQ(q.grid_width(), 333);  // 333.3
  EXPECT_EQ(q.grid_height(), 109);  // 108.9
  EXPECT_DOUBLE_EQ(make_pattern(PatternKind::Sobol, 0, 4, 4, 4).rays_per_pixel(), 16.0);
}

TEST(Pattern, RegularIsThePixelCentresOfTheSupersampledRender) {
  for (double s : {1.0, 2.0, 4.0, 1.5, 3.3}) {
    const SamplePattern p = make_pattern(PatternKind::Regular, 7, 23, 17, s);
    const long gw = p.grid_width(), gh = p.grid_height();
    const std::vector<double> xy = positions(p);
    for (long l = 0; l < gh; ++l)
      for (long i = 0; i < gw; ++i) {
        const long k = l * gw + i;
        ASSERT_EQ(xy[2 * k], (i + 0.5) * 23.0 / double(gw)) << s << " " << k;
        ASSERT_EQ(xy[2 * k + 1], (l + 0.5) * 17.0 / double(gh)) << s << " " << k;
      }
  }
}

TEST(Pattern, ReproducibleFromTheSeedAndDifferentBetweenSeeds) {
  for (PatternKind kind : kAll) {
    const std::vector<double> a = positions(make_pattern(kind, 11, 40, 30, 2));
    const std::vector<double> b = positions(make_pattern(kind, 11, 40, 30, 2));
    const std::vector<double> c = positions(make_pattern(kind, 12, 40, 30, 2));
    EXPECT_EQ(a, b) << pattern_name(kind);
    long differ = 0;
    for (std::size_t q = 0; q < a.size(); ++q) differ += a[q] != c[q];
    if (kind == PatternKind::Regular)
      EXPECT_EQ(differ, 0);
    else  // every coordinate moves with the seed
      EXPECT_EQ(differ, long(a.size())) << pattern_name(kind);
  }
}

TEST(Pattern, InsideTheFrame) {
  for (PatternKind kind : kAll)
    for (std::uint64_t seed : {0ULL, 1ULL, ~0ULL}) {
      const SamplePattern p = make_pattern(kind, seed, 37, 21, 2.7);
      const std::vector<double> xy = positions(p);
      for (long k = 0; k < p.count(); ++k) {
        ASSERT_GT(xy[2 * k], 0.0);
        ASSERT_LT(xy[2 * k], 37.0);
        ASSERT_GT(xy[2 * k + 1], 0.0);
        ASSERT_LT(xy[2 * k + 1], 21.0);
      }
    }
}

TEST(Pattern, JitterHasOneSampleInEachCell) {
  for (double s : {4.0, 2.5}) {
    const SamplePattern p = make_pattern(PatternKind::Jitter, 3, 19, 13, s);
    const long gw = p.grid_width(), gh = p.grid_height();
    const std::vector<double> xy = positions(p);
    std::vector<int> count(std::size_t(gw * gh), 0);
    double mean_u = 0;
    for (long k = 0; k < p.count(); ++k) {
      const double cx = xy[2 * k] * double(gw) / 19.0, cy = xy[2 * k + 1] * double(gh) / 13.0;
      const long i = long(std::floor(cx)), l = long(std::floor(cy));
      ASSERT_EQ(l * gw + i, k) << "sample " << k << " is not in its own cell";
      ++count[std::size_t(l * gw + i)];
      mean_u += cx - double(i);
    }
    for (int c : count) ASSERT_EQ(c, 1);
    // the offsets are uniform: their mean within 4 standard deviations of 1/2
    mean_u /= double(p.count());
    EXPECT_NEAR(mean_u, 0.5, 4 * std::sqrt(1.0 / 12 / double(p.count())));
  }
}

// Every elementary interval [a 2^-j, (a + 1) 2^-j) x [b 2^-(m-j), (b + 1) 2^-(m-j))
// of pixel (px, py) holds exactly one of the samples [first, first + 2^m).
void expect_net(const std::vector<double>& xy, long px, long py, long first, int m) {
  const long n = 1L << m;
  for (int j = 0; j <= m; ++j) {
    const long cx = 1L << j, cy = 1L << (m - j);
    std::vector<int> count(std::size_t(n), 0);
    for (long k = first; k < first + n; ++k) {
      const double u = xy[2 * k] - double(px), v = xy[2 * k + 1] - double(py);
      ASSERT_TRUE(u >= 0 && u < 1 && v >= 0 && v < 1) << "sample " << k << " outside pixel " << px << ", " << py;
      ++count[std::size_t(long(std::floor(v * double(cy))) * cx + long(std::floor(u * double(cx))))];
    }
    for (long q = 0; q < n; ++q)
      ASSERT_EQ(count[std::size_t(q)], 1) << "pixel (" << px << ", " << py << "), 2^" << m << " samples, intervals "
                                          << cx << " x " << cy << ", interval " << q;
  }
}

TEST(Pattern, SobolPixelsAreNets) {
  for (std::uint64_t seed : {0ULL, 5ULL, 123456789ULL}) {
    // 256 rays per pixel: each pixel's samples are consecutive and a (0, 8, 2)-net
    const SamplePattern p = make_pattern(PatternKind::Sobol, seed, 3, 2, 16);
    ASSERT_EQ(p.count(), 6 * 256);
    const std::vector<double> xy = positions(p);
    for (long q = 0; q < 6; ++q) {
      expect_net(xy, q % 3, q / 3, 256 * q, 8);
      for (int m = 0; m < 8; ++m) expect_net(xy, q % 3, q / 3, 256 * q, m);  // every prefix of 2^m
    }
  }
}

TEST(Pattern, SobolSpreadsAnyDensityEvenlyOverThePixels) {
  // 12 x 9 = 108 samples over 35 pixels: each pixel holds 3 or 4
  const SamplePattern p = make_pattern(PatternKind::Sobol, 1, 7, 5, 1.7);
  ASSERT_EQ(p.count(), 108);
  const std::vector<double> xy = positions(p);
  std::vector<int> count(35, 0);
  long last = -1;
  for (long k = 0; k < p.count(); ++k) {
    const long q = long(std::floor(xy[2 * k + 1])) * 7 + long(std::floor(xy[2 * k]));
    ASSERT_GE(q, last) << "the pixels' samples are consecutive";
    last = q;
    ++count[std::size_t(q)];
  }
  for (int c : count) {
    EXPECT_GE(c, 3);
    EXPECT_LE(c, 4);
  }
}

TEST(Pattern, BulkEqualsSingleOnAnyThreads) {
  for (PatternKind kind : kAll) {
    const SamplePattern p = make_pattern(kind, 9, 31, 17, 2.2);
    const std::vector<double> one = positions(p, 1), three = positions(p, 3);
    EXPECT_EQ(one, three);
    for (long k : {0L, 1L, p.count() / 2, p.count() - 1}) {
      const Vec2 s = sample_position(p, k);
      EXPECT_EQ(s.x, one[2 * k]);
      EXPECT_EQ(s.y, one[2 * k + 1]);
    }
    std::vector<double> part(2 * 10);
    sample_positions(p, 100, 110, part.data());
    EXPECT_EQ(part, std::vector<double>(one.begin() + 200, one.begin() + 220));
  }
}

TEST(Pattern, RefusesBadPatterns) {
  EXPECT_THROW(make_pattern(PatternKind::Jitter, 0, 0, 10, 2), std::invalid_argument);
  EXPECT_THROW(make_pattern(PatternKind::Jitter, 0, 10, 10, 0), std::invalid_argument);
  EXPECT_THROW(make_pattern(PatternKind::Jitter, 0, 10, 10, NAN), std::invalid_argument);
  EXPECT_THROW(make_pattern(PatternKind::Jitter, 0, 10, 10, 0.01), std::invalid_argument);  // no sample
  EXPECT_THROW(make_pattern(PatternKind::Sobol, 0, 100000, 100000, 1), std::invalid_argument);  // > 2^32
  const SamplePattern p = make_pattern(PatternKind::Sobol, 0, 4, 4, 1);
  std::vector<double> xy(40);
  EXPECT_THROW(sample_positions(p, 0, 17, xy.data()), std::invalid_argument);
}

}  // namespace
}  // namespace sis
