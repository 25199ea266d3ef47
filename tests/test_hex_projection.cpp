// The hexagonal lattice end to end in the library (docs/design.md section 7):
// lattice and layout, acquisition against a slow direct sum and exact
// inner products, polynomial reproduction, approximation order, the seam of
// the periodic grid, the noise gain. What every space must do (flat areas at
// any sampling, the display modes against direct evaluation, the pixel
// average) is tested once for all in tests/test_space_conformance.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <random>
#include <thread>
#include <tuple>
#include <unordered_map>

#include "sis/hex_acquisition.h"
#include "sis/hex_projection.h"
#include "sis/space.h"
#include "sis/projection.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {

const Boundary kRules[] = {Boundary::Mirror, Boundary::Periodic};

// Point samples of f at ((i + 1/2) W / win, (j + 1/2) H / hin), in double.
Grid<double> sample(const std::function<double(double, double)>& f, long win, long hin, double W,
                    double H) {
  Grid<double> g(win, hin, 1);
  for (long j = 0; j < hin; ++j)
    for (long i = 0; i < win; ++i) g.at(i, j, 0) = f((i + 0.5) * W / win, (j + 0.5) * H / hin);
  return g;
}

HexProjectionOptions options(int order, Boundary b = Boundary::Mirror, int margin = -1,
                             double density = 1.0) {
  HexProjectionOptions o;
  o.order = order;
  o.boundary = b;
  o.margin = margin;
  o.density = density;
  return o;
}

}  // namespace

TEST(HexLattice, DensityDeterminantAndDescription) {
  for (double d : {1.0, 2.0, 0.37}) {
    const Lattice L = Lattice::hexagonal(d, {0.25, -1.0});
    EXPECT_NEAR(L.determinant(), 1.0 / d, 1e-14 / d);
    EXPECT_NEAR(L.matrix()[0], std::sqrt(2 / (std::sqrt(3.0) * d)), 1e-15);
    EXPECT_TRUE(L.is_hexagonal());
    EXPECT_FALSE(L.separable());
    EXPECT_EQ(L.description().rfind("hexagonal origin 0.25 -1 matrix", 0), 0u) << L.description();
    // the six neighbours at distance h
    for (auto [k1, k2] : {std::pair{1, 0}, {0, 1}, {-1, 1}}) {
      const Vec2 p = L.position(k1, k2), o = L.origin();
      EXPECT_NEAR(std::hypot(p.x - o.x, p.y - o.y), L.matrix()[0], 1e-14);
    }
  }
  EXPECT_NEAR(Lattice::hexagonal().matrix()[0], std::sqrt(2 / std::sqrt(3.0)), 1e-15);  // DESIGN 2
  EXPECT_FALSE(Lattice::cartesian().is_hexagonal());
  EXPECT_THROW(Lattice::hexagonal(0), std::invalid_argument);
}

TEST(HexLayout, LatticePointAtTheCentreAndMarginOnEverySide) {
  for (double d : {1.0, 2.5, 0.5})
    for (auto [W, H] : {std::pair{40.0, 30.0}, {17.0, 9.0}, {3.0, 200.0}})
      for (int m : {0, 3, 20}) {
        const HexLayout L = hex_layout(d, W, H, m);
        const double h = L.step(), M = m * h;
        EXPECT_EQ(L.rows % 2, 0);
        bool centre = false;
        for (long j = 0; j < L.rows; ++j) {
          EXPECT_LE(L.position(0, j).x, -M + 1e-9);
          EXPECT_GE(L.position(L.columns - 1, j).x, W + M - 1e-9);
          for (long i = 0; i < L.columns; ++i) {
            const Vec2 p = L.position(i, j);
            // lattice index n = (i - floor(j/2), j)
            const Vec2 q = L.lattice.position(double(i - (j >> 1)), double(j));
            EXPECT_NEAR(p.x, q.x, 1e-9);
            EXPECT_NEAR(p.y, q.y, 1e-9);
            centre = centre || (std::abs(p.x - W / 2) < 1e-9 && std::abs(p.y - H / 2) < 1e-9);
          }
        }
        EXPECT_TRUE(centre) << d << " " << W << " " << H;
        EXPECT_LE(L.position(0, 0).y, -M + 1e-9);
        EXPECT_GE(L.position(0, L.rows - 1).y, H + M - 1e-9);
      }
}

