// Measures (docs/design.md section 8): against slow direct references and
// images whose answer is known exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <random>

#include "sis/metrics.h"
#include "sis/hex_projection.h"
#include "sis/projection.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {

// Share of |F|^2 above each cutoff by a direct O(N^2) complex DFT over every
// bin (no Hermitian folding), frequencies folded into [-1/2, 1/2].
std::vector<double> direct_highpass(const Image& img, const std::vector<double>& cutoffs) {
  const long W = img.width, H = img.height;
  std::vector<double> y(W * H);
  double mean = 0;
  for (long j = 0; j < H; ++j)
    for (long i = 0; i < W; ++i) {
      const double v = img.channels >= 3 ? 0.2126 * img.at(i, j, 0) + 0.7152 * img.at(i, j, 1) +
                                               0.0722 * img.at(i, j, 2)
                                         : img.at(i, j, 0);
      y[j * W + i] = v;
      mean += v;
    }
  mean /= W * H;
  double total = 0;
  std::vector<double> high(cutoffs.size(), 0.0);
  for (long ky = 0; ky < H; ++ky)
    for (long kx = 0; kx < W; ++kx) {
      std::complex<double> F = 0;
      for (long j = 0; j < H; ++j)
        for (long i = 0; i < W; ++i)
          F += (y[j * W + i] - mean) *
               std::polar(1.0, -2 * kPi * (double(kx * i) / W + double(ky * j) / H));
      const double fx = (kx <= W / 2 ? kx : kx - W) / double(W);
      const double fy = (ky <= H / 2 ? ky : ky - H) / double(H);
      const double e = std::norm(F);
      total += e;
      for (std::size_t q = 0; q < cutoffs.size(); ++q)
        if (std::hypot(fx, fy) > cutoffs[q]) high[q] += e;
    }
  for (double& h : high) h /= total;
  return high;
}

Coefficients project_with(const Image& in, long w, long h, int degree) {
  ProjectionOptions o;
  o.generator = Kernel::bspline(degree);
  o.method = Method::MinError;
  o.boundary = Boundary::Mirror;
  return project(in, w, h, o);
}

}  // namespace

TEST(Metrics, LuminanceWeights) {
  Image rgba(2, 1, 4);
  rgba.data = {1, 0, 0, 0.5f, 0.25f, 0.5f, 1, 9};
  const Grid<double> y = luminance(rgba);
  ASSERT_EQ(y.channels, 1);
  EXPECT_DOUBLE_EQ(y.at(0, 0, 0), 0.2126);
  EXPECT_DOUBLE_EQ(y.at(1, 0, 0), 0.2126 * 0.25 + 0.7152 * 0.5 + 0.0722);
  Image grey_alpha(1, 1, 2);
  grey_alpha.data = {0.375f, 0.5f};
  EXPECT_EQ(luminance(grey_alpha).at(0, 0, 0), 0.375);
  Image grey(1, 1, 1);
  grey.data = {0.625f};
  EXPECT_EQ(luminance(grey).at(0, 0, 0), 0.625);
  // The weights sum to 1: white has luminance 1.
  Image white(1, 1, 3);
  white.data = {1, 1, 1};
  EXPECT_NEAR(luminance(white).at(0, 0, 0), 1.0, 1e-15);
  EXPECT_THROW(luminance(Image()), std::invalid_argument);
}

