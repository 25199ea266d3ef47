// Acquisition, projection and resampling: against slow direct sums, and the
// identities of the orthogonal projection (docs/design.md sections 2 to 5).
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include <atomic>
#include <cmath>
#include <functional>
#include <random>
#include <thread>

#include "sis/projection.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {

const Boundary kRules[] = {Boundary::Mirror, Boundary::Periodic};

Coefficients project_with(const Image& in, long w, long h, const Kernel& g, Method m, Boundary b,
                          int threads = 1) {
  ProjectionOptions o;
  o.generator = g;
  o.method = m;
  o.boundary = b;
  o.threads = threads;
  return project(in, w, h, o);
}

// 1-D Gram entries <b_d, b_d(. - k)> by Gauss-Legendre on the knot pieces,
// independent of the autocorrelation formula.
double gram_entry(int d, int k) {
  static const double X[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                              0.8611363115940526};
  static const double Wt[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                               0.3478548451374538};
  // pieces of width 1/2 (knots on the half-integer grid); 4 points exact to
  // degree 7 per piece would not do for 2d = 14: subdivide each piece 8 times.
  const double r = 0.5 * (d + 1);
  double s = 0;
  const int pieces = 16 * (d + 1);
  const double h = 2 * r / pieces;
  for (int p = 0; p < pieces; ++p) {
    const double m = -r + (p + 0.5) * h;
    for (int i = 0; i < 4; ++i) {
      const double x = m + 0.5 * h * X[i];
      s += 0.5 * h * Wt[i] * bspline(d, x) * bspline(d, x - k);
    }
  }
  return s;
}

// The acquisition of coefficient (n1, n2), channel c, by the direct double
// sum over the boundary-extended samples (min-error: dx dy sum w f;
// conventional: sum w f / sum w).
double direct_acquisition(const Image& in, const Kernel& k, Method m, Boundary b, long W, long H,
                          long n1, long n2, int c) {
  const long win = in.width, hin = in.height;
  const double dx = double(W) / win, dy = double(H) / hin;
  double num = 0, wsum = 0;
  for (long j = -3 * hin; j < 4 * hin; ++j)
    for (long i = -3 * win; i < 4 * win; ++i) {
      const double w = k.eval((i + 0.5) * dx - (n1 + 0.5)) * k.eval((j + 0.5) * dy - (n2 + 0.5));
      if (w == 0) continue;
      num += w * in.at(extend_index(i, win, b), extend_index(j, hin, b), c);
      wsum += w;
    }
  return m == Method::MinError ? num * dx * dy : num / wsum;
}

}  // namespace

TEST(Acquisition, MatchesDirectSumAtWholeRatios) {
  // Output 9 x 7 from 27 x 35 samples: 3 and 5 samples per pixel, where the
  // plain sum is the acquisition (at other ratios, test_factor.cpp).
  const long W = 9, H = 7, win = 27, hin = 35;
  const Image in = random_image(win, hin, 2, 42);
  const Kernel kernels[] = {Kernel::bspline(0), Kernel::bspline(1), Kernel::bspline(3),
                            Kernel::bspline(6), Kernel::mitchell(),  Kernel::lanczos(3),
                            Kernel::gaussian()};
  for (const Kernel& k : kernels)
    for (Method m : {Method::MinError, Method::Conventional}) {
      if (m == Method::MinError && !k.is_bspline()) continue;
      for (Boundary b : kRules) {
        const AcquisitionPlan plan(win, hin, 2, W, H, Lattice::cartesian(), k, b, m);
        const Coefficients got = acquire(in, plan, 2);
        for (long n2 = 0; n2 < H; ++n2)
          for (long n1 = 0; n1 < W; ++n1)
            for (int c = 0; c < 2; ++c)
              EXPECT_NEAR(got.c.at(n1, n2, c), direct_acquisition(in, k, m, b, W, H, n1, n2, c), 1e-12)
                  << k.name() << " " << method_name(m) << " " << boundary_name(b);
      }
    }
}

