// Pyramids (sis/pyramid.h): maketx's level sizes, each level the bits of
// its own projection, the box pyramid equal to repeated 2 x 2 averaging,
// the mean kept at every level.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "sis/pyramid.h"
#include "support.h"

namespace sis {
namespace {

using Sizes = std::vector<std::pair<long, long>>;

TEST(Pyramid, SizesAreMaketxs) {
  // as `maketx in.exr -o tx.exr; oiiotool --info -v tx.exr` lists them
  // (OpenImageIO 2.4.4: "MIP-map levels: ...")
  EXPECT_EQ(pyramid_sizes(64, 64),
            (Sizes{{64, 64}, {32, 32}, {16, 16}, {8, 8}, {4, 4}, {2, 2}, {1, 1}}));
  EXPECT_EQ(pyramid_sizes(37, 21), (Sizes{{37, 21}, {18, 10}, {9, 5}, {4, 2}, {2, 1}, {1, 1}}));
  EXPECT_EQ(pyramid_sizes(100, 75),
            (Sizes{{100, 75}, {50, 37}, {25, 18}, {12, 9}, {6, 4}, {3, 2}, {1, 1}}));
  EXPECT_EQ(pyramid_sizes(1, 5), (Sizes{{1, 5}, {1, 2}, {1, 1}}));
  EXPECT_EQ(pyramid_sizes(1, 1), (Sizes{{1, 1}}));
  // OpenEXR's rule stated directly: level j is max(1, floor(side / 2^j)),
  // floor(log2(max side)) + 1 levels
  for (long w = 1; w <= 70; ++w)
    for (long h : {1L, 2L, 3L, 7L, 64L, 65L, 1000L}) {
      const Sizes s = pyramid_sizes(w, h);
      const long m = std::max(w, h);
      long levels = 0;
      while ((2L << levels) <= m) ++levels;
      ASSERT_EQ(long(s.size()), levels + 1) << w << " x " << h;
      for (std::size_t j = 0; j < s.size(); ++j) {
        EXPECT_EQ(s[j].first, std::max(1L, w >> j));
        EXPECT_EQ(s[j].second, std::max(1L, h >> j));
      }
    }
  EXPECT_THROW(pyramid_sizes(0, 5), RequestError);
}

ProjectionRequest level0(const Image& samples, Space space, Method method, Boundary boundary,
                         long w, long h, int threads = 1) {
  ProjectionRequest rq;
  rq.inputs = {ProjectionInput::memory(samples)};
  rq.space = space;
  rq.method = method;
  rq.boundary = boundary;
  rq.width = w;
  rq.height = h;
  rq.threads = threads;
  return rq;
}

bool same_bits(const Buffer<double>& a, const Buffer<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

TEST(Pyramid, EveryLevelIsItsOwnProjectionsBits) {
  // odd sizes (whole and fractional ratios to the samples), every kind of target
  const Image samples = test::random_image(150, 97, 3, 31);
  struct Case {
    Space space;
    Method method;
    Boundary boundary;
  };
  const Case cases[] = {
      {CartesianSpace{Kernel::bspline(3)}, Method::MinError, Boundary::Mirror},
      {CartesianSpace{Kernel::bspline(1)}, Method::MinError, Boundary::Periodic},
      {CartesianSpace{Kernel::bspline(0)}, Method::MinError, Boundary::Mirror},
      {CartesianSpace{Kernel::parse("lanczos3")}, Method::Conventional, Boundary::Mirror},
  };
  for (const Case& c : cases)
    for (int threads : {1, 2}) {
      const ProjectionRequest rq = level0(samples, c.space, c.method, c.boundary, 37, 25, threads);
      const std::vector<Projection> levels = project_pyramid(rq);
      const Sizes sizes = pyramid_sizes(37, 25);
      ASSERT_EQ(levels.size(), sizes.size());
      for (std::size_t j = 0; j < levels.size(); ++j) {
        ProjectionRequest alone = rq;
        alone.width = sizes[j].first;
        alone.height = sizes[j].second;
        const Projection own = project(alone);
        EXPECT_EQ(levels[j].coefficients.c.width, sizes[j].first);
        EXPECT_EQ(levels[j].coefficients.c.height, sizes[j].second);
        EXPECT_TRUE(same_bits(levels[j].coefficients.c.data, own.coefficients.c.data))
            << generator_name(own.coefficients) << ", level " << j << ", " << threads << " threads";
      }
    }
}

TEST(Pyramid, BoxLevelsAreRepeatedTwoByTwoAverages) {
  // 32 x 24 at factor 3: levels 32x24 16x12 8x6 4x3 2x1 1x1; where level j
  // has even sides, level j + 1 is the 2 x 2 average of level j
  const Image samples = test::random_image(96, 72, 2, 32, -1.0f, 3.0f);
  ProjectionRequest rq = level0(samples, CartesianSpace{Kernel::bspline(0)}, Method::MinError,
                                Boundary::Mirror, 32, 24);
  rq.float_coefficients = false;
  const std::vector<Projection> levels = project_pyramid(rq);
  int compared = 0;
  for (std::size_t j = 0; j + 1 < levels.size(); ++j) {
    const Grid<double>& fine = levels[j].coefficients.c;
    const Grid<double>& coarse = levels[j + 1].coefficients.c;
    if (fine.width % 2 || fine.height % 2) continue;
    ++compared;
    for (long y = 0; y < coarse.height; ++y)
      for (long x = 0; x < coarse.width; ++x)
        for (int c = 0; c < 2; ++c) {
          const double avg = (fine.at(2 * x, 2 * y, c) + fine.at(2 * x + 1, 2 * y, c) +
                              fine.at(2 * x, 2 * y + 1, c) + fine.at(2 * x + 1, 2 * y + 1, c)) /
                             4;
          // equal in exact arithmetic: the level sums its 9 * 4^(j+1)
          // samples in another order than the average of averages, and
          // passes the (identity) prefilter's FFT; each adds rounding of
          // order 1e-16 per term, far below 1e-12 at these counts (at most
          // 2304 samples of magnitude at most 3)
          EXPECT_NEAR(coarse.at(x, y, c), avg, 1e-12) << "level " << j + 1 << " at " << x << ", " << y;
        }
  }
  EXPECT_EQ(compared, 3);
}

double mean(const Buffer<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s / double(v.size());
}

TEST(Pyramid, TheMeanIsKeptAtEveryLevel) {
  // 40 x 24 at factor 2: every level (40x24 20x12 10x6 5x3 2x1 1x1) holds a
  // whole number of samples per pixel on each axis, where the acquisition is
  // the plain sum: the coefficients' mean (the integral of f_app over the
  // frame) is the samples' mean (partition of unity; the prefilter's gain at
  // frequency 0 is 1), for every degree, both boundary rules
  const Image samples = test::random_image(80, 48, 1, 33, 0.0f, 2.0f);
  double sample_mean = 0;
  for (float v : samples.data) sample_mean += v;
  sample_mean /= double(samples.data.size());
  for (int degree : {0, 1, 2, 3})
    for (Boundary b : {Boundary::Mirror, Boundary::Periodic}) {
      ProjectionRequest rq =
          level0(samples, CartesianSpace{Kernel::bspline(degree)}, Method::MinError, b, 40, 24);
      rq.float_coefficients = false;
      const std::vector<Projection> levels = project_pyramid(rq);
      ASSERT_EQ(levels.size(), 6u);
      for (std::size_t j = 0; j < levels.size(); ++j) {
        // exact in real arithmetic; 1e-12: double rounding of sums of at
        // most 3840 samples of magnitude at most 2 and of the FFT
        EXPECT_NEAR(mean(levels[j].coefficients.c.data), sample_mean, 1e-12)
            << "degree " << degree << ", level " << j;
        // and the exact pixel averages of f_app (float: 1e-6 relative)
        const FinalImage shown = final_image(levels[j].coefficients, Display::pixel(),
                                             levels[j].coefficients.c.width,
                                             levels[j].coefficients.c.height, Clamp::None, nullptr, 1);
        double m = 0;
        for (float v : shown.image.data) m += v;
        m /= double(shown.image.data.size());
        EXPECT_NEAR(m, sample_mean, 1e-6 * sample_mean) << "degree " << degree << ", level " << j;
      }
    }
}

TEST(Pyramid, TheHexagonalLatticeIsRefused) {
  const Image samples = test::random_image(40, 40, 1, 34);
  try {
    project_pyramid(level0(samples, HexagonalSpace{2, 1.0}, Method::MinError, Boundary::Mirror, 20, 20));
    ADD_FAILURE() << "a hexagonal pyramid was made";
  } catch (const RequestError& e) {
    EXPECT_NE(std::string(e.what()).find("--mip"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("hexagonal"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sis
