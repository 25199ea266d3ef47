#include "sis/range.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "sis/coefficients.h"
#include "sis/parallel.h"
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
    if (b <= a) {  // no sample inside (upsampling): the two either side of the centre
      const long i = static_cast<long>(std::floor((p + 0.5) / step - 0.5));
      a = std::clamp(i, 0L, samples - 1);
      b = std::clamp(i + 1, 0L, samples - 1) + 1;
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

LocalRange::LocalRange(long input_width, long input_height, int channels, long width, long height,
                       long band_rows)
    : win_(input_width),
      hin_(input_height),
      width_(width),
      height_(height),
      channels_(channels),
      bands_(input_height, band_rows) {
  pixel_ranges(input_width, width, x_begin_, x_end_);
  pixel_ranges(input_height, height, y_begin_, y_end_);
  std::vector<std::vector<long>> row_bands(height);
  for (long o = 0; o < height; ++o)
    for (long b = bands_.of(y_begin_[o]); b <= bands_.of(y_end_[o] - 1); ++b) row_bands[o].push_back(b);
  slots_ = BandSlots<float>(row_bands, bands_.count(), 2 * std::size_t(width) * channels);
  ended_.assign(bands_.count(), 0);
  // unset: the bands write every pixel of an output row, so no serial fill
  // first touches these pages
  min_ = Image(width, height, channels, kUnset);
  max_ = Image(width, height, channels, kUnset);
}

LocalRange::~LocalRange() = default;

namespace {
// out[k] = min(out[k], in[k]) (Min = false: max), elementwise: v < o ? v : o,
// which a vector min computes too, so every clone gives the same values.
template <bool Min>
__attribute__((target_clones("avx512f", "avx2", "default"))) void fold_into(
    float* __restrict out, const float* __restrict in, long n) {
  for (long k = 0; k < n; ++k)
    out[k] = Min ? (in[k] < out[k] ? in[k] : out[k]) : (in[k] > out[k] ? in[k] : out[k]);
}

// Min (Max = false: max) over the samples [xb[n], xe[n]) of one row into out.
template <bool Min, int C>
void across_fixed(const float* row, const long* xb, const long* xe, long width, float* out) {
  for (long n = 0; n < width; ++n) {
    float a[C];
    for (int c = 0; c < C; ++c) a[c] = Min ? INFINITY : -INFINITY;
    for (long i = xb[n]; i < xe[n]; ++i)
      for (int c = 0; c < C; ++c) {
        const float v = row[std::size_t(i) * C + c];
        a[c] = Min ? (v < a[c] ? v : a[c]) : (v > a[c] ? v : a[c]);
      }
    for (int c = 0; c < C; ++c) out[n * C + c] = a[c];
  }
}

#if defined(__SSE2__)
// Three or four channels at once. With three, the fourth lane reads the next
// sample's first channel (ignored), except at the row's last sample.
template <bool Min, int C>
void across_sse(const float* row, const long* xb, const long* xe, long width, long samples,
                float* out) {
  static_assert(C == 3 || C == 4);
  auto take = [](__m128 v, __m128 a) { return Min ? _mm_min_ps(v, a) : _mm_max_ps(v, a); };  // v < a ? v : a
  // Four pixels of as many samples at once, each in its own register (the
  // same operations in the same order per pixel): four dependency chains in
  // flight instead of one.
  auto four = [&](long n) {
    const long count = xe[n] - xb[n];
    if (n + 4 > width) return false;
    for (long j = n; j < n + 4; ++j)  // as many samples; with three channels, loads of 4 in the row
      if (xe[j] - xb[j] != count || (C == 3 && xe[j] >= samples)) return false;
    __m128 a0 = _mm_set1_ps(Min ? INFINITY : -INFINITY), a1 = a0, a2 = a0, a3 = a0;
    const float* p0 = row + std::size_t(xb[n]) * C;
    const float* p1 = row + std::size_t(xb[n + 1]) * C;
    const float* p2 = row + std::size_t(xb[n + 2]) * C;
    const float* p3 = row + std::size_t(xb[n + 3]) * C;
    for (long i = 0; i < count * C; i += C) {
      a0 = take(_mm_loadu_ps(p0 + i), a0);
      a1 = take(_mm_loadu_ps(p1 + i), a1);
      a2 = take(_mm_loadu_ps(p2 + i), a2);
      a3 = take(_mm_loadu_ps(p3 + i), a3);
    }
    alignas(16) float r[4][4];
    _mm_store_ps(r[0], a0);
    _mm_store_ps(r[1], a1);
    _mm_store_ps(r[2], a2);
    _mm_store_ps(r[3], a3);
    for (int j = 0; j < 4; ++j)
      for (int c = 0; c < C; ++c) out[(n + j) * C + c] = r[j][c];
    return true;
  };
  for (long n = 0; n < width;) {
    if (four(n)) {
      n += 4;
      continue;
    }
    __m128 a = _mm_set1_ps(Min ? INFINITY : -INFINITY);
    const long last = (C == 4 || xe[n] < samples) ? xe[n] : xe[n] - 1;  // loads of 4 stay in the row
    for (long i = xb[n]; i < last; ++i) a = take(_mm_loadu_ps(row + std::size_t(i) * C), a);
    if (last < xe[n]) {
      const float* s = row + std::size_t(last) * C;
      a = take(_mm_setr_ps(s[0], s[1], s[2], 0.0f), a);
    }
    alignas(16) float r[4];
    _mm_store_ps(r, a);
    for (int c = 0; c < C; ++c) out[n * C + c] = r[c];
    ++n;
  }
}
#endif

template <bool Min>
void across(const float* row, const long* xb, const long* xe, long width, long samples, int C,
            float* out) {
#if defined(__SSE2__)
  if (C == 3) return across_sse<Min, 3>(row, xb, xe, width, samples, out);
  if (C == 4) return across_sse<Min, 4>(row, xb, xe, width, samples, out);
#endif
  switch (C) {
    case 1: return across_fixed<Min, 1>(row, xb, xe, width, out);
    case 3: return across_fixed<Min, 3>(row, xb, xe, width, out);
    case 4: return across_fixed<Min, 4>(row, xb, xe, width, out);
    default:
      for (long n = 0; n < width; ++n)
        for (int c = 0; c < C; ++c) {
          float a = Min ? INFINITY : -INFINITY;
          for (long i = xb[n]; i < xe[n]; ++i) {
            const float v = row[std::size_t(i) * C + c];
            a = Min ? (v < a ? v : a) : (v > a ? v : a);
          }
          out[n * C + c] = a;
        }
  }
}
}  // namespace

LocalRange::Band::Band(LocalRange& whole) : whole_(whole) {}
LocalRange::Band::~Band() = default;

void LocalRange::Band::begin(long band) {
  LocalRange& w = whole_;
  if (band_ >= 0 || band < 0 || band >= w.bands_.count())
    throw std::logic_error("LocalRange::Band::begin(" + std::to_string(band) + "): " +
                           (band_ >= 0 ? "band " + std::to_string(band_) + " not ended" : "no such band"));
  band_ = band;
  y0_ = next_row_ = w.bands_.begin(band);
  y1_ = w.bands_.end(band);
  // the first output row that takes input rows from here on (they are in
  // order of their input rows)
  next_open_ = std::upper_bound(w.y_end_.begin(), w.y_end_.end(), y0_) - w.y_end_.begin();
}

void LocalRange::Band::open(long y0, long y1) {
  LocalRange& w = whole_;
  if (band_ < 0 || y0 != next_row_ || y1 < y0 || y1 > y1_)
    throw std::logic_error("LocalRange: rows [" + std::to_string(y0) + ", " + std::to_string(y1) +
                           ") opened out of order or outside the band");
  const std::size_t values = std::size_t(w.win_) * w.channels_;
  auto columns = [&] {
    if (spare_.empty()) return std::vector<float>(values);
    std::vector<float> v = std::move(spare_.back());
    spare_.pop_back();
    return v;
  };
  open_y0_ = y0;
  strip_targets_.assign(y1 - y0, {});
  for (; next_open_ < w.height_ && w.y_begin_[next_open_] < y1; ++next_open_)
    open_.push_back({next_open_, columns(), columns()});
  for (Open& o : open_) {
    const long first = std::max(y0_, w.y_begin_[o.row]);
    for (long y = std::max(y0, first); y < std::min(y1, w.y_end_[o.row]); ++y)
      strip_targets_[y - y0].push_back({o.lo.data(), o.hi.data(), y == first});
  }
  next_row_ = y1;
}

void LocalRange::Band::fold(long y, long k0, long k1, const float* values) {
  for (const Target& t : strip_targets_[y - open_y0_]) {
    if (t.first) {
      std::copy(values, values + (k1 - k0), t.lo + k0);
      std::copy(values, values + (k1 - k0), t.hi + k0);
    } else {
      fold_into<true>(t.lo + k0, values, k1 - k0);
      fold_into<false>(t.hi + k0, values, k1 - k0);
    }
  }
}

void LocalRange::Band::close(long y1) {
  LocalRange& w = whole_;
  const long W = w.width_;
  auto done = [&](const Open& o) { return std::min(w.y_end_[o.row], y1_) <= y1; };
  for (Open& o : open_)
    if (done(o)) {
      float* slot = w.slots_.slot(o.row, band_);
      float* lo = slot ? slot : w.min_.row(o.row);
      float* hi = slot ? slot + w.min_.row_size() : w.max_.row(o.row);
      across<true>(o.lo.data(), w.x_begin_.data(), w.x_end_.data(), W, w.win_, w.channels_, lo);
      across<false>(o.hi.data(), w.x_begin_.data(), w.x_end_.data(), W, w.win_, w.channels_, hi);
      spare_.push_back(std::move(o.lo));
      spare_.push_back(std::move(o.hi));
    }
  open_.erase(std::remove_if(open_.begin(), open_.end(), done), open_.end());
  strip_targets_.clear();
}

void LocalRange::Band::end() {
  LocalRange& w = whole_;
  if (band_ < 0 || next_row_ != y1_ || !open_.empty())
    throw std::logic_error("LocalRange::Band::end(): band " + std::to_string(band_) +
                           " not begun or not complete");
  const long b = band_;
  band_ = -1;
  w.ended_[b] = 1;
  w.slots_.ended(b, [&](long o, const float* slot) { w.merge_slot(o, slot); });
}

void LocalRange::merge_slot(long o, const float* slot) {
  const std::size_t n = min_.row_size();
  float* lo = min_.row(o);
  float* hi = max_.row(o);
  for (std::size_t q = 0; q < n; ++q) {
    lo[q] = slot[q] < lo[q] ? slot[q] : lo[q];
    hi[q] = slot[n + q] > hi[q] ? slot[n + q] : hi[q];
  }
}

BandPartial<float> LocalRange::partial(std::vector<long>* taken) const {
  taken->clear();
  for (long b = 0; b < long(ended_.size()); ++b)
    if (ended_[b]) taken->push_back(b);
  const std::size_t n = min_.row_size();
  return slots_.partial(*taken, [&](long o, float* out) {
    std::copy(min_.row(o), min_.row(o) + n, out);
    std::copy(max_.row(o), max_.row(o) + n, out + n);
  });
}

void LocalRange::absorb(const BandPartial<float>& p, const std::vector<long>& taken) {
  for (long b : taken)
    if (b < 0 || b >= long(ended_.size()) || ended_[b])
      throw std::invalid_argument("band " + std::to_string(b) + " out of range or already taken");
  const std::size_t n = min_.row_size();
  slots_.absorb(
      p, taken,
      [&](long o, const float* v) {
        std::copy(v, v + n, min_.row(o));
        std::copy(v + n, v + 2 * n, max_.row(o));
      },
      [&](long o, const float* slot) { merge_slot(o, slot); });
  for (long b : taken) ended_[b] = 1;
}

void LocalRange::open(long y0, long y1) {
  if (!in_order_) in_order_ = std::make_unique<Band>(*this);
  if (in_order_->band_ < 0 && y0 < hin_) in_order_->begin(bands_.of(y0));
  in_order_->open(y0, y1);
}

void LocalRange::fold(long y, long k0, long k1, const float* values) {
  in_order_->fold(y, k0, k1, values);
}

void LocalRange::close(long y1) {
  in_order_->close(y1);
  if (y1 == in_order_->y1_) in_order_->end();
}

void LocalRange::add_rows(long y0, long y1, const float* rows) {
  const long values = win_ * channels_;
  for (long y = y0; y < y1;) {
    const long e = std::min(y1, bands_.end(bands_.of(y)));
    open(y, e);
    for (long r = y; r < e; ++r) fold(r, 0, values, rows + std::size_t(r - y0) * values);
    close(e);
    y = e;
  }
}

namespace {
// The report's sums over values [0, n): kLanes independent lanes updated
// elementwise (so they run on whole vectors), combined at the end. Min and
// max are exact in any order but for the sign of a zero, which the report
// drops; v < a ? v : a skips NaN as std::min does.
constexpr int kLanes = 16;
struct Lanes {
  float min[kLanes], max[kLanes];
  std::int32_t negative[kLanes] = {}, out[kLanes] = {};
  Lanes() {
    std::fill(min, min + kLanes, std::numeric_limits<float>::infinity());
    std::fill(max, max + kLanes, -std::numeric_limits<float>::infinity());
  }
};

// Sample x, with the local range [a, b] under it (Local), into lane j.
template <bool Local>
inline void take(Lanes& l, int j, float x, float a, float b) {
  l.min[j] = x < l.min[j] ? x : l.min[j];
  l.max[j] = x > l.max[j] ? x : l.max[j];
  l.negative[j] += x < 0.0f;
  if constexpr (Local) {
    // float rounding of the projection chain is about 1e-6 relative:
    // departures below 1e-5 of the local scale do not count
    const float scale = std::max(1.0f, std::max(a < 0 ? -a : a, b < 0 ? -b : b));
    const float tol = 1e-5f * scale;
    l.out[j] += (x < a - tol) | (x > b + tol);
  }
}

// Values [0, n) into the lanes: whole blocks lane by lane, the tail in lane 0.
template <bool Local>
__attribute__((target_clones("avx512f", "avx2", "default"))) void report_lanes(
    const float* v, const float* lo, const float* hi, long n, Lanes& l) {
  long k = 0;
  for (; k + kLanes <= n; k += kLanes)
    for (int j = 0; j < kLanes; ++j)
      take<Local>(l, j, v[k + j], Local ? lo[k + j] : 0.0f, Local ? hi[k + j] : 0.0f);
  for (; k < n; ++k) take<Local>(l, 0, v[k], Local ? lo[k] : 0.0f, Local ? hi[k] : 0.0f);
}
}  // namespace

RangeReport report_range(const Image& image, const LocalRange* local, int threads) {
  const long n = long(image.data.size());
  // parts of whole lane blocks, under 2^31 values (the lanes' counters)
  const long blocks = n / kLanes;
  const long parts = std::max({1L, std::min<long>(threads, blocks / 4096), blocks * kLanes >> 30});
  std::vector<RangeReport> part(parts);
  const float* v = image.data.data();
  const float* lo = local ? local->min().data.data() : nullptr;
  const float* hi = local ? local->max().data.data() : nullptr;
  parallel_for(parts, threads, [&](long p0, long p1) {
    for (long p = p0; p < p1; ++p) {
      const long q0 = blocks * p / parts * kLanes;
      const long q1 = p + 1 == parts ? n : blocks * (p + 1) / parts * kLanes;
      Lanes l;
      if (local)
        report_lanes<true>(v + q0, lo + q0, hi + q0, q1 - q0, l);
      else
        report_lanes<false>(v + q0, nullptr, nullptr, q1 - q0, l);
      RangeReport& r = part[p];
      r.min = std::numeric_limits<double>::infinity();
      r.max = -r.min;
      for (int j = 0; j < kLanes; ++j) {
        r.min = std::min<double>(r.min, l.min[j]);
        r.max = std::max<double>(r.max, l.max[j]);
        r.negative += l.negative[j];
        r.out_of_range += l.out[j];
      }
    }
  });
  RangeReport r = part[0];
  for (long p = 1; p < parts; ++p) {
    r.min = std::min(r.min, part[p].min);
    r.max = std::max(r.max, part[p].max);
    r.negative += part[p].negative;
    r.out_of_range += part[p].out_of_range;
  }
  // a zero extreme as +0 whatever the lanes and parts met first (-0 == +0)
  if (r.min == 0) r.min = 0.0;
  if (r.max == 0) r.max = 0.0;
  r.samples = n;
  return r;
}

StepResponse step_response(int degree, const Display& display) {
  const long n = 96, edge = n / 2;  // far from the border: its effect is below 1e-12
  Coefficients k;
  k.space = CartesianSpace{Kernel::bspline(degree)};
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