TEST(Metrics, HighpassShareOfACosineSplitsAtItsFrequency) {
  // An integer number of periods puts all the energy in the bins at +-f: the
  // share jumps from 1 to 0 as the cutoff passes |f|. The floor is the float
  // rounding of the samples, relative energy about (6e-8)^2.
  const Image horizontal = sample(
      [](double x, double, int) { return 0.5 + 0.4 * std::cos(2 * kPi * 0.3 * x + 0.7); }, 100, 40,
      1, 100, 40);  // 30 periods
  EXPECT_NEAR(highpass_energy_share(horizontal, 0.25), 1.0, 1e-10);
  EXPECT_NEAR(highpass_energy_share(horizontal, 0.29), 1.0, 1e-10);
  EXPECT_NEAR(highpass_energy_share(horizontal, 0.35), 0.0, 1e-10);
  // Strictly above: a component exactly at the cutoff is low-pass
  // (30 / 100 rounds to the double 0.3).
  EXPECT_NEAR(highpass_energy_share(horizontal, 0.3), 0.0, 1e-10);

  // Diagonal, radius hypot(0.2, 0.15) = 0.25, RGB, 10 x 6 periods.
  const Image diagonal = sample(
      [](double x, double y, int c) { return 0.5 + (0.1 + 0.1 * c) * std::cos(2 * kPi * (0.2 * x + 0.15 * y)); },
      50, 40, 3, 50, 40);
  const std::vector<double> s = highpass_energy_shares(diagonal, {0.2, 0.24, 0.26, 0.5});
  EXPECT_NEAR(s[0], 1.0, 1e-10);
  EXPECT_NEAR(s[1], 1.0, 1e-10);
  EXPECT_NEAR(s[2], 0.0, 1e-10);
  EXPECT_NEAR(s[3], 0.0, 1e-10);
}

TEST(Metrics, HighpassShareMatchesDirectDft) {
  // Odd and even sizes on both axes: the Hermitian twins of the r2c output
  // and the folding at Nyquist must add up to the full complex DFT.
  const std::vector<double> cutoffs = {0.0, 0.1, 0.2, 0.25, 0.3, 0.45, 0.5, 0.6, 0.75};
  const long sizes[][2] = {{9, 7}, {8, 6}, {8, 7}, {9, 6}, {1, 12}, {13, 1}};
  unsigned seed = 1;
  for (const auto& wh : sizes)
    for (int channels : {1, 3}) {
      const Image img = random_image(wh[0], wh[1], channels, seed++);
      const std::vector<double> got = highpass_energy_shares(img, cutoffs);
      const std::vector<double> ref = direct_highpass(img, cutoffs);
      for (std::size_t q = 0; q < cutoffs.size(); ++q)
        EXPECT_NEAR(got[q], ref[q], 1e-12) << wh[0] << " x " << wh[1] << " cutoff " << cutoffs[q];
      EXPECT_NEAR(got[0], 1.0, 1e-15);  // every non-DC bin lies above 0
      EXPECT_EQ(got.back(), 0.0);       // no bin lies beyond sqrt(1/2)
      EXPECT_EQ(got[0], highpass_energy_share(img, 0.0));
    }
}

