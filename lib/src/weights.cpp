#include "sis/weights.h"

#include <algorithm>
#include <map>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace sis {

double AxisWeights::sum(long t) const {
  double s = 0;
  for (long e = begin(t); e < end(t); ++e) s += weight[e];
  return s;
}


namespace {

// apply_weights for 1, 3 or 4 channels, unrolled; a target whose sources are
// contiguous (all but a few at the borders) runs without index look-ups.
template <int C>
void apply_fixed(const AxisWeights& w, const double* in, long t0, long t1, double* out) {
  for (long n = t0; n < t1; ++n) {
    double acc[4][C] = {};
    const long b = w.begin(n), e = w.end(n);
    const double* wt = w.weight.data() + b;
    if (e > b && w.index[e - 1] - w.index[b] == e - 1 - b) {
      const double* s = in + std::size_t(w.index[b]) * C;
      for (long k = 0; k < e - b; ++k)
        for (int c = 0; c < C; ++c) acc[k & 3][c] += wt[k] * s[k * C + c];
    } else {
      for (long k = 0; k < e - b; ++k) {
        const double* s = in + std::size_t(w.index[b + k]) * C;
        for (int c = 0; c < C; ++c) acc[k & 3][c] += wt[k] * s[c];
      }
    }
    for (int c = 0; c < C; ++c)
      out[std::size_t(n) * C + c] = (acc[0][c] + acc[1][c]) + (acc[2][c] + acc[3][c]);
  }
}

#if defined(__x86_64__)
// apply_fixed for three or four channels with AVX: the channels of a sample
// in the lanes of one vector (with three, the fourth lane reads the next
// sample's first channel and is ignored; the row's last sample is loaded
// alone). Each lane adds the same products in the same order as the scalar
// loop (no fused multiply-add), so the sums are the same bits.
__attribute__((target("avx"))) inline __m256d tap(__m256d acc, double weight, __m256d v) {
  return _mm256_add_pd(acc, _mm256_mul_pd(_mm256_set1_pd(weight), v));
}

template <int C>
__attribute__((target("avx"))) void apply_avx(const AxisWeights& w, const double* in, long t0,
                                              long t1, double* out) {
  static_assert(C == 3 || C == 4);
  const long last = w.sources - 1;
  for (long n = t0; n < t1; ++n) {
    __m256d acc[4] = {_mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd(),
                      _mm256_setzero_pd()};
    const long b = w.begin(n), K = w.end(n) - b;
    const double* wt = w.weight.data() + b;
    const long* idx = w.index.data() + b;
    if (K > 0 && idx[K - 1] - idx[0] == K - 1 && (C == 4 || idx[K - 1] < last)) {
      const double* s = in + std::size_t(idx[0]) * C;
      long k = 0;
      for (; k + 4 <= K; k += 4) {
        acc[0] = tap(acc[0], wt[k], _mm256_loadu_pd(s + k * C));
        acc[1] = tap(acc[1], wt[k + 1], _mm256_loadu_pd(s + (k + 1) * C));
        acc[2] = tap(acc[2], wt[k + 2], _mm256_loadu_pd(s + (k + 2) * C));
        acc[3] = tap(acc[3], wt[k + 3], _mm256_loadu_pd(s + (k + 3) * C));
      }
      for (; k < K; ++k) acc[k & 3] = tap(acc[k & 3], wt[k], _mm256_loadu_pd(s + k * C));
    } else {
      for (long k = 0; k < K; ++k) {
        const double* s = in + std::size_t(idx[k]) * C;
        const __m256d v = (C == 4 || idx[k] < last) ? _mm256_loadu_pd(s) : _mm256_setr_pd(s[0], s[1], s[2], 0.0);
        acc[k & 3] = tap(acc[k & 3], wt[k], v);
      }
    }
    alignas(32) double a[4];
    _mm256_store_pd(a, _mm256_add_pd(_mm256_add_pd(acc[0], acc[1]), _mm256_add_pd(acc[2], acc[3])));
    for (int c = 0; c < C; ++c) out[std::size_t(n) * C + c] = a[c];
  }
}

bool has_avx() {
  static const bool avx = __builtin_cpu_supports("avx");
  return avx;
}
#endif

// sums[i][k] += w[r][i] * x[r][k] for N sums i and R rows r at once, the
// rows in order: each sum element is loaded once, gets its R terms (a
// product, then a sum, each) and is stored once; each x[r][k] is read once.
// AssignFirst: row 0's term is the sums' first, 0.0 + w[0][i] * x[0][k],
// the bits of adding it to zeros, without reading the sums. Elementwise, so
// the same bits at any vector width, which the clones choose by the
// processor.
template <int N, int R, bool AssignFirst, typename T>
__attribute__((target_clones("avx512f", "avx2", "default"))) void add_scaled(
    double* const* sums, const double* const* w, const T* const* xs, long n) {
  static_assert(N >= 1 && N <= 4 && R >= 1 && R <= 4);
  double* __restrict s0 = sums[0];
  double* __restrict s1 = N > 1 ? sums[1] : nullptr;
  double* __restrict s2 = N > 2 ? sums[2] : nullptr;
  double* __restrict s3 = N > 3 ? sums[3] : nullptr;
  const T* __restrict x0 = xs[0];
  const T* __restrict x1 = R > 1 ? xs[1] : nullptr;
  const T* __restrict x2 = R > 2 ? xs[2] : nullptr;
  const T* __restrict x3 = R > 3 ? xs[3] : nullptr;
  double a[R][N];
  for (int r = 0; r < R; ++r)
    for (int i = 0; i < N; ++i) a[r][i] = w[r][i];
  for (long k = 0; k < n; ++k) {
    double v[R];
    v[0] = x0[k];
    if constexpr (R > 1) v[1] = x1[k];
    if constexpr (R > 2) v[2] = x2[k];
    if constexpr (R > 3) v[3] = x3[k];
    auto one = [&](double* __restrict s, int i) {
      double t = AssignFirst ? 0.0 : s[k];
      for (int r = 0; r < R; ++r) t = t + a[r][i] * v[r];
      s[k] = t;
    };
    one(s0, 0);
    if constexpr (N > 1) one(s1, 1);
    if constexpr (N > 2) one(s2, 2);
    if constexpr (N > 3) one(s3, 3);
  }
}

// Any number of sums, four at a time, for R rows.
template <int R, bool AssignFirst, typename T>
void scaled(double* const* sums, const double* const* w, int count, long offset,
            const T* const* x, long n) {
  for (int t = 0; t < count; t += 4) {
    double* s[4];
    const double* wt[R];
    const int m = std::min(4, count - t);
    for (int i = 0; i < m; ++i) s[i] = sums[t + i] + offset;
    for (int r = 0; r < R; ++r) wt[r] = w[r] + t;
    switch (m) {
      case 1: add_scaled<1, R, AssignFirst>(s, wt, x, n); break;
      case 2: add_scaled<2, R, AssignFirst>(s, wt, x, n); break;
      case 3: add_scaled<3, R, AssignFirst>(s, wt, x, n); break;
      default: add_scaled<4, R, AssignFirst>(s, wt, x, n); break;
    }
  }
}

// Up to four rows.
template <bool AssignFirst, typename T>
void scaled(double* const* sums, const double* const* w, int count, long offset,
            const T* const* x, int rows, long n) {
  switch (rows) {
    case 1: return scaled<1, AssignFirst>(sums, w, count, offset, x, n);
    case 2: return scaled<2, AssignFirst>(sums, w, count, offset, x, n);
    case 3: return scaled<3, AssignFirst>(sums, w, count, offset, x, n);
    default: return scaled<4, AssignFirst>(sums, w, count, offset, x, n);
  }
}

}  // namespace

