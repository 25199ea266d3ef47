// Scattered samples on the hexagonal lattice (hex_scattered.h, docs/design.md
// section 11).
#include "hex_scattered.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

#include "sis/parallel.h"
#include "value_width.h"

namespace sis {
namespace detail {
namespace {

constexpr long kBlock = 4096;  // samples a block, for the evaluation's threads

// floor(m / 2) for any integer m.
inline long floor_half(long m) { return m >= 0 ? m / 2 : -((1 - m) / 2); }

// The taps of M_n for a point at lattice coordinates U: with f = floor(U),
// w = U - f and the triangle of the unit square w falls in (upper where
// w1 + w2 > 1), lattice point m = f - k holds M_n(k + w), the polynomial of
// piece (k, upper) at w (BoxSpline::piece). Per triangle, the pieces that
// are not zero, each as its coefficients in the order of mono().
template <int N>
struct Taps {
  static constexpr int P = 3 * N - 2;                  // the pieces' degree
  static constexpr int M = (P + 1) * (P + 2) / 2;      // monomials w1^a w2^b, a + b <= P
  static constexpr int T = 3 * N * N;                  // pieces per triangle in the hexagon
  int count[2] = {0, 0};
  long k1[2][T] = {}, k2[2][T] = {};
  // coef[upper][q][t]: monomial q's coefficient in tap t (zero past count),
  // so that the taps' values are one loop over q of T lanes
  alignas(64) double coef[2][M][T] = {};