TEST(Metrics, HighpassShareOfAConstantImageIsZero) {
  const Image flat = sample([](double, double, int c) { return 0.1 + 0.3 * c; }, 17, 11, 3, 17, 11);
  EXPECT_EQ(highpass_energy_share(flat, 0.0), 0.0);
  EXPECT_EQ(highpass_energy_share(flat, 0.25), 0.0);
  EXPECT_THROW(highpass_energy_share(flat, -0.1), std::invalid_argument);
  EXPECT_THROW(highpass_energy_share(flat, std::numeric_limits<double>::quiet_NaN()),
               std::invalid_argument);
  Image nan = flat;
  nan.at(3, 4, 1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(highpass_energy_share(nan, 0.25), std::invalid_argument);
}

TEST(Metrics, RmsAndPsnrOfAConstantOffset) {
  // Multiples of 1/256 below 4: a + 1/4 and the difference are exact in float.
  const long W = 20, H = 15, C = 3, border = 3;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> u(0, 255);
  Image a(W, H, C), b(W, H, C);
  for (std::size_t q = 0; q < a.data.size(); ++q) {
    a.data[q] = u(rng) / 256.0f;
    b.data[q] = a.data[q] + 0.25f;
  }
  EXPECT_EQ(rms_difference(a, b), 0.25);
  EXPECT_EQ(rms_difference(b, a, border), 0.25);
  EXPECT_NEAR(psnr(a, b), 20 * std::log10(4.0), 1e-12);
  EXPECT_NEAR(psnr(a, b, 2.0), 20 * std::log10(8.0), 1e-12);
  EXPECT_EQ(psnr(a, a), std::numeric_limits<double>::infinity());

  // Garbage in the border band changes nothing inside it, and shows with a
  // narrower border.
  for (long y = 0; y < H; ++y)
    for (long x = 0; x < W; ++x)
      if (x < border || y < border || x >= W - border || y >= H - border)
        for (int c = 0; c < C; ++c) b.at(x, y, c) = 1e6f;
  EXPECT_EQ(rms_difference(a, b, border), 0.25);
  EXPECT_NEAR(psnr(a, b, 1.0, border), 20 * std::log10(4.0), 1e-12);
  EXPECT_GT(rms_difference(a, b, border - 1), 1e3);
  // One value off by d among n values inside the border: rms = |d| / sqrt(n).
  Image c = a;
  c.at(border, H - border - 1, 2) += 0.5f;
  const double n = double(W - 2 * border) * (H - 2 * border) * C;
  EXPECT_NEAR(rms_difference(a, c, border), 0.5 / std::sqrt(n), 1e-15);

  EXPECT_THROW(rms_difference(a, Image(W, H, 1)), std::invalid_argument);
  EXPECT_THROW(rms_difference(a, Image(W + 1, H, C)), std::invalid_argument);
  EXPECT_THROW(rms_difference(a, b, 8), std::invalid_argument);  // 15 rows, no row left
  EXPECT_THROW(rms_difference(a, b, -1), std::invalid_argument);
  EXPECT_THROW(psnr(a, b, 0.0), std::invalid_argument);
}

TEST(Metrics, L2ErrorOfReproducedConstantAndShiftedReference) {
  // Constants lie in every B-spline space and the mirror rule extends a
  // constant image to a constant: f_app = f everywhere, to rounding (the
  // float output of resample: about 6e-8 of 0.7).
  const long N = 16, s = 2, ref = 8;
  auto f = [](double, double, int c) { return 0.3 + 0.4 * c; };
  const Image in = sample(f, N * s, N * s, 2, N, N);
  const Image reference = sample(f, N * ref, N * ref, 2, N, N);
  const Image shifted =
      sample([&](double x, double y, int c) { return f(x, y, c) + 0.125; }, N * ref, N * ref, 2, N, N);
  for (int d : {0, 1, 3}) {
    const Coefficients k = project_with(in, N, N, d);
    EXPECT_NEAR(l2_error(k, reference), 0.0, 1e-6) << d;
    EXPECT_NEAR(l2_error(k, shifted), 0.125, 1e-6) << d;
    EXPECT_NEAR(l2_error(k, f, 4), 0.0, 1e-6) << d;
    EXPECT_NEAR(l2_error(k, [&](double x, double y, int c) { return f(x, y, c) - 0.125; }, 3, 2.0),
                0.125, 1e-6)
        << d;
  }
}

TEST(Metrics, L2ErrorOfTentOnARampAwayFromTheBorder) {
  // The tent reproduces degree 1 away from the border; the mirror rule's
  // effect decays like 0.268^k, below 1e-11 at 20 pixels. Samples and
  // f_app pass through float: values up to 2.3 carry about 1.4e-7.
  const long N = 60, s = 2;
  auto ramp = [](double x, double y, int) { return (x + 2 * y) / 80; };
  const Image in = sample(ramp, N * s, N * s, 1, N, N);
  const Coefficients tent = project_with(in, N, N, 1);
  EXPECT_LT(l2_error(tent, ramp, 4, 20.0), 5e-7);
  const Image reference = sample(ramp, N * 6, N * 6, 1, N, N);
  EXPECT_LT(l2_error(tent, reference, 20.0), 5e-7);
  // Without the border band the boundary rule's error shows.
  EXPECT_GT(l2_error(tent, ramp, 4, 0.0), 1e-4);
  // The box does not reproduce a ramp: inside a pixel f_app is the pixel's
  // mean while f rises by 1/80 along x and 2/80 along y. On m points
  // (i + 1/2)/m a unit rise has variance (m^2 - 1)/(12 m^2), so the RMS is
  // sqrt(5)/80 sqrt((m^2 - 1)/(12 m^2)). Float rounding of f_app (1.4e-7)
  // is far below the 1e-6 tolerance; the continuous value (m infinite) is
  // 1.6e-5 away.
  const Coefficients box = project_with(in, N, N, 0);
  const double m = 16;
  EXPECT_NEAR(l2_error(box, ramp, 16, 20.0),
              std::sqrt(5.0) / 80 * std::sqrt((m * m - 1) / (12 * m * m)), 1e-6);
}

// The slow direct reference of every l2_error: f_app by evaluate() (double
// precision, coefficient by coefficient) at each sample position inside the
// border, against truth(i, j, c) at sample (i, j) of a ref_w x ref_h grid.
double direct_l2(const Coefficients& k, long ref_w, long ref_h, double border,
                 const std::function<double(long, long, int)>& truth) {
  double sum = 0;
  long count = 0;
  for (long j = 0; j < ref_h; ++j)
    for (long i = 0; i < ref_w; ++i) {
      const double x = (i + 0.5) * k.image_width / ref_w, y = (j + 0.5) * k.image_height / ref_h;
      if (x < border || x > k.image_width - border || y < border || y > k.image_height - border)
        continue;
      for (int c = 0; c < k.c.channels; ++c) {
        const double e = evaluate(k, {x, y}, c) - truth(i, j, c);
        sum += e * e;
        ++count;
      }
    }
  return std::sqrt(sum / count);
}

// Coefficients with random values in a Cartesian space of any generator,
// step and boundary rule: the sums of the Cartesian route against the
// direct evaluation, away from any projection.
Coefficients random_coefficients(long w, long h, int channels, Kernel g, double hx, double hy,
                                 Boundary b, unsigned seed) {
  Coefficients k;
  k.c = Grid<double>(w, h, channels);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.2, 1.2);
  for (double& v : k.c.data) v = u(rng);
  k.lattice = Lattice::cartesian(hx, hy);
  k.space = CartesianSpace{g};
  k.boundary = b;
  k.image_width = w * hx;
  k.image_height = h * hy;
  return k;
}

