// Scattered samples on the hexagonal lattice (sis/scattered.h with a
// HexagonalSpace target, docs/design.md section 11) against slow direct
// references: double sums of the box spline over every image of the
// samples, a dense solve of the fit's normal equations on the periodic
// grid, the grid acquisition at the grid's own positions, and the grid
// projection as the samples densify.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "sis/hex_projection.h"
#include "sis/scattered.h"
#include "hex_scattered_reference.h"
#include "scattered_samples.h"
#include "support.h"

namespace sis {
namespace {

using test::all_images;
using test::dense_solve;
using test::layout_of;
using test::normal_equations;
using test::order_of;
using test::phi;
using test::weight_of;
using test::jittered;
using test::random_samples;
using test::smooth;
using test::uniform;

ScatteredTarget target(double W, double H, int order, Boundary b, int margin = -1,
                       double density = 1.0) {
  ScatteredTarget t;
  t.width = W;
  t.height = H;
  t.space = HexagonalSpace{order, density};
  t.boundary = b;
  t.margin = margin;
  return t;
}

// The one-pass sums by direct double sums: per stored coefficient (i, j),
// num = sum_i w_i f_i sum_images M, den = sum_i w_i sum_images M, every
// image of every sample, no wrap (the grid acquisition's rule).
struct Sums {
  std::vector<double> num, den;  // num: channels per coefficient
};
Sums direct_sums(const ScatteredSamples& s, const ScatteredTarget& t) {
  const HexLayout L = layout_of(t);
  const BoxSpline& B = BoxSpline::hexagonal(order_of(t));
  const int C = s.channels;
  const double reach = (B.radius() + 0.1) * L.step();
  Sums out;
  out.num.assign(std::size_t(L.columns) * L.rows * C, 0.0);
  out.den.assign(std::size_t(L.columns) * L.rows, 0.0);
  for (long i = 0; i < s.count(); ++i) {
    const double w = weight_of(s, t, i);
    for (double y : all_images(s.positions[2 * i + 1], t.height, t.boundary))
      for (double x : all_images(s.positions[2 * i], t.width, t.boundary))
        for (long j = 0; j < L.rows; ++j) {
          if (std::abs(L.position(0, j).y - y) > reach) continue;
          for (long c = 0; c < L.columns; ++c) {
            const Vec2 p = L.position(c, j);
            if (std::abs(p.x - x) > reach) continue;
            const double m = phi(B, L, x, y, p);
            if (m == 0) continue;
            const std::size_t n = std::size_t(j) * L.columns + c;
            out.den[n] += w * m;
            for (int ch = 0; ch < C; ++ch) out.num[n * C + ch] += w * m * s.values[i * C + ch];
          }
        }
  }
  return out;
}

Coefficients hex_coefficients_like(const Coefficients& k, std::vector<double> values) {
  Coefficients out = k;
  out.c.data.assign(values.begin(), values.end());
  return out;
}

double max_abs_diff(const Grid<double>& a, const Grid<double>& b) {
  EXPECT_EQ(a.data.size(), b.data.size());
  double m = 0;
  for (std::size_t e = 0; e < a.data.size(); ++e) m = std::max(m, std::abs(a.data[e] - b.data[e]));
  return m;
}

struct Case {
  int order;
  Boundary boundary;
};
std::vector<Case> cases() {
  return {{1, Boundary::Mirror}, {1, Boundary::Periodic}, {2, Boundary::Mirror},
          {2, Boundary::Periodic}};
}
std::string name(const Case& c) {
  return std::string(c.order == 1 ? "hex-hat " : "hex-quartic ") + boundary_name(c.boundary);
}

ScatteredOptions rule(ScatteredRule r) {
  ScatteredOptions o;
  o.rule = r;
  return o;
}

TEST(HexScattered, LayoutIsTheGridAcquisitions) {
  for (const Case& cs : cases()) {
    const ScatteredTarget t = target(7, 5, cs.order, cs.boundary);
    const Coefficients k =
        project_scattered(random_samples(600, 1, 7, 5, 3), t, rule(ScatteredRule::NormalisedSum));
    HexProjectionOptions po;
    po.order = cs.order;
    po.boundary = cs.boundary;
    Image input(21, 15, 1);
    const Coefficients grid = project_hexagonal(input, 7, 5, po);
    EXPECT_EQ(k.c.width, grid.c.width) << name(cs);
    EXPECT_EQ(k.c.height, grid.c.height) << name(cs);
    EXPECT_EQ(k.lattice.description(), grid.lattice.description()) << name(cs);
    EXPECT_EQ(generator_name(k), generator_name(grid)) << name(cs);
    EXPECT_EQ(k.boundary, grid.boundary);
    EXPECT_EQ(k.image_width, 7);
    EXPECT_EQ(k.image_height, 5);
    EXPECT_TRUE(k.min_error);
  }
}

TEST(HexScattered, NormalisedAndPlainSumsEqualDirectDoubleSums) {
  for (const Case& cs : cases())
    for (int margin : {2, -1})
      for (bool weighted : {false, true}) {
        const ScatteredTarget t = target(5, 4, cs.order, cs.boundary, margin);
        const ScatteredSamples s = random_samples(300, 2, 5, 4, 11 + cs.order, weighted);
        const Sums d = direct_sums(s, t);
        const Coefficients got = project_scattered(s, t, rule(ScatteredRule::NormalisedSum));
        const Coefficients plain = project_scattered(s, t, rule(ScatteredRule::PlainSum));
        const double det = std::abs(got.lattice.determinant());
        std::vector<double> r(d.num.size()), p(d.num.size());
        for (std::size_t e = 0; e < r.size(); ++e) {
          r[e] = d.num[e] / d.den[e / 2];  // int M = 1 in lattice units
          p[e] = d.num[e] / det;
        }
        Coefficients want = hex_coefficients_like(got, r), want_plain = hex_coefficients_like(got, p);
        hex_prefilter(want);
        hex_prefilter(want_plain);
        // The same sums in another order, through another evaluation of
        // M_n (BoxSpline::eval's Horner form against the monomials), then
        // the same prefilter, whose gain is at most its condition number
        // (4 for the hat, about 52 for the quartic).
        const std::string what = name(cs) + " margin " + std::to_string(margin) +
                                 (weighted ? " weighted" : "");
        EXPECT_LT(max_abs_diff(got.c, want.c), 1e-12) << what;
        EXPECT_LT(max_abs_diff(plain.c, want_plain.c), 1e-12) << what;
        // and they are not the same rule (a check that the test can fail)
        EXPECT_GT(max_abs_diff(got.c, plain.c), 1e-3) << what;
      }
}

TEST(HexScattered, FitEqualsDenseSolve) {
  for (const Case& cs : cases()) {
    const ScatteredTarget t = target(3, 3, cs.order, cs.boundary, 1);
    const ScatteredSamples s = random_samples(400, 1, 3, 3, 21 + cs.order, true);
    std::vector<std::vector<double>> G;
    std::vector<double> b;
    normal_equations(s, t, G, b);
    const std::vector<double> want = dense_solve(G, b);
    ScatteredOptions o = rule(ScatteredRule::LeastSquares);
    o.iterations = 300;
    o.tolerance = 1e-15;
    ScatteredReport rep;
    const Coefficients got = project_scattered(s, t, o, &rep);
    ASSERT_EQ(got.c.data.size(), want.size()) << name(cs);
    double m = 0, scale = 0;
    for (std::size_t a = 0; a < want.size(); ++a) {
      m = std::max(m, std::abs(got.c.data[a] - want[a]));
      scale = std::max(scale, std::abs(want[a]));
    }
    // The solve's rounding is about cond(G) eps (cond(G) is the
    // prefilter's, 4 or 52, times the samples' irregularity); the CG stops
    // at 1e-15 of ||b||.
    EXPECT_LT(m, 1e-10 * std::max(1.0, scale))
        << name(cs) << " after " << rep.iterations << " iterations";
    EXPECT_LT(rep.residual[0], 1e-14) << name(cs);
    // The normalised sum is another rule (a check that the test can fail).
    const Coefficients n = project_scattered(s, t, rule(ScatteredRule::NormalisedSum));
    double off = 0;
    for (std::size_t a = 0; a < want.size(); ++a) off = std::max(off, std::abs(n.c.data[a] - want[a]));
    EXPECT_GT(off, 1e-3) << name(cs);
  }
}

TEST(HexScattered, FlatImageExactFromRandomPositions) {
  for (const Case& cs : cases())
    for (double density : {1.0, 2.5})
      for (ScatteredRule r : {ScatteredRule::NormalisedSum, ScatteredRule::LeastSquares}) {
        const ScatteredTarget t = target(9, 7, cs.order, cs.boundary, -1, density);
        ScatteredSamples s = random_samples(1600, 3, 9, 7, 3, true);  // about 25 per pixel
        for (std::size_t e = 0; e < s.values.size(); ++e) s.values[e] = 0.37 + 0.1 * (e % 3);
        ScatteredOptions o = rule(r);
        o.iterations = 5;
        const Coefficients k = project_scattered(s, t, o);
        // Exact but for double rounding: the weight sums, a quotient, the
        // prefilter's FFT (relative errors of order 1e-15 times its gain).
        for (std::size_t e = 0; e < k.c.data.size(); ++e)
          ASSERT_NEAR(k.c.data[e], 0.37 + 0.1 * (e % 3), 1e-12)
              << name(cs) << " density " << density << ' ' << scattered_rule_name(r) << " element "
              << e;
        const std::vector<double> at = evaluate_at_samples(k, s);
        for (std::size_t e = 0; e < at.size(); ++e)
          ASSERT_NEAR(at[e], 0.37 + 0.1 * (e % 3), 1e-12) << name(cs) << " sample " << e / 3;
      }
}

// The input grid of a supersampled render aligned with the lattice: W_in x
// H_in samples (both odd, so that the frame's centre, a lattice point, is a
// sample) at steps h / s1 and hy / s2, so that the grid acquisition's
// aligned grid is the input itself and its Lagrange interpolation the
// identity: the samples, each weighing its pixel's area, are the grid
// acquisition's quadrature points.
TEST(HexScattered, GridPositionsGiveTheGridResult) {
  for (const Case& cs : cases())
    for (const auto& [s1, s2] : {std::pair<int, int>{2, 1}, {4, 3}}) {
      const Lattice base = Lattice::hexagonal(1.0);
      const double dx = base.matrix()[0] / s1, dy = base.matrix()[3] / s2;
      const long win = 8 * s1 + 1, hin = 8 * s2 + 1;
      const double W = win * dx, H = hin * dy;
      Grid<double> input(win, hin, 1);
      ScatteredSamples smp;
      for (long j = 0; j < hin; ++j)
        for (long i = 0; i < win; ++i) {
          const double x = (i + 0.5) * dx, y = (j + 0.5) * dy;
          input.at(i, j, 0) = smooth(x, y);
          smp.positions.push_back(x);
          smp.positions.push_back(y);
          smp.values.push_back(smooth(x, y));
          smp.weights.push_back(dx * dy);
        }
      HexProjectionOptions po;
      po.order = cs.order;
      po.boundary = cs.boundary;
      const Coefficients grid = project_hexagonal(input, W, H, po);
      const std::string what = name(cs) + " s1 " + std::to_string(s1) + " s2 " + std::to_string(s2);
      for (ScatteredRule r : {ScatteredRule::NormalisedSum, ScatteredRule::PlainSum}) {
        const Coefficients got = project_scattered(smp, target(W, H, cs.order, cs.boundary), rule(r));
        // The grid's plain sum in another order, through another evaluation
        // of M_n (its table of slices against the pieces), the Lagrange
        // weights 1 and 0 to rounding (the positions computed two ways);
        // the normalised rule's denominator is the aligned quadrature of
        // int M_n = 1, exact for constants (section 10), so 1 to rounding.
        // Then the prefilter's gain (at most 52).
        EXPECT_LT(max_abs_diff(got.c, grid.c), 1e-12) << what << ' ' << scattered_rule_name(r);
      }
    }
}

TEST(HexScattered, ConvergesToTheGridProjectionAsDensityGrows) {
  const long W = 12, H = 10;
  Grid<double> fine(W * 32, H * 32, 1);
  for (long j = 0; j < H * 32; ++j)
    for (long i = 0; i < W * 32; ++i) fine.at(i, j, 0) = smooth((i + 0.5) / 32, (j + 0.5) / 32);
  for (int order : {1, 2}) {
    HexProjectionOptions po;
    po.order = order;
    const Coefficients grid = project_hexagonal(fine, W, H, po);
    const HexLayout L = hex_layout(grid);
    for (ScatteredRule r : {ScatteredRule::NormalisedSum, ScatteredRule::LeastSquares}) {
      std::vector<double> err;
      for (int s : {2, 4, 8, 16}) {
        const Coefficients k =
            project_scattered(jittered(W, H, s, 7), target(W, H, order, Boundary::Mirror), rule(r));
        // over the coefficients in the frame (the margin's are the
        // extended image's, whose samples are the frame's reflected)
        double e2 = 0;
        long count = 0;
        for (long j = 0; j < L.rows; ++j)
          for (long i = 0; i < L.columns; ++i) {
            const Vec2 p = L.position(i, j);
            if (p.x < 0 || p.x > W || p.y < 0 || p.y > H) continue;
            const double d = k.c.at(i, j, 0) - grid.c.at(i, j, 0);
            e2 += d * d;
            ++count;
          }
        err.push_back(std::sqrt(e2 / count));
      }
      // Jittered quadrature of a smooth integrand with M = s^2 samples per
      // pixel errs like s^{-2} in 2-D: 4 times less per doubling of s.
      // Asserted on the RMS: at least 2.5 times.
      for (std::size_t e = 1; e < err.size(); ++e)
        EXPECT_GT(err[e - 1] / err[e], 2.5)
            << "order " << order << ' ' << scattered_rule_name(r) << " step " << e << ": "
            << err[e - 1] << " -> " << err[e];
    }
  }
}

TEST(HexScattered, SameBitsForAnyThreadCount) {
  const ScatteredSamples s = jittered(20, 14, 3, 5);
  for (const Case& cs : cases())
    for (ScatteredRule r :
         {ScatteredRule::NormalisedSum, ScatteredRule::PlainSum, ScatteredRule::LeastSquares}) {
      const ScatteredTarget t = target(20, 14, cs.order, cs.boundary);
      ScatteredOptions o = rule(r);
      o.threads = 1;
      const Coefficients one = project_scattered(s, t, o);
      const std::vector<double> at_one = evaluate_at_samples(one, s, 1);
      for (int threads : {2, 3, 7}) {
        o.threads = threads;
        const Coefficients k = project_scattered(s, t, o);
        EXPECT_TRUE(std::equal(k.c.data.begin(), k.c.data.end(), one.c.data.begin()))
            << name(cs) << ' ' << scattered_rule_name(r) << ' ' << threads << " threads";
        EXPECT_EQ(evaluate_at_samples(one, s, threads), at_one) << threads << " threads";
      }
    }
}

TEST(HexScattered, EvaluateAtSamplesIsHexEvaluate) {
  const ScatteredTarget t = target(6, 5, 2, Boundary::Mirror);
  const ScatteredSamples s = random_samples(200, 2, 6, 5, 4);
  const Coefficients k = project_scattered(s, t, rule(ScatteredRule::NormalisedSum));
  const std::vector<double> at = evaluate_at_samples(k, s);
  for (long i = 0; i < s.count(); ++i)
    for (int c = 0; c < 2; ++c)
      EXPECT_NEAR(at[i * 2 + c], hex_evaluate(k, {s.positions[2 * i], s.positions[2 * i + 1]}, c),
                  1e-13);
}

TEST(HexScattered, BadInputIsRefusedWithAClearMessage) {
  const ScatteredTarget t = target(4, 3, 2, Boundary::Mirror);
  ScatteredSamples s = random_samples(100, 1, 4, 3, 1);
  s.positions[10] = 4.5;
  try {
    project_scattered(s, t);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sample 5 at (4.5"), std::string::npos) << e.what();
  }
  ScatteredTarget conv = t;
  conv.method = Method::Conventional;
  EXPECT_THROW(project_scattered(random_samples(100, 1, 4, 3, 1), conv, rule(ScatteredRule::NormalisedSum)),
               std::invalid_argument);
  ScatteredTarget dense = t;
  dense.space = HexagonalSpace{2, -1.0};
  EXPECT_THROW(project_scattered(random_samples(100, 1, 4, 3, 1), dense), std::invalid_argument);
}

}  // namespace
}  // namespace sis