TEST(Acquisition, RowGroupGivesTheBitsOfRowAfterRow) {
  // add_scaled_row_group against a plain scalar loop, one row after another:
  // each sum's terms in row order, a product then a sum each, the started
  // sums' first term added to 0.0. Lengths not a multiple of any vector
  // width, any row and sum count, float and double rows.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  const long n = 203, offset = 5;
  for (int rows = 1; rows <= 6; ++rows)
    for (int count = 1; count <= 6; ++count)
      for (int starts = 0; starts <= count; ++starts) {
        std::vector<std::vector<float>> xf(rows, std::vector<float>(n));
        std::vector<std::vector<double>> xd(rows, std::vector<double>(n)), w(rows, std::vector<double>(count));
        for (int r = 0; r < rows; ++r) {
          for (long k = 0; k < n; ++k) xd[r][k] = xf[r][k] = float(u(rng));
          for (double& v : w[r]) v = u(rng);
        }
        std::vector<std::vector<double>> ref(count, std::vector<double>(offset + n));
        for (auto& s : ref)
          for (double& v : s) v = u(rng);
        std::vector<std::vector<double>> got_f = ref, got_d = ref;
        for (int i = 0; i < count; ++i)
          for (int r = 0; r < rows; ++r)
            for (long k = 0; k < n; ++k) {
              const double before = (r == 0 && i >= count - starts) ? 0.0 : ref[i][offset + k];
              const double term = w[r][i] * double(xf[r][k]);
              ref[i][offset + k] = before + term;
            }
        std::vector<double*> sf(count), sd(count);
        std::vector<const double*> wp(rows);
        std::vector<const float*> xfp(rows);
        std::vector<const double*> xdp(rows);
        for (int i = 0; i < count; ++i) sf[i] = got_f[i].data(), sd[i] = got_d[i].data();
        for (int r = 0; r < rows; ++r) wp[r] = w[r].data(), xfp[r] = xf[r].data(), xdp[r] = xd[r].data();
        add_scaled_row_group(sf.data(), wp.data(), count, starts, offset, xfp.data(), rows, n);
        add_scaled_row_group(sd.data(), wp.data(), count, starts, offset, xdp.data(), rows, n);
        for (int i = 0; i < count; ++i) {
          EXPECT_EQ(got_f[i], ref[i]) << rows << " rows, sum " << i << " of " << count << ", " << starts << " started";
          EXPECT_EQ(got_d[i], ref[i]) << rows << " rows, sum " << i << " of " << count << ", " << starts << " started";
        }
      }
}

namespace {

// One axis of the acquisition, by a slow direct route: the matrix A[n][m]
// from the samples m in [0, samples) to the coefficients n, the sample
// spacing step = count / samples output pixels. Samples at least as dense
// as the lattice: the point sum step * phi(x_i - p_n) over the extended
// samples i, folded. Sparser (upsampling): the samples' cubic interpolant
// under the rule, its coefficients c = B^{-1} f from a dense solve of the
// interpolation system, projected: sum over the extended k of
// I[n][k] c[fold(k)], I[n][k] = int b3((x - x_k) / step) phi(x - p_n) dx by
// the midpoint rule on 20000 points.
std::vector<std::vector<double>> direct_axis(long count, long samples, const Kernel& phi,
                                             Boundary rule) {
  const double step = double(count) / samples, R = phi.radius();
  std::vector<std::vector<double>> A(count, std::vector<double>(samples, 0.0));
  if (step <= 1) {
    for (long n = 0; n < count; ++n)
      for (long i = -4 * samples - 8; i < 5 * samples + 8; ++i)
        A[n][extend_index(i, samples, rule)] += step * phi.eval((i + 0.5) * step - (n + 0.5));
    return A;
  }
  std::vector<double> B(samples * samples, 0.0);
  for (long j = 0; j < samples; ++j)
    for (long k = j - 2; k <= j + 2; ++k) B[j * samples + extend_index(k, samples, rule)] += bspline(3, double(j - k));
  std::vector<std::vector<double>> inverse(samples);  // column m: B^{-1} e_m
  for (long m = 0; m < samples; ++m) {
    std::vector<double> e(samples, 0.0);
    e[m] = 1;
    inverse[m] = dense_solve(B, e);
  }
  const int N = 20000;
  for (long n = 0; n < count; ++n) {
    const double p = n + 0.5;
    for (long k = long(std::floor((p - R) / step)) - 3; k <= long(std::ceil((p + R) / step)) + 3; ++k) {
      double I = 0;
      for (int q = 0; q < N; ++q) {
        const double x = p - R + (q + 0.5) * (2 * R / N);
        I += bspline(3, (x - (k + 0.5) * step) / step) * phi.eval(x - p);
      }
      I *= 2 * R / N;
      const long kk = extend_index(k, samples, rule);
      for (long m = 0; m < samples; ++m) A[n][m] += I * inverse[m][kk];
    }
  }
  return A;
}

}  // namespace

