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

// out[n] = sum_e w[e] in[index[e]] per channel, for every target n. The sum
// over a target's taps k is four interleaved partial sums, p_j over k = j
// mod 4 in increasing k, combined as (p0 + p1) + (p2 + p3): the four chains
// run in parallel in the processor, and every path below (scalar, vector,
// float or double rows) keeps this order, so they give the same bits.
// Channel counts 1, 3 and 4 are unrolled; a target whose sources are
// contiguous (all but a few at the borders) runs without index look-ups.
template <int C, typename T>
void filter_row_fixed(const AxisWeights& w, const T* in, long targets, double* out) {
  for (long n = 0; n < targets; ++n) {
    double acc[4][C] = {};
    const long b = w.begin(n), e = w.end(n);
    const double* wt = w.weight.data() + b;
    if (e > b && w.index[e - 1] - w.index[b] == e - 1 - b) {
      const T* s = in + std::size_t(w.index[b]) * C;
      for (long k = 0; k < e - b; ++k)
        for (int c = 0; c < C; ++c) acc[k & 3][c] += wt[k] * s[k * C + c];
    } else {
      for (long k = 0; k < e - b; ++k) {
        const T* s = in + std::size_t(w.index[b + k]) * C;
        for (int c = 0; c < C; ++c) acc[k & 3][c] += wt[k] * s[c];
      }
    }
    for (int c = 0; c < C; ++c)
      out[std::size_t(n) * C + c] = (acc[0][c] + acc[1][c]) + (acc[2][c] + acc[3][c]);
  }
}

#if defined(__x86_64__)
// filter_row_fixed for float rows of three or four channels, with AVX: the
// channels of a sample in the lanes of one vector (with three, the fourth
// lane reads the next sample's first channel and is ignored; the row's last
// sample is loaded alone). Each lane adds the same products in the same
// order as the scalar loop (no fused multiply-add), so the sums are the same
// bits.
__attribute__((target("avx"))) inline __m256d tap(__m256d acc, double weight, __m128 v) {
  return _mm256_add_pd(acc, _mm256_mul_pd(_mm256_set1_pd(weight), _mm256_cvtps_pd(v)));
}

