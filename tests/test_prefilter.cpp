// Digital prefilter c = r * a^{-1}: against a dense solve of the Gram system
// (slow direct reference), FFT against the recursive form, and thread
// invariance.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sis/prefilter.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {

// Dense 1-D Gram matrix of the boundary-extended system:
// r[n] = sum_k a[k] c_ext[n + k].
std::vector<std::vector<double>> gram(int d, long n, Boundary b) {
  const auto a = bspline_autocorrelation(d);
  std::vector<std::vector<double>> G(n, std::vector<double>(n, 0.0));
  for (long i = 0; i < n; ++i)
    for (int k = -d; k <= d; ++k) G[i][extend_index(i + k, n, b)] += a[std::abs(k)];
  return G;
}

const Boundary kRules[] = {Boundary::Mirror, Boundary::Periodic};

}  // namespace

TEST(Prefilter, EqualsDenseSolveOfGramSystem2D) {
  const long nx = 7, ny = 6;
  for (int d = 0; d <= kMaxDegree; ++d)
    for (Boundary b : kRules) {
      Grid<double> r = random_grid(nx, ny, 2, 100 + d);
      // Kronecker Gram: G[(y,x),(y',x')] = Gy[y][y'] Gx[x][x'].
      const auto Gx = gram(d, nx, b), Gy = gram(d, ny, b);
      const long N = nx * ny;
      std::vector<double> G(N * N);
      for (long y = 0; y < ny; ++y)
        for (long x = 0; x < nx; ++x)
          for (long yy = 0; yy < ny; ++yy)
            for (long xx = 0; xx < nx; ++xx) G[(y * nx + x) * N + yy * nx + xx] = Gy[y][yy] * Gx[x][xx];
      for (PrefilterMethod m : {PrefilterMethod::FFT, PrefilterMethod::Recursive}) {
        Grid<double> c = r;
        PrefilterPlan(d, nx, ny, b, m).execute(c);
        for (int ch = 0; ch < 2; ++ch) {
          std::vector<double> rhs(nx * ny);
          for (long q = 0; q < nx * ny; ++q) rhs[q] = r.data[q * 2 + ch];
          const auto ref = dense_solve(G, rhs);
          // Rounding (a few eps) amplified by the 2-D condition number
          // 1/A_d(pi)^2, relative to the size of c.
          const double cond = std::pow(bspline_autocorrelation_spectrum(d, std::acos(-1.0)), -2);
          double peak = 1;
          for (double v : ref) peak = std::max(peak, std::abs(v));
          for (long q = 0; q < nx * ny; ++q)
            EXPECT_NEAR(c.data[q * 2 + ch], ref[q], 1e-15 * cond * peak)
                << "degree " << d << " " << boundary_name(b) << " method " << int(m);
        }
      }
    }
}

TEST(Prefilter, AutocorrelationTimesInverseIsDelta) {
  // Prefiltering the autocorrelation sequence itself (placed at n0, extended
  // by the rule) gives the unit impulse at n0.
  const long n = 64, n0 = 30;
  for (int d = 0; d <= kMaxDegree; ++d)
    for (Boundary b : kRules) {
      const auto a = bspline_autocorrelation(d);
      Grid<double> r(n, n, 1);
      for (int k = -d; k <= d; ++k)
        for (int l = -d; l <= d; ++l)
          r.at(extend_index(n0 + k, n, b), extend_index(n0 + l, n, b), 0) +=
              a[std::abs(k)] * a[std::abs(l)];
      PrefilterPlan(d, n, n, b).execute(r);
      for (long y = 0; y < n; ++y)
        for (long x = 0; x < n; ++x)
          EXPECT_NEAR(r.at(x, y, 0), (x == n0 && y == n0) ? 1.0 : 0.0, 1e-12)
              << d << " " << boundary_name(b);
    }
}

TEST(Prefilter, RecursiveEqualsFFTForEverySizeAndDegree) {
  for (long n : {1L, 2L, 3L, 17L, 64L, 255L})
    for (int d = 0; d <= kMaxDegree; ++d)
      for (Boundary b : kRules) {
        Grid<double> f = random_grid(n, 5, 3, 7 * d + n);
        Grid<double> r = f;
        PrefilterPlan(d, n, 5, b, PrefilterMethod::FFT).execute(f);
        PrefilterPlan(d, n, 5, b, PrefilterMethod::Recursive).execute(r);
        double err = 0, peak = 1;
        for (std::size_t q = 0; q < f.data.size(); ++q) {
          err = std::max(err, std::abs(f.data[q] - r.data[q]));
          peak = std::max(peak, std::abs(f.data[q]));
        }
        // rounding (a few eps) times the 2-D condition number 1/A_d(pi)^2
        const double cond = std::pow(bspline_autocorrelation_spectrum(d, std::acos(-1.0)), -2);
        EXPECT_LT(err, 1e-15 * cond * peak) << "n " << n << " degree " << d << " " << boundary_name(b);
      }
}

TEST(Prefilter, BitIdenticalForAnyThreadCount) {
  for (PrefilterMethod m : {PrefilterMethod::FFT, PrefilterMethod::Recursive}) {
    Grid<double> a = random_grid(301, 157, 3, 5), b = a, c = a;
    const PrefilterPlan plan(3, 301, 157, Boundary::Mirror, m);
    plan.execute(a, 1);
    plan.execute(b, 2);
    plan.execute(c, 7);
    EXPECT_EQ(a.data, b.data);
    EXPECT_EQ(a.data, c.data);
  }
}
