// The spaces' conformance suite (issue 30: one suite that every space
// passes, in place of twin tests). Each test takes a Space value and goes
// through the one interface only (the engine, visit_space, the space's own
// functions, the coefficients' description of themselves); none asks which
// lattice it has. What a single lattice owns (the hexagonal layout, box
// spline values, Cartesian taps and quadrature rules) stays in its own file.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <iterator>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "sis/coefficients.h"
#include "sis/engine.h"
#include "sis/partial.h"
#include "sis/projection.h"
#include "sis/range.h"
#include "sis/resample.h"
#include "sis/space.h"
#include "support.h"

namespace sis {
namespace {

struct Case {
  const char* name;
  Space space;
  Method method;  // the space's own method (its check accepts it with the FFT prefilter)
};
const Case kCases[] = {
    {"cubic", CartesianSpace{Kernel::bspline(3)}, Method::MinError},
    {"tent", CartesianSpace{Kernel::bspline(1)}, Method::MinError},
    {"mitchell", CartesianSpace{Kernel::parse("mitchell")}, Method::Conventional},
    {"hex_hat", HexagonalSpace{1, 1.0}, Method::MinError},
    {"hex_quartic", HexagonalSpace{2, 1.0}, Method::MinError},
    {"hex_quartic_density_1_7", HexagonalSpace{2, 1.7}, Method::MinError},
};

// gtest names a case by its name (not its bytes) in messages and ctest's list.
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

const Boundary kRules[] = {Boundary::Mirror, Boundary::Periodic};
const Method kMethods[] = {Method::MinError, Method::Conventional};

ProjectionRequest request(const Case& c, std::vector<ProjectionInput> inputs, long W, long H,
                          Boundary b = Boundary::Mirror, Method m = Method::MinError,
                          int threads = 1) {
  ProjectionRequest rq;
  rq.inputs = std::move(inputs);
  rq.width = W;
  rq.height = H;
  rq.space = c.space;
  rq.method = m;
  rq.boundary = b;
  rq.threads = threads;
  return rq;
}
ProjectionRequest request(const Case& c, const Image& in, long W, long H) {
  return request(c, {ProjectionInput::memory(in)}, W, H, Boundary::Mirror, c.method);
}

SpaceRequest space_request(const ProjectionRequest& rq, const Image& in) {
  SpaceRequest s;
  s.input_width = in.width;
  s.input_height = in.height;
  s.channels = in.channels;
  s.width = rq.width;
  s.height = rq.height;
  s.method = rq.method;
  s.prefilter = rq.prefilter;
  s.boundary = rq.boundary;
  s.threads = rq.threads;
  return s;
}

// Whether the space takes this method (its check refuses the others).
bool takes(const Space& space, Method m, PrefilterMethod p = PrefilterMethod::FFT) {
  SpaceRequest s;
  s.input_width = s.input_height = 64;
  s.channels = 1;
  s.width = s.height = 16;
  s.method = m;
  s.prefilter = p;
  try {
    visit_space(space, [&](const auto& sp) { sp.check(s); });
    return true;
  } catch (const RequestError&) {
    return false;
  }
}

template <typename T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}
template <typename T>
bool same_bits(const Buffer<T>& a, const Buffer<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// The rows [y0, y1) of `in` as an in-memory band of its grid.
ProjectionInput band(const Image& in, long y0, long y1) {
  ProjectionInput p = ProjectionInput::memory(
      SampleView(in.row(y0), in.width, y1 - y0, in.channels, false), "rows " + std::to_string(y0));
  p.row = y0;
  p.rows = in.height;
  return p;
}

const Display kDisplays[] = {Display::centred(), Display::antialiased_2x2(), Display::pixel()};

Image shown(const Coefficients& k, const Display& d, long W, long H, int threads = 1) {
  return final_image(k, d, W, H, Clamp::None, nullptr, threads).image;
}

Metadata parameters(const Space& s) {
  return visit_space(s, [](const auto& sp) { return sp.parameters(); });
}

class Conformance : public ::testing::TestWithParam<Case> {};
class ConformanceFiles : public test::TempDirTest, public ::testing::WithParamInterface<Case> {};

// A flat image (one constant per channel) projects to coefficients whose
// final image is that constant, at every display, at the frame's size and
// another, for every method and boundary rule the space takes, at whole
// and non-whole sampling factors (3, 4, 3.3, 2.65 x 2.47). Exact: the samples are floats, f_app is
// the constant times weights that sum to 1 to double rounding (1e-15
// relative), and the one rounding to float returns the sample's float
// (1e-15 is far below half a float ulp, 6e-8).
TEST_P(Conformance, FlatImageGivesAFlatFinalImage) {
  const Case& c = GetParam();
  const float flat[3] = {0.3f, 1.7f, 0.05f};
  for (const auto& [win, hin, W, H] : {std::array<long, 4>{60, 48, 20, 16}, {80, 64, 20, 16}, {66, 33, 20, 10}, {61, 47, 23, 19}}) {
    Image in(win, hin, 3);
    for (long q = 0; q < win * hin; ++q)
      for (int ch = 0; ch < 3; ++ch) in.data[q * 3 + ch] = flat[ch];
    for (Method m : kMethods) {
      if (!takes(c.space, m)) continue;
      for (Boundary b : kRules) {
        const Projection p = project(request(c, {ProjectionInput::memory(in)}, W, H, b, m));
        for (const Display& d : kDisplays)
          for (const auto& [w, h] : {std::pair<long, long>{W, H}, {13, 29}}) {
            const Image img = shown(p.coefficients, d, w, h);
            for (long q = 0; q < w * h; ++q)
              for (int ch = 0; ch < 3; ++ch)
                ASSERT_EQ(img.data[q * 3 + ch], flat[ch])
                    << c.name << ", " << method_name(m) << ", " << boundary_name(b) << ", "
                    << d.name() << " at " << w << " x " << h << ", pixel " << q << ", channel " << ch;
          }
      }
    }
  }
}

// The space's budget counts exactly the coefficients the projection makes
// (values per channel), and the engine's estimate covers their bytes.
TEST_P(Conformance, BudgetCoversTheCoefficients) {
  const Case& c = GetParam();
  const Image in = test::random_image(60, 48, 3, 1);
  for (const auto& [W, H] : {std::pair<long, long>{20, 16}, {23, 19}}) {
    const ProjectionRequest rq = request(c, in, W, H);
    const SpaceBudget b =
        visit_space(c.space, [&](const auto& s) { return s.budget(space_request(rq, in)); });
    const Projection p = project(rq);
    const Grid<double>& g = p.coefficients.c;
    EXPECT_EQ(b.coefficients, std::uint64_t(g.width) * std::uint64_t(g.height)) << c.name;
    EXPECT_TRUE(std::isfinite(b.tables) && b.tables >= 0) << c.name << ": " << b.tables;
    EXPECT_GE(p.estimated_bytes, g.data.size() * sizeof(double)) << c.name;
  }
}

// check() accepts the space's own method and refuses the others as a
// RequestError naming the refused option; project() does what check()
// accepts and refuses what it refuses, with the same message.
TEST_P(Conformance, CheckRefusesWhatTheSpaceCannotDo) {
  const Case& c = GetParam();
  const Image in = test::random_image(48, 48, 1, 2);
  EXPECT_TRUE(takes(c.space, c.method)) << c.name;
  for (Method m : kMethods)
    for (PrefilterMethod pf : {PrefilterMethod::FFT, PrefilterMethod::Recursive}) {
      ProjectionRequest rq = request(c, {ProjectionInput::memory(in)}, 16, 16, Boundary::Mirror, m);
      rq.prefilter = pf;
      std::string refused;
      try {
        visit_space(c.space, [&](const auto& s) { s.check(space_request(rq, in)); });
      } catch (const RequestError& e) {
        refused = e.what();
      }
      const std::string what = std::string(c.name) + ", " + method_name(m) +
                               (pf == PrefilterMethod::FFT ? ", fft" : ", recursive");
      if (refused.empty()) {
        EXPECT_NO_THROW(project(rq)) << what;
        continue;
      }
      // the option refused: the method where the space does not take it
      // with the FFT prefilter, else the prefilter
      const bool method_refused = !takes(c.space, m);
      EXPECT_NE(refused.find(method_refused ? "method" : "prefilter"), std::string::npos)
          << what << ": " << refused;
      try {
        project(rq);
        ADD_FAILURE() << what << ": project() did what check() refused";
      } catch (const RequestError& e) {
        EXPECT_EQ(std::string(e.what()), refused) << what;
      }
    }
}

// A coefficient file read back is the same space (its name, generator and
// parameters), lattice, frame, boundary and method, with the same
// coefficients and bit-identical final images.
TEST_P(ConformanceFiles, CoefficientFileRoundTrip) {
  const Case& c = GetParam();
  const Image in = test::random_image(61, 47, 3, 3);
  for (Boundary b : kRules) {
    const Projection p = project(request(c, {ProjectionInput::memory(in)}, 23, 19, b, c.method));
    const Coefficients& k = p.coefficients;
    EXPECT_EQ(space_name(k.space), space_name(c.space)) << c.name;
    EXPECT_EQ(parameters(k.space), parameters(c.space)) << c.name;
    const std::string file = path("c.exr");
    write_coefficients(file, k);
    const Coefficients back = load_coefficients(file, false);
    EXPECT_EQ(space_name(back.space), space_name(k.space)) << c.name;
    EXPECT_EQ(generator_name(back), generator_name(k)) << c.name;
    EXPECT_EQ(parameters(back.space), parameters(k.space)) << c.name;
    EXPECT_EQ(back.lattice.origin().x, k.lattice.origin().x) << c.name;
    EXPECT_EQ(back.lattice.origin().y, k.lattice.origin().y) << c.name;
    EXPECT_EQ(back.lattice.matrix(), k.lattice.matrix()) << c.name;
    EXPECT_EQ(back.image_width, k.image_width) << c.name;
    EXPECT_EQ(back.image_height, k.image_height) << c.name;
    const auto frame = [](const Coefficients& x) {
      return visit_space(x, [&](const auto& s) { return s.frame(x); });
    };
    EXPECT_EQ(frame(back), frame(k)) << c.name;
    EXPECT_EQ(back.boundary, k.boundary) << c.name;
    EXPECT_EQ(back.min_error, k.min_error) << c.name;
    EXPECT_EQ(back.c.width, k.c.width) << c.name;
    EXPECT_EQ(back.c.height, k.c.height) << c.name;
    EXPECT_TRUE(same_bits(back.c.data, k.c.data)) << c.name;  // float coefficients, stored float
    for (const Display& d : kDisplays)
      for (const auto& [w, h] : {std::pair<long, long>{23, 19}, {41, 17}})
        EXPECT_TRUE(same_bits(shown(back, d, w, h).data, shown(k, d, w, h).data))
            << c.name << ", " << boundary_name(b) << ", " << d.name() << " at " << w << " x " << h;
  }
}

// The space's resample() at a display's points is its evaluate() there (the
// mean over the display's offsets), at the frame's size and others; the
// free functions are the space's. Bound: resample rounds once to float
// (half an ulp of the value) after double sums in another order than
// evaluate's (a few 1e-16 of the largest coefficient times the terms).
TEST_P(Conformance, EvaluateAtTheDisplaysPointsIsResample) {
  const Case& c = GetParam();
  const Image in = test::random_image(60, 48, 2, 4);
  const Display displays[] = {Display::centred(), Display::antialiased_2x2(),
                              Display::parse("offsets:0.1,-0.2;-0.3,0.05;0.4,0.4")};
  for (Boundary b : kRules) {
    const Projection p = project(request(c, {ProjectionInput::memory(in)}, 20, 16, b, c.method));
    const Coefficients& k = p.coefficients;
    double scale = 0;
    for (double v : k.c.data) scale = std::max(scale, std::abs(v));
    for (const Display& d : displays)
      for (const auto& [w, h] : {std::pair<long, long>{20, 16}, {27, 13}}) {
        const Image r = visit_space(k, [&](const auto& s) { return s.resample(k, d, w, h, 1); });
        EXPECT_TRUE(same_bits(r.data, resample(k, d, w, h).data)) << c.name;
        const double sx = k.image_width / w, sy = k.image_height / h;
        for (long j = 0; j < h; ++j)
          for (long i = 0; i < w; ++i)
            for (int ch = 0; ch < 2; ++ch) {
              double e = 0;
              for (const Vec2& o : d.offsets) {
                const Vec2 x{(i + 0.5 + o.x) * sx, (j + 0.5 + o.y) * sy};
                const double v = visit_space(k, [&](const auto& s) { return s.evaluate(k, x, ch); });
                ASSERT_EQ(v, evaluate(k, x, ch));
                e += v;
              }
              e /= double(d.offsets.size());
              const float got = r.at(i, j, ch);
              const double ulp = std::nextafter(static_cast<float>(std::abs(e)),
                                                std::numeric_limits<float>::infinity()) -
                                 static_cast<float>(std::abs(e));
              ASSERT_LE(std::abs(got - e), 0.5 * ulp + 1e-14 * scale)
                  << c.name << ", " << boundary_name(b) << ", " << d.name() << " at " << w << " x "
                  << h << ", pixel " << i << ", " << j;
            }
      }
  }
}

// The pixel display is the exact average of f_app over each final pixel:
// against a midpoint sum of the space's evaluate() on m x m points, at a
// size other than the frame's. Bound: the midpoint rule's error, (sx/m)^2
// / 24 times f_app's second derivatives (~1 for these random images), plus
// the generators' kinks crossing the cells: 2e-3 at m = 60.
TEST_P(Conformance, PixelDisplayIsThePixelAverage) {
  const Case& c = GetParam();
  const long N = 12, w = 5, h = 7;
  const Image in = test::random_image(N * 3, N * 3, 1, 9);
  const Projection p = project(request(c, {ProjectionInput::memory(in)}, N, N, Boundary::Mirror, c.method));
  const Coefficients& k = p.coefficients;
  const Image out = visit_space(k, [&](const auto& s) { return s.resample(k, Display::pixel(), w, h, 1); });
  const double sx = double(N) / w, sy = double(N) / h;
  const int m = 60;
  for (long y = 0; y < h; ++y)
    for (long x = 0; x < w; ++x) {
      double sum = 0;
      for (int j = 0; j < m; ++j)
        for (int i = 0; i < m; ++i) {
          const Vec2 at{(x + (i + 0.5) / m) * sx, (y + (j + 0.5) / m) * sy};
          sum += visit_space(k, [&](const auto& s) { return s.evaluate(k, at, 0); });
        }
      EXPECT_NEAR(out.at(x, y, 0), sum / (m * m), 2e-3) << c.name << ", pixel " << x << ", " << y;
    }
}

// The inputs as several in-memory row bands (cut anywhere, given in any
// order) give the single input's bits, and so do 1, 2 and 3 threads: the
// coefficients, the local range and the final image.
TEST_P(Conformance, BandsAndThreadsGiveTheSingleRunsBits) {
  const Case& c = GetParam();
  // 2 of the engine's bands and part of a third: workers take bands at once
  const Image in = test::random_image(48, 2 * 256 + 77, 3, 5);
  const long W = 16, H = 197;
  const Projection whole =
      project(request(c, {ProjectionInput::memory(in)}, W, H, Boundary::Mirror, c.method, 1));
  std::vector<Image> want;
  for (const Display& d : kDisplays) want.push_back(shown(whole.coefficients, d, W, H));
  for (int threads : {1, 2, 3})
    for (bool bands : {false, true}) {
      std::vector<ProjectionInput> inputs{ProjectionInput::memory(in)};
      if (bands) inputs = {band(in, 333, in.height), band(in, 0, 100), band(in, 100, 333)};
      const Projection p = project(request(c, inputs, W, H, Boundary::Mirror, c.method, threads));
      const std::string what = std::string(c.name) + ", " + std::to_string(threads) + " threads" +
                               (bands ? ", 3 bands" : "");
      EXPECT_TRUE(same_bits(p.coefficients.c.data, whole.coefficients.c.data)) << what;
      EXPECT_TRUE(same_bits(p.local_range->min().data, whole.local_range->min().data)) << what;
      EXPECT_TRUE(same_bits(p.local_range->max().data, whole.local_range->max().data)) << what;
      for (std::size_t d = 0; d < std::size(kDisplays); ++d)
        EXPECT_TRUE(same_bits(shown(p.coefficients, kDisplays[d], W, H, threads).data, want[d].data))
            << what << ", " << kDisplays[d].name();
    }
}

// Several targets from one reading: the space at two frames and both
// boundary rules, beside another space, each with its own run's bits.
TEST_P(Conformance, SeveralTargetsFromOneReadingGiveEachItsOwnRunsBits) {
  const Case& c = GetParam();
  const Image in = test::random_image(60, 300, 3, 6);
  const std::vector<ProjectionInput> inputs{ProjectionInput::memory(in)};
  std::vector<ProjectionRequest> all{
      request(c, inputs, 20, 100, Boundary::Mirror, c.method, 2),
      request(c, {}, 13, 71, Boundary::Periodic, c.method, 2),
      request(kCases[0], {}, 30, 150, Boundary::Mirror, kCases[0].method, 2),
  };
  const std::vector<Projection> one_read = project(all);
  ASSERT_EQ(one_read.size(), all.size());
  for (std::size_t t = 0; t < all.size(); ++t) {
    ProjectionRequest alone = all[t];
    alone.inputs = inputs;
    const Projection own = project(alone);
    EXPECT_TRUE(same_bits(one_read[t].coefficients.c.data, own.coefficients.c.data))
        << c.name << ", target " << t;
    EXPECT_TRUE(same_bits(one_read[t].local_range->min().data, own.local_range->min().data))
        << c.name << ", target " << t;
    EXPECT_EQ(parameters(one_read[t].coefficients.space), parameters(own.coefficients.space));
  }
}

// Partials of 1, 2 and 3 parts of the grid's bands, merged in shuffled
// order, give the single run's bits.
TEST_P(Conformance, PartialsInAnyOrderMergeToTheSingleRunsBits) {
  const Case& c = GetParam();
  const Image in = test::random_image(40, 2 * 256 + 77, 2, 7);
  const long W = 10, H = 147;
  const Projection whole =
      project(request(c, {ProjectionInput::memory(in)}, W, H, Boundary::Mirror, c.method, 2));
  std::mt19937 rng(8);
  for (long parts : {1L, 2L, 3L}) {
    const std::vector<long> cuts = band_cuts(in.height, parts);
    std::vector<Partial> ps;
    for (long t = 0; t < parts; ++t)
      ps.push_back(project_partial(
          request(c, {band(in, cuts[t], cuts[t + 1])}, W, H, Boundary::Mirror, c.method, 2)));
    std::shuffle(ps.begin(), ps.end(), rng);
    const Projection merged = merge(ps, 2);
    EXPECT_TRUE(same_bits(merged.coefficients.c.data, whole.coefficients.c.data))
        << c.name << ", " << parts << " parts";
    EXPECT_TRUE(same_bits(merged.local_range->min().data, whole.local_range->min().data))
        << c.name << ", " << parts << " parts";
    EXPECT_EQ(parameters(merged.coefficients.space), parameters(whole.coefficients.space));
  }
}

// Min-error is the orthogonal projection: the residual f - f_app is
// orthogonal to the generators phi_m whose support lies in the frame,
// <f - f_app, phi_m> = 0, against a slow direct reference: phi_m is f_app
// of the unit coefficient at m (the space's own evaluate), and the inner
// product is a composite Gauss-Legendre sum over phi_m's support. Only the
// acquisition's quadrature of the samples remains (the boundary rule and
// the prefilter's folding do not reach phi_m in the frame's interior):
// the midpoint sum errs at the generator's kinks by about
// delta^2 / 24 |f_xx + f_yy| <= 5e-5, delta = 1/4 the sample spacing and
// |f''| <= 0.25 (pi / 16)^2 for this f; the hexagonal rule's cubic model
// by ~delta^4 |f''''| where the generator is smooth, more at the hat's
// kinks. Smaller still: the reference's own quadrature across the kinks
// (cells of 1/12 pixel, 3 x 3 points, on a residual of size 1e-2), the
// float samples (6e-8) and the hexagonal seam (below 1e-7).
// Bound: 1e-4 of int |phi_m|, where a 1 % error in half the coefficients
// leaves some 2e-3 of it (f is about 0.5), and a missing prefilter more.
TEST_P(Conformance, MinErrorResidualIsOrthogonalToTheSpace) {
  const Case& c = GetParam();
  if (!takes(c.space, Method::MinError)) GTEST_SKIP() << c.name << " has no min-error method";
  const long W = 16, H = 16, s = 4;
  const auto f = [&](double x, double y) {
    return 0.5 + 0.25 * std::cos(test::kPi * x / W + 0.3) * std::sin(test::kPi * y / H + 0.1);
  };
  const Image in = test::sample([&](double x, double y, int) { return f(x, y); }, W * s, H * s, 1, W, H);
  const Projection p =
      project(request(c, {ProjectionInput::memory(in)}, W, H, Boundary::Mirror, Method::MinError));
  const Coefficients& k = p.coefficients;
  const auto eval = [](const Coefficients& x, Vec2 at) {
    return visit_space(x, [&](const auto& sp) { return sp.evaluate(x, at, 0); });
  };
  const double R = visit_space(k, [&](const auto& sp) { return sp.radius(k); });
  const Vec2 centre{W / 2.0, H / 2.0};
  ASSERT_LT(2 * R + 0.5, W / 2.0) << c.name << ": the frame is too small for the generator";
  // the (at most 4) generators largest at the centre: their supports lie
  // within 2R of it
  Coefficients unit = k;
  std::fill(unit.c.data.begin(), unit.c.data.end(), 0.0);
  std::vector<std::pair<double, std::size_t>> at_centre;
  for (std::size_t q = 0; q < unit.c.data.size(); ++q) {
    unit.c.data[q] = 1;
    if (const double v = eval(unit, centre); v > 1e-3) at_centre.push_back({v, q});
    unit.c.data[q] = 0;
  }
  ASSERT_FALSE(at_centre.empty());
  std::sort(at_centre.rbegin(), at_centre.rend());
  std::vector<std::size_t> near;
  for (std::size_t t = 0; t < std::min<std::size_t>(4, at_centre.size()); ++t)
    near.push_back(at_centre[t].second);
  static const double X[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
  static const double Wt[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
  const double cell = 1.0 / 12, x0 = centre.x - 2 * R - 0.5, y0 = centre.y - 2 * R - 0.5;
  const long cells = std::lround((4 * R + 1) / cell) + 1;
  for (std::size_t q : near) {
    unit.c.data[q] = 1;
    double residual = 0, mass = 0, bias = 0;
    for (long b = 0; b < cells; ++b)
      for (long a = 0; a < cells; ++a)
        for (int j = 0; j < 3; ++j)
          for (int i = 0; i < 3; ++i) {
            const Vec2 x{x0 + (a + 0.5 + 0.5 * X[i]) * cell, y0 + (b + 0.5 + 0.5 * X[j]) * cell};
            const double phi = eval(unit, x);
            if (phi == 0) continue;
            const double w = Wt[i] * Wt[j] * cell * cell / 4;
            residual += w * (f(x.x, x.y) - eval(k, x)) * phi;
            mass += w * std::abs(phi);
            bias += w * f(x.x, x.y) * phi;
          }
    unit.c.data[q] = 0;
    EXPECT_LT(std::abs(residual), 1e-4 * mass)
        << c.name << ", generator " << q << ": <f - f_app, phi> " << residual << ", <f, phi> "
        << bias << ", int |phi| " << mass;
  }
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) { return info.param.name; }

INSTANTIATE_TEST_SUITE_P(Spaces, Conformance, ::testing::ValuesIn(kCases), case_name);
INSTANTIATE_TEST_SUITE_P(Spaces, ConformanceFiles, ::testing::ValuesIn(kCases), case_name);

}  // namespace
}  // namespace sis