TEST(Acquisition, UpsampledAxesProjectTheCubicInterpolant) {
  // Where the samples are sparser than the lattice (here both axes, then x
  // downsampled by a whole factor and y upsampled), the acquisition is the
  // exact inner product of the samples' cubic interpolant with each
  // generator, against the slow route of direct_axis(). Tolerance: the midpoint rule's error on
  // piecewise polynomials with kinks, about (2R / 20000)^2 of the values'
  // scale, and the model's truncation (2^-64 of its peak). The coefficient
  // grid starts unset; a freed grid of its size filled with non-zeros goes
  // first, so that unset memory would show.
  for (auto [W, H, win, hin] : {std::array<long, 4>{19, 15, 4, 3}, {9, 13, 36, 5}})
    for (Boundary rule : kRules)
      for (const Kernel& k : {Kernel::bspline(0), Kernel::bspline(1), Kernel::bspline(3),
                              Kernel::bspline(4), Kernel::mitchell()}) {
        const Method method = k.is_bspline() ? Method::MinError : Method::Conventional;
        const Image in = random_image(win, hin, 2, 7);
        const AcquisitionPlan plan(win, hin, 2, W, H, Lattice::cartesian(), k, rule, method);
        {
          Grid<double> junk(W, H, 2);
          std::fill(junk.data.begin(), junk.data.end(), 7.0);
        }
        const Coefficients got = acquire(in, plan, 2);
        auto ax = direct_axis(W, win, k, rule), ay = direct_axis(H, hin, k, rule);
        if (method == Method::Conventional)
          for (auto* a : {&ax, &ay})
            for (auto& row : *a) {
              double sum = 0;
              for (double v : row) sum += v;
              for (double& v : row) v /= sum;
            }
        for (long n2 = 0; n2 < H; ++n2)
          for (long n1 = 0; n1 < W; ++n1)
            for (int c = 0; c < 2; ++c) {
              double want = 0;
              for (long j = 0; j < hin; ++j)
                for (long i = 0; i < win; ++i) want += ay[n2][j] * ax[n1][i] * in.at(i, j, c);
              ASSERT_NEAR(got.c.at(n1, n2, c), want, 1e-7)
                  << k.name() << " " << boundary_name(rule) << " " << win << " -> " << W << " at "
                  << n1 << ", " << n2;
            }
      }
}

