// Prefilter on the hexagonal lattice (offset rows, periodic on the grid):
// against a dense solve of the Gram system, a * a^{-1} = delta, thread
// invariance.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sis/hex_prefilter.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

namespace {

long floor_div(long a, long b) { return a / b - ((a % b != 0) && ((a < 0) != (b < 0))); }

// Dense Gram matrix of the periodic offset-row grid: row (i, j) holds a[k] at
// the stored index of lattice neighbour n + k, n = (i - floor(j/2), j).
std::vector<double> dense_gram(int order, long Q, long R) {
  const long N = Q * R;
  std::vector<double> G(std::size_t(N) * N, 0.0);
  for (long j = 0; j < R; ++j)
    for (long i = 0; i < Q; ++i)
      for (const HexTap& t : BoxSpline::hexagonal(order).autocorrelation()) {
        const long jj = j + t.k2;
        const long ii = i + t.k1 + floor_div(jj, 2) - floor_div(j, 2);
        const long wi = ((ii % Q) + Q) % Q, wj = ((jj % R) + R) % R;
        G[std::size_t(j * Q + i) * N + wj * Q + wi] += t.value;
      }
  return G;
}

}  // namespace

TEST(HexPrefilter, EqualsDenseSolveOfGramSystem) {
  // Odd and even column counts, tiny grids where the quartic's radius-3 taps
  // wrap onto themselves several times.
  const std::pair<long, long> sizes[] = {{7, 6}, {8, 4}, {5, 10}, {1, 2}, {3, 2}, {6, 8}};
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n)
    for (const auto& [Q, R] : sizes) {
      const Grid<double> r = random_grid(Q, R, 2, unsigned(10 * n + Q + R));
      Grid<double> c = r;
      HexPrefilterPlan(n, Q, R).execute(c);
      const std::vector<double> G = dense_gram(n, Q, R);
      const double kappa = BoxSpline::hexagonal(n).condition_number();
      for (int ch = 0; ch < 2; ++ch) {
        std::vector<double> rhs(Q * R);
        for (long q = 0; q < Q * R; ++q) rhs[q] = r.data[q * 2 + ch];
        const std::vector<double> ref = dense_solve(G, rhs);
        double peak = 1;
        for (double v : ref) peak = std::max(peak, std::abs(v));
        // rounding (a few eps per FFT stage) amplified by the condition number
        for (long q = 0; q < Q * R; ++q)
          EXPECT_NEAR(c.data[q * 2 + ch], ref[q], 1e-15 * kappa * peak * 10)
              << "order " << n << " grid " << Q << " x " << R;
      }
    }
}

TEST(HexPrefilter, AutocorrelationTimesInverseIsDelta) {
  // The autocorrelation placed around stored (i0, j0) (odd row: the half
  // shift is exercised), prefiltered, is the unit impulse there.
  const long Q = 24, R = 20, i0 = 9, j0 = 7;
  for (int n = 1; n <= kMaxBoxSplineOrder; ++n) {
    Grid<double> r(Q, R, 1);
    for (const HexTap& t : BoxSpline::hexagonal(n).autocorrelation()) {
      const long jj = j0 + t.k2;
      const long ii = i0 + t.k1 + floor_div(jj, 2) - floor_div(j0, 2);
      r.at(((ii % Q) + Q) % Q, ((jj % R) + R) % R, 0) += t.value;
    }
    HexPrefilterPlan(n, Q, R).execute(r);
    for (long j = 0; j < R; ++j)
      for (long i = 0; i < Q; ++i)
        EXPECT_NEAR(r.at(i, j, 0), (i == i0 && j == j0) ? 1.0 : 0.0, 1e-13) << n;
  }
}

TEST(HexPrefilter, BitIdenticalForAnyThreadCount) {
  Grid<double> a = random_grid(61, 38, 3, 5), b = a, c = a;
  const HexPrefilterPlan plan(2, 61, 38);
  plan.execute(a, 1);
  plan.execute(b, 2);
  plan.execute(c, 7);
  EXPECT_EQ(a.data, b.data);
  EXPECT_EQ(a.data, c.data);
}

TEST(HexPrefilter, RejectsGridsThatAreNotOffsetRows) {
  EXPECT_THROW(HexPrefilterPlan(1, 8, 5), std::invalid_argument);  // odd rows: parity not periodic
  EXPECT_THROW(HexPrefilterPlan(1, 0, 4), std::invalid_argument);
  Grid<double> g(8, 6, 1);
  EXPECT_THROW(HexPrefilterPlan(1, 8, 4).execute(g), std::invalid_argument);
}