namespace {

// Joint moments E[X^a Y^b], a, b <= 3, of the offset D = L U when U has the
// density M_n: M_n is the law of the sum of n independent uniform segments
// (T - 1/2) xi along each direction, Lxi = (h, 0), (h/2, hy), (-h/2, hy).
// Exact: binomial updates with E[(T - 1/2)^m] = 1 / ((m + 1) 2^m), m even.
std::array<std::array<double, 4>, 4> box_spline_moments(int n, double h, double hy) {
  std::array<std::array<double, 4>, 4> m{};
  m[0][0] = 1;
  auto uniform = [](int k) { return k % 2 ? 0.0 : 1.0 / ((k + 1) * std::pow(2.0, k)); };
  auto binom = [](int a, int b) {
    double r = 1;
    for (int i = 0; i < b; ++i) r = r * (a - i) / (i + 1);
    return r;
  };
  const double dirs[3][2] = {{h, 0}, {h / 2, hy}, {-h / 2, hy}};
  for (int rep = 0; rep < n; ++rep)
    for (const auto& d : dirs) {
      std::array<std::array<double, 4>, 4> next{};
      for (int a = 0; a <= 3; ++a)
        for (int b = 0; a + b <= 3; ++b)
          for (int i = 0; i <= a; ++i)
            for (int j = 0; j <= b; ++j)  // (X + s dx)^a (Y + s dy)^b
              next[a][b] += binom(a, i) * binom(b, j) * m[i][j] *
                            std::pow(d[0], a - i) * std::pow(d[1], b - j) * uniform(a - i + b - j);
      m = next;
    }
  return m;
}

// A polynomial of total degree `degree` in ((x - x0) / 20, (y - y0) / 20),
// random coefficients, and its exact inner products r[n] = E[p(x_n + D)].
struct Polynomial {
  int degree;
  double x0, y0;
  std::array<std::array<double, 4>, 4> c{};
  double operator()(double x, double y) const {
    const double a = (x - x0) / 20, b = (y - y0) / 20;
    double s = 0;
    for (int i = 0; i <= degree; ++i)
      for (int j = 0; i + j <= degree; ++j) s += c[i][j] * std::pow(a, i) * std::pow(b, j);
    return s;
  }
  double inner_product(Vec2 p, const std::array<std::array<double, 4>, 4>& m) const {
    const double A = (p.x - x0) / 20, B = (p.y - y0) / 20;
    auto binom = [](int a, int b) {
      double r = 1;
      for (int i = 0; i < b; ++i) r = r * (a - i) / (i + 1);
      return r;
    };
    double s = 0;
    for (int i = 0; i <= degree; ++i)
      for (int j = 0; i + j <= degree; ++j)
        for (int a = 0; a <= i; ++a)
          for (int b = 0; b <= j; ++b)
            s += c[i][j] * binom(i, a) * binom(j, b) * std::pow(A, i - a) * std::pow(B, j - b) *
                 m[a][b] / std::pow(20.0, a + b);
    return s;
  }
};

Polynomial random_polynomial(int degree, double x0, double y0, unsigned seed) {
  Polynomial p{degree, x0, y0};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (auto& row : p.c)
    for (double& v : row) v = u(rng);
  return p;
}

}  // namespace

TEST(HexAcquisition, AlignedRuleIsExactForPolynomialsOfTheGeneratorsDegree) {
  // The aligned rule's r[n] against the exact inner products E[p(x_n + D)]
  // for p of degree 2n - 1 (linear for the hat, cubic for the quartic), at
  // every stored coefficient whose support and interpolation taps lie inside
  // the input: integer and non-integer factors, two densities (so lattice
  // and samples meet at other offsets). Each r[n] sums about (4 s)^2 terms of
  // size 1: rounding below 1e-12. A polynomial of degree 2n is not
  // reproduced (the rule's degree is sharp).
  const double W = 31, H = 26;
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n)
    for (double density : {1.0, 1.7})
      for (double factor : {2.0, 3.0, 4.0, 4.37}) {
        const long win = std::lround(W * factor), hin = std::lround(H * factor);
        const double dx = W / win, dy = H / hin;
        const HexLayout L = hex_layout(density, W, H, 2);
        const HexAcquisitionPlan plan(win, hin, 1, W, H, L, n, Boundary::Mirror);
        const auto m = box_spline_moments(n, L.step(), L.row_step());
        double worst[2] = {0, 0};
        long checked = 0;
        for (int extra = 0; extra < 2; ++extra) {
          const Polynomial p = random_polynomial(2 * n - 1 + extra, W / 2, H / 2, 7 * n + extra);
          const Coefficients k = acquire(sample(p, win, hin, W, H), plan, 2);
          const double rx = n * L.step() + 3 * dx, ry = n * L.row_step() + 3 * dy;
          for (long j = 0; j < L.rows; ++j)
            for (long i = 0; i < L.columns; ++i) {
              const Vec2 x = L.position(i, j);
              if (x.x < rx || x.x > W - rx || x.y < ry || x.y > H - ry) continue;
              worst[extra] = std::max(worst[extra], std::abs(k.c.at(i, j, 0) - p.inner_product(x, m)));
              checked += extra == 0;
            }
        }
        const std::string what = "order " + std::to_string(n) + " density " +
                                 std::to_string(density) + " factor " + std::to_string(factor);
        EXPECT_GT(checked, 100) << what;
        EXPECT_LT(worst[0], 1e-12) << what;
        EXPECT_GT(worst[1], 1e-9) << what;
      }
}