TEST(Metrics, L2ErrorMatchesDirectEvaluation) {
  // The Cartesian route (the Gram matrices, the acquired reference and the
  // reference's energy, all in double) against evaluate() at each sample:
  // the two differ only in the order of the double sums, so by a few ulps
  // of sum f^2 relative to sum (f_app - f)^2 (here about 0.3 against 0.5
  // for random data): 1e-12 relative. Generators of every kind and width,
  // steps that are not the output pixel's, both boundary rules (reached
  // with border 0), non-integer factors.
  const Image reference = random_image(53, 38, 2, 22);
  struct Case {
    Kernel g;
    double hx, hy;
    Boundary b;
  };
  const Case cases[] = {{Kernel::bspline(0), 1, 1, Boundary::Mirror},
                        {Kernel::bspline(1), 1, 1, Boundary::Periodic},
                        {Kernel::bspline(3), 0.5, 0.75, Boundary::Mirror},
                        {Kernel::bspline(5), 1, 1, Boundary::Periodic},
                        {Kernel::mitchell(), 1.5, 1, Boundary::Mirror},
                        {Kernel::lanczos(3), 1, 1, Boundary::Mirror}};
  for (const Case& t : cases)
    for (double border : {0.0, 1.5}) {
      const Coefficients k = random_coefficients(long(12 / t.hx), long(9 / t.hy), 2, t.g, t.hx, t.hy,
                                                 t.b, 7);
      const double direct = direct_l2(k, reference.width, reference.height, border,
                                      [&](long i, long j, int c) { return reference.at(i, j, c); });
      const std::string what = t.g.name() + " " + boundary_name(t.b) + " border " + std::to_string(border);
      EXPECT_NEAR(l2_error(k, reference, border, 2), direct, 1e-12 * direct) << what;
      auto f = [](double x, double y, int c) { return std::sin(x + 0.3 * c) * std::cos(0.7 * y); };
      const double direct_f = direct_l2(k, 12 * 4, 9 * 4, border, [&](long i, long j, int c) {
        return f((i + 0.5) / 4, (j + 0.5) / 4, c);
      });
      EXPECT_NEAR(l2_error(k, f, 4, border, 2), direct_f, 1e-12 * direct_f) << what;
    }
  const Coefficients k = project_with(random_image(36, 24, 2, 21), 12, 12, 1);
  EXPECT_THROW(l2_error(k, random_image(10, 10, 1, 1)), std::invalid_argument);  // channels
  EXPECT_THROW(l2_error(k, reference, 6.5), std::invalid_argument);  // nothing left
  EXPECT_THROW(l2_error(k, reference, -1.0), std::invalid_argument);
  EXPECT_THROW(l2_error(k, [](double, double, int) { return 0.0; }, 0), std::invalid_argument);
}