  explicit Taps(const BoxSpline& B) {
    for (int upper = 0; upper < 2; ++upper)
      for (int a1 = -N; a1 < N; ++a1)
        for (int a2 = -N; a2 < N; ++a2) {
          const BoxSpline::Poly& p = B.piece(a1, a2, upper != 0);
          double c[M];
          bool nonzero = false;
          int q = 0;
          for (int a = 0; a <= P; ++a)
            for (int b = 0; a + b <= P; ++b, ++q) nonzero |= (c[q] = p[a][b]) != 0.0;
          if (!nonzero) continue;
          const int t = count[upper]++;
          if (t >= T) throw std::logic_error("hex scattered taps: more pieces than the hexagon holds");
          k1[upper][t] = a1;
          k2[upper][t] = a2;
          for (int r = 0; r < M; ++r) coef[upper][r][t] = c[r];
        }
  }
  // The taps at lattice coordinates U: their count, the lattice points
  // (m1, m2) (m = floor(U) - k) and the values M_n(U - m) in v (T lanes).
  inline __attribute__((always_inline)) int operator()(double U1, double U2, long* m1, long* m2,
                                                       double* v) const {
    const double f1 = std::floor(U1), f2 = std::floor(U2), w1 = U1 - f1, w2 = U2 - f2;
    const int up = w1 + w2 > 1 ? 1 : 0;
    double m[M];
    {
      double pa = 1;
      int q = 0;
      for (int a = 0; a <= P; ++a, pa *= w1) {
        double pb = pa;
        for (int b = 0; a + b <= P; ++b, ++q, pb *= w2) m[q] = pb;
      }
    }
    // two partial sums (even and odd q), halving the chain of dependent adds
    const double(*c)[T] = coef[up];
    double odd[T];
    for (int t = 0; t < T; ++t) v[t] = c[0][t], odd[t] = 0.0;
    for (int q = 1; q + 1 < M; q += 2)
      for (int t = 0; t < T; ++t) {
        odd[t] += c[q][t] * m[q];
        v[t] += c[q + 1][t] * m[q + 1];
      }
    if constexpr (M % 2 == 0)
      for (int t = 0; t < T; ++t) odd[t] += c[M - 1][t] * m[M - 1];
    for (int t = 0; t < T; ++t) v[t] += odd[t];
    const long F1 = long(f1), F2 = long(f2);
    for (int t = 0; t < T; ++t) {
      m1[t] = F1 - k1[up][t];
      m2[t] = F2 - k2[up][t];
    }
    return count[up];
  }
};

template <typename F>
void with_order(int order, F&& f) {
  if (order == 1) return f(std::integral_constant<int, 1>{});
  if (order == 2) return f(std::integral_constant<int, 2>{});
  throw std::invalid_argument("hexagonal scattered projection: box spline order " +
                              std::to_string(order) + " outside [1, 2]");
}

// Where a rule's images may lie: [lo, hi) per axis (Grid: the open ranges
// from which a support reaches a stored coefficient; Period: the period D).
struct Window {
  double x0, x1, y0, y1;
};

Window window(const HexScatteredGrid& g, HexImages images) {
  const HexLayout& L = g.layout;
  const double h = L.step(), hy = L.row_step(), n = g.spline->radius();
  const Vec2 o = L.lattice.origin();
  if (images == HexImages::Period)
    return {o.x - 0.25 * h, o.x - 0.25 * h + h * double(L.columns), o.y - 0.5 * hy,
            o.y - 0.5 * hy + hy * double(L.rows)};
  return {o.x - n * h, o.x + (double(L.columns) - 0.5 + n) * h, o.y - n * hy,
          o.y + (double(L.rows) - 1 + n) * hy};
}

// The images of coordinate x of a frame of extent E under the rule, inside
// [lo, hi), increasing k (mirror: x + 2 k E, then -x + 2 k E for each k).
void axis_images(double x, double E, Boundary b, double lo, double hi, std::vector<double>& out) {
  out.clear();
  // Most samples: no image but themselves in the window (the nearest
  // others are -x and 2E - x for mirror, x - E and x + E for periodic).
  if (x >= lo && x < hi &&
      (b == Boundary::Mirror ? (-x < lo && 2 * E - x >= hi) : (x - E < lo && x + E >= hi))) {
    out.push_back(x);
    return;
  }
  const double period = b == Boundary::Mirror ? 2 * E : E;
  const long k0 = long(std::floor((lo - E) / period)) - 1, k1 = long(std::ceil((hi + E) / period)) + 1;
  for (long k = k0; k <= k1; ++k) {
    const double a = x + double(k) * period;
    if (a >= lo && a < hi) out.push_back(a);
    if (b == Boundary::Mirror) {
      const double r = -x + double(k) * period;
      if (r >= lo && r < hi) out.push_back(r);
    }
  }
}

// The images of one sample the rule counts: every (xs[a], ys[b]), taken
// y outer, each axis's in axis_images' order (the order the passes and the
// per-image values share).
struct Imager {
  const HexScatteredGrid& g;
  HexImages images;
  Window w;
  std::vector<double> xs, ys;
  Imager(const HexScatteredGrid& grid, HexImages rule) : g(grid), images(rule), w(window(grid, rule)) {}
  void of(double x, double y) {
    if (images == HexImages::Sample) {
      xs.assign(1, x);
      ys.assign(1, y);
      return;
    }
    axis_images(x, g.width, g.boundary, w.x0, w.x1, xs);
    axis_images(y, g.height, g.boundary, w.y0, w.y1, ys);
  }
  long count() const { return long(xs.size() * ys.size()); }
};

}  // namespace

HexScatteredGrid hex_scattered_grid(const ScatteredTarget& t) {
  const auto* hex = std::get_if<HexagonalSpace>(&t.space);
  if (!hex) throw std::logic_error("hex_scattered_grid(): not a hexagonal target");
  if (!(t.width > 0) || !(t.height > 0) || !std::isfinite(t.width) || !std::isfinite(t.height))
    throw std::invalid_argument("scattered projection: the frame must have a finite positive size");
  if (t.method != Method::MinError)
    throw std::invalid_argument(
        "scattered projection: the hexagonal lattice has min-error only (no conventional filter)");
  if (!(hex->density > 0) || !std::isfinite(hex->density)) {
    std::ostringstream m;
    m << "scattered projection: hexagonal density " << hex->density << " must be finite and > 0";
    throw std::invalid_argument(m.str());
  }
  HexScatteredGrid g;
  g.spline = &BoxSpline::hexagonal(hex->order);
  const int margin = t.margin >= 0 ? t.margin : hex_default_margin(hex->order);
  g.layout = hex_layout(hex->density, t.width, t.height, margin);
  g.width = t.width;
  g.height = t.height;
  g.boundary = t.boundary;
  return g;
}

Coefficients hex_scattered_coefficients(const HexScatteredGrid& g, Grid<double> c) {
  Coefficients k;
  k.c = std::move(c);
  k.lattice = g.layout.lattice;
  k.space = HexagonalSpace{g.spline->order(), 1.0 / std::abs(k.lattice.determinant())};
  k.boundary = g.boundary;
  k.min_error = true;
  k.image_width = g.width;
  k.image_height = g.height;
  return k;
}

long hex_image_count(const HexScatteredGrid& g, const ScatteredSamples& s, HexImages images) {
  if (images == HexImages::Sample) return s.count();
  Imager im(g, images);
  long n = 0;
  for (long i = 0; i < s.count(); ++i) {
    im.of(s.positions[2 * i], s.positions[2 * i + 1]);
    n += im.count();
  }
  return n;
}

std::vector<long> hex_image_owners(const HexScatteredGrid& g, const ScatteredSamples& s,
                                   HexImages images) {
  std::vector<long> owner;
  Imager im(g, images);
  for (long i = 0; i < s.count(); ++i) {
    if (images == HexImages::Sample) {
      owner.push_back(i);
      continue;
    }
    im.of(s.positions[2 * i], s.positions[2 * i + 1]);
    owner.insert(owner.end(), std::size_t(im.count()), i);
  }
  return owner;
}

namespace {

// Coefficient rows [r0, r1) of the splat (hex_splat); AA: the values a
// coefficient when fixed (1..5), else 0.
template <int N, int AA>
__attribute__((target_clones("avx512f", "avx2", "default"))) void splat_strip(
    const Taps<N>& taps, const HexScatteredGrid& g, const ScatteredSamples& s, const double* values,
    int width, bool per_image, HexImages images, double* acc, int A_rt, long r0, long r1) {
  constexpr int T = Taps<N>::T;
  const int A = AA > 0 ? AA : A_rt;
  const HexLayout& L = g.layout;
  const long Q = L.columns;
  const bool wrap = images != HexImages::Grid;
  const double h = L.step(), hy = L.row_step(), sx = 1.0 / h, sy = 1.0 / hy;
  const Vec2 o = L.lattice.origin();
  const long n = s.count();
  const double w0 = n > 0 ? g.width * g.height / double(n) : 0.0;
  const double* wts = s.weights.empty() ? nullptr : s.weights.data();
  Imager im(g, images);
  double wv_dyn[AA > 0 ? 1 : 64];
  std::vector<double> wv_big(AA > 0 || A <= 64 ? 0 : A);
  alignas(64) double wv_fixed[AA > 0 ? AA : 1];
  double* wv = AA > 0 ? wv_fixed : (A <= 64 ? wv_dyn : wv_big.data());
  long m1[T], m2[T];
  alignas(64) double tv[T];
  long image = 0;
  for (long i = 0; i < n; ++i) {
    im.of(s.positions[2 * i], s.positions[2 * i + 1]);
    const double w = wts ? wts[i] : w0;
    for (std::size_t b = 0; b < im.ys.size(); ++b) {
      const double U2 = (im.ys[b] - o.y) * sy;
      const long f2 = long(std::floor(U2));
      // the rows its taps reach: f2 - N + 1 .. f2 + N
      bool reaches = false;
      for (long j = f2 - N + 1; j <= f2 + N && !reaches; ++j) {
        const long jj = wrap ? L.wrap_row(j) : j;
        reaches = jj >= r0 && jj < r1;
      }
      if (!reaches) {
        image += long(im.xs.size());
        continue;
      }
      for (std::size_t a = 0; a < im.xs.size(); ++a, ++image) {
        const double* v = values + std::size_t(per_image ? image : i) * width;
        for (int c = 0; c < width; ++c) wv[c] = w * v[c];
        if (A > width) wv[width] = w;
        const double U1 = (im.xs[a] - o.x) * sx - 0.5 * U2;
        const int k = taps(U1, U2, m1, m2, tv);
        for (int t = 0; t < k; ++t) {
          long j = m2[t], col = m1[t] + floor_half(m2[t]);
          if (wrap) {
            j = L.wrap_row(j);
            col = L.wrap_column(col);
          } else if (col < 0 || col >= Q) {
            continue;
          }
          if (j < r0 || j >= r1) continue;
          double* out = acc + (std::size_t(j) * Q + col) * A;
          const double f = tv[t];
          for (int c = 0; c < A; ++c) out[c] += f * wv[c];
        }
      }
    }
  }
}

// f_app at the images of samples [i0, i1), the first at out (C values each).
template <int N, int CC>
__attribute__((target_clones("avx512f", "avx2", "default"))) void evaluate_block(
    const Taps<N>& taps, const HexScatteredGrid& g, const ScatteredSamples& s, const double* coef,
    int C_rt, HexImages images, double* out, long i0, long i1) {
  constexpr int T = Taps<N>::T;
  const int C = CC > 0 ? CC : C_rt;
  const HexLayout& L = g.layout;
  const long Q = L.columns;
  const double h = L.step(), hy = L.row_step(), sx = 1.0 / h, sy = 1.0 / hy;
  const Vec2 o = L.lattice.origin();
  Imager im(g, images);
  long m1[T], m2[T];
  alignas(64) double tv[T];
  for (long i = i0; i < i1; ++i) {
    im.of(s.positions[2 * i], s.positions[2 * i + 1]);
    for (const double y : im.ys) {
      const double U2 = (y - o.y) * sy;
      for (const double x : im.xs) {
        const double U1 = (x - o.x) * sx - 0.5 * U2;
        const int k = taps(U1, U2, m1, m2, tv);
        for (int ch = 0; ch < C; ++ch) out[ch] = 0.0;
        for (int t = 0; t < k; ++t) {
          const long j = L.wrap_row(m2[t]), col = L.wrap_column(m1[t] + floor_half(m2[t]));
          const double* cf = coef + (std::size_t(j) * Q + col) * C;
          for (int ch = 0; ch < C; ++ch) out[ch] += tv[t] * cf[ch];
        }
        out += C;
      }
    }
  }
}


}  // namespace

void hex_splat(const HexScatteredGrid& g, const ScatteredSamples& s, const double* values,
               int width, bool per_image, HexImages images, Grid<double>& acc, int threads) {
  const HexLayout& L = g.layout;
  const long Q = L.columns, R = L.rows;
  if (acc.width != Q || acc.height != R || (acc.channels != width && acc.channels != width + 1))
    throw std::logic_error("hex_splat(): the sums do not match the grid");
  const int A = acc.channels;
  with_order(g.spline->order(), [&](auto order) {
    constexpr int N = decltype(order)::value;
    const Taps<N> taps(*g.spline);
    with_width(A, [&](auto a) {
      constexpr int AA = decltype(a)::value;
      const long parts = std::max(1L, std::min<long>(threads, R));
      parallel_for(parts, threads, [&](long p0, long p1) {
        for (long p = p0; p < p1; ++p)
          splat_strip<N, AA>(taps, g, s, values, width, per_image, images, acc.data.data(), A,
                             R * p / parts, R * (p + 1) / parts);
      });
    });
  });
}

void hex_evaluate_images(const HexScatteredGrid& g, const ScatteredSamples& s,
                         const Grid<double>& c, HexImages images, double* out, int threads) {
  const int C = c.channels;
  const long n = s.count(), blocks = (n + kBlock - 1) / kBlock;
  // where each block's images start
  std::vector<long> first(blocks + 1, 0);
  if (images == HexImages::Sample) {
    for (long b = 0; b <= blocks; ++b) first[b] = std::min(n, b * kBlock);
  } else {
    parallel_for(blocks, threads, [&](long b0, long b1) {
      Imager im(g, images);
      for (long b = b0; b < b1; ++b) {
        long k = 0;
        for (long i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
          im.of(s.positions[2 * i], s.positions[2 * i + 1]);
          k += im.count();
        }
        first[b + 1] = k;
      }
    });
    for (long b = 0; b < blocks; ++b) first[b + 1] += first[b];
  }
  with_order(g.spline->order(), [&](auto order) {
    constexpr int N = decltype(order)::value;
    const Taps<N> taps(*g.spline);
    with_width(C, [&](auto cc) {
      constexpr int CC = decltype(cc)::value;
      parallel_for(blocks, threads, [&](long b0, long b1) {
        for (long b = b0; b < b1; ++b)
          evaluate_block<N, CC>(taps, g, s, c.data.data(), C, images, out + std::size_t(first[b]) * C,
                                b * kBlock, std::min(n, (b + 1) * kBlock));
      });
    });
  });
}

}  // namespace detail
}  // namespace sis