// The aligned rule's direct double sum (hex_acquisition.h) at stored
// coefficient (i, j), channel c: r[n] = sum over the aligned grid points g
// of M(g - x_n) / (s1 s2) times f~(g), f~ the 4 x 4 cubic Lagrange
// interpolant of the extended samples (taps -1 .. 2 around floor of g's
// sample coordinates). s1, s2 as the header defines them.
double direct_aligned_sum(const Grid<double>& in, double W, double H, const HexLayout& L, int n,
                          Boundary b, long i, long j, int c) {
  const long win = in.width, hin = in.height;
  const double dx = W / win, dy = H / hin;
  auto lagrange = [](double f) {
    return std::array<double, 4>{-f * (f - 1) * (f - 2) / 6, (f + 1) * (f - 1) * (f - 2) / 2,
                                 -(f + 1) * f * (f - 2) / 2, (f + 1) * f * (f - 1) / 6};
  };
  const BoxSpline& B = BoxSpline::hexagonal(n);
  const int s1 = std::max(2, 2 * int(std::lround(L.step() / dx / 2)));
  const int s2 = std::max(1, int(std::lround(L.row_step() / dy)));
  const double dxa = L.step() / s1, dya = L.row_step() / s2;
  const Vec2 o = L.lattice.origin();
  const Vec2 p = L.position(i, j);
  const Vec2 un = L.lattice.coordinates(p);
  double ref = 0;
  const long mc = std::lround((p.x - o.x) / dxa), rc = std::lround((p.y - o.y) / dya);
  for (long r = rc - n * s2; r <= rc + n * s2; ++r)
    for (long mm = mc - n * s1; mm <= mc + n * s1; ++mm) {
      const double gx = o.x + mm * dxa, gy = o.y + r * dya;
      const Vec2 u = L.lattice.coordinates({gx, gy});
      const double w = B.eval(u.x - un.x, u.y - un.y) / (s1 * s2);
      if (w == 0) continue;
      const double px = gx / dx - 0.5, py = gy / dy - 0.5;
      const long qx = long(std::floor(px)) - 1, qy = long(std::floor(py)) - 1;
      const auto lx = lagrange(px - std::floor(px)), ly = lagrange(py - std::floor(py));
      double f = 0;
      for (int a = 0; a < 4; ++a)
        for (int bb = 0; bb < 4; ++bb)
          f += ly[a] * lx[bb] * in.at(extend_index(qx + bb, win, b), extend_index(qy + a, hin, b), c);
      ref += w * f;
    }
  return ref;
}

TEST(HexAcquisition, AlignedRuleMatchesItsDirectDoubleSum) {
  // Every stored coefficient, both rules, non-integer factor; double samples
  // (float samples keep the interpolated rows in float).
  const long win = 37, hin = 29;
  const double W = 9, H = 7, dx = W / win, dy = H / hin;
  const Image samples = random_image(win, hin, 2, 44);
  Grid<double> in(win, hin, 2);
  std::copy(samples.data.begin(), samples.data.end(), in.data.begin());
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n)
    for (Boundary b : kRules) {
      const HexLayout L = hex_layout(1.0, W, H, 3);
      const HexAcquisitionPlan plan(win, hin, 2, W, H, L, n, b);
      const Coefficients got = acquire(in, plan, 2);
      EXPECT_EQ(plan.aligned().s1, std::max(2, 2 * int(std::lround(L.step() / dx / 2))));
      EXPECT_EQ(plan.aligned().s2, std::max(1, int(std::lround(L.row_step() / dy))));
      double worst = 0;
      for (long j = 0; j < L.rows; ++j)
        for (long i = 0; i < L.columns; ++i)
          for (int c = 0; c < 2; ++c)
            worst = std::max(worst, std::abs(got.c.at(i, j, c) -
                                             direct_aligned_sum(in, W, H, L, n, b, i, j, c)));
      EXPECT_LT(worst, 1e-13) << n << " " << boundary_name(b);
    }
}