void apply_weights(const AxisWeights& w, const double* in, int channels, long t0, long t1,
                   double* out) {
  const int C = channels;
#if defined(__x86_64__)
  if (C == 3 && has_avx()) return apply_avx<3>(w, in, t0, t1, out);
  if (C == 4 && has_avx()) return apply_avx<4>(w, in, t0, t1, out);
#endif
  switch (C) {
    case 1: return apply_fixed<1>(w, in, t0, t1, out);
    case 3: return apply_fixed<3>(w, in, t0, t1, out);
    case 4: return apply_fixed<4>(w, in, t0, t1, out);
    default: {
      std::vector<double> acc(4 * std::size_t(C));
      for (long n = t0; n < t1; ++n) {
        std::fill(acc.begin(), acc.end(), 0.0);
        for (long e = w.begin(n); e < w.end(n); ++e) {
          const double* s = in + std::size_t(w.index[e]) * C;
          double* a = acc.data() + ((e - w.begin(n)) & 3) * C;
          for (int c = 0; c < C; ++c) a[c] += w.weight[e] * s[c];
        }
        for (int c = 0; c < C; ++c)
          out[std::size_t(n) * C + c] = (acc[c] + acc[C + c]) + (acc[2 * C + c] + acc[3 * C + c]);
      }
    }
  }
}

template <typename T>
void add_scaled_rows(double* const* sums, const double* w, int count, long offset, const T* x,
                     long n, bool assign) {
  const double* ws[1] = {w};
  const T* xs[1] = {x};
  if (assign)
    scaled<1, true>(sums, ws, count, offset, xs, n);
  else
    scaled<1, false>(sums, ws, count, offset, xs, n);
}
template void add_scaled_rows(double* const*, const double*, int, long, const float*, long, bool);
template void add_scaled_rows(double* const*, const double*, int, long, const double*, long, bool);

template <typename T>
void add_scaled_row_group(double* const* sums, const double* const* w, int count, int starts,
                          long offset, const T* const* x, int rows, long n) {
  const int adds = count - starts;
  for (int r = 0; r < rows; r += 4) {
    const int g = std::min(4, rows - r);
    scaled<false>(sums, w + r, adds, offset, x + r, g, n);
    if (starts == 0) continue;
    const double* ws[4];
    for (int i = 0; i < g; ++i) ws[i] = w[r + i] + adds;
    if (r == 0)
      scaled<true>(sums + adds, ws, starts, offset, x, g, n);
    else
      scaled<false>(sums + adds, ws, starts, offset, x + r, g, n);
  }
}
template void add_scaled_row_group(double* const*, const double* const*, int, int, long,
                                   const float* const*, int, long);
template void add_scaled_row_group(double* const*, const double* const*, int, int, long,
                                   const double* const*, int, long);

AxisWeights make_axis_weights(long targets, long sources, Boundary boundary,
                              const std::function<std::pair<long, long>(long)>& range,
                              const std::function<double(long, long)>& weight) {
  AxisWeights w;
  w.targets = targets;
  w.sources = sources;
  w.offset.reserve(targets + 1);
  w.offset.push_back(0);
  std::map<long, double> merged;
  for (long t = 0; t < targets; ++t) {
    merged.clear();
    const auto [first, last] = range(t);
    for (long k = first; k <= last; ++k) {
      const double v = weight(t, k);
      if (v != 0.0) merged[extend_index(k, sources, boundary)] += v;
    }
    for (const auto& [i, v] : merged) {
      w.index.push_back(i);
      w.weight.push_back(v);
    }
    w.offset.push_back(static_cast<long>(w.index.size()));
  }
  return w;
}

}  // namespace sis