TEST(Metrics, L2ReferenceGivesL2ErrorsBitsForManyApproximations) {
  // One reference, approximations in three Cartesian spaces met twice each
  // (the second time from the kept acquisition) and one hexagonal one: each
  // error has the bits of l2_error on its own, for 1 and 3 threads.
  const long N = 16;
  const Image in = random_image(N * 3, N * 3, 3, 51);
  const Image reference = random_image(N * 5, N * 5, 3, 52);
  std::vector<Coefficients> ks;
  for (int round = 0; round < 2; ++round)
    for (int d : {0, 1, 3}) ks.push_back(project_with(random_image(N * 3, N * 3, 3, 53 + round), N, N, d));
  HexProjectionOptions ho;
  ks.push_back(project_hexagonal(in, double(N), double(N), ho));
  for (int threads : {1, 3}) {
    L2Reference ref(reference, 2.0, threads);
    for (const Coefficients& k : ks) EXPECT_EQ(ref.l2_error(k), l2_error(k, reference, 2.0, 1));
  }
  EXPECT_THROW(L2Reference(reference, -1.0), std::invalid_argument);
  L2Reference ref(reference, 8.5);
  EXPECT_THROW(ref.l2_error(ks[0]), std::invalid_argument);  // the border leaves nothing
}

TEST(Metrics, L2ErrorIsTheSameForEveryThreadCount) {
  // The reference's rows are acquired on the workers and added in row
  // order: the same bits for 1, 2 and 7 threads, against a reference and
  // against a pure closed form called from every thread (or the calling one
  // only); the hexagonal space's direct evaluation likewise.
  const long N = 20;
  const Image in = random_image(N * 3, N * 3, 3, 31);
  const Image reference = random_image(N * 5, N * 5, 3, 32);
  auto f = [](double x, double y, int c) { return std::sin(x + 0.3 * c) * std::cos(0.7 * y); };
  HexProjectionOptions ho;
  for (const Coefficients& k : {project_with(in, N, N, 3), project_hexagonal(in, double(N), double(N), ho)}) {
    const double ref1 = l2_error(k, reference, 1.0, 1);
    const double fun1 = l2_error(k, f, 4, 1.0, 1, false);
    for (int threads : {2, 7}) {
      EXPECT_EQ(l2_error(k, reference, 1.0, threads), ref1) << threads;
      EXPECT_EQ(l2_error(k, f, 4, 1.0, threads, true), fun1) << threads;
      EXPECT_EQ(l2_error(k, f, 4, 1.0, threads, false), fun1) << threads;
    }
  }
}