TEST(HexAcquisition, BandsMatchTheDirectSumAndGiveTheSameBitsInAnyOrder) {
  // Bands of 1, 3 and 16 rows (29 rows: coefficient rows whose input rows
  // lie in up to a dozen bands; periodic: bands at both ends). In order
  // (any strip and thread count), and band by band on two threads at once
  // in decreasing order: the same bits; against the direct double sum:
  // rounding (double samples).
  const long win = 37, hin = 29;
  const double W = 9, H = 7;
  const Image samples = random_image(win, hin, 3, 45);
  Grid<double> in(win, hin, 3);
  std::copy(samples.data.begin(), samples.data.end(), in.data.begin());
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n)
    for (Boundary b : kRules)
      for (long band_rows : {1L, 3L, 16L}) {
        SCOPED_TRACE("order " + std::to_string(n) + " " + boundary_name(b) + ", bands of " +
                     std::to_string(band_rows));
        const HexLayout L = hex_layout(1.0, W, H, 3);
        const HexAcquisitionPlan plan(win, hin, 3, W, H, L, n, b);
        HexAcquisition whole(plan, 1, band_rows);
        ASSERT_EQ(whole.bands().count(), (hin + band_rows - 1) / band_rows);
        for (long y = 0; y < hin; y += 4) whole.add_rows(y, std::min(hin, y + 4), in.row(y));
        const Coefficients ref = whole.finish();
        double worst = 0;
        for (long j = 0; j < L.rows; ++j)
          for (long i = 0; i < L.columns; ++i)
            for (int c = 0; c < 3; ++c)
              worst = std::max(worst, std::abs(ref.c.at(i, j, c) -
                                               direct_aligned_sum(in, W, H, L, n, b, i, j, c)));
        EXPECT_LT(worst, 1e-13);
        for (int threads : {2, 3})
          for (long strip : {1L, 5L, 29L}) {
            HexAcquisition a(plan, threads, band_rows);
            for (long y = 0; y < hin; y += strip) a.add_rows(y, std::min(hin, y + strip), in.row(y));
            EXPECT_EQ(a.finish().c.data, ref.c.data) << threads << " threads in order, strips of "
                                                     << strip;
          }
        HexAcquisition a(plan, 1, band_rows);
        const BandPartition& bands = a.bands();
        std::atomic<long> next{bands.count() - 1};
        auto worker = [&] {
          HexAcquisition::Band band(a);
          for (long k; (k = next--) >= 0;) {
            band.begin(k);
            for (long y = bands.begin(k); y < bands.end(k); y += 2)
              band.add_rows(y, std::min(bands.end(k), y + 2), in.row(y));
            band.end();
          }
        };
        std::thread other(worker);
        worker();
        other.join();
        EXPECT_EQ(a.finish().c.data, ref.c.data) << "bands at once, in decreasing order";
      }
}