TEST(Projection, UpsamplingKeepsFlatImagesFlatAndRampsRamps) {
  // The input's cubic interpolant reproduces polynomials of degree 3, and
  // the projection onto a space that holds them (degree >= 1; at pixel
  // centres, degree 0 too: a symmetric pixel's average of a ramp is its
  // centre value) or a symmetric normalised filter keeps them: a flat
  // image is flat everywhere, a ramp a ramp away from the border, where the
  // boundary rule's extension is not a ramp (its effect decays as the
  // prefilters' poles, |z| <= 0.54 per pixel: 2^-40 after 45 pixels).
  // Samples in double (acquire of a double grid): exact to rounding.
  const double kRamp[3] = {0.25, 0.013, -0.007};  // a + b x + c y, output pixels
  for (double factor : {0.5, 0.3, 0.77})
    for (Boundary rule : kRules)
      for (const Kernel& k : {Kernel::bspline(0), Kernel::bspline(1), Kernel::bspline(2),
                              Kernel::bspline(3), Kernel::mitchell(), Kernel::lanczos()}) {
        const Method method = k.is_bspline() ? Method::MinError : Method::Conventional;
        const long W = 150, H = 140;
        const long win = std::lround(W * factor), hin = std::lround(H * factor);
        Grid<double> flat(win, hin, 1), ramp(win, hin, 1);
        for (long j = 0; j < hin; ++j)
          for (long i = 0; i < win; ++i) {
            flat.at(i, j, 0) = 0.5;
            const double x = (i + 0.5) * W / win, y = (j + 0.5) * H / hin;
            ramp.at(i, j, 0) = kRamp[0] + kRamp[1] * x + kRamp[2] * y;
          }
        const AcquisitionPlan plan(win, hin, 1, W, H, Lattice::cartesian(), k, rule, method);
        for (const Grid<double>* in : {&flat, &ramp}) {
          Coefficients c = acquire(*in, plan, 2);
          prefilter(c, 2);
          const Image out = final_image(c, Display::centred(), W, H, 2);
          const long border = in == &flat ? 0 : 45;
          for (long y = border; y < H - border; ++y)
            for (long x = border; x < W - border; ++x) {
              const double want =
                  in == &flat ? 0.5 : kRamp[0] + kRamp[1] * (x + 0.5) + kRamp[2] * (y + 0.5);
              // the final image is float
              ASSERT_NEAR(out.at(x, y, 0), want, 4e-7)
                  << k.name() << " " << boundary_name(rule) << " factor " << factor
                  << (in == &flat ? " flat" : " ramp") << " at " << x << ", " << y;
            }
        }
      }
}

TEST(Acquisition, BitIdenticalForAnyStripAndThreadCount) {
  const Image in = random_image(203, 171, 3, 1);
  const AcquisitionPlan plan(203, 171, 3, 50, 40, Lattice::cartesian(), Kernel::bspline(3),
                             Boundary::Mirror, Method::MinError);
  const Coefficients ref = acquire(in, plan, 1);
  for (int threads : {1, 2, 5})
    for (long strip : {1L, 13L, 171L}) {
      Acquisition a(plan, threads);
      for (long y = 0; y < in.height; y += strip)
        a.add_rows(y, std::min(in.height, y + strip), in.row(y));
      EXPECT_EQ(a.finish().c.data, ref.c.data) << threads << " " << strip;
    }
}

TEST(Acquisition, BandsMatchTheDirectSumAndGiveTheSameBitsInAnyOrder) {
  // Bands of 1, 3 and 16 rows: coefficient rows whose input rows lie in
  // up to a dozen bands (periodic: bands at both ends). In order (any strip
  // and thread count), and band by band on two threads at once in
  // decreasing order: the same bits; against the direct sum (3 and 6
  // samples per pixel): rounding.
  const long W = 9, H = 7, win = 27, hin = 42;
  const Image in = random_image(win, hin, 3, 17);
  for (const Kernel& k : {Kernel::bspline(3), Kernel::mitchell()})
    for (Boundary b : kRules)
      for (long band_rows : {1L, 3L, 16L}) {
        const Method m = k.is_bspline() ? Method::MinError : Method::Conventional;
        const AcquisitionPlan plan(win, hin, 3, W, H, Lattice::cartesian(), k, b, m, band_rows);
        ASSERT_EQ(plan.bands().count(), (hin + band_rows - 1) / band_rows);
        const Coefficients ref = acquire(in, plan, 1);
        SCOPED_TRACE(k.name() + " " + boundary_name(b) + ", bands of " + std::to_string(band_rows));
        for (long n2 = 0; n2 < H; ++n2)
          for (long n1 = 0; n1 < W; ++n1)
            for (int c = 0; c < 3; ++c)
              EXPECT_NEAR(ref.c.at(n1, n2, c), direct_acquisition(in, k, m, b, W, H, n1, n2, c), 1e-12);
        for (int threads : {2, 3}) {
          Acquisition a(plan, threads);
          for (long y = 0; y < hin; y += 5) a.add_rows(y, std::min(hin, y + 5), in.row(y));
          EXPECT_EQ(a.finish().c.data, ref.c.data) << threads << " threads in order";
        }
        Acquisition a(plan);
        const BandPartition& bands = plan.bands();
        std::atomic<long> next{bands.count() - 1};
        auto worker = [&] {
          Acquisition::Band band(a);
          for (long n; (n = next--) >= 0;) {
            band.begin(n);
            for (long y = bands.begin(n); y < bands.end(n); y += 2)
              band.add_rows(y, std::min(bands.end(n), y + 2), in.row(y));
            band.end();
          }
        };
        std::thread other(worker);
        worker();
        other.join();
        EXPECT_EQ(a.finish().c.data, ref.c.data) << "bands at once";
      }
}