TEST(Metrics, ZoneplateL2ErrorEqualsTheDirectClosedForm) {
  // The factored form (per-axis acquisitions and sums) against evaluate()
  // and the direct plate at every point: they differ in the order of the
  // double sums only (the error, about 0.3 here, by less than 1e-12 of
  // itself); the same bits for any thread count. Non-square, with an odd
  // number of samples per pixel.
  const long W = 24, H = 18;
  const Image in = random_image(W * 2, H * 2, 1, 41);
  const Coefficients k = project_with(in, W, H, 3);
  const double K = 0.7 * M_PI * W;
  const double direct = direct_l2(k, W * 5, H * 5, 2.0, [&](long i, long j, int) {
    return zoneplate(K, double(W), double(H), (i + 0.5) / 5, (j + 0.5) / 5);
  });
  const double factored = zoneplate_l2_error(k, K, 5, 2.0, 1);
  EXPECT_NEAR(factored, direct, 1e-12 * direct);
  EXPECT_EQ(zoneplate_l2_error(k, K, 5, 2.0, 3), factored);
  EXPECT_THROW(zoneplate_l2_error(k, K, 0, 2.0, 1), std::invalid_argument);
  // The hexagonal space evaluates f_app at every sample, through float.
  HexProjectionOptions ho;
  const Coefficients hex = project_hexagonal(in, double(W), double(H), ho);
  const double hex_direct = direct_l2(hex, W * 5, H * 5, 2.0, [&](long i, long j, int) {
    return zoneplate(K, double(W), double(H), (i + 0.5) / 5, (j + 0.5) / 5);
  });
  EXPECT_NEAR(zoneplate_l2_error(hex, K, 5, 2.0, 2), hex_direct, 1e-6 * hex_direct);
}

TEST(Metrics, OvershootOfAHandMadeOutput) {
  // A checkerboard input in {0, 1} at factor 2: every neighbourhood's range
  // is [0, 1]. One pixel at 1.5, one at -0.25.
  const long W = 6, H = 5, s = 2;
  Image input(W * s, H * s, 1);
  for (long l = 0; l < H * s; ++l)
    for (long k = 0; k < W * s; ++k) input.at(k, l, 0) = float((k + l) % 2);
  Image output(W, H, 1);
  for (float& v : output.data) v = 0.5f;
  output.at(2, 1, 0) = 1.5f;
  output.at(5, 3, 0) = -0.25f;
  const OvershootReport r = overshoot(output, input);
  EXPECT_EQ(r.pixels, W * H);
  EXPECT_EQ(r.max_overshoot, 0.5);
  EXPECT_EQ(r.max_undershoot, 0.25);
  EXPECT_EQ(r.pixels_out_of_range, 2);
  EXPECT_EQ(r.negative_pixels, 1);
  EXPECT_EQ(r.negative_energy, 0.0625);
  EXPECT_EQ(r.min, -0.25);
  EXPECT_EQ(r.max, 1.5);

  // Rounding-sized excursions pass the tolerance but are still reported.
  Image near = output;
  near.at(2, 1, 0) = 1.0f + 4.0f * std::numeric_limits<float>::epsilon();
  near.at(5, 3, 0) = -std::numeric_limits<float>::epsilon();
  const OvershootReport t = overshoot(near, input);
  EXPECT_EQ(t.pixels_out_of_range, 0);
  EXPECT_EQ(t.negative_pixels, 0);
  EXPECT_NEAR(t.max_overshoot, 4.0 * std::numeric_limits<float>::epsilon(), 1e-12);
  EXPECT_GT(t.negative_energy, 0.0);
  OvershootOptions strict;
  strict.tolerance = 0;
  EXPECT_EQ(overshoot(near, input, strict).pixels_out_of_range, 2);
  EXPECT_EQ(overshoot(near, input, strict).negative_pixels, 1);

  // A border band of 1 leaves the pixel at (5, 3) out, not the one at (2, 1).
  OvershootOptions bordered;
  bordered.border = 1;
  const OvershootReport b = overshoot(output, input, bordered);
  EXPECT_EQ(b.pixels, (W - 2) * (H - 2));
  EXPECT_EQ(b.negative_pixels, 0);
  EXPECT_EQ(b.pixels_out_of_range, 1);
  EXPECT_EQ(b.negative_energy, 0.0);
  EXPECT_EQ(b.min, 0.5);
  EXPECT_EQ(b.max, 1.5);

  EXPECT_THROW(overshoot(output, Image(W * s, H * s, 3)), std::invalid_argument);
  bordered.border = 3;
  EXPECT_THROW(overshoot(output, input, bordered), std::invalid_argument);
}