TEST(HexAcquisition, BandsMustBeTakenWhole) {
  const Image in = random_image(20, 12, 1, 1);
  const HexLayout L = hex_layout(1.0, 5, 3, 2);
  const HexAcquisitionPlan plan(20, 12, 1, 5, 3, L, 1, Boundary::Mirror);
  HexAcquisition a(plan, 1, 4);
  HexAcquisition::Band band(a);
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

TEST(HexAcquisition, BitIdenticalForAnyStripAndThreadCount) {
  const Image in = random_image(203, 171, 3, 1);
  const HexLayout L = hex_layout(1.0, 50, 40, hex_default_margin(2));
  const HexAcquisitionPlan plan(203, 171, 3, 50, 40, L, 2, Boundary::Mirror);
  const Coefficients ref = acquire(in, plan, 1);
  for (int threads : {1, 2, 5})
    for (long strip : {1L, 13L, 171L}) {
      HexAcquisition a(plan, threads);
      for (long y = 0; y < in.height; y += strip)
        a.add_rows(y, std::min(in.height, y + strip), in.row(y));
      EXPECT_EQ(a.finish().c.data, ref.c.data) << threads << " " << strip;
    }
  HexAcquisition a(plan);
  EXPECT_THROW(a.add_rows(2, 4, in.row(2)), std::logic_error);
  a.add_rows(0, 4, in.row(0));
  EXPECT_THROW(a.finish(), std::logic_error);
}

TEST(HexProjection, ReproducesPolynomialsAwayFromTheBorder) {
  // The hat reproduces degree 1, the quartic degree 3, and the quadrature
  // is exact for these degrees (hex_acquisition.h), so what remains is the
  // border: the mirror-extended polynomial is not one, and its effect decays
  // like rho^d at d steps (rho about 0.2 and 0.48). At 40 steps in, 0.48^40 is
  // 2e-13 of the border's jump (the polynomials here are of size ~1).
  const double h = Lattice::hexagonal().matrix()[0], hy = Lattice::hexagonal().matrix()[3];
  const long cols = 100, rows = 90;
  const double W = cols * h, H = rows * hy;
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    const int degree = 2 * n - 1;
    std::mt19937 rng(n);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> coef((degree + 1) * (degree + 1));
    for (double& v : coef) v = u(rng);
    auto poly = [&](double x, double y) {
      const double a = (x - W / 2) / 20, b = (y - H / 2) / 20;
      double s = 0, pa = 1;
      for (int i = 0; i <= degree; ++i, pa *= a) {
        double pb = 1;
        for (int j = 0; i + j <= degree; ++j, pb *= b) s += coef[i * (degree + 1) + j] * pa * pb;
      }
      return s;
    };
    const Grid<double> in = sample(poly, 2 * cols, 2 * rows, W, H);
    const Coefficients k = project_hexagonal(in, W, H, options(n));
    std::mt19937 pick(99);
    std::uniform_real_distribution<double> x(40 * h, W - 40 * h), y(40 * hy, H - 40 * hy);
    for (int t = 0; t < 100; ++t) {
      const double px = x(pick), py = y(pick);
      EXPECT_NEAR(evaluate(k, {px, py}), poly(px, py), 1e-12) << "order " << n;
    }
    // and the exact pixel average of f_app is the exact average of the polynomial
    const Image avg = resample(k, Display::pixel(), cols / 2, rows / 2);
    const double sx = W / (cols / 2), sy = H / (rows / 2);
    for (long j = rows / 4 - 2; j < rows / 4 + 2; ++j)
      for (long i = cols / 4 - 2; i < cols / 4 + 2; ++i) {
        // exact for degree <= 3 by 2 x 2 Gauss-Legendre
        const double g = 0.5 / std::sqrt(3.0);
        double ref = 0;
        for (double a : {0.5 - g, 0.5 + g})
          for (double b : {0.5 - g, 0.5 + g}) ref += 0.25 * poly((i + a) * sx, (j + b) * sy);
        // float output: half an ulp is 6e-8 of values up to 2
        EXPECT_NEAR(avg.at(i, j, 0), ref, 6e-8 * std::max(2.0, std::abs(ref))) << "order " << n;
      }
  }
}

TEST(HexProjection, ApproximationOrder) {
  // A smooth image, periodic on the frame, with the periodic rule: the L2
  // error of f_app falls like h^(2n) when the density grows 4 times (h halves):
  // the hat's order 2, the quartic's 4. Frame 12 x 12 steps at density 1,
  // 24 x 24 at density 4; samples commensurate (4 per step and row).
  const double h0 = Lattice::hexagonal().matrix()[0], hy0 = Lattice::hexagonal().matrix()[3];
  const double W = 12 * h0, H = 12 * hy0;
  auto f = [&](double x, double y) {
    return std::cos(2 * kPi * x / W + 0.3) * std::sin(2 * kPi * y / H + 0.1) +
           0.5 * std::cos(2 * kPi * (x / W + y / H));
  };
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    double err[2];
    for (int t = 0; t < 2; ++t) {
      const long steps = t ? 24 : 12;
      const Grid<double> in = sample(f, 4 * steps, 4 * steps, W, H);
      const Coefficients k =
          project_hexagonal(in, W, H, options(n, Boundary::Periodic, -1, t ? 4.0 : 1.0));
      double sum = 0;
      const long fine = 97;
      for (long j = 0; j < fine; ++j)
        for (long i = 0; i < fine; ++i) {
          const double x = (i + 0.5) * W / fine, y = (j + 0.5) * H / fine;
          const double e = evaluate(k, {x, y}) - f(x, y);
          sum += e * e;
        }
      err[t] = std::sqrt(sum / (fine * fine));
    }
    const double slope = std::log(err[0] / err[1]) / std::log(2.0);
    EXPECT_NEAR(slope, 2 * n, 0.3) << "order " << n << " errors " << err[0] << " " << err[1];
  }
}

