// Projection from scattered samples (sis/scattered.h, docs/design.md section 11).
#include "sis/scattered.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <mutex>

#include <fftw3.h>
#include <initializer_list>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

#include "fftw_planner.h"
#include "hex_scattered.h"
#include "sis/hex_prefilter.h"
#include "sis/parallel.h"
#include "sis/smoothness.h"
#include "sis/generator.h"
#include "value_width.h"

namespace sis {
namespace {

// At most this many taps per axis: a radius of 7.5 lattice steps (degree 14).
constexpr int kMaxTaps = 16;

// Samples are checked, and the threads' rows planned, in blocks of this many.
constexpr long kBlock = 4096;

// The taps of one axis for a sample at lattice coordinate u: a rule returns
// the first tap's extended index m0 and writes phi(u - m0 - a), a < count(),
// from the generator's polynomial pieces (K: the count when fixed, else 0).
//
// Generators of at most 4 taps whose pieces are polynomials: with
// b = floor(u + half) and t = u - b, tap a (index b - back + a) weighs
// w_a(t) = sum_p c[p][a] t^p, by Horner's rule; lanes 4..7 of c repeat
// lanes 0..3, so that one 8-lane evaluation gives both axes' weights.
template <int KK>
struct PolyTaps {
  static constexpr int K = KK;
  double half = 0;
  long back = 0;
  alignas(64) double c[4][8] = {};
  int count() const { return K; }
  void set(int p, std::initializer_list<double> v) {
    int a = 0;
    for (double x : v) c[p][a] = c[p][a + 4] = x, ++a;
  }
  long operator()(double u, double* w) const {
    const double b = std::floor(u + half), t = u - b;
    for (int a = 0; a < K; ++a) {
      double v = c[K - 1][a];
      for (int p = K - 2; p >= 0; --p) v = v * t + c[p][a];
      w[a] = v;
    }
    return long(b) - back;
  }
};

PolyTaps<1> box_taps() {
  PolyTaps<1> t;
  t.half = 0.5;
  t.set(0, {1.0});
  return t;
}

PolyTaps<2> tent_taps() {  // 1 - t, t
  PolyTaps<2> t;
  t.set(0, {1.0, 0.0});
  t.set(1, {-1.0, 1.0});
  return t;
}

PolyTaps<3> quadratic_taps() {  // (1/2 - t)^2 / 2, 3/4 - t^2, (1/2 + t)^2 / 2, t in [-1/2, 1/2)
  PolyTaps<3> t;
  t.half = 0.5;
  t.back = 1;
  t.set(0, {0.125, 0.75, 0.125});
  t.set(1, {-0.5, 0.0, 0.5});
  t.set(2, {0.5, -1.0, 0.5});
  return t;
}

PolyTaps<4> cubic_taps() {  // (1 - t)^3 / 6, (4 - 6 t^2 + 3 t^3) / 6, (1 + 3 t + 3 t^2 - 3 t^3) / 6, t^3 / 6
  PolyTaps<4> t;
  t.back = 1;
  t.set(0, {1.0 / 6, 2.0 / 3, 1.0 / 6, 0.0});
  t.set(1, {-0.5, 0.0, 0.5, 0.0});
  t.set(2, {0.5, -1.0, 0.5, 0.0});
  t.set(3, {-1.0 / 6, 0.5, -0.5, 1.0 / 6});
  return t;
}

// Mitchell-Netravali: near(x) = n3 x^3 + n2 x^2 + n0 for |x| < 1 and
// far(x) = f3 x^3 + f2 x^2 + f1 x + f0 for 1 <= |x| < 2, at the taps'
// distances 1 + t, t, 1 - t, 2 - t, expanded in t.
PolyTaps<4> mitchell_taps(const Kernel& k) {
  const double B = k.param(0), C = k.param(1);
  const double n3 = (12 - 9 * B - 6 * C) / 6, n2 = (-18 + 12 * B + 6 * C) / 6, n0 = (6 - 2 * B) / 6;
  const double f3 = (-B - 6 * C) / 6, f2 = (6 * B + 30 * C) / 6, f1 = (-12 * B - 48 * C) / 6,
               f0 = (8 * B + 24 * C) / 6;
  PolyTaps<4> t;
  t.back = 1;
  t.set(0, {f3 + f2 + f1 + f0, n0, n3 + n2 + n0, 8 * f3 + 4 * f2 + 2 * f1 + f0});
  t.set(1, {3 * f3 + 2 * f2 + f1, 0.0, -3 * n3 - 2 * n2, -12 * f3 - 4 * f2 - f1});
  t.set(2, {3 * f3 + f2, n2, 3 * n3 + n2, 6 * f3 + f2});
  t.set(3, {f3, n3, -n3, -f3});
  return t;
}

// A B-spline of any degree d: its d + 1 pieces at the sample by the
// Cox-de Boor recursion on the integer knots.
struct BSplineTaps {
  static constexpr int K = 0;
  int d;
  int count() const { return d + 1; }
  long operator()(double u, double* w) const {
    const double z = u + 0.5 * (d + 1), k = std::floor(z), t = z - k;
    w[0] = 1.0;
    for (int q = 1; q <= d; ++q) {
      // w[j] <- ((t - j + q) w[j - 1] + (j + 1 - t) w[j]) / q, j from q down
      w[q] = (t * w[q - 1]) / q;
      for (int j = q - 1; j >= 1; --j) w[j] = ((t - j + q) * w[j - 1] + (j + 1 - t) * w[j]) / q;
      w[0] = ((1 - t) * w[0]) / q;
    }
    return long(k) - d;
  }
};

// Any other kernel: its value at each of the taps its radius can reach
// (those beyond its support are 0).
struct KernelTaps {
  static constexpr int K = 0;
  const Kernel* kernel;
  int n;
  double radius;
  explicit KernelTaps(const Kernel& k)
      : kernel(&k), n(int(std::floor(2 * k.radius())) + 1), radius(k.radius()) {}
  int count() const { return n; }
  long operator()(double u, double* w) const {
    const long m0 = long(std::ceil(u - radius));
    for (int j = 0; j < n; ++j) w[j] = kernel->eval(u - double(m0 + j));
    return m0;
  }
};

// Calls f(taps) with the generator's rule.
template <typename F>
void with_taps(const Kernel& k, F&& f) {
  if (k.is_bspline()) {
    switch (k.degree()) {
      case 0: return f(box_taps());
      case 1: return f(tent_taps());
      case 2: return f(quadratic_taps());
      case 3: return f(cubic_taps());
      default: return f(BSplineTaps{k.degree()});
    }
  }
  if (k.kind() == KernelKind::Mitchell) return f(mitchell_taps(k));
  return f(KernelTaps(k));
}

// The Cartesian target's generator.
const Kernel& kernel_of(const ScatteredTarget& t) {
  const auto* c = std::get_if<CartesianSpace>(&t.space);
  if (!c) throw std::logic_error("scattered projection: not a Cartesian target");
  return c->generator;
}

bool is_hexagonal(const ScatteredTarget& t) {
  return std::holds_alternative<HexagonalSpace>(t.space);
}

struct Geometry {
  long nx, ny;
  double ox, oy, hx, hy;
};

Geometry geometry(const ScatteredTarget& t) {
  if (!(t.width > 0) || !(t.height > 0) || !std::isfinite(t.width) || !std::isfinite(t.height))
    throw std::invalid_argument("scattered projection: the frame must have a finite positive size");
  const Lattice& L = t.lattice;
  if (!L.separable())
    throw std::invalid_argument("scattered projection: the lattice must be Cartesian (separable)");
  const auto e = L.extent(t.width, t.height);
  Geometry g{e[0], e[1], L.origin().x, L.origin().y, L.axis_step(0), L.axis_step(1)};
  if (std::abs(g.ox - g.hx / 2) > 1e-12 * g.hx || std::abs(g.oy - g.hy / 2) > 1e-12 * g.hy)
    throw std::invalid_argument(
        "scattered projection: the lattice's origin must be half a step in (coefficients centred in "
        "their cells), as the boundary rule folds about the frame's edges");
  const Kernel& phi = kernel_of(t);
  if (phi.radius() * 2 + 1 > kMaxTaps)
    throw std::invalid_argument("scattered projection: generator " + phi.name() + " is too wide");
  if (t.method == Method::MinError && !phi.is_bspline())
    throw std::invalid_argument("scattered projection: min-error needs a B-spline generator, not " +
                                phi.name());
  return g;
}

[[noreturn]] void bad_sample(long i, const std::string& what) {
  std::ostringstream s;
  s << "scattered samples: sample " << i << ' ' << what;
  throw std::invalid_argument(s.str());
}

void check_counts(const ScatteredSamples& s, int channels) {
  if (s.channels < 1) throw std::invalid_argument("scattered samples: channels must be >= 1");
  if (s.channels != channels) {
    std::ostringstream m;
    m << "scattered samples: " << s.channels << " channels, the acquisition has " << channels;
    throw std::invalid_argument(m.str());
  }
  if (s.positions.size() % 2 != 0)
    throw std::invalid_argument("scattered samples: positions hold " +
                                std::to_string(s.positions.size()) +
                                " numbers, not two (x, y) per sample");
  const long n = s.count();
  auto count_error = [&](const char* what, std::size_t got, std::size_t want) {
    std::ostringstream m;
    m << "scattered samples: " << what << " hold " << got << " numbers, expected " << want
      << " for " << n << " samples";
    throw std::invalid_argument(m.str());
  };
  if (s.values.size() != std::size_t(n) * s.channels)
    count_error("values", s.values.size(), std::size_t(n) * s.channels);
  if (!s.weights.empty() && s.weights.size() != std::size_t(n))
    count_error("weights", s.weights.size(), std::size_t(n));
  if (!s.times.empty() && s.times.size() != std::size_t(n))
    count_error("times", s.times.size(), std::size_t(n));
}

// The first bad sample, named: what runs once the fast check has found one.
void name_bad_sample(const ScatteredSamples& s, const ScatteredTarget& t) {
  for (long i = 0; i < s.count(); ++i) {
    const double x = s.positions[2 * i], y = s.positions[2 * i + 1];
    if (!std::isfinite(x) || !std::isfinite(y)) bad_sample(i, "has a non-finite position");
    if (x < 0 || x > t.width || y < 0 || y > t.height) {
      std::ostringstream m;
      m << "at (" << x << ", " << y << ") lies outside the frame [0, " << t.width << "] x [0, "
        << t.height << "]";
      bad_sample(i, m.str());
    }
    if (!s.weights.empty() && !(std::isfinite(s.weights[i]) && s.weights[i] > 0))
      bad_sample(i, "has weight " + std::to_string(s.weights[i]) + " (must be finite and > 0)");
    for (int c = 0; c < s.channels; ++c)
      if (!std::isfinite(s.values[std::size_t(i) * s.channels + c]))
        bad_sample(i, "has a non-finite value in channel " + std::to_string(c));
  }
}

// Whether samples [i0, i1) are good: positions in the frame (NaN fails the
// comparisons), weights finite and > 0, values finite. Branch-free, so that
// it vectorises.
__attribute__((target_clones("avx512f", "avx2", "default"))) bool samples_good(
    const double* pos, const double* val, const double* wts, int C, long i0, long i1, double W,
    double H) {
  int ok = 1;
  for (long e = 2 * i0; e < 2 * i1; e += 2) {
    const double x = pos[e], y = pos[e + 1];
    ok &= int(x >= 0) & int(x <= W) & int(y >= 0) & int(y <= H);
  }
  if (wts)
    for (long i = i0; i < i1; ++i) ok &= int(wts[i] > 0) & int(wts[i] <= DBL_MAX);
  for (long e = i0 * C; e < i1 * C; ++e) ok &= int(std::abs(val[e]) <= DBL_MAX);
  return ok != 0;
}

// Throws std::invalid_argument, naming the first bad sample, unless every
// sample is good.
void check(const ScatteredSamples& s, const ScatteredTarget& t, int channels, int threads) {
  check_counts(s, channels);
  const long n = s.count(), blocks = (n + kBlock - 1) / kBlock;
  std::vector<char> good(blocks, 1);
  const double* wts = s.weights.empty() ? nullptr : s.weights.data();
  parallel_for(blocks, threads, [&](long b0, long b1) {
    for (long b = b0; b < b1; ++b)
      good[b] = samples_good(s.positions.data(), s.values.data(), wts, s.channels, b * kBlock,
                             std::min(n, (b + 1) * kBlock), t.width, t.height);
  });
  if (std::find(good.begin(), good.end(), 0) != good.end()) name_bad_sample(s, t);
}

// The samples of a pass: positions (x, y), `width` values each, weights
// (null: w0 each).
struct Batch {
  const double* pos;
  const double* val;
  const double* wts;
  double w0;
  int width;
  long n;
  double weight(long i) const { return wts ? wts[i] : w0; }
};

Batch batch(const ScatteredSamples& s, const ScatteredTarget& t, const double* values, int width) {
  return {s.positions.data(), values, s.weights.empty() ? nullptr : s.weights.data(),
          s.count() > 0 ? t.width * t.height / double(s.count()) : 0.0, width, s.count()};
}

// Positions to lattice coordinates and the folding of the taps.
struct Axes {
  long nx, ny;
  double ox, oy, sx, sy;
  Boundary boundary;
};

Axes axes(const Geometry& g, Boundary b) { return {g.nx, g.ny, g.ox, g.oy, 1.0 / g.hx, 1.0 / g.hy, b}; }

// acc[n] += sum_i w_i phi_i,n (v_i, 1) over samples [i0, i1) in order, for
// the coefficient rows [r0, r1): each coefficient holds A values, the
// sample's `width` values and, where A = width + 1, the weight sum. Each
// term is wy_b (wx_a (w_i v_i)), the same products in the same order
// whether the sample's taps fold at the frame's edges or not, so a
// coefficient's sum is the same bits however the rows are split among
// threads. KK and AA: the taps and A when fixed, else 0.
template <typename Taps, int AA>
__attribute__((target_clones("avx512f", "avx2", "default"))) void splat_range(
    const Taps& taps, const Axes& g, const Batch& s, int A_rt, double* acc, long i0, long i1,
    long r0, long r1, double* scratch) {
  constexpr int KS = Taps::K;
  constexpr bool fixed = KS > 0 && AA > 0;
  const int K = KS > 0 ? KS : taps.count();
  const int A = AA > 0 ? AA : A_rt;
  const int C = s.width;
  const long nx = g.nx, ny = g.ny;
  const std::size_t stride = std::size_t(nx) * A;
  alignas(64) double fixed_p[fixed ? KS * AA : 1];
  alignas(64) double fixed_v[AA > 0 ? AA : 1];
  double* P = fixed ? fixed_p : scratch;
  double* wv = AA > 0 ? fixed_v : scratch + K * A;
  double wx[kMaxTaps], wy[kMaxTaps];
  long ix[kMaxTaps];
  for (long i = i0; i < i1; ++i) {
    const long my = taps((s.pos[2 * i + 1] - g.oy) * g.sy, wy);
    const bool inside_y = my >= 0 && my + K <= ny;
    if (inside_y && (my + K <= r0 || my >= r1)) continue;
    const long mx = taps((s.pos[2 * i] - g.ox) * g.sx, wx);
    const double w = s.weight(i);
    const double* v = s.val + std::size_t(i) * C;
    for (int c = 0; c < C; ++c) wv[c] = w * v[c];
    if (A > C) wv[C] = w;
    for (int a = 0; a < K; ++a)
      for (int c = 0; c < A; ++c) P[a * A + c] = wx[a] * wv[c];
    if (inside_y && mx >= 0 && mx + K <= nx) {
      double* base = acc + std::size_t(my) * stride + std::size_t(mx) * A;
      const int b0 = int(std::max(0L, r0 - my)), b1 = int(std::min(long(K), r1 - my));
      for (int b = b0; b < b1; ++b) {
        double* row = base + std::size_t(b) * stride;
        const double f = wy[b];
        for (int j = 0; j < K * A; ++j) row[j] += f * P[j];
      }
    } else {
      for (int a = 0; a < K; ++a) ix[a] = extend_index(mx + a, nx, g.boundary) * A;
      for (int b = 0; b < K; ++b) {
        const long r = extend_index(my + b, ny, g.boundary);
        if (r < r0 || r >= r1) continue;
        double* row = acc + std::size_t(r) * stride;
        const double f = wy[b];
        for (int a = 0; a < K; ++a) {
          double* o = row + ix[a];
          for (int c = 0; c < A; ++c) o[c] += f * P[a * A + c];
        }
      }
    }
  }
}

// out[i] = f_app(x_i) = sum_a wx_a (sum_b wy_b c[my + b, mx + a]) for
// samples [i0, i1), the same products in the same order at the edges.
template <typename Taps, int CC>
__attribute__((target_clones("avx512f", "avx2", "default"))) void evaluate_range(
    const Taps& taps, const Axes& g, const Batch& s, int C_rt, const double* coef, double* out,
    long i0, long i1, double* scratch) {
  constexpr int KS = Taps::K;
  constexpr bool fixed = KS > 0 && CC > 0;
  const int K = KS > 0 ? KS : taps.count();
  const int C = CC > 0 ? CC : C_rt;
  const long nx = g.nx, ny = g.ny;
  const std::size_t stride = std::size_t(nx) * C;
  alignas(64) double fixed_t[fixed ? KS * CC : 1];
  double* T = fixed ? fixed_t : scratch;
  double wx[kMaxTaps], wy[kMaxTaps];
  long ix[kMaxTaps];
  for (long i = i0; i < i1; ++i) {
    const long my = taps((s.pos[2 * i + 1] - g.oy) * g.sy, wy);
    const long mx = taps((s.pos[2 * i] - g.ox) * g.sx, wx);
    if (my >= 0 && my + K <= ny && mx >= 0 && mx + K <= nx) {
      const double* base = coef + std::size_t(my) * stride + std::size_t(mx) * C;
      for (int j = 0; j < K * C; ++j) T[j] = wy[0] * base[j];
      for (int b = 1; b < K; ++b) {
        const double* row = base + std::size_t(b) * stride;
        const double f = wy[b];
        for (int j = 0; j < K * C; ++j) T[j] += f * row[j];
      }
    } else {
      for (int a = 0; a < K; ++a) ix[a] = extend_index(mx + a, nx, g.boundary) * C;
      const double* row0 = coef + std::size_t(extend_index(my, ny, g.boundary)) * stride;
      for (int a = 0; a < K; ++a)
        for (int c = 0; c < C; ++c) T[a * C + c] = wy[0] * row0[ix[a] + c];
      for (int b = 1; b < K; ++b) {
        const double* row = coef + std::size_t(extend_index(my + b, ny, g.boundary)) * stride;
        const double f = wy[b];
        for (int a = 0; a < K; ++a)
          for (int c = 0; c < C; ++c) T[a * C + c] += f * row[ix[a] + c];
      }
    }
    double* o = out + std::size_t(i) * C;
    for (int c = 0; c < C; ++c) {
      double v = wx[0] * T[c];
      for (int a = 1; a < K; ++a) v += wx[a] * T[a * C + c];
      o[c] = v;
    }
  }
}

// The passes of the polynomial taps (PolyTaps) with A <= 5 values a
// coefficient, in vectors: both axes' weights in one 8-lane Horner
// evaluation; the products P[j] = wx[j / A] (w v)[j % A] of a row of taps
// built in lanes; each of the K rows of the sample's support added as
// L = K A contiguous values. Lane by lane the same products in the same order
// as the scalar loops of the folded taps, so the vector width and the path
// do not change the bits. GCC's vector types lower to whatever width the
// clone's target has. They never cross a call the inlining leaves (the
// ABI note -Wpsabi gives for them is moot), and GCC gives it where the
// templates are instantiated, at the end of the file: off for the file.
#pragma GCC diagnostic ignored "-Wpsabi"
typedef double v8d __attribute__((vector_size(64)));
typedef double v4d __attribute__((vector_size(32)));
typedef double v2d __attribute__((vector_size(16)));
typedef double v8du __attribute__((vector_size(64), aligned(8)));
typedef double v4du __attribute__((vector_size(32), aligned(8)));
typedef double v2du __attribute__((vector_size(16), aligned(8)));

// Lanes [J, J + N) of P, from W (lanes 0..3: wx) and V (lanes 0..A-1: w v).
template <int A, int J, std::size_t... l>
inline __attribute__((always_inline)) auto products(const v8d& W, const v8d& V,
                                                    std::index_sequence<l...>) {
  return __builtin_shufflevector(W, W, int((J + l) / A)...) *
         __builtin_shufflevector(V, V, int((J + l) % A)...);
}

// P[J, L) = products(W, V), 8, 4, 2, then 1 lanes at a time.
template <int L, int A, int J = 0>
inline __attribute__((always_inline)) void make_products(double* P, const v8d& W, const v8d& V) {
  if constexpr (J + 8 <= L) {
    *reinterpret_cast<v8d*>(P + J) = products<A, J>(W, V, std::make_index_sequence<8>{});
    make_products<L, A, J + 8>(P, W, V);
  } else if constexpr (J + 4 <= L) {
    *reinterpret_cast<v4d*>(P + J) = products<A, J>(W, V, std::make_index_sequence<4>{});
    make_products<L, A, J + 4>(P, W, V);
  } else if constexpr (J + 2 <= L) {
    *reinterpret_cast<v2d*>(P + J) = products<A, J>(W, V, std::make_index_sequence<2>{});
    make_products<L, A, J + 2>(P, W, V);
  } else if constexpr (J < L) {
    P[J] = W[J / A] * V[J % A];
  }
}

// row[J, L) += f * P[J, L), in the chunks make_products wrote.
template <int L, int J = 0>
inline __attribute__((always_inline)) void add_products(double* row, double f, const double* P) {
  if constexpr (J + 8 <= L) {
    v8du* r = reinterpret_cast<v8du*>(row + J);
    *r = *r + f * *reinterpret_cast<const v8d*>(P + J);
    add_products<L, J + 8>(row, f, P);
  } else if constexpr (J + 4 <= L) {
    v4du* r = reinterpret_cast<v4du*>(row + J);
    *r = *r + f * *reinterpret_cast<const v4d*>(P + J);
    add_products<L, J + 4>(row, f, P);
  } else if constexpr (J + 2 <= L) {
    v2du* r = reinterpret_cast<v2du*>(row + J);
    *r = *r + f * *reinterpret_cast<const v2d*>(P + J);
    add_products<L, J + 2>(row, f, P);
  } else if constexpr (J < L) {
    row[J] = row[J] + f * P[J];
  }
}

// t[J, L) (=, or += where Add) f * row[J, L), 8, 4, 2, then 1 lanes at a time.
template <int L, bool Add, int J = 0>
inline __attribute__((always_inline)) void gather_row(double* t, double f, const double* row) {
  if constexpr (J + 8 <= L) {
    v8du* d = reinterpret_cast<v8du*>(t + J);
    const v8du r = *reinterpret_cast<const v8du*>(row + J);
    *d = Add ? *d + f * r : f * r;
    gather_row<L, Add, J + 8>(t, f, row);
  } else if constexpr (J + 4 <= L) {
    v4du* d = reinterpret_cast<v4du*>(t + J);
    const v4du r = *reinterpret_cast<const v4du*>(row + J);
    *d = Add ? *d + f * r : f * r;
    gather_row<L, Add, J + 4>(t, f, row);
  } else if constexpr (J + 2 <= L) {
    v2du* d = reinterpret_cast<v2du*>(t + J);
    const v2du r = *reinterpret_cast<const v2du*>(row + J);
    *d = Add ? *d + f * r : f * r;
    gather_row<L, Add, J + 2>(t, f, row);
  } else if constexpr (J < L) {
    t[J] = Add ? t[J] + f * row[J] : f * row[J];
  }
}

// Vectors made in registers (element by element, GCC goes through memory,
// whose wide loads of narrow stores stall).
inline __attribute__((always_inline)) v8d broadcast(double a) {
  return v8d{a, a, a, a, a, a, a, a};
}

// a in lanes 0..3, b in lanes 4..7.
inline __attribute__((always_inline)) v8d halves(double a, double b) {
  const v4d x = {a, a, a, a}, y = {b, b, b, b};
  return __builtin_shufflevector(x, y, 0, 1, 2, 3, 4, 5, 6, 7);
}

// Lanes 0..A-1: w v_c for c < C = A - Den, then w where Den (lanes from A
// on unused), from vectors of 4 lanes.
template <int A, bool Den>
inline __attribute__((always_inline)) v8d weighted_values(double w, const double* v) {
  constexpr int C = A - int(Den);
  auto x = [&](int c) { return c < C ? w * v[c] : w; };
  if constexpr (A == 1) {
    return broadcast(x(0));
  } else if constexpr (A == 2) {
    const double a = x(0), b = x(1);
    const v4d X = {a, b, a, b};
    return __builtin_shufflevector(X, X, 0, 1, 2, 3, 0, 1, 2, 3);
  } else if constexpr (A == 3) {
    const double a = x(0), b = x(1), c = x(2);
    const v4d X = {a, b, c, c};
    return __builtin_shufflevector(X, X, 0, 1, 2, 3, 0, 1, 2, 3);
  } else if constexpr (A == 4) {
    const v4d X = {x(0), x(1), x(2), x(3)};
    return __builtin_shufflevector(X, X, 0, 1, 2, 3, 0, 1, 2, 3);
  } else {
    static_assert(A == 5);
    const double e = x(4);
    const v4d X = {x(0), x(1), x(2), x(3)}, Y = {e, e, e, e};
    return __builtin_shufflevector(X, Y, 0, 1, 2, 3, 4, 5, 6, 7);
  }
}

// Both axes' weights: lanes 0..K-1 wx, 4..4+K-1 wy; m0 of each axis.
template <int K>
inline __attribute__((always_inline)) v8d poly_weights(const PolyTaps<K>& taps, double u, double v,
                                                       long& mx, long& my) {
  const double bu = std::floor(u + taps.half), bv = std::floor(v + taps.half);
  mx = long(bu) - taps.back;
  my = long(bv) - taps.back;
  const v8d t = halves(u - bu, v - bv);
  v8d W = *reinterpret_cast<const v8d*>(taps.c[K - 1]);
  for (int p = K - 2; p >= 0; --p) W = W * t + *reinterpret_cast<const v8d*>(taps.c[p]);
  return W;
}

template <int K, int A, bool Den>
__attribute__((target_clones("avx512f", "avx2", "default"))) void splat_poly(
    const PolyTaps<K>& taps, const Axes& g, const Batch& s, double* acc, long i0, long i1, long r0,
    long r1) {
  constexpr int L = K * A, C = A - int(Den);
  const long nx = g.nx, ny = g.ny;
  const std::size_t stride = std::size_t(nx) * A;
  alignas(64) double w8[8], v8[8], P[L];
  long ix[K];
  for (long i = i0; i < i1; ++i) {
    long mx, my;
    const v8d W = poly_weights(taps, (s.pos[2 * i] - g.ox) * g.sx, (s.pos[2 * i + 1] - g.oy) * g.sy,
                               mx, my);
    const bool inside_y = my >= 0 && my + K <= ny;
    if (inside_y && (my + K <= r0 || my >= r1)) continue;
    const double w = s.weight(i);
    const double* val = s.val + std::size_t(i) * C;
    const v8d V = weighted_values<A, Den>(w, val);
    if (inside_y && mx >= 0 && mx + K <= nx) {
      make_products<L, A>(P, W, V);
      double* base = acc + std::size_t(my) * stride + std::size_t(mx) * A;
      if (my >= r0 && my + K <= r1) {
        for (int b = 0; b < K; ++b) add_products<L>(base + std::size_t(b) * stride, W[4 + b], P);
      } else {
        for (int b = 0; b < K; ++b)
          if (my + b >= r0 && my + b < r1)
            add_products<L>(base + std::size_t(b) * stride, W[4 + b], P);
      }
    } else {
      *reinterpret_cast<v8d*>(w8) = W;
      *reinterpret_cast<v8d*>(v8) = V;
      for (int a = 0; a < K; ++a) ix[a] = extend_index(mx + a, nx, g.boundary) * A;
      for (int b = 0; b < K; ++b) {
        const long r = extend_index(my + b, ny, g.boundary);
        if (r < r0 || r >= r1) continue;
        double* row = acc + std::size_t(r) * stride;
        const double f = w8[4 + b];
        for (int a = 0; a < K; ++a)
          for (int c = 0; c < A; ++c) row[ix[a] + c] = row[ix[a] + c] + f * (w8[a] * v8[c]);
      }
    }
  }
}

template <int K, int C>
__attribute__((target_clones("avx512f", "avx2", "default"))) void evaluate_poly(
    const PolyTaps<K>& taps, const Axes& g, const Batch& s, const double* coef, double* out,
    long i0, long i1) {
  constexpr int L = K * C;
  const long nx = g.nx, ny = g.ny;
  const std::size_t stride = std::size_t(nx) * C;
  alignas(64) double w8[8], T[L];
  long ix[K];
  for (long i = i0; i < i1; ++i) {
    long mx, my;
    const v8d W = poly_weights(taps, (s.pos[2 * i] - g.ox) * g.sx, (s.pos[2 * i + 1] - g.oy) * g.sy,
                               mx, my);
    *reinterpret_cast<v8d*>(w8) = W;
    if (my >= 0 && my + K <= ny && mx >= 0 && mx + K <= nx) {
      const double* base = coef + std::size_t(my) * stride + std::size_t(mx) * C;
      gather_row<L, false>(T, W[4], base);
      for (int b = 1; b < K; ++b) gather_row<L, true>(T, W[4 + b], base + std::size_t(b) * stride);
    } else {
      for (int a = 0; a < K; ++a) ix[a] = extend_index(mx + a, nx, g.boundary) * C;
      for (int b = 0; b < K; ++b) {
        const double* row = coef + std::size_t(extend_index(my + b, ny, g.boundary)) * stride;
        const double f = w8[4 + b];
        for (int a = 0; a < K; ++a)
          for (int c = 0; c < C; ++c)
            T[a * C + c] = b == 0 ? f * row[ix[a] + c] : T[a * C + c] + f * row[ix[a] + c];
      }
    }
    double* o = out + std::size_t(i) * C;
    for (int c = 0; c < C; ++c) {
      double v = w8[0] * T[c];
      for (int a = 1; a < K; ++a) v = v + w8[a] * T[a * C + c];
      o[c] = v;
    }
  }
}

template <typename T>
struct is_poly : std::false_type {};
template <int K>
struct is_poly<PolyTaps<K>> : std::true_type {};


// How the coefficient rows are split among threads for the splats: strip p
// is rows [strips[p], strips[p + 1]); a thread visits the blocks of samples
// whose taps reach its strip (rows[b]: the first and last row block b's
// taps reach, [0, ny) when they fold at the top or bottom edge). Each
// coefficient's sum runs over its samples in order whatever the strips, so
// the strips only balance the work: each block's samples are spread evenly
// over the rows it reaches, and the strips cut the total into equal parts.
struct RowPlan {
  std::vector<long> strips;
  std::vector<std::pair<long, long>> rows;
  long parts() const { return long(strips.size()) - 1; }
};

// Rows a sample's taps reach from the row of its lattice coordinate, either
// side, at most.
int reach(const Kernel& k) { return int(std::floor(2 * k.radius())) + 1; }

// Where `check` is given, the samples are checked in the same pass, and a
// bad one is named (std::invalid_argument) before any is added.
RowPlan plan_rows(const ScatteredSamples& s, const Geometry& g, int K, int threads,
                  const ScatteredTarget* check = nullptr) {
  RowPlan p;
  const long n = s.count(), blocks = (n + kBlock - 1) / kBlock;
  const long parts = std::min<long>(threads, g.ny);
  if (parts <= 1 || blocks == 0) {
    p.strips = {0, g.ny};
    p.rows.assign(blocks, {0, g.ny - 1});
    return p;
  }
  p.rows.resize(blocks);
  const double sy = 1.0 / g.hy;
  std::vector<char> good(blocks, 1);
  parallel_for(blocks, threads, [&](long b0, long b1) {
    for (long b = b0; b < b1; ++b) {
      if (check && !samples_good(s.positions.data(), s.values.data(),
                                 s.weights.empty() ? nullptr : s.weights.data(), s.channels,
                                 b * kBlock, std::min(n, (b + 1) * kBlock), check->width,
                                 check->height)) {
        good[b] = 0;
        continue;
      }
      double lo = INFINITY, hi = -INFINITY;
      for (long i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
        const double v = s.positions[2 * i + 1];
        lo = v < lo ? v : lo;
        hi = v > hi ? v : hi;
      }
      long r0 = long(std::floor((lo - g.oy) * sy)) - K, r1 = long(std::floor((hi - g.oy) * sy)) + K;
      if (r0 < 0 || r1 >= g.ny) r0 = 0, r1 = g.ny - 1;
      p.rows[b] = {r0, r1};
    }
  });
  if (std::find(good.begin(), good.end(), 0) != good.end()) name_bad_sample(s, *check);
  std::vector<double> density(g.ny + 1, 0.0);
  for (long b = 0; b < blocks; ++b) {
    const long count = std::min(n, (b + 1) * kBlock) - b * kBlock;
    const double per_row = double(count) / double(p.rows[b].second - p.rows[b].first + 1);
    density[p.rows[b].first] += per_row;
    density[p.rows[b].second + 1] -= per_row;
  }
  p.strips.assign(parts + 1, g.ny);
  p.strips[0] = 0;
  double level = 0, total = 0;
  for (long r = 0; r < g.ny; ++r) total += (level += density[r]);
  level = 0;
  double sum = 0;
  long part = 1;
  for (long r = 0; r < g.ny && part < parts; ++r) {
    sum += (level += density[r]);
    while (part < parts && sum >= total * double(part) / double(parts)) p.strips[part++] = r + 1;
  }
  return p;
}

// acc += the splat of values (`width` each) at the samples, with the weight
// sums in the same pass where acc holds width + 1 values a coefficient.
// Where `check`, each block of samples is checked before it is added (one
// thread: the plan has not checked them): returns false at the first bad
// block, the blocks before it added.
bool splat(const ScatteredSamples& s, const ScatteredTarget& t, const Geometry& g,
           const RowPlan& plan, const double* values, int width, Grid<double>& acc, int threads,
           bool check = false) {
  bool good = true;
  const Batch bt = batch(s, t, values, width);
  const Axes ax = axes(g, t.boundary);
  const int A = acc.channels;
  const long n = s.count();
  with_taps(kernel_of(t), [&](const auto& taps) {
    const int K = taps.count();
    with_width(A, [&](auto a) {
      constexpr int AA = decltype(a)::value;
      auto run = [&](long p0, long p1) {
        std::vector<double> scratch(std::size_t(K) * A + A);
        for (long p = p0; p < p1; ++p) {
          const long r0 = plan.strips[p], r1 = plan.strips[p + 1];
          if (r0 == r1) continue;
          for (long b = 0; b < long(plan.rows.size()); ++b) {
            if (plan.rows[b].second < r0 || plan.rows[b].first >= r1) continue;
            const long i0 = b * kBlock, i1 = std::min(n, (b + 1) * kBlock);
            if (check && !samples_good(s.positions.data(), s.values.data(),
                                       s.weights.empty() ? nullptr : s.weights.data(), s.channels,
                                       i0, i1, t.width, t.height)) {
              good = false;
              return;
            }
            using Taps = std::decay_t<decltype(taps)>;
            if constexpr (is_poly<Taps>::value && AA > 0) {
              if (A == width + 1)
                splat_poly<Taps::K, AA, true>(taps, ax, bt, acc.data.data(), i0, i1, r0, r1);
              else
                splat_poly<Taps::K, AA, false>(taps, ax, bt, acc.data.data(), i0, i1, r0, r1);
            } else
              splat_range<Taps, AA>(taps, ax, bt, A, acc.data.data(), i0, i1, r0, r1,
                                    scratch.data());
          }
        }
      };
      if (plan.parts() == 1)
        run(0, 1);
      else
        parallel_for(plan.parts(), threads, run);
    });
  });
  return good;
}

// f_app at every sample, channel fastest.
void evaluate(const ScatteredSamples& s, const ScatteredTarget& t, const Geometry& g,
              const Grid<double>& c, double* out, int threads) {
  const Batch bt = batch(s, t, nullptr, c.channels);
  const Axes ax = axes(g, t.boundary);
  const int C = c.channels;
  const long n = s.count(), blocks = (n + kBlock - 1) / kBlock;
  with_taps(kernel_of(t), [&](const auto& taps) {
    const int K = taps.count();
    with_width(C, [&](auto cc) {
      constexpr int CC = decltype(cc)::value;
      parallel_for(blocks, threads, [&](long b0, long b1) {
        std::vector<double> scratch(std::size_t(K) * C);
        const long i0 = b0 * kBlock, i1 = std::min(n, b1 * kBlock);
        using Taps = std::decay_t<decltype(taps)>;
        if constexpr (is_poly<Taps>::value && CC > 0)
          evaluate_poly<Taps::K, CC>(taps, ax, bt, c.data.data(), out, i0, i1);
        else
          evaluate_range<Taps, CC>(taps, ax, bt, C, c.data.data(), out, i0, i1, scratch.data());
      });
    });
  });
}

Coefficients make_coefficients(const ScatteredTarget& t, Grid<double> c) {
  Coefficients k;
  k.c = std::move(c);
  k.lattice = t.lattice;
  k.space = t.space;
  k.boundary = t.boundary;
  k.min_error = t.method == Method::MinError;
  k.image_width = t.width;
  k.image_height = t.height;
  return k;
}

}  // namespace

Sample ScatteredSamples::sample(long i) const {
  Sample s;
  s.position = {positions[2 * i], positions[2 * i + 1]};
  s.weight = weights.empty() ? 0.0 : weights[i];
  s.time = times.empty() ? 0.0 : times[i];
  return s;
}

const char* scattered_rule_name(ScatteredRule rule) {
  switch (rule) {
    case ScatteredRule::NormalisedSum: return "normalised";
    case ScatteredRule::LeastSquares: return "fit";
    case ScatteredRule::PlainSum: return "plain";
    case ScatteredRule::Variational: return "variational";
  }
  return "?";
}

ScatteredRule parse_scattered_rule(const std::string& spelling) {
  if (spelling == "normalised") return ScatteredRule::NormalisedSum;
  if (spelling == "fit") return ScatteredRule::LeastSquares;
  if (spelling == "plain") return ScatteredRule::PlainSum;
  if (spelling == "variational") return ScatteredRule::Variational;
  throw std::invalid_argument("unknown scattered rule '" + spelling +
                              "' (expected normalised, fit, plain or variational)");
}

ScatteredAcquisition::ScatteredAcquisition(const ScatteredTarget& target, int channels,
                                           int threads)
    : target_(target), channels_(channels), threads_(threads < 1 ? 1 : threads) {
  if (channels < 1) throw std::invalid_argument("scattered acquisition: channels must be >= 1");
  const auto [nx, ny] = scattered_grid(target_);
  sums_ = Grid<double>(nx, ny, channels + 1);
}

std::size_t ScatteredAcquisition::bytes() const { return sums_.data.size() * sizeof(double); }

Grid<double> ScatteredAcquisition::numerator() const {
  Grid<double> out(sums_.width, sums_.height, channels_, kUnset);
  const std::size_t n = std::size_t(sums_.width) * sums_.height;
  for (std::size_t e = 0; e < n; ++e)
    for (int c = 0; c < channels_; ++c)
      out.data[e * channels_ + c] = sums_.data[e * (channels_ + 1) + c];
  return out;
}

Grid<double> ScatteredAcquisition::denominator() const {
  Grid<double> out(sums_.width, sums_.height, 1, kUnset);
  const std::size_t n = std::size_t(sums_.width) * sums_.height;
  for (std::size_t e = 0; e < n; ++e) out.data[e] = sums_.data[e * (channels_ + 1) + channels_];
  return out;
}

void ScatteredAcquisition::add(const ScatteredSamples& s) {
  if (failed_)
    throw std::logic_error(
        "scattered acquisition: an earlier add() met a bad sample; its sums hold part of that call");
  check_counts(s, channels_);
  // A bad sample leaves the acquisition refusing more, however many
  // threads (and so whether part of the call was added).
  failed_ = true;
  if (is_hexagonal(target_)) {
    // Every sample is checked before any is added.
    check(s, target_, channels_, threads_);
    const detail::HexScatteredGrid g = detail::hex_scattered_grid(target_);
    detail::hex_splat(g, s, s.values.data(), channels_, false, detail::HexImages::Grid, sums_,
                      threads_);
    failed_ = false;
    return;
  }
  const Geometry g = geometry(target_);
  // Several threads: the plan of their rows checks every sample first. One:
  // each block is checked as it is added, while it is in the cache.
  const RowPlan plan = plan_rows(s, g, reach(kernel_of(target_)), threads_, &target_);
  if (!splat(s, target_, g, plan, s.values.data(), channels_, sums_, threads_, plan.parts() == 1))
    name_bad_sample(s, target_);
  failed_ = false;
}

Coefficients ScatteredAcquisition::finish(ScatteredRule rule) const {
  if (failed_)
    throw std::logic_error(
        "scattered acquisition: an earlier add() met a bad sample; its sums hold part of that call");
  if (rule == ScatteredRule::LeastSquares || rule == ScatteredRule::Variational)
    throw std::invalid_argument(
        "scattered acquisition: the least-squares and variational fits need every sample again "
        "(project_scattered), not one pass");
  const bool min_error = target_.method == Method::MinError;
  if (!min_error && rule != ScatteredRule::NormalisedSum)
    throw std::invalid_argument(
        std::string("scattered projection: the conventional method takes the normalised weighted "
                    "average, not the ") + scattered_rule_name(rule) + " rule");
  const bool hex = is_hexagonal(target_);
  const long nx = sums_.width, ny = sums_.height;
  Grid<double> r(nx, ny, channels_, kUnset);
  // In lattice units the inner product of a flat 1 with phi is int phi
  // (1 for the B-splines and the box splines); the plain sum's lattice-unit
  // scale is 1 / (hx hy), on the hexagonal lattice 1 / |det L|.
  double integral = 1, plain = 1;
  std::unique_ptr<detail::HexScatteredGrid> hg;
  if (hex) {
    hg = std::make_unique<detail::HexScatteredGrid>(detail::hex_scattered_grid(target_));
    plain = 1.0 / std::abs(hg->layout.lattice.determinant());
  } else {
    const Geometry g = geometry(target_);
    integral = kernel_of(target_).integral() * kernel_of(target_).integral();
    plain = 1.0 / (g.hx * g.hy);
  }
  const int A = channels_ + 1;
  for (long y = 0; y < ny; ++y)
    for (long x = 0; x < nx; ++x) {
      const double* sum = sums_.data.data() + (std::size_t(y) * nx + x) * A;
      double* out = &r.at(x, y, 0);
      const double d = sum[channels_];
      if (rule == ScatteredRule::PlainSum) {
        for (int c = 0; c < channels_; ++c) out[c] = sum[c] * plain;
        continue;
      }
      if (!(d > 0)) {
        std::ostringstream m;
        m << "scattered projection: coefficient (" << x << ", " << y
          << ") has weight sum " << d
          << " (no sample in its generator's support; the normalised rule needs one there)";
        throw std::invalid_argument(m.str());
      }
      const double scale = min_error ? integral / d : 1.0 / d;
      for (int c = 0; c < channels_; ++c) out[c] = sum[c] * scale;
    }
  if (hex) {
    Coefficients k = detail::hex_scattered_coefficients(*hg, std::move(r));
    HexPrefilterPlan(hg->spline->order(), nx, ny).execute(k.c, threads_);
    return k;
  }
  Coefficients k = make_coefficients(target_, std::move(r));
  if (min_error) prefilter(k, threads_, target_.prefilter);
  return k;
}

namespace {

// The variational rule's working set for n coefficients, N samples, C
// channels and P probes (A = C + P channels solved together): the samples'
// copy (positions, weights, values), f_app at them, the splatted sums (A + 1),
// b, the CG's r, z, p, q, R v, x and the best x (A each), the
// preconditioner's transform and inverse.
std::uint64_t variational_bytes(std::uint64_t n, long N, int C, int P) {
  const std::uint64_t A = std::uint64_t(C + P);
  return 8 * (n * (9 * A + 1 + 2) + std::uint64_t(N) * (3 + 2 * A));
}

// On the hexagonal lattice, for n coefficients and M images of the samples
// in the grid's period: per image its owner, weight, values and f_app
// (2 + 2A); b, the CG's r, z, p, q, R v, x and the best x (8A a
// coefficient); the preconditioner's spectrum and divisors (about 2).
std::uint64_t variational_bytes_hex(std::uint64_t n, long M, long N, int C, int P) {
  const std::uint64_t A = std::uint64_t(C + P);
  return 8 * (n * (8 * A + 2) + std::uint64_t(M) * (2 + 2 * A) + std::uint64_t(N) * (1 + 2 * A));
}

}  // namespace

std::pair<long, long> scattered_grid(const ScatteredTarget& target) {
  if (is_hexagonal(target)) {
    const detail::HexScatteredGrid g = detail::hex_scattered_grid(target);
    return {g.layout.columns, g.layout.rows};
  }
  const Geometry g = geometry(target);
  return {g.nx, g.ny};
}

std::uint64_t scattered_bytes(const ScatteredTarget& target, const ScatteredSamples& samples,
                              const ScatteredOptions& options) {
  const auto [nx, ny] = scattered_grid(target);
  const int C = samples.channels;
  if (options.rule == ScatteredRule::Variational && !is_hexagonal(target))
    return variational_bytes(std::uint64_t(nx) * std::uint64_t(ny), samples.count(), C,
                             options.lambda ? 0 : options.gcv_probes);
  if (options.rule == ScatteredRule::Variational) {
    const detail::HexScatteredGrid g = detail::hex_scattered_grid(target);
    const long images = detail::hex_image_count(g, samples, detail::HexImages::Period);
    return variational_bytes_hex(std::uint64_t(nx) * std::uint64_t(ny), images, samples.count(), C,
                                 options.lambda ? 0 : options.gcv_probes);
  }
  const std::uint64_t grid = std::uint64_t(nx) * std::uint64_t(ny) * C;
  // Cartesian: the sums, the fit's four grids and r, values per sample.
  // Hexagonal: one grid more (b), values per image in the grid's period
  // (a sample near the frame's edges has images in the margin).
  if (is_hexagonal(target)) {
    const detail::HexScatteredGrid g = detail::hex_scattered_grid(target);
    const long images = detail::hex_image_count(g, samples, detail::HexImages::Period);
    return 8 * (7 * grid + std::uint64_t(images) * C);
  }
  return 8 * (6 * grid + std::uint64_t(samples.count()) * C);
}

std::vector<double> evaluate_at_samples(const Coefficients& k, const ScatteredSamples& samples,
                                        int threads) {
  ScatteredTarget t;
  t.width = k.image_width;
  t.height = k.image_height;
  t.boundary = k.boundary;
  t.method = k.min_error ? Method::MinError : Method::Conventional;
  if (std::holds_alternative<HexagonalSpace>(k.space)) {
    const HexLayout layout = hex_layout(k);
    detail::HexScatteredGrid g;
    g.layout = layout;
    g.spline = &hex_generator(k);
    g.width = t.width;
    g.height = t.height;
    g.boundary = t.boundary;
    if (!(t.width > 0) || !(t.height > 0))
      throw std::invalid_argument("evaluate_at_samples: the coefficients' frame is empty");
    check(samples, t, k.c.channels, threads);
    std::vector<double> out(std::size_t(samples.count()) * k.c.channels);
    detail::hex_evaluate_images(g, samples, k.c, detail::HexImages::Sample, out.data(), threads);
    return out;
  }
  t.lattice = k.lattice;
  t.space = k.space;
  const Geometry g = geometry(t);
  check(samples, t, k.c.channels, threads);
  std::vector<double> out(std::size_t(samples.count()) * k.c.channels);
  evaluate(samples, t, g, k.c, out.data(), threads);
  return out;
}

namespace {

// The fit's preconditioned conjugate gradients (docs/design.md section 11):
// G x = b per channel from x, apply_G(v, out) out = G v, precondition(in,
// out) out ~ G^{-1} in; the report's iterations and residual.
template <typename ApplyG, typename Precondition>
void conjugate_gradients(Grid<double>& x, const Grid<double>& b, const ApplyG& apply_G,
                         const Precondition& precondition, const ScatteredOptions& options,
                         ScatteredReport& rep) {
  const int C = x.channels;
  const long nx = x.width, ny = x.height;
  Grid<double> r(nx, ny, C), z(nx, ny, C), p(nx, ny, C), q(nx, ny, C);
  auto dots = [&](const Grid<double>& u, const Grid<double>& v) {
    std::vector<double> s(C, 0.0);
    for (std::size_t e = 0; e < u.data.size(); ++e) s[e % C] += u.data[e] * v.data[e];
    return s;
  };
  apply_G(x, q);
  for (std::size_t e = 0; e < r.data.size(); ++e) r.data[e] = b.data[e] - q.data[e];
  const std::vector<double> bb = dots(b, b);
  std::vector<double> rr = dots(r, r);
  auto done = [&] {
    for (int c = 0; c < C; ++c)
      if (rr[c] > options.tolerance * options.tolerance * bb[c]) return false;
    return true;
  };
  precondition(r, z);
  p.data = z.data;
  std::vector<double> rz = dots(r, z);
  int it = 0;
  while (it < options.iterations && !done()) {
    apply_G(p, q);
    const std::vector<double> pq = dots(p, q);
    std::vector<double> alpha(C, 0.0);
    for (int c = 0; c < C; ++c) alpha[c] = pq[c] > 0 ? rz[c] / pq[c] : 0.0;
    for (std::size_t e = 0; e < x.data.size(); ++e) {
      const int c = int(e % C);
      x.data[e] += alpha[c] * p.data[e];
      r.data[e] -= alpha[c] * q.data[e];
    }
    ++it;
    rr = dots(r, r);
    if (it == options.iterations || done()) break;
    precondition(r, z);
    const std::vector<double> rz_new = dots(r, z);
    for (std::size_t e = 0; e < p.data.size(); ++e) {
      const int c = int(e % C);
      const double beta = rz[c] > 0 ? rz_new[c] / rz[c] : 0.0;
      p.data[e] = z.data[e] + beta * p.data[e];
    }
    rz = rz_new;
  }
  rep.iterations = it;
  rep.residual.resize(C);
  for (int c = 0; c < C; ++c) rep.residual[c] = bb[c] > 0 ? std::sqrt(rr[c] / bb[c]) : 0.0;
  rep.bytes += (r.data.size() * 5) * sizeof(double);
}

// The variational rule's spectral preconditioner: out = (hx hy a + lambda R)^{-1} in,
// diagonal in the boundary rule's transform (mirror: the 2-D DCT-II, periodic:
// the 2-D DFT), one channel at a time on one thread.
class SpectralPreconditioner {
 public:
  SpectralPreconditioner(long nx, long ny, Boundary boundary, const std::vector<double>& a,
                         double area, const SmoothnessOperator& R, double lambda)
      : nx_(nx), ny_(ny), periodic_(boundary == Boundary::Periodic) {
    const long kx = periodic_ ? nx / 2 + 1 : nx;
    const double step = periodic_ ? 2 * M_PI : M_PI;
    inverse_.resize(std::size_t(kx) * ny);
    for (long y = 0; y < ny; ++y)
      for (long x = 0; x < kx; ++x) {
        const double wx = step * x / nx, wy = step * y / ny;
        const double e = area * taps_spectrum(a, wx) * taps_spectrum(a, wy) + lambda * R.spectrum(wx, wy);
        inverse_[std::size_t(y) * kx + x] = 1.0 / (e * (periodic_ ? double(nx) * ny : 4.0 * nx * ny));
      }
    real_ = fftw_alloc_real(std::size_t(nx) * ny);
    bins_ = periodic_ ? fftw_alloc_complex(std::size_t(kx) * ny) : nullptr;
    std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
    if (periodic_) {
      forward_ = fftw_plan_dft_r2c_2d(int(ny), int(nx), real_, bins_, FFTW_ESTIMATE);
      backward_ = fftw_plan_dft_c2r_2d(int(ny), int(nx), bins_, real_, FFTW_ESTIMATE);
    } else {
      forward_ = fftw_plan_r2r_2d(int(ny), int(nx), real_, real_, FFTW_REDFT10, FFTW_REDFT10,
                                  FFTW_ESTIMATE);
      backward_ = fftw_plan_r2r_2d(int(ny), int(nx), real_, real_, FFTW_REDFT01, FFTW_REDFT01,
                                   FFTW_ESTIMATE);
    }
  }
  ~SpectralPreconditioner() {
    std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
    fftw_destroy_plan(forward_);
    fftw_destroy_plan(backward_);
    fftw_free(real_);
    if (bins_) fftw_free(bins_);
  }
  SpectralPreconditioner(const SpectralPreconditioner&) = delete;
  SpectralPreconditioner& operator=(const SpectralPreconditioner&) = delete;

