#include "sis/acquisition.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace sis {

namespace {

// Weights from the samples (i + 1/2) * step, i in [0, samples), to the
// coefficients n along one axis of a separable lattice.
AxisWeights acquisition_axis(int axis, long coefficients, long samples, double extent,
                             const Lattice& lattice, const Kernel& kernel, Boundary boundary,
                             Method method) {
  const double step = extent / samples;  // sample spacing, output pixels
  const double h = lattice.axis_step(axis);
  const double support = kernel.radius() * h;
  auto range = [&](long n) {
    const double p = lattice.axis_position(axis, n);
    return std::pair<long, long>(static_cast<long>(std::ceil((p - support) / step - 0.5)),
                                 static_cast<long>(std::floor((p + support) / step - 0.5)));
  };
  // Quadrature weight step / h makes r[n] an inner product in lattice units.
  const double scale = (method == Method::MinError) ? step / h : 1.0;
  auto weight = [&](long n, long i) {
    const double p = lattice.axis_position(axis, n);
    return scale * kernel.eval(((i + 0.5) * step - p) / h);
  };
  AxisWeights w = make_axis_weights(coefficients, samples, boundary, range, weight);
  if (method == Method::Conventional) {
    for (long n = 0; n < coefficients; ++n) {
      const double s = w.sum(n);
      if (!(s > 0)) {
        std::ostringstream m;
        m << "conventional acquisition(): no input sample under the " << kernel.name()
          << " filter of pixel " << n << " along " << (axis ? "y" : "x") << " (" << samples
          << " samples for " << coefficients << " pixels)";
        throw std::invalid_argument(m.str());
      }
      for (long e = w.begin(n); e < w.end(n); ++e) w.weight[e] /= s;
    }
  }
  return w;
}

// out[n] = sum_e w[e] in[index[e]] per channel, for the targets [n0, n1).
// The sum over a target's taps k is four interleaved partial sums, p_j over
// k = j mod 4 in increasing k, combined as (p0 + p1) + (p2 + p3): the four
// chains run in parallel in the processor, and every path below (scalar or
// vector) keeps this order, so they give the same bits. Channel counts 1, 3
// and 4 are unrolled; a target whose sources are contiguous (all but a few
// at the borders) runs without index look-ups.
template <int C>
void filter_row_fixed(const AxisWeights& w, const double* in, long n0, long n1, double* out) {
  for (long n = n0; n < n1; ++n) {
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
// filter_row_fixed for three or four channels, with AVX: the channels of a
// sample in the lanes of one vector (with three, the fourth lane reads the
// next sample's first channel, or the row's padding, and is ignored). Each
// lane adds the same products in the same order as the scalar loop (no
// fused multiply-add), so the sums are the same bits.
__attribute__((target("avx"))) inline __m256d tap(__m256d acc, double weight, const double* s) {
  return _mm256_add_pd(acc, _mm256_mul_pd(_mm256_set1_pd(weight), _mm256_loadu_pd(s)));
}

template <int C>
__attribute__((target("avx"))) void filter_row_avx(const AxisWeights& w, const double* in,
                                                   long n0, long n1, double* out) {
  static_assert(C == 3 || C == 4);
  for (long n = n0; n < n1; ++n) {
    __m256d acc[4] = {_mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd(),
                      _mm256_setzero_pd()};
    const long b = w.begin(n), K = w.end(n) - b;
    const double* wt = w.weight.data() + b;
    const long* idx = w.index.data() + b;
    if (K > 0 && idx[K - 1] - idx[0] == K - 1) {
      const double* s = in + std::size_t(idx[0]) * C;
      long k = 0;
      for (; k + 4 <= K; k += 4) {
        acc[0] = tap(acc[0], wt[k], s + k * C);
        acc[1] = tap(acc[1], wt[k + 1], s + (k + 1) * C);
        acc[2] = tap(acc[2], wt[k + 2], s + (k + 2) * C);
        acc[3] = tap(acc[3], wt[k + 3], s + (k + 3) * C);
      }
      for (; k < K; ++k) acc[k & 3] = tap(acc[k & 3], wt[k], s + k * C);
    } else {
      for (long k = 0; k < K; ++k) acc[k & 3] = tap(acc[k & 3], wt[k], in + std::size_t(idx[k]) * C);
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

// A vertical sum's row holds this many doubles beyond its W_in * C values,
// zero, so that the vector path may read one sample's four lanes at the end.
constexpr long kRowPadding = 4;

// One input row (W_in * C values, plus kRowPadding readable) filtered onto
// the targets [n0, n1).
void filter_row(const AxisWeights& w, const double* in, int C, long n0, long n1, double* out) {
#if defined(__x86_64__)
  if (C == 3 && has_avx()) return filter_row_avx<3>(w, in, n0, n1, out);
  if (C == 4 && has_avx()) return filter_row_avx<4>(w, in, n0, n1, out);
#endif
  switch (C) {
    case 1: return filter_row_fixed<1>(w, in, n0, n1, out);
    case 3: return filter_row_fixed<3>(w, in, n0, n1, out);
    case 4: return filter_row_fixed<4>(w, in, n0, n1, out);
    default: {
      std::vector<double> acc(4 * std::size_t(C));
      for (long n = n0; n < n1; ++n) {
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

// sums[t][k] += w[t] * x[k] for N rows t at once, x read once: elementwise,
// a product then a sum, so the same bits at any vector width, which the
// clones choose by the processor.
template <int N, typename T>
__attribute__((target_clones("avx512f", "avx2", "default"))) void add_scaled(
    double* const* sums, const double* w, const T* __restrict x, long n) {
  static_assert(N >= 1 && N <= 4);
  double* __restrict s0 = sums[0];
  double* __restrict s1 = N > 1 ? sums[1] : nullptr;
  double* __restrict s2 = N > 2 ? sums[2] : nullptr;
  double* __restrict s3 = N > 3 ? sums[3] : nullptr;
  const double w0 = w[0], w1 = N > 1 ? w[1] : 0, w2 = N > 2 ? w[2] : 0, w3 = N > 3 ? w[3] : 0;
  for (long k = 0; k < n; ++k) {
    const double v = x[k];
    s0[k] += w0 * v;
    if constexpr (N > 1) s1[k] += w1 * v;
    if constexpr (N > 2) s2[k] += w2 * v;
    if constexpr (N > 3) s3[k] += w3 * v;
  }
}

// x[k] * w[t] added to sums[t] + offset for every t in [0, count).
template <typename T>
void add_to_sums(double* const* sums, const double* w, int count, long offset, const T* x, long n) {
  for (int t = 0; t < count; t += 4) {
    double* s[4];
    const int m = std::min(4, count - t);
    for (int i = 0; i < m; ++i) s[i] = sums[t + i] + offset;
    switch (m) {
      case 1: add_scaled<1>(s, w + t, x, n); break;
      case 2: add_scaled<2>(s, w + t, x, n); break;
      case 3: add_scaled<3>(s, w + t, x, n); break;
      default: add_scaled<4>(s, w + t, x, n); break;
    }
  }
}

// Values of a row handed to the vertical pass per call: the vertical sums of
// a few coefficient rows over one block stay in the first-level cache.
constexpr long kBlock = 512;

}  // namespace

AcquisitionPlan::AcquisitionPlan(long input_width, long input_height, int channels,
                                 double image_width, double image_height, const Lattice& lattice,
                                 const Kernel& generator, Boundary boundary, Method method)
    : channels_(channels),
      image_w_(image_width),
      image_h_(image_height),
      lattice_(lattice),
      generator_(generator),
      boundary_(boundary),
      method_(method) {
  if (input_width < 1 || input_height < 1 || channels < 1) {
    std::ostringstream m;
    m << "AcquisitionPlan(): empty input " << input_width << " x " << input_height << " x "
      << channels;
    throw std::invalid_argument(m.str());
  }
  if (method == Method::MinError && !generator.is_bspline())
    throw std::invalid_argument("AcquisitionPlan(): min-error needs a B-spline generator, not " +
                                generator.name());
  const auto extent = lattice.extent(image_width, image_height);
  wx_ = acquisition_axis(0, extent[0], input_width, image_width, lattice, generator, boundary,
                         method);
  wy_ = acquisition_axis(1, extent[1], input_height, image_height, lattice, generator, boundary,
                         method);
}

Acquisition::Acquisition(const AcquisitionPlan& plan, int threads)
    : plan_(plan),
      threads_(threads < 1 ? 1 : threads),
      cursor_(plan.coefficients_y()),
      sums_(plan.coefficients_y()) {
  for (long n = 0; n < plan.coefficients_y(); ++n) cursor_[n] = plan.weights_y().begin(n);
}

void Acquisition::add_rows(long y0, long y1, const float* rows) {
  const std::size_t row_size = std::size_t(plan_.input_width()) * plan_.channels();
  add<float>(y0, y1, [&](long y, long k0, long, float*) { return rows + (y - y0) * row_size + k0; });
}
void Acquisition::add_rows(long y0, long y1, const double* rows) {
  const std::size_t row_size = std::size_t(plan_.input_width()) * plan_.channels();
  add<double>(y0, y1, [&](long y, long k0, long, double*) { return rows + (y - y0) * row_size + k0; });
}
void Acquisition::add_rows(long y0, long y1, const PieceSource& piece) { add<float>(y0, y1, piece); }

// The horizontal pass of the complete rows, targets [n0, n1) of part `part`.
void Acquisition::filter_complete(long part, long parts) {
  const long ncx = plan_.coefficients_x();
  const long n0 = ncx * part / parts, n1 = ncx * (part + 1) / parts;
  for (long m : complete_)
    filter_row(plan_.weights_x(), sums_[m].data(), plan_.channels(), n0, n1, acc_.row(m));
}

void Acquisition::release_complete() {
  for (long m : complete_) spare_.push_back(std::move(sums_[m]));
  complete_.clear();
}

// piece(y, k0, k1, scratch) -> const T*: values [k0, k1) of input row y.
template <typename T, typename Piece>
void Acquisition::add(long y0, long y1, const Piece& piece) {
  if (y0 != next_row_ || y1 < y0 || y1 > plan_.input_height()) {
    std::ostringstream m;
    m << "Acquisition::add_rows(): rows [" << y0 << ", " << y1 << ") out of order (next row "
      << next_row_ << " of " << plan_.input_height() << ")";
    throw std::logic_error(m.str());
  }
  const long values = plan_.input_width() * plan_.channels();
  const AxisWeights& wy = plan_.weights_y();
  if (acc_.data.empty())  // here, not in the constructor: a caller may overlap this with reading
    acc_ = Grid<double>(plan_.coefficients_x(), plan_.coefficients_y(), plan_.channels());

  // The coefficient rows each input row adds to (their vertical sums and
  // weights); rows summed to the end here are filtered in the next call.
  std::vector<std::vector<double*>> row_sums(y1 - y0);
  std::vector<std::vector<double>> row_weights(y1 - y0);
  std::vector<long> completed;
  for (long n = 0; n < plan_.coefficients_y(); ++n) {
    long e = cursor_[n];
    if (e == wy.end(n) || wy.index[e] >= y1) continue;
    if (sums_[n].empty()) {
      if (spare_.empty()) {
        sums_[n].assign(values + kRowPadding, 0.0);
      } else {
        sums_[n] = std::move(spare_.back());
        spare_.pop_back();
        std::fill(sums_[n].begin(), sums_[n].end(), 0.0);
      }
    }
    for (; e < wy.end(n) && wy.index[e] < y1; ++e) {
      row_sums[wy.index[e] - y0].push_back(sums_[n].data());
      row_weights[wy.index[e] - y0].push_back(wy.weight[e]);
    }
    cursor_[n] = e;
    if (e == wy.end(n)) completed.push_back(n);
  }

  // Each part: its share of the targets of the rows completed before, then
  // its share of the columns of this strip's rows, block by block, row by
  // row in increasing order.
  const long parts = std::min<long>(threads_, std::max(1L, values / kBlock));
  parallel_for(parts, threads_, [&](long p0, long p1) {
    std::vector<T> scratch(kBlock);
    for (long part = p0; part < p1; ++part) {
      filter_complete(part, parts);
      const long k0 = values * part / parts, k1 = values * (part + 1) / parts;
      for (long b = k0; b < k1; b += kBlock) {
        const long len = std::min(k1, b + kBlock) - b;
        for (long r = 0; r < y1 - y0; ++r) {
          const T* x = piece(y0 + r, b, b + len, scratch.data());
          add_to_sums(row_sums[r].data(), row_weights[r].data(), int(row_sums[r].size()), b, x, len);
        }
      }
    }
  });
  release_complete();
  complete_ = std::move(completed);
  next_row_ = y1;
}

Coefficients Acquisition::finish() {
  if (next_row_ != plan_.input_height()) {
    std::ostringstream m;
    m << "Acquisition::finish(): only " << next_row_ << " of " << plan_.input_height()
      << " rows were added";
    throw std::logic_error(m.str());
  }
  parallel_for(threads_, threads_, [&](long p0, long p1) {
    for (long part = p0; part < p1; ++part) filter_complete(part, threads_);
  });
  release_complete();
  spare_.clear();
  Coefficients out;
  out.c = std::move(acc_);
  out.lattice = plan_.lattice();
  out.generator = plan_.generator();
  out.boundary = plan_.boundary();
  out.min_error = plan_.method() == Method::MinError;
  out.image_width = plan_.image_width();
  out.image_height = plan_.image_height();
  return out;
}

namespace {
template <typename T>
Coefficients acquire_grid(const Grid<T>& input, const AcquisitionPlan& plan, int threads) {
  if (input.width != plan.input_width() || input.height != plan.input_height() ||
      input.channels != plan.channels())
    throw std::invalid_argument("acquire(): image size does not match the plan");
  Acquisition a(plan, threads);
  const long strip = 64;
  for (long y = 0; y < input.height; y += strip) {
    const long y1 = std::min(input.height, y + strip);
    a.add_rows(y, y1, input.row(y));
  }
  return a.finish();
}
}  // namespace

Coefficients acquire(const Image& input, const AcquisitionPlan& plan, int threads) {
  return acquire_grid(input, plan, threads);
}
Coefficients acquire(const Grid<double>& input, const AcquisitionPlan& plan, int threads) {
  return acquire_grid(input, plan, threads);
}

}  // namespace sis