TEST(HexProjection, SeamEffectBelowFloatResolution) {
  // The periodic rule on the enlarged grid puts a seam at its edge; with the
  // default margins its effect anywhere in the frame (edges included) is
  // below 1e-7 of an image in [0, 1], against a margin three times larger.
  const long W = 40, H = 30, s = 3;
  const Image in = random_image(W * s, H * s, 1, 3);
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    const Coefficients k = project_hexagonal(in, W, H, options(n));
    const Coefficients ref =
        project_hexagonal(in, W, H, options(n, Boundary::Mirror, 3 * hex_default_margin(n)));
    double worst = 0;
    for (int a = 0; a <= 80; ++a)
      for (int b = 0; b <= 60; ++b) {
        const Vec2 x{W * a / 80.0, H * b / 60.0};
        worst = std::max(worst, std::abs(evaluate(k, x) - evaluate(ref, x)));
      }
    EXPECT_LT(worst, 1e-7) << "order " << n;
  }
}

TEST(HexNoise, MeasuredGainIsTheDiscreteOperatorsExactGain) {
  // The seeded measurement (the variance of the centred display inside a
  // 4-pixel border, averaged over K noise images) against hex_noise_gain,
  // the exact gain of the operator from its acquisition weights, prefilter
  // and resampling weights: within 4 standard deviations of the measurement
  // (hex_noise_gain's for one image, over sqrt(K)). About 1.05 for the hat
  // and 1.01 for the quartic at factor 4.
  const long N = 32, s = 4, border = 4;
  const int K = 16;
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    const HexNoiseGain exact = hex_noise_gain(n, 1.0, N, s, border);
    std::mt19937 rng(77 + n);
    std::normal_distribution<double> noise(0, 1);
    double measured = 0;
    const long P = (N - 2 * border) * (N - 2 * border);
    for (int t = 0; t < K; ++t) {
      Grid<double> in(N * s, N * s, 1);
      for (double& v : in.data) v = noise(rng);
      const Image p = resample(project_hexagonal(in, double(N), double(N), options(n, Boundary::Periodic)),
                               Display::centred(), N, N);
      double m = 0, q = 0;
      for (long j = border; j < N - border; ++j)
        for (long i = border; i < N - border; ++i) m += p.at(i, j, 0);
      m /= P;
      for (long j = border; j < N - border; ++j)
        for (long i = border; i < N - border; ++i) q += (p.at(i, j, 0) - m) * (p.at(i, j, 0) - m);
      measured += s * s * q / (P - 1) / K;
    }
    const double sd = exact.relative_sd * exact.gain / std::sqrt(double(K));
    EXPECT_NEAR(measured, exact.gain, 4 * sd)
        << "order " << n << ": measured " << measured << ", exact " << exact.gain << ", sd " << sd;
  }
  EXPECT_THROW(hex_noise_gain(2, 0.0, 32, 4, 4), std::invalid_argument);
  EXPECT_THROW(hex_noise_gain(2, 0.05, 16, 4, 4), std::invalid_argument);  // reach beyond the frame
}

TEST(HexProjection, DispatchThroughTheCartesianEntryPoints) {
  const Image in = random_image(48, 36, 1, 7);
  const HexLayout L = hex_layout(1.0, 16, 12, hex_default_margin(1));
  const HexAcquisitionPlan plan(48, 36, 1, 16, 12, L, 1, Boundary::Mirror);
  Coefficients a = acquire(in, plan), b = a;
  prefilter(a);
  hex_prefilter(b);
  EXPECT_EQ(a.c.data, b.c.data);
  EXPECT_THROW(prefilter(a, 1, PrefilterMethod::Recursive), std::invalid_argument);
  EXPECT_EQ(evaluate(a, {3.3, 4.4}), hex_evaluate(a, {3.3, 4.4}));
  EXPECT_EQ(resample(a, Display::antialiased_2x2(), 16, 12).data,
            hex_resample(a, Display::antialiased_2x2(), 16, 12).data);
}