TEST(Metrics, OvershootNeighbourhoodIsTheSquarePlusRadius) {
  // A ramp input 0..11 along x at factor 2 (sample k at (k + 1/2) / 2):
  // output pixel i holds samples 2i and 2i + 1, radius r adds 2r per side.
  const long W = 6, s = 2;
  Image input(W * s, 1, 1);
  for (long k = 0; k < W * s; ++k) input.at(k, 0, 0) = float(k);
  Image output(W, 1, 1);
  for (long i = 0; i < W; ++i) output.at(i, 0, 0) = float(2 * i + 1);  // the square's max
  OvershootOptions o;
  o.neighbourhood = 0;
  EXPECT_EQ(overshoot(output, input, o).pixels_out_of_range, 0);
  output.at(3, 0, 0) = 8.0f;  // past the square's max 7, within radius 1 (max 9)
  EXPECT_EQ(overshoot(output, input, o).pixels_out_of_range, 1);
  EXPECT_EQ(overshoot(output, input, o).max_overshoot, 1.0);
  o.neighbourhood = 1;
  EXPECT_EQ(overshoot(output, input, o).pixels_out_of_range, 0);
  o.neighbourhood = 0.5;  // one more sample per side: max 8
  EXPECT_EQ(overshoot(output, input, o).pixels_out_of_range, 0);
  output.at(3, 0, 0) = 9.0f;
  EXPECT_EQ(overshoot(output, input, o).pixels_out_of_range, 1);

  // An output finer than the input: pixels that hold no sample take the
  // nearest. Input samples at x = 1 and 3 of a 4-pixel output.
  Image coarse(2, 1, 1);
  coarse.data = {0, 1};
  Image fine(4, 1, 1);
  fine.data = {0, 0, 1, 1};
  o.neighbourhood = 0;
  EXPECT_EQ(overshoot(fine, coarse, o).pixels_out_of_range, 0);
  fine.data = {0.125f, 0, 1, 1};
  EXPECT_EQ(overshoot(fine, coarse, o).max_overshoot, 0.125);
}