TEST(Acquisition, BandsMustBeTakenWhole) {
  const Image in = random_image(8, 12, 1, 1);
  const AcquisitionPlan plan(8, 12, 1, 4, 6, Lattice::cartesian(), Kernel::bspline(1),
                             Boundary::Mirror, Method::MinError, 4);
  Acquisition a(plan);
  Acquisition::Band band(a);
  EXPECT_THROW(band.add_rows(0, 2, in.row(0)), std::logic_error);  // no band begun
  EXPECT_THROW(band.begin(3), std::logic_error);                   // bands 0, 1, 2
  band.begin(1);
  EXPECT_THROW(band.begin(2), std::logic_error);                   // band 1 not ended
  EXPECT_THROW(band.add_rows(0, 2, in.row(0)), std::logic_error);  // not band 1's rows
  band.add_rows(4, 6, in.row(4));
  EXPECT_THROW(band.end(), std::logic_error);                      // rows 6, 7 missing
  EXPECT_THROW(band.add_rows(6, 9, in.row(6)), std::logic_error);  // past the band
  band.add_rows(6, 8, in.row(6));
  band.end();
  EXPECT_THROW(band.begin(1), std::logic_error);                   // taken before
  EXPECT_THROW(a.finish(), std::logic_error);                      // bands 0 and 2 missing
}

TEST(Acquisition, EveryPathGivesTheSameBits) {
  // Float rows are widened to double, double rows summed as they are, rows
  // from a function (siproject's path) arrive in pieces; 3 and 4 channels
  // take the vectorised horizontal filter, the others the scalar one. With
  // the same values all must give the same sums.
  for (int C : {1, 2, 3, 4, 5})
    for (const Kernel& k : {Kernel::bspline(1), Kernel::bspline(3), Kernel::mitchell()})
      for (Boundary b : kRules) {
        const Image in = random_image(203, 61, C, C);
        Grid<double> wide(in.width, in.height, C);
        for (std::size_t q = 0; q < in.data.size(); ++q) wide.data[q] = in.data[q];
        const Method m = k.is_bspline() ? Method::MinError : Method::Conventional;
        const AcquisitionPlan plan(203, 61, C, 30, 17, Lattice::cartesian(), k, b, m);
        const Coefficients ref = acquire(wide, plan, 1);
        EXPECT_EQ(acquire(in, plan, 2).c.data, ref.c.data) << C << " " << k.name();
        Acquisition a(plan, 2);
        for (long y = 0; y < in.height; y += 16) {
          const long y1 = std::min(in.height, y + 16);
          a.add_rows(y, y1, [&](long row, long k0, long k1, float* scratch) {
            std::copy(in.row(row) + k0, in.row(row) + k1, scratch);
            return static_cast<const float*>(scratch);
          });
        }
        EXPECT_EQ(a.finish().c.data, ref.c.data) << C << " " << k.name();
      }
}

TEST(Parallel, EveryIndexOnceAlsoWhenNested) {
  // Chunks of a parallel_for that call parallel_for themselves (run in the
  // calling thread): every index of every level exactly once.
  const long n = 37, m = 53;
  std::vector<std::atomic<int>> seen(n * m);
  parallel_for(n, 3, [&](long i0, long i1) {
    for (long i = i0; i < i1; ++i)
      parallel_for(m, 2, [&](long j0, long j1) {
        for (long j = j0; j < j1; ++j) ++seen[i * m + j];
      });
  });
  for (const auto& s : seen) EXPECT_EQ(s.load(), 1);
  EXPECT_THROW(parallel_for(4, 2, [](long, long) { throw std::runtime_error("part"); }),
               std::runtime_error);
}