template <int C>
__attribute__((target("avx"))) void filter_row_avx(const AxisWeights& w, const float* in,
                                                   long targets, double* out) {
  static_assert(C == 3 || C == 4);
  const long last = w.sources - 1;
  for (long n = 0; n < targets; ++n) {
    __m256d acc[4] = {_mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd(),
                      _mm256_setzero_pd()};
    const long b = w.begin(n), K = w.end(n) - b;
    const double* wt = w.weight.data() + b;
    const long* idx = w.index.data() + b;
    if (K > 0 && idx[K - 1] - idx[0] == K - 1 && (C == 4 || idx[K - 1] < last)) {
      const float* s = in + std::size_t(idx[0]) * C;
      long k = 0;
      for (; k + 4 <= K; k += 4) {
        acc[0] = tap(acc[0], wt[k], _mm_loadu_ps(s + k * C));
        acc[1] = tap(acc[1], wt[k + 1], _mm_loadu_ps(s + (k + 1) * C));
        acc[2] = tap(acc[2], wt[k + 2], _mm_loadu_ps(s + (k + 2) * C));
        acc[3] = tap(acc[3], wt[k + 3], _mm_loadu_ps(s + (k + 3) * C));
      }
      for (; k < K; ++k) acc[k & 3] = tap(acc[k & 3], wt[k], _mm_loadu_ps(s + k * C));
    } else {
      for (long k = 0; k < K; ++k) {
        const float* s = in + std::size_t(idx[k]) * C;
        const __m128 v = (C == 4 || idx[k] < last) ? _mm_loadu_ps(s) : _mm_setr_ps(s[0], s[1], s[2], 0.0f);
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

template <typename T>
void filter_row(const AxisWeights& w, const T* in, int C, long targets, double* out) {
#if defined(__x86_64__)
  if constexpr (std::is_same_v<T, float>) {
    if (C == 3 && has_avx()) return filter_row_avx<3>(w, in, targets, out);
    if (C == 4 && has_avx()) return filter_row_avx<4>(w, in, targets, out);
  }
#endif
  switch (C) {
    case 1: return filter_row_fixed<1>(w, in, targets, out);
    case 3: return filter_row_fixed<3>(w, in, targets, out);
    case 4: return filter_row_fixed<4>(w, in, targets, out);
    default: {
      std::vector<double> acc(4 * std::size_t(C));
      for (long n = 0; n < targets; ++n) {
        std::fill(acc.begin(), acc.end(), 0.0);
        for (long e = w.begin(n); e < w.end(n); ++e) {
          const T* s = in + std::size_t(w.index[e]) * C;
          double* a = acc.data() + ((e - w.begin(n)) & 3) * C;
          for (int c = 0; c < C; ++c) a[c] += w.weight[e] * s[c];
        }
        for (int c = 0; c < C; ++c)
          out[std::size_t(n) * C + c] = (acc[c] + acc[C + c]) + (acc[2 * C + c] + acc[3 * C + c]);
      }
    }
  }
}

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
      acc_(plan.coefficients_x(), plan.coefficients_y(), plan.channels()),
      cursor_(plan.coefficients_y()) {
  for (long n = 0; n < plan.coefficients_y(); ++n) cursor_[n] = plan.weights_y().begin(n);
}

void Acquisition::add_rows(long y0, long y1, const float* rows) {
  const std::size_t row_size = std::size_t(plan_.input_width()) * plan_.channels();
  add<float>(y0, y1, [&](long y, float*) { return rows + (y - y0) * row_size; }, false);
}
void Acquisition::add_rows(long y0, long y1, const double* rows) {
  const std::size_t row_size = std::size_t(plan_.input_width()) * plan_.channels();
  add<double>(y0, y1, [&](long y, double*) { return rows + (y - y0) * row_size; }, false);
}
void Acquisition::add_rows(long y0, long y1, const RowSource& row) {
  add<float>(y0, y1, row, true);
}

// row(y, scratch) -> const T*: input row y; scratch has room for a row when
// `scratch_row` is set.
template <typename T, typename Row>
void Acquisition::add(long y0, long y1, const Row& row, bool scratch_row) {
  if (y0 != next_row_ || y1 < y0 || y1 > plan_.input_height()) {
    std::ostringstream m;
    m << "Acquisition::add_rows(): rows [" << y0 << ", " << y1 << ") out of order (next row "
      << next_row_ << " of " << plan_.input_height() << ")";
    throw std::logic_error(m.str());
  }
  const int C = plan_.channels();
  const long win = plan_.input_width(), ncx = plan_.coefficients_x();
  const AxisWeights& wx = plan_.weights_x();
  const AxisWeights& wy = plan_.weights_y();
  const std::size_t hrow = std::size_t(ncx) * C;
  strip_.resize(hrow * (y1 - y0));  // every entry is written by the horizontal pass

  // Horizontal pass: each input row filtered onto the coefficient columns.
  parallel_for(y1 - y0, threads_, [&](long r0, long r1) {
    std::vector<T> scratch(scratch_row ? std::size_t(win) * C : 0);
    for (long r = r0; r < r1; ++r)
      filter_row(wx, row(y0 + r, scratch.data()), C, ncx, strip_.data() + r * hrow);
  });

  // Vertical pass: each coefficient row adds the rows of this strip in its
  // support, in increasing row order. The few rows a strip touches are split
  // among the threads by columns, so every thread has work; each sum keeps
  // its order whatever the split.
  long first = -1, last = -1;  // coefficient rows this strip touches
  for (long n = 0; n < plan_.coefficients_y(); ++n)
    if (cursor_[n] < wy.end(n) && wy.index[cursor_[n]] < y1) {
      if (first < 0) first = n;
      last = n;
    }
  if (first >= 0) {
    std::vector<long> stop(last - first + 1);
    for (long n = first; n <= last; ++n) {
      long e = cursor_[n];
      while (e < wy.end(n) && wy.index[e] < y1) ++e;
      stop[n - first] = e;
    }
    parallel_for(long(hrow), threads_, [&](long k0, long k1) {
      for (long n = first; n <= last; ++n) {
        double* acc = acc_.row(n);
        for (long e = cursor_[n]; e < stop[n - first]; ++e) {
          const double w = wy.weight[e];
          const double* h = strip_.data() + std::size_t(wy.index[e] - y0) * hrow;
          for (long k = k0; k < k1; ++k) acc[k] += w * h[k];
        }
      }
    });
    for (long n = first; n <= last; ++n) cursor_[n] = stop[n - first];
  }
  next_row_ = y1;
}

Coefficients Acquisition::finish() {
  if (next_row_ != plan_.input_height()) {
    std::ostringstream m;
    m << "Acquisition::finish(): only " << next_row_ << " of " << plan_.input_height()
      << " rows were added";
    throw std::logic_error(m.str());
  }
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