TEST(Metrics, OvershootMatchesBruteForce) {
  // Any ratio per axis: every output pixel against every input sample.
  const long W = 9, H = 7;
  // Ratios of at least 1 per axis: every square holds a sample.
  const long in_sizes[][2] = {{23, 19}, {9, 7}, {40, 15}};
  for (const auto& in_size : in_sizes)
    for (double r : {0.0, 0.5, 1.0, 2.0}) {
      const Image input = random_image(in_size[0], in_size[1], 2, 31);
      const Image output = random_image(W, H, 2, 32, -0.2f, 1.2f);
      OvershootOptions o;
      o.neighbourhood = r;
      o.border = 1;
      const OvershootReport got = overshoot(output, input, o);
      OvershootReport ref;
      ref.min = 1e300;
      ref.max = -1e300;
      for (long j = 1; j < H - 1; ++j)
        for (long i = 1; i < W - 1; ++i) {
          bool out = false, neg = false;
          for (int c = 0; c < 2; ++c) {
            double lo = 1e300, hi = -1e300;
            for (long l = 0; l < input.height; ++l)
              for (long k = 0; k < input.width; ++k) {
                const double x = (k + 0.5) * W / input.width, y = (l + 0.5) * H / input.height;
                if (x < i - r || x >= i + 1 + r || y < j - r || y >= j + 1 + r) continue;
                lo = std::min(lo, double(input.at(k, l, c)));
                hi = std::max(hi, double(input.at(k, l, c)));
              }
            ASSERT_LE(lo, hi);
            const double v = output.at(i, j, c);
            ref.max_overshoot = std::max(ref.max_overshoot, v - hi);
            ref.max_undershoot = std::max(ref.max_undershoot, lo - v);
            out |= v > hi + 1e-6 * std::max(1.0, std::abs(hi)) ||
                   v < lo - 1e-6 * std::max(1.0, std::abs(lo));
            neg |= v < -1e-6;
            if (v < 0) ref.negative_energy += v * v;
            ref.min = std::min(ref.min, v);
            ref.max = std::max(ref.max, v);
          }
          ++ref.pixels;
          ref.pixels_out_of_range += out;
          ref.negative_pixels += neg;
        }
      const std::string what = std::to_string(in_size[0]) + " r " + std::to_string(r);
      EXPECT_EQ(got.pixels, ref.pixels) << what;
      EXPECT_EQ(got.pixels_out_of_range, ref.pixels_out_of_range) << what;
      EXPECT_EQ(got.negative_pixels, ref.negative_pixels) << what;
      EXPECT_DOUBLE_EQ(got.max_overshoot, ref.max_overshoot) << what;
      EXPECT_DOUBLE_EQ(got.max_undershoot, ref.max_undershoot) << what;
      EXPECT_DOUBLE_EQ(got.negative_energy, ref.negative_energy) << what;
      EXPECT_EQ(got.min, ref.min) << what;
      EXPECT_EQ(got.max, ref.max) << what;
      EXPECT_GT(ref.pixels_out_of_range, 0) << what;  // the test sees something
    }
}

// A NaN or an infinity in any image or number a measure is given is refused
// (a NaN scored as a perfect 0 before: every comparison with it is false),
// and so is an overshoot neighbourhood past the output's larger side (its
// window indices overflowed, and the search never ended).
TEST(Metrics, NonFiniteArgumentsAreRefused) {
  const Image in = random_image(32, 24, 2, 41);
  const Coefficients k = project_with(in, 8, 6, 3);
  Image bad = in;
  bad.at(5, 3, 1) = std::numeric_limits<float>::quiet_NaN();
  Image out = random_image(8, 6, 2, 42);
  Image worse = out;
  worse.at(2, 1, 0) = std::numeric_limits<float>::infinity();
  auto refused = [](const std::function<void()>& f, const std::string& part) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << "not refused: " << part;
  };
  refused([&] { l2_error(k, bad); }, "l2_error(): non-finite value (NaN or Inf) in the reference at x 5, y 3, channel 1");
  refused([&] { L2Reference r(bad); }, "in the reference at x 5, y 3");
  refused([&] { zoneplate_l2_error(k, std::nan(""), 8); }, "l2_error(): the zone plate's K nan is not finite");
  refused([&] { zoneplate_l2_error(k, 40, 2000); }, "samples_per_pixel 2000: expected 1 to 1024");
  refused([&] { l2_error(k, [](double, double, int) { return std::nan(""); }, 4); },
          "l2_error(): the error is not finite");
  refused([&] { rms_difference(out, worse); }, "rms_difference(): non-finite value (NaN or Inf) in the second image at x 2, y 1");
  refused([&] { psnr(worse, out); }, "in the first image at x 2, y 1");
  refused([&] { overshoot(worse, in); }, "overshoot(): non-finite value (NaN or Inf) in the output at x 2, y 1");
  refused([&] { overshoot(out, bad); }, "overshoot(): non-finite value (NaN or Inf) in the input at x 5, y 3");
  OvershootOptions far;
  far.neighbourhood = 1e19;
  refused([&] { overshoot(out, in, far); }, "overshoot(): neighbourhood 1e+19 output pixels: at most 8");
  far.neighbourhood = 8;  // the largest taken: every window the whole input
  const OvershootReport whole = overshoot(out, in, far);
  EXPECT_EQ(whole.pixels, 48);
}