TEST(Acquisition, RowsMustArriveInOrder) {
  const Image in = random_image(8, 8, 1, 1);
  const AcquisitionPlan plan(8, 8, 1, 4, 4, Lattice::cartesian(), Kernel::bspline(1),
                             Boundary::Mirror, Method::MinError);
  Acquisition a(plan);
  EXPECT_THROW(a.add_rows(2, 4, in.row(2)), std::logic_error);
  a.add_rows(0, 4, in.row(0));
  EXPECT_THROW(a.finish(), std::logic_error);
  EXPECT_THROW(AcquisitionPlan(8, 8, 1, 4, 4, Lattice::cartesian(), Kernel::mitchell(),
                               Boundary::Mirror, Method::MinError),
               std::invalid_argument);
}

TEST(Projection, CoordinateConvention) {
  // f = x + 2y sampled at ((i + 1/2)/s, (j + 1/2)/s): the tent projection
  // reproduces it, so f_app at the pixel centre (n + 1/2, m + 1/2) must be
  // n + 1/2 + 2(m + 1/2). Samples at i/s would shift it by 1/(2s).
  const long N = 40, s = 3;
  const Image in = sample([](double x, double y, int) { return x + 2 * y; }, N * s, N * s, 1, N, N);
  const Coefficients k = project_with(in, N, N, Kernel::bspline(1), Method::MinError,
                                      Boundary::Mirror);
  for (long m = 15; m < 25; ++m)
    for (long n = 15; n < 25; ++n)
      EXPECT_NEAR(evaluate(k, {n + 0.5, m + 0.5}), n + 0.5 + 2 * (m + 0.5), 2e-5);
}

TEST(Projection, BoxAtIntegerFactorIsTheAreaAverage) {
  for (long s : {1L, 2L, 3L, 4L}) {
    const long N = 11;
    const Image in = random_image(N * s, N * s, 3, unsigned(s));
    for (Method m : {Method::MinError, Method::Conventional}) {
      const Coefficients k = project_with(in, N, N, Kernel::bspline(0), m, Boundary::Mirror);
      for (long y = 0; y < N; ++y)
        for (long x = 0; x < N; ++x)
          for (int c = 0; c < 3; ++c) {
            double sum = 0;
            for (long j = 0; j < s; ++j)
              for (long i = 0; i < s; ++i) sum += in.at(x * s + i, y * s + j, c);
            EXPECT_NEAR(k.c.at(x, y, c), sum / (s * s), 1e-15) << s;
          }
    }
  }
}

TEST(Projection, ReproducesPolynomialsUpToDegreeD) {
  // Away from the border: the mirror rule's effect decays like |z_1|^k, and
  // z_1 = -0.757 for d = 7 (the degree-15 spline's largest pole), so 64
  // pixels in it is below 1e-8.
  const long N = 140, s = 2, lo = 64, hi = 76;
  for (int d = 0; d <= kMaxDegree; ++d) {
    std::mt19937 rng(d);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> coef((d + 1) * (d + 1));
    for (double& v : coef) v = u(rng);
    auto poly = [&](double x, double y, int) {
      const double a = (x - N / 2.0) / 16, b = (y - N / 2.0) / 16;
      double sum = 0, pa = 1;
      for (int i = 0; i <= d; ++i, pa *= a) {
        double pb = 1;
        for (int j = 0; j <= d; ++j, pb *= b) sum += coef[i * (d + 1) + j] * pa * pb;
      }
      return sum;
    };
    // Float samples carry relative rounding 6e-8 of values up to ~1e2.
    const Image in = sample(poly, N * s, N * s, 1, N, N);
    const Coefficients k = project_with(in, N, N, Kernel::bspline(d), Method::MinError,
                                        Boundary::Mirror);
    std::mt19937 pick(99);
    std::uniform_real_distribution<double> where(lo, hi);
    for (int t = 0; t < 40; ++t) {
      const double x = where(pick), y = where(pick);
      EXPECT_NEAR(evaluate(k, {x, y}), poly(x, y, 0), 2e-5) << "degree " << d;
    }
  }
}