  void operator()(const Grid<double>& in, Grid<double>& out) const {
    const int C = in.channels;
    const std::size_t n = std::size_t(nx_) * ny_;
    for (int c = 0; c < C; ++c) {
      for (std::size_t e = 0; e < n; ++e) real_[e] = in.data[e * C + c];
      fftw_execute(forward_);
      if (periodic_)
        for (std::size_t e = 0; e < inverse_.size(); ++e) {
          bins_[e][0] *= inverse_[e];
          bins_[e][1] *= inverse_[e];
        }
      else
        for (std::size_t e = 0; e < n; ++e) real_[e] *= inverse_[e];
      fftw_execute(backward_);
      for (std::size_t e = 0; e < n; ++e) out.data[e * C + c] = real_[e];
    }
  }

 private:
  long nx_, ny_;
  bool periodic_;
  std::vector<double> inverse_;
  double* real_ = nullptr;
  fftw_complex* bins_ = nullptr;
  fftw_plan forward_ = nullptr, backward_ = nullptr;
};

// A Rademacher value (+-1) for probe p at sample i: splitmix64 of (p, i).
double rademacher(int p, long i) {
  std::uint64_t z = (std::uint64_t(p) << 40) ^ std::uint64_t(i);
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return (z >> 63) ? 1.0 : -1.0;
}

// The variational rule's solves and lambda search, shared by both lattices
// (docs/design.md section 15): (G + lambda R) x = b by conjugate gradients,
// x from zero for a given lambda; for GCV, from the largest lambda down
// (unit 10^(-6 + k/2), k = 14 .. 0), each solve warm-started from the
// previous one's solution, stopping once the score has risen at two
// successive lambdas below the best. The data are N points (the samples;
// on the hexagonal lattice their images in the grid's period), point i
// with weight weights[i] and A = C + P values (the C channels, then the P
// probes z_i / sqrt(w_i)); evaluate_at(v, at) puts f_app of coefficients v
// at the points in at (A values each), splat_at(at, out) adds
// sum_i w_i at_i phi_i to out; apply_R(v, out) out = R v; make_pre(lambda)
// the preconditioner (a pointer to a callable (in, out)). GCV scores at the
// samples themselves: Ns samples of weights sw and values sv (C a sample),
// f_app of the A channels at them by evaluate_score(v, sat); a sample's
// probe values are those of every point it stands for (on the hexagonal
// lattice its images), so the hat matrix is the samples'. Returns the best
// solution, all A channels; best_lambda the lambda it belongs to, and the
// report's residual its solve's.
template <typename Evaluate, typename EvaluateScore, typename Splat, typename ApplyR,
          typename MakePre>
Grid<double> variational_search(int C, int P, const Grid<double>& b, std::vector<double>& at,
                                const Evaluate& evaluate_at, const Splat& splat_at,
                                const ApplyR& apply_R, const MakePre& make_pre, long Ns,
                                const std::vector<double>& sw, const std::vector<double>& sv,
                                std::vector<double>& sat, const EvaluateScore& evaluate_score,
                                double unit, const ScatteredOptions& options,
                                ScatteredReport& rep, double& best_lambda) {
  const int A = C + P;
  const bool gcv = P > 0;
  const long nx = b.width, ny = b.height;
  ScatteredOptions cg = options;
  cg.iterations = options.variational_iterations;
  cg.tolerance = options.variational_tolerance;
  double wsum = 0;
  for (long i = 0; i < Ns; ++i) wsum += sw[i];
  // x is the starting point (zero, or the previous lambda's solution).
  auto solve = [&](double lambda, Grid<double>& x) {
    Grid<double> rc(nx, ny, A);
    auto apply = [&](const Grid<double>& v, Grid<double>& out) {
      evaluate_at(v, at.data());
      std::fill(out.data.begin(), out.data.end(), 0.0);
      splat_at(at.data(), out);
      rep.passes += 2;
      if (lambda > 0) {
        apply_R(v, rc);
        for (std::size_t e = 0; e < out.data.size(); ++e) out.data[e] += lambda * rc.data[e];
      }
    };
    const auto pre = make_pre(lambda);
    ScatteredReport r;
    conjugate_gradients(x, b, apply, *pre, cg, r);
    rep.iterations += r.iterations;
    rep.residual = r.residual;
  };
  Grid<double> x(nx, ny, A), best;
  std::vector<double> best_residual;
  best_lambda = 0;
  if (!gcv) {
    best_lambda = *options.lambda;
    solve(best_lambda, x);
    best = std::move(x);
  } else {
    // From the largest lambda down, each solve starting from the previous
    // one's solution; the search stops once the score has risen at two
    // successive lambdas below the best (the small lambdas are the costly
    // solves, and the score rises towards interpolation).
    double best_score = 0;
    int rises = 0;
    for (int k = 14; k >= 0 && rises < 2; --k) {
      const double lambda = unit * std::pow(10.0, -6 + 0.5 * k);
      solve(lambda, x);
      evaluate_score(x, sat.data());
      rep.passes += 1;
      double rss = 0, trace = 0;
      for (long i = 0; i < Ns; ++i) {
        const double w = sw[i] * double(Ns) / wsum;
        for (int c = 0; c < C; ++c) {
          const double r = sv[std::size_t(i) * C + c] - sat[std::size_t(i) * A + c];
          rss += w * r * r;
        }
        for (int p = 0; p < P; ++p)
          trace += rademacher(p, i) * std::sqrt(sw[i]) * sat[std::size_t(i) * A + C + p];
      }
      trace /= P;
      const double dof = std::max(double(Ns) - trace, 1e-300);
      const double score = double(Ns) * rss / C / (dof * dof);
      rep.gcv.push_back({lambda, score});
      if (k == 14 || score < best_score) {
        best_score = score;
        best_lambda = lambda;
        best = x;
        best_residual = rep.residual;
        rises = 0;
      } else {
        ++rises;
      }
    }
    rep.residual = best_residual;
  }
  return best;
}

// The hexagonal lattice's variational rule (docs/design.md section 15): the
// hexagonal fit's model and data (the coefficients periodic on their
// offset-row grid, margin included; the samples' images in one period, each
// with its sample's value and weight) plus lambda c^T R c, R the box
// spline's smoothness stencil (HexSmoothnessOperator) applied periodically
// on the grid; preconditioned by the exact inverse of the shift-invariant
// approximation |det L| a + lambda R, diagonal in the grid's twisted 2-D DFT
// (HexPrefilterPlan with those taps). GCV counts the images as the data
// points, as the least-squares term does.
Coefficients project_variational_hex(const ScatteredSamples& samples, const ScatteredTarget& target,
                                     const ScatteredOptions& options, ScatteredReport* report) {
  const int threads = options.threads < 1 ? 1 : options.threads;
  const detail::HexScatteredGrid g = detail::hex_scattered_grid(target);
  const HexSmoothnessOperator R(*g.spline, options.smoothness, g.layout.lattice.matrix());
  const int C = samples.channels;
  check(samples, target, C, threads);
  const bool gcv = !options.lambda;
  const int P = gcv ? options.gcv_probes : 0;
  const int A = C + P;
  const long nx = g.layout.columns, ny = g.layout.rows;
  const long N = samples.count();
  const std::vector<long> owner = detail::hex_image_owners(g, samples, detail::HexImages::Period);
  const long M = long(owner.size());
  // Per image: its sample's weight, values and probes (z / sqrt(w), z = +-1 per image).
  const double w0 = target.width * target.height / double(N);
  std::vector<double> weights(static_cast<std::size_t>(M)), values(std::size_t(M) * A);
  for (long m = 0; m < M; ++m) {
    const long i = owner[m];
    weights[m] = samples.weights.empty() ? w0 : samples.weights[i];
    for (int c = 0; c < C; ++c) values[std::size_t(m) * A + c] = samples.values[std::size_t(i) * C + c];
    // a sample's probe value, the same at each of its images
    for (int p = 0; p < P; ++p) values[std::size_t(m) * A + C + p] = rademacher(p, i) / std::sqrt(weights[m]);
  }
  // GCV scores at the samples themselves (their images repeat their values)
  std::vector<double> sample_weights(std::size_t(N), w0);
  if (!samples.weights.empty()) sample_weights = samples.weights;
  std::vector<double> at_samples(gcv ? std::size_t(N) * A : 0);
  auto evaluate_samples = [&](const Grid<double>& v, double* out) {
    detail::hex_evaluate_images(g, samples, v, detail::HexImages::Sample, out, threads);
  };
  ScatteredReport rep;
  Grid<double> b(nx, ny, A);
  detail::hex_splat(g, samples, values.data(), A, true, detail::HexImages::Period, b, threads);
  rep.passes = 1;
  std::vector<double> at(std::size_t(M) * A);
  const double area = std::abs(g.layout.lattice.determinant());
  auto evaluate_at = [&](const Grid<double>& v, double* out) {
    detail::hex_evaluate_images(g, samples, v, detail::HexImages::Period, out, threads);
  };
  auto splat_at = [&](const double* v, Grid<double>& out) {
    detail::hex_splat(g, samples, v, A, true, detail::HexImages::Period, out, threads);
  };
  auto apply_R = [&](const Grid<double>& v, Grid<double>& out) { R.apply(v, out, threads); };
  struct Pre {
    HexPrefilterPlan plan;
    int threads;
    void operator()(const Grid<double>& in, Grid<double>& out) const {
      out.data = in.data;
      plan.execute(out, threads);
    }
  };
  auto make_pre = [&](double lambda) {
    std::map<std::pair<int, int>, double> sum;
    for (const HexTap& t : g.spline->autocorrelation()) sum[{t.k1, t.k2}] += area * t.value;
    for (const HexTap& t : R.taps()) sum[{t.k1, t.k2}] += lambda * t.value;
    std::vector<HexTap> taps;
    for (const auto& [k, v] : sum) taps.push_back({k.first, k.second, v});
    return std::unique_ptr<Pre>(new Pre{HexPrefilterPlan(taps, nx, ny), threads});
  };
  double best_lambda = 0;
  const double unit = std::pow(g.layout.step(), 2 * options.smoothness);
  const Grid<double> best = variational_search(C, P, b, at, evaluate_at, splat_at, apply_R, make_pre, N,
                                               sample_weights, samples.values, at_samples,
                                               evaluate_samples, unit, options, rep, best_lambda);
  Grid<double> c(nx, ny, C, kUnset);
  for (std::size_t e = 0; e < c.data.size() / C; ++e)
    for (int ch = 0; ch < C; ++ch) c.data[e * C + ch] = best.data[e * A + ch];
  rep.lambda = best_lambda;
  rep.residual.resize(C);
  rep.bytes = variational_bytes_hex(std::uint64_t(nx) * std::uint64_t(ny), M, N, C, P);
  if (report) *report = rep;
  return detail::hex_scattered_coefficients(g, std::move(c));
}

std::string too_few_samples(int order, long needed, long n) {
  return "scattered projection: the variational rule of order " + std::to_string(order) +
         " needs at least " + std::to_string(needed) + " samples, got " + std::to_string(n);
}

Coefficients project_variational(const ScatteredSamples& samples, const ScatteredTarget& target,
                                 const ScatteredOptions& options, ScatteredReport* report) {
  const int threads = options.threads < 1 ? 1 : options.threads;
  if (target.method != Method::MinError)
    throw std::invalid_argument(
        "scattered projection: the conventional method takes the normalised weighted average, not "
        "the variational rule");
  if (options.lambda && !(*options.lambda >= 0 && std::isfinite(*options.lambda)))
    throw std::invalid_argument("scattered projection: the variational rule's lambda must be a "
                                "finite number >= 0, not " + std::to_string(*options.lambda));
  if (options.smoothness != 1 && options.smoothness != 2)
    throw std::invalid_argument("scattered projection: the smoothness order must be 1 or 2, not " +
                                std::to_string(options.smoothness));
  if (options.variational_iterations < 0 || !(options.variational_tolerance >= 0) ||
      options.gcv_probes < 1)
    throw std::invalid_argument(
        "scattered projection: the variational rule's iterations and tolerance must be >= 0, its "
        "probes >= 1");
  if (is_hexagonal(target)) {
    const auto* hex = std::get_if<HexagonalSpace>(&target.space);
    if (options.smoothness == 2 && hex->order < 2)
      throw std::invalid_argument(
          "scattered projection: --smoothness 2 (the thin plate) needs a generator with square "
          "integrable second derivatives; hex-hat (C0) has none: use --smoothness 1 or "
          "--generator hex-quartic");
  }
  const long N = samples.count();
  const long needed = options.smoothness == 2 ? 3 : 1;  // J's null space: affine / constant
  if (is_hexagonal(target)) {
    if (N < needed)
      throw std::invalid_argument(too_few_samples(options.smoothness, needed, N));
    return project_variational_hex(samples, target, options, report);
  }
  const Geometry g = geometry(target);
  const int degree = kernel_of(target).degree();
  const SmoothnessOperator R(degree, options.smoothness, g.hx, g.hy, target.boundary);
  if (N < needed) throw std::invalid_argument(too_few_samples(options.smoothness, needed, N));
  const int C = samples.channels;
  check(samples, target, C, threads);
  const bool gcv = !options.lambda;
  const int P = gcv ? options.gcv_probes : 0;
  // The samples with their weights explicit and, for GCV, the probes as
  // extra channels: value z_i / sqrt(w_i), so that b = Phi^T W^{1/2} z.
  ScatteredSamples s;
  s.positions = samples.positions;
  s.times = samples.times;
  s.channels = C + P;
  s.weights = samples.weights.empty()
                  ? std::vector<double>(std::size_t(N), target.width * target.height / double(N))
                  : samples.weights;
  s.values.resize(std::size_t(N) * (C + P));
  for (long i = 0; i < N; ++i) {
    for (int c = 0; c < C; ++c) s.values[std::size_t(i) * (C + P) + c] = samples.values[std::size_t(i) * C + c];
    for (int p = 0; p < P; ++p)
      s.values[std::size_t(i) * (C + P) + C + p] = rademacher(p, i) / std::sqrt(s.weights[i]);
  }
  const int A = C + P;
  const RowPlan rows = plan_rows(s, g, reach(kernel_of(target)), threads);
  ScatteredReport rep;
  Grid<double> sums(g.nx, g.ny, A + 1);
  splat(s, target, g, rows, s.values.data(), A, sums, threads);
  rep.passes = 1;
  Grid<double> b(g.nx, g.ny, A);
  for (std::size_t e = 0; e < b.data.size() / A; ++e)
    for (int c = 0; c < A; ++c) b.data[e * A + c] = sums.data[e * (A + 1) + c];
  std::vector<double> at(std::size_t(N) * A);
  const std::vector<double> a = bspline_derivative_autocorrelation(degree, 0);
  const double area = g.hx * g.hy;
  auto evaluate_at = [&](const Grid<double>& v, double* out) {
    evaluate(s, target, g, v, out, threads);
  };
  auto splat_at = [&](const double* v, Grid<double>& out) {
    splat(s, target, g, rows, v, A, out, threads);
  };
  auto apply_R = [&](const Grid<double>& v, Grid<double>& out) { R.apply(v, out); };
  auto make_pre = [&](double lambda) {
    return std::make_unique<SpectralPreconditioner>(g.nx, g.ny, target.boundary, a, area, R, lambda);
  };
  double best_lambda = 0;
  const double h = std::max(g.hx, g.hy), unit = std::pow(h, 2 * options.smoothness);
  const Grid<double> best = variational_search(C, P, b, at, evaluate_at, splat_at, apply_R, make_pre, N,
                                               s.weights, samples.values, at, evaluate_at, unit,
                                               options, rep, best_lambda);
  Grid<double> c(g.nx, g.ny, C, kUnset);
  for (std::size_t e = 0; e < c.data.size() / C; ++e)
    for (int ch = 0; ch < C; ++ch) c.data[e * C + ch] = best.data[e * A + ch];
  rep.lambda = best_lambda;
  rep.residual.resize(C);
  rep.bytes = variational_bytes(std::uint64_t(g.nx) * std::uint64_t(g.ny), N, C, P);
  if (report) *report = rep;
  return make_coefficients(target, std::move(c));
}

}  // namespace

Coefficients project_scattered(const ScatteredSamples& samples, const ScatteredTarget& target,
                               const ScatteredOptions& options, ScatteredReport* report) {
  if (options.rule == ScatteredRule::Variational) return project_variational(samples, target, options, report);
  const int threads = options.threads < 1 ? 1 : options.threads;
  ScatteredAcquisition acq(target, samples.channels, threads);
  acq.add(samples);
  const ScatteredRule first =
      options.rule == ScatteredRule::LeastSquares ? ScatteredRule::NormalisedSum : options.rule;
  if (target.method != Method::MinError && options.rule != ScatteredRule::NormalisedSum)
    throw std::invalid_argument(
        std::string("scattered projection: the conventional method takes the normalised weighted "
                    "average, not the ") + scattered_rule_name(options.rule) + " rule");
  Coefficients k = acq.finish(first);
  ScatteredReport rep;
  rep.passes = 1;
  rep.bytes = acq.bytes();
  if (options.rule == ScatteredRule::LeastSquares) {
    if (options.iterations < 0 || !(options.tolerance >= 0))
      throw std::invalid_argument(
          "scattered projection: the fit's iterations and tolerance must be >= 0");
    const int C = samples.channels;
    if (is_hexagonal(target)) {
      // The model: the coefficients periodic on their grid; the data: the
      // samples' images in one period (hex_scattered.h, Period). b is their
      // splat, not the pass's numerator (which sums every image the grid
      // acquisition would).
      const detail::HexScatteredGrid g = detail::hex_scattered_grid(target);
      const long images = detail::hex_image_count(g, samples, detail::HexImages::Period);
      const long nx = k.c.width, ny = k.c.height;
      Grid<double> b(nx, ny, C);
      detail::hex_splat(g, samples, samples.values.data(), C, false, detail::HexImages::Period, b,
                        threads);
      rep.passes += 1;
      std::vector<double> at(std::size_t(images) * C);
      const HexPrefilterPlan plan(g.spline->order(), nx, ny);
      const double area = std::abs(g.layout.lattice.determinant());  // G ~ |det L| a
      auto apply_G = [&](const Grid<double>& v, Grid<double>& out) {
        detail::hex_evaluate_images(g, samples, v, detail::HexImages::Period, at.data(), threads);
        std::fill(out.data.begin(), out.data.end(), 0.0);
        detail::hex_splat(g, samples, at.data(), C, true, detail::HexImages::Period, out, threads);
        rep.passes += 2;
      };
      auto precondition = [&](const Grid<double>& in, Grid<double>& out) {
        for (std::size_t e = 0; e < in.data.size(); ++e) out.data[e] = in.data[e] / area;
        plan.execute(out, threads);
      };
      conjugate_gradients(k.c, b, apply_G, precondition, options, rep);
      rep.bytes += b.data.size() * sizeof(double) + at.size() * sizeof(double);
    } else {
      const Geometry g = geometry(target);
      const long N = samples.count();
      const RowPlan rows = plan_rows(samples, g, reach(kernel_of(target)), threads);
      // b = sum_i w_i f_i phi_i,n is the numerator of the pass above.
      const Grid<double> b = acq.numerator();
      std::vector<double> at(std::size_t(N) * C);
      const int degree = kernel_of(target).degree();
      std::unique_ptr<PrefilterPlan> plan;
      if (degree > 0)
        plan = std::make_unique<PrefilterPlan>(degree, g.nx, g.ny, target.boundary, target.prefilter);
      const double area = g.hx * g.hy;  // G ~ (hx hy) a
      auto apply_G = [&](const Grid<double>& v, Grid<double>& out) {
        evaluate(samples, target, g, v, at.data(), threads);
        std::fill(out.data.begin(), out.data.end(), 0.0);
        splat(samples, target, g, rows, at.data(), C, out, threads);
        rep.passes += 2;
      };
      auto precondition = [&](const Grid<double>& in, Grid<double>& out) {
        for (std::size_t e = 0; e < in.data.size(); ++e) out.data[e] = in.data[e] / area;
        if (plan) plan->execute(out, threads);
      };
      conjugate_gradients(k.c, b, apply_G, precondition, options, rep);
      rep.bytes += at.size() * sizeof(double);
    }
  }
  if (report) *report = rep;
  return k;
}

}  // namespace sis
