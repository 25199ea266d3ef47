#include "sis/range.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "sis/prefilter.h"
#include "sis/resample.h"

namespace sis {

namespace {
// OpenImageIO's constants ("received wisdom"): identity below x1.
constexpr double kX1 = 0.18, kA = -0.54576885700225830078, kB = 0.18351669609546661377,
                 kC = 284.3577880859375;

// For each of `count` pixels over `samples` samples: [begin, end) of the
// samples whose positions (i + 1/2) samples/count... fall inside it.
void pixel_ranges(long samples, long count, std::vector<long>& begin, std::vector<long>& end) {
  begin.resize(count);
  end.resize(count);
  const double step = double(count) / samples;  // sample spacing in pixels
  for (long p = 0; p < count; ++p) {
    // samples i with p <= (i + 1/2) step < p + 1
    long a = static_cast<long>(std::ceil(p / step - 0.5));
    long b = static_cast<long>(std::ceil((p + 1) / step - 0.5));
    a = std::clamp(a, 0L, samples);
    b = std::clamp(b, 0L, samples);
    if (b <= a) {  // no sample inside: the nearest to the centre
      const long i = std::clamp(static_cast<long>(std::floor((p + 0.5) / step)), 0L, samples - 1);
      a = i;
      b = i + 1;
    }
    begin[p] = a;
    end[p] = b;
  }
}
}  // namespace

double highlight_compress(double x) {
  const double ax = std::abs(x);
  if (ax <= kX1) return x;
  return std::copysign(kA + kB * std::log(kC * ax + 1.0), x);
}

double highlight_expand(double y) {
  const double ay = std::abs(y);
  if (ay <= kX1) return y;
  return std::copysign((std::exp((ay - kA) / kB) - 1.0) / kC, y);
}

Clamp parse_clamp(const std::string& s) {
  if (s == "none") return Clamp::None;
  if (s == "zero") return Clamp::Zero;
  if (s == "local") return Clamp::Local;
  throw std::invalid_argument("unknown clamp '" + s + "' (expected none, zero or local)");
}

std::string clamp_name(Clamp c) {
  return c == Clamp::None ? "none" : c == Clamp::Zero ? "zero" : "local";
}

LocalRange::LocalRange(long input_width, long input_height, int channels, long width, long height)
    : win_(input_width),
      channels_(channels),
      min_(width, height, channels),
      max_(width, height, channels) {
  pixel_ranges(input_width, width, x_begin_, x_end_);
  pixel_ranges(input_height, height, y_begin_, y_end_);
  std::fill(min_.data.begin(), min_.data.end(), std::numeric_limits<float>::infinity());
  std::fill(max_.data.begin(), max_.data.end(), -std::numeric_limits<float>::infinity());
}

namespace {
// Min/max over the samples [x_begin[n], x_end[n]) of one row into lo/hi.
template <int C>
void row_range_fixed(const float* row, const long* xb, const long* xe, long width, float* lo,
                     float* hi) {
  for (long n = 0; n < width; ++n) {
    float l[C], h[C];
    for (int c = 0; c < C; ++c) l[c] = INFINITY, h[c] = -INFINITY;
    for (long i = xb[n]; i < xe[n]; ++i)
      for (int c = 0; c < C; ++c) {
        const float v = row[std::size_t(i) * C + c];
        l[c] = v < l[c] ? v : l[c];
        h[c] = v > h[c] ? v : h[c];
      }
    for (int c = 0; c < C; ++c) lo[n * C + c] = l[c], hi[n * C + c] = h[c];
  }
}
}  // namespace

#if defined(__SSE2__)
// Three or four channels at once. With three, the fourth lane reads the next
// sample's first channel (ignored), except at the row's last sample.
template <int C>
void row_range_sse(const float* row, const long* xb, const long* xe, long width, long samples,
                   float* lo, float* hi) {
  static_assert(C == 3 || C == 4);
  for (long n = 0; n < width; ++n) {
    __m128 l = _mm_set1_ps(INFINITY), h = _mm_set1_ps(-INFINITY);
    const long end = (C == 4 || xe[n] < samples) ? xe[n] : xe[n] - 1;  // loads of 4 stay in the row
    for (long i = xb[n]; i < end; ++i) {
      const __m128 v = _mm_loadu_ps(row + std::size_t(i) * C);
      l = _mm_min_ps(v, l);  // v < l ? v : l, as row_range_fixed
      h = _mm_max_ps(v, h);
    }
    if (end < xe[n]) {
      const float* s = row + std::size_t(end) * C;
      const __m128 v = _mm_setr_ps(s[0], s[1], s[2], 0.0f);
      l = _mm_min_ps(v, l);
      h = _mm_max_ps(v, h);
    }
    alignas(16) float a[4], b[4];
    _mm_store_ps(a, l);
    _mm_store_ps(b, h);
    for (int c = 0; c < C; ++c) lo[n * C + c] = a[c], hi[n * C + c] = b[c];
  }
}
#endif

void LocalRange::reduce_row(const float* row, float* lo, float* hi) const {
  const int C = channels_;
#if defined(__SSE2__)
  if (C == 3) return row_range_sse<3>(row, x_begin_.data(), x_end_.data(), min_.width, win_, lo, hi);
  if (C == 4) return row_range_sse<4>(row, x_begin_.data(), x_end_.data(), min_.width, win_, lo, hi);
#endif
  switch (C) {
    case 1: return row_range_fixed<1>(row, x_begin_.data(), x_end_.data(), min_.width, lo, hi);
    case 3: return row_range_fixed<3>(row, x_begin_.data(), x_end_.data(), min_.width, lo, hi);
    case 4: return row_range_fixed<4>(row, x_begin_.data(), x_end_.data(), min_.width, lo, hi);
    default:
      for (long n = 0; n < min_.width; ++n)
        for (int c = 0; c < C; ++c) {
          float l = INFINITY, h = -INFINITY;
          for (long i = x_begin_[n]; i < x_end_[n]; ++i) {
            const float v = row[std::size_t(i) * C + c];
            l = std::min(l, v);
            h = std::max(h, v);
          }
          lo[n * C + c] = l;
          hi[n * C + c] = h;
        }
  }
}

void LocalRange::add_reduced(long y0, long y1, const float* lo, const float* hi, long k0, long k1) {
  const std::size_t entries = std::size_t(row_entries());
  for (long m = 0; m < min_.height; ++m) {
    const long a = std::max(y0, y_begin_[m]), b = std::min(y1, y_end_[m]);
    float* mn = min_.row(m);
    float* mx = max_.row(m);
    for (long j = a; j < b; ++j) {
      const float* l = lo + std::size_t(j - y0) * entries;
      const float* h = hi + std::size_t(j - y0) * entries;
      for (long k = k0; k < k1; ++k) {
        mn[k] = l[k] < mn[k] ? l[k] : mn[k];
        mx[k] = h[k] > mx[k] ? h[k] : mx[k];
      }
    }
  }
}

void LocalRange::add_rows(long y0, long y1, const float* rows) {
  std::vector<float> lo(row_entries()), hi(row_entries());
  for (long j = y0; j < y1; ++j) {
    reduce_row(rows + std::size_t(j - y0) * win_ * channels_, lo.data(), hi.data());
    add_reduced(j, j + 1, lo.data(), hi.data(), 0, row_entries());
  }
}

RangeReport report_range(const Image& image, const LocalRange* local) {
  RangeReport r;
  r.min = std::numeric_limits<double>::infinity();
  r.max = -r.min;
  r.samples = long(image.data.size());
  for (std::size_t q = 0; q < image.data.size(); ++q) {
    const float v = image.data[q];
    r.min = std::min<double>(r.min, v);
    r.max = std::max<double>(r.max, v);
    if (v < 0) ++r.negative;
    if (local) {
      // float rounding of the projection chain is about 1e-6 relative:
      // departures below 1e-5 of the local scale do not count
      const float lo = local->min().data[q], hi = local->max().data[q];
      const float tol = 1e-5f * std::max({1.0f, std::abs(lo), std::abs(hi)});
      if (v < lo - tol || v > hi + tol) ++r.out_of_range;
    }
  }
  return r;
}

StepResponse step_response(int degree, const Display& display) {
  const long n = 96, edge = n / 2;  // far from the border: its effect is below 1e-12
  Coefficients k;
  k.generator = Kernel::bspline(degree);
  k.boundary = Boundary::Mirror;
  k.image_width = double(n);
  k.image_height = 1.0;
  k.c = Grid<double>(n, 1, 1);
  // r[m] = integral of H(x - edge) b_d(x - m - 1/2) = 1 - I_d(edge - m - 1/2)
  for (long m = 0; m < n; ++m) k.c.at(m, 0, 0) = 1.0 - bspline_cumulative(degree, edge - m - 0.5);
  prefilter(k);
  const Image p = resample(k, display, n, 1);
  StepResponse s;
  for (long m = n / 4; m < 3 * n / 4; ++m) {
    s.overshoot = std::max(s.overshoot, double(p.at(m, 0, 0)) - 1.0);
    s.undershoot = std::max(s.undershoot, -double(p.at(m, 0, 0)));
  }
  return s;
}

void apply_clamp(Image& image, Clamp clamp, const LocalRange* local) {
  if (clamp == Clamp::None) return;
  if (clamp == Clamp::Local &&
      (!local || local->min().width != image.width || local->min().height != image.height ||
       local->min().channels != image.channels))
    throw std::invalid_argument("apply_clamp(): the local clamp needs the input range of each output pixel");
  for (std::size_t q = 0; q < image.data.size(); ++q) {
    float& v = image.data[q];
    v = clamp == Clamp::Zero ? std::max(v, 0.0f)
                             : std::clamp(v, local->min().data[q], local->max().data[q]);
  }
}

}  // namespace sis