TEST(Projection, ResidualOrthogonalAndProjectionIdempotent) {
  // r[n] = <f, phi_n> by the acquisition's quadrature. With c = P f, the
  // inner products of f_app, <f_app, phi_n> = sum_m c[m] <phi_m, phi_n>
  // (Gram entries integrated independently), must equal r: the residual
  // f - f_app is orthogonal to every phi_n. Prefiltering them returns c:
  // P(f_app) = f_app.
  const long N = 24, s = 3;
  const Image in = random_image(N * s, N * s, 1, 3);
  for (int d = 0; d <= kMaxDegree; ++d)
    for (Boundary b : kRules) {
      ProjectionOptions o;
      o.generator = Kernel::bspline(d);
      o.boundary = b;
      const AcquisitionPlan plan(N * s, N * s, 1, N, N, Lattice::cartesian(), o.generator, b,
                                 Method::MinError);
      const Coefficients r = acquire(in, plan);
      Coefficients k = r;
      prefilter(k);
      std::vector<double> g(d + 2);
      for (int q = 0; q <= d + 1; ++q) g[q] = gram_entry(d, q);
      Coefficients inner = k;
      double scale = 0;
      for (long y = 0; y < N; ++y)
        for (long x = 0; x < N; ++x) {
          double sum = 0;
          for (int q = -d - 1; q <= d + 1; ++q)
            for (int p = -d - 1; p <= d + 1; ++p)
              sum += g[std::abs(p)] * g[std::abs(q)] *
                     k.c.at(extend_index(x + p, N, b), extend_index(y + q, N, b), 0);
          inner.c.at(x, y, 0) = sum;
          scale = std::max(scale, std::abs(r.c.at(x, y, 0)));
        }
      for (std::size_t q = 0; q < r.c.data.size(); ++q)
        EXPECT_NEAR(inner.c.data[q], r.c.data[q], 1e-12 * scale) << d << " " << boundary_name(b);
      Coefficients again = inner;
      prefilter(again);
      for (std::size_t q = 0; q < k.c.data.size(); ++q)
        EXPECT_NEAR(again.c.data[q], k.c.data[q], 1e-9) << d << " " << boundary_name(b);
    }
}

TEST(Projection, ApproximationOrder) {
  // A smooth periodic image, L2 error of f_app against f on a fine grid, at
  // lattice steps h = 1/24 and 1/48 of its period: the error falls like
  // h^(d+1). Double samples: float rounding would floor the error near 3e-9,
  // where degrees 5 to 7 still fall.
  auto f = [](double u, double v) { return std::cos(2 * kPi * u + 0.3) * std::sin(2 * kPi * v + 0.1); };
  for (int d = 0; d <= kMaxDegree; ++d) {
    double err[2];
    for (int t = 0; t < 2; ++t) {
      const long N = t ? 48 : 24, s = 4;
      Grid<double> in(N * s, N * s, 1);
      for (long j = 0; j < N * s; ++j)
        for (long i = 0; i < N * s; ++i) in.at(i, j, 0) = f((i + 0.5) / s / N, (j + 0.5) / s / N);
      const AcquisitionPlan plan(N * s, N * s, 1, N, N, Lattice::cartesian(), Kernel::bspline(d),
                                 Boundary::Periodic, Method::MinError);
      Coefficients k = acquire(in, plan);
      prefilter(k);
      double sum = 0;
      const long fine = 5;
      for (long j = 0; j < N * fine; ++j)
        for (long i = 0; i < N * fine; ++i) {
          const double x = (i + 0.5) / fine, y = (j + 0.5) / fine;
          const double e = evaluate(k, {x, y}) - f(x / N, y / N);
          sum += e * e;
        }
      err[t] = std::sqrt(sum / (N * fine * N * fine));
    }
    const double slope = std::log(err[0] / err[1]) / std::log(2.0);
    EXPECT_NEAR(slope, d + 1, 0.3) << "degree " << d << " errors " << err[0] << " " << err[1];
  }
}

TEST(Projection, MeanPreservedPeriodic) {
  const long N = 32, s = 2;
  const Image in = random_image(N * s, N * s, 1, 8);
  double mean_in = 0;
  for (float v : in.data) mean_in += v;
  mean_in /= in.data.size();
  for (int d = 0; d <= kMaxDegree; ++d) {
    const Coefficients k =
        project_with(in, N, N, Kernel::bspline(d), Method::MinError, Boundary::Periodic);
    double mean_c = 0;
    for (double v : k.c.data) mean_c += v;
    EXPECT_NEAR(mean_c / k.c.data.size(), mean_in, 1e-12) << d;
  }
}

TEST(Projection, ConventionalPreservesConstants) {
  const Image in = sample([](double, double, int c) { return 0.25 + c; }, 37, 29, 3, 10, 8);
  for (const char* g : {"box", "tent", "cubic", "mitchell", "gaussian", "catmull-rom", "lanczos3"}) {
    const Coefficients k =
        project_with(in, 10, 8, Kernel::parse(g), Method::Conventional, Boundary::Mirror);
    for (long y = 0; y < 8; ++y)
      for (long x = 0; x < 10; ++x)
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(k.c.at(x, y, c), 0.25 + c, 1e-6) << g;
  }
}

TEST(Resample, DisplayModesMatchTheirTapsAndDirectEvaluation) {
  const long N = 20;
  const Image in = random_image(N * 3, N * 3, 2, 11);
  for (int d = 0; d <= kMaxDegree; ++d)
    for (Boundary b : kRules) {
      const Coefficients k = project_with(in, N, N, Kernel::bspline(d), Method::MinError, b);
      const Image centred = resample(k, Display::centred(), N, N);
      const Image pixel = resample(k, Display::pixel(), N, N);
      const Image aa = resample(k, Display::antialiased_2x2(), N, N);
      const Image offs = resample(k, Display::parse("offsets:0.1,-0.2;-0.3,0.05;0.4,0.4"), N, N);
      const Image bigger = resample(k, Display::centred(), 27, 13);
      for (long y = 0; y < N; ++y)
        for (long x = 0; x < N; ++x)
          for (int c = 0; c < 2; ++c) {
            // centred: taps b_d(k); pixel: taps b_{d+1}(k)
            double tc = 0, tp = 0;
            for (int q = -d - 2; q <= d + 2; ++q)
              for (int p = -d - 2; p <= d + 2; ++p) {
                const double cv = k.c.at(extend_index(x + p, N, b), extend_index(y + q, N, b), c);
                tc += bspline(d, p) * bspline(d, q) * cv;
                tp += bspline(d + 1, p) * bspline(d + 1, q) * cv;
              }
            EXPECT_NEAR(centred.at(x, y, c), tc, 1e-5);
            EXPECT_NEAR(pixel.at(x, y, c), tp, 1e-5);
            double e = 0;
            for (double dy : {-0.25, 0.25})
              for (double dx : {-0.25, 0.25}) e += evaluate(k, {x + 0.5 + dx, y + 0.5 + dy}, c);
            EXPECT_NEAR(aa.at(x, y, c), e / 4, 1e-5);
            const double o = (evaluate(k, {x + 0.6, y + 0.3}, c) + evaluate(k, {x + 0.2, y + 0.55}, c) +
                              evaluate(k, {x + 0.9, y + 0.9}, c)) / 3;
            EXPECT_NEAR(offs.at(x, y, c), o, 1e-5);
          }
      for (long y = 0; y < 13; ++y)
        for (long x = 0; x < 27; ++x)
          EXPECT_NEAR(bigger.at(x, y, 1), evaluate(k, {(x + 0.5) * N / 27.0, (y + 0.5) * N / 13.0}, 1),
                      1e-5);
    }
  EXPECT_THROW(Display::parse("offsets:1,2;3"), std::invalid_argument);
  EXPECT_THROW(Display::parse("3x3"), std::invalid_argument);
}

TEST(Projection, ConventionalFinalImageIsTheFilteredPixels) {
  const Image in = random_image(40, 40, 1, 9);
  const Coefficients k = project_with(in, 10, 10, Kernel::mitchell(), Method::Conventional, Boundary::Mirror);
  const Image p = final_image(k, Display::centred(), 10, 10);
  for (long y = 0; y < 10; ++y)
    for (long x = 0; x < 10; ++x) EXPECT_EQ(p.at(x, y, 0), static_cast<float>(k.c.at(x, y, 0)));
}
