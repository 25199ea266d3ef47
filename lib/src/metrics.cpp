#include "sis/metrics.h"

#include "sis/parallel.h"

#include <fftw3.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

#include "fftw_planner.h"
#include "sis/resample.h"
#include "sis/space.h"
#include "sis/weights.h"

namespace sis {

namespace {

struct FftwFree {
  void operator()(void* p) const { fftw_free(p); }
};

std::string size_of(const ImageView& a) {
  std::ostringstream s;
  s << a.width << " x " << a.height << " x " << a.channels;
  return s.str();
}

void check_not_empty(const ImageView& a, const char* fn) {
  if (a.width < 1 || a.height < 1 || a.channels < 1)
    throw std::invalid_argument(std::string(fn) + "(): image " + size_of(a) + " is empty");
}

void check_same_shape(const ImageView& a, const ImageView& b, const char* fn) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    throw std::invalid_argument(std::string(fn) + "(): images differ in size: " + size_of(a) +
                                " against " + size_of(b));
}

// Every value of `a` finite: a NaN or an infinity would make a measure
// meaningless (a NaN even scores as perfect, every comparison with it false).
void check_finite(const ImageView& a, const char* fn, const char* what) {
  const std::size_t n = std::size_t(a.width) * std::size_t(a.height) * std::size_t(a.channels);
  for (std::size_t q = 0; q < n; ++q)
    if (!std::isfinite(a.data[q])) {
      const std::size_t p = q / std::size_t(a.channels);
      std::ostringstream m;
      m << fn << "(): non-finite value (NaN or Inf) in the " << what << " at x "
        << p % std::size_t(a.width) << ", y " << p / std::size_t(a.width) << ", channel "
        << q % std::size_t(a.channels);
      throw std::invalid_argument(m.str());
    }
}

// A number argument that must be finite (K, a peak...).
void check_finite_number(double v, const char* fn, const char* what) {
  if (!std::isfinite(v)) {
    std::ostringstream m;
    m << fn << "(): " << what << " " << v << " is not finite";
    throw std::invalid_argument(m.str());
  }
}

// The most points per output pixel and axis the closed-form error samples
// (a million per pixel): beyond, the sample grid's sides overflow or the
// error takes years.
constexpr int kMaxSamplesPerPixel = 1024;

void check_samples_per_pixel(int n) {
  if (n < 1 || n > kMaxSamplesPerPixel)
    throw std::invalid_argument("l2_error(): samples_per_pixel " + std::to_string(n) +
                                ": expected 1 to " + std::to_string(kMaxSamplesPerPixel));
}

// Inclusive range [first, last] of the indices k in [0, n_in) whose sample
// position (k + 1/2) n_out / n_in lies in [lo, hi); last < first when none.
std::pair<long, long> samples_in(double lo, double hi, long n_in, long n_out) {
  auto pos = [&](long k) { return (k + 0.5) * double(n_out) / double(n_in); };
  const double q = double(n_in) / double(n_out);
  long first = static_cast<long>(std::ceil(lo * q - 0.5));
  long last = static_cast<long>(std::ceil(hi * q - 0.5)) - 1;
  // The estimates can be one off where a position meets a window edge.
  while (pos(first - 1) >= lo) --first;
  while (pos(first) < lo) ++first;
  while (pos(last + 1) < hi) ++last;
  while (pos(last) >= hi) --last;
  return {std::max(first, 0L), std::min(last, n_in - 1)};
}

// Per output index along one axis, the inclusive input range of the
// neighbourhood (the nearest sample when it holds none).
std::vector<std::pair<long, long>> axis_windows(long n_out, long n_in, double r) {
  std::vector<std::pair<long, long>> w(n_out);
  for (long i = 0; i < n_out; ++i) {
    w[i] = samples_in(i - r, i + 1 + r, n_in, n_out);
    if (w[i].second < w[i].first) {
      const double centre = (i + 0.5) * double(n_in) / double(n_out) - 0.5;
      const long k = std::clamp(static_cast<long>(std::lround(centre)), 0L, n_in - 1);
      w[i] = {k, k};
    }
  }
  return w;
}

// --- the Cartesian route of the continuous L2 error -------------------------
// f_app at the inside samples is Wy C Wx' (per channel), Wx and Wy the tables
// from coefficients to sample columns and rows. Then
//   sum (f_app - f)^2 = sum_{ky,ly} Gy[ky][ly] sum_{kx,lx} Gx[kx][lx] c[ky][kx] c[ly][lx]
//                       - 2 sum_k c[k] a[k] + sum f^2,
// Gx = Wx' Wx and Gy = Wy' Wy over the inside samples, a = Wy' F Wx the
// reference acquired by the same tables.

void check_coefficients(const Coefficients& k) {
  if (k.c.width < 1 || k.c.height < 1 || k.c.channels < 1 || !(k.image_width > 0) ||
      !(k.image_height > 0) || !std::isfinite(k.image_width) || !std::isfinite(k.image_height)) {
    std::ostringstream m;
    m << "l2_error(): coefficients " << k.c.width << " x " << k.c.height << " x " << k.c.channels
      << " over an image of " << k.image_width << " x " << k.image_height << " are empty";
    throw std::invalid_argument(m.str());
  }
  for (std::size_t q = 0; q < k.c.data.size(); ++q)
    if (!std::isfinite(k.c.data[q]))
      throw std::invalid_argument("l2_error(): non-finite coefficient (NaN or Inf) at index " +
                                  std::to_string(q));
}

void check_border(double border) {
  if (!(border >= 0) || !std::isfinite(border))
    throw std::invalid_argument("l2_error(): border " + std::to_string(border) +
                                " is not a finite value >= 0");
}

[[noreturn]] void nothing_inside(const Coefficients& k, double border) {
  std::ostringstream m;
  m << "l2_error(): border " << border << " leaves no sample of the " << k.image_width << " x "
    << k.image_height << " image";
  throw std::invalid_argument(m.str());
}

// The samples [first, last) of n across `extent` whose position
// (i + 1/2) extent / n lies in [border, extent - border].
std::pair<long, long> inside_samples(long n, double extent, double border) {
  const double s = extent / n;
  long first = 0, last = n;
  while (first < n && (first + 0.5) * s < border) ++first;
  while (last > first && !((last - 1 + 0.5) * s <= extent - border)) --last;
  return {first, last};
}

// Sparse symmetric Gram matrix of one axis' table over its inside samples.
using Gram = std::vector<std::vector<std::pair<long, double>>>;

Gram gram(const AxisWeights& w, long first, long last) {
  Gram g(w.sources);
  for (long i = first; i < last; ++i)
    for (long e = w.begin(i); e < w.end(i); ++e)
      for (long f = w.begin(i); f < w.end(i); ++f) {
        auto& row = g[w.index[e]];
        const double v = w.weight[e] * w.weight[f];
        auto it = std::find_if(row.begin(), row.end(), [&](const auto& p) { return p.first == w.index[f]; });
        if (it == row.end())
          row.emplace_back(w.index[f], v);
        else
          it->second += v;
      }
  return g;
}

// A Cartesian space's samples of the reference grid: the tables, the inside
// ranges and the Gram matrices.
struct SamplePlan {
  AxisWeights wx, wy;
  std::pair<long, long> xs, ys;
  Gram gx, gy;
  long count(int channels) const { return (xs.second - xs.first) * (ys.second - ys.first) * long(channels); }
};

SamplePlan sample_plan(const Coefficients& k, long ref_w, long ref_h, double border) {
  SamplePlan p;
  p.xs = inside_samples(ref_w, k.image_width, border);
  p.ys = inside_samples(ref_h, k.image_height, border);
  if (p.xs.first >= p.xs.second || p.ys.first >= p.ys.second) nothing_inside(k, border);
  p.wx = CartesianSpace::sample_weights(k, 0, ref_w);
  p.wy = CartesianSpace::sample_weights(k, 1, ref_h);
  p.gx = gram(p.wx, p.xs.first, p.xs.second);
  p.gy = gram(p.wy, p.ys.first, p.ys.second);
  return p;
}

// sum over the inside samples of f_app^2: c' (Gy x Gx) c.
double app_energy(const SamplePlan& p, const Grid<double>& c) {
  const int C = c.channels;
  Grid<double> u(c.width, c.height, C);  // u[ly] = c[ly] Gx
  for (long ly = 0; ly < c.height; ++ly)
    for (long kx = 0; kx < c.width; ++kx)
      for (const auto& [lx, g] : p.gx[kx])
        for (int ch = 0; ch < C; ++ch) u.at(kx, ly, ch) += g * c.at(lx, ly, ch);
  double s = 0;
  for (long ky = 0; ky < c.height; ++ky)
    for (const auto& [ly, g] : p.gy[ky]) {
      const double* a = c.row(ky);
      const double* b = u.row(ly);
      double d = 0;
      for (std::size_t q = 0; q < c.row_size(); ++q) d += a[q] * b[q];
      s += g * d;
    }
  return s;
}

double dot(const Grid<double>& a, const Grid<double>& b) {
  double s = 0;
  for (std::size_t q = 0; q < a.data.size(); ++q) s += a.data[q] * b.data[q];
  return s;
}

// The reference acquired by the plan's tables, a = Wy' F Wx, and sum f^2
// over the inside samples. fill(j, row) writes the inside samples of
// reference row j (row[(i - xs.first) C + c]); it is called from the
// workers where fill_on_any_thread. Rows are acquired in blocks on the
// workers and added in row order: the same bits for any thread count.
struct AcquiredReference {
  Grid<double> a;
  double energy = 0;
};

AcquiredReference acquire_reference(const SamplePlan& p, long cw, long ch, int C, int threads,
                                    bool fill_on_any_thread,
                                    const std::function<void(long, double*)>& fill) {
  AcquiredReference r{Grid<double>(cw, ch, C), 0.0};
  const long nx = p.xs.second - p.xs.first;
  constexpr long kBlock = 64;
  std::vector<double> samples(std::size_t(kBlock) * nx * C);
  std::vector<double> rows(std::size_t(kBlock) * cw * C);
  std::vector<double> energy(kBlock);
  for (long j0 = p.ys.first; j0 < p.ys.second; j0 += kBlock) {
    const long n = std::min(kBlock, p.ys.second - j0);
    auto row_pass = [&](long b0, long b1) {
      for (long b = b0; b < b1; ++b) {
        double* f = samples.data() + std::size_t(b) * nx * C;
        if (fill_on_any_thread) fill(j0 + b, f);
        double* t = rows.data() + std::size_t(b) * cw * C;
        std::fill(t, t + std::size_t(cw) * C, 0.0);
        double e2 = 0;
        for (long i = 0; i < nx; ++i) {
          const double* v = f + std::size_t(i) * C;
          for (int c = 0; c < C; ++c) e2 += v[c] * v[c];
          const long ii = i + p.xs.first;
          for (long e = p.wx.begin(ii); e < p.wx.end(ii); ++e) {
            double* dst = t + std::size_t(p.wx.index[e]) * C;
            const double w = p.wx.weight[e];
            for (int c = 0; c < C; ++c) dst[c] += w * v[c];
          }
        }
        energy[b] = e2;
      }
    };
    if (!fill_on_any_thread)
      for (long b = 0; b < n; ++b) fill(j0 + b, samples.data() + std::size_t(b) * nx * C);
    parallel_for(n, threads, row_pass);
    for (long b = 0; b < n; ++b) {
      const long j = j0 + b;
      const double* t = rows.data() + std::size_t(b) * cw * C;
      for (long e = p.wy.begin(j); e < p.wy.end(j); ++e) {
        double* dst = r.a.row(p.wy.index[e]);
        const double w = p.wy.weight[e];
        for (std::size_t q = 0; q < std::size_t(cw) * C; ++q) dst[q] += w * t[q];
      }
      r.energy += energy[b];
    }
  }
  return r;
}

double rms_of(double app_energy, double cross, double ref_energy, long count) {
  const double sum = app_energy - 2 * cross + ref_energy;
  // a truth function's NaN, or sums past double's range: never a score
  if (!std::isfinite(sum))
    throw std::invalid_argument("l2_error(): the error is not finite (a NaN or an infinity in "
                                "the truth, or values past double's range)");
  return std::sqrt(std::max(0.0, sum) / double(count));
}

// What identifies a Cartesian space's samples of the reference grid.
std::vector<double> space_key(const Coefficients& k) {
  const Kernel& g = k.kernel();
  const auto& L = k.lattice.matrix();
  return {double(int(g.kind())), double(g.degree()), g.radius(), g.param(0), g.param(1),
          g.param(2), L[0], L[1], L[2], L[3], k.lattice.origin().x, k.lattice.origin().y,
          double(k.c.width), double(k.c.height), double(k.c.channels), double(int(k.boundary)),
          k.image_width, k.image_height};
}


// Whether the coefficients' space evaluates on a grid by per-axis tables.
bool sampled_by_axes(const Coefficients& k) {
  return visit_space(k, [](auto space) { return decltype(space)::sampled_by_axes; });
}

// RMS of f_app - f over the centred reference grid of ref_w x ref_h samples
// inside the border; truth(i, j, c) is f at sample (i, j).
template <typename Truth>
double l2_on_grid(const Coefficients& k, long ref_w, long ref_h, double border, int threads,
                  bool truth_on_any_thread, const Truth& truth) {
  check_coefficients(k);
  check_border(border);
  const Image app = resample(k, Display::centred(), ref_w, ref_h, threads);
  const double sx = k.image_width / ref_w, sy = k.image_height / ref_h;
  auto inside = [&](long i, double s, double extent) {
    const double x = (i + 0.5) * s;
    return x >= border && x <= extent - border;
  };
  // Each row's sum of squares (on the worker threads where the truth may be
  // called from any), then the rows' sums in order: the same bits for any
  // thread count.
  std::vector<double> rows(ref_h, 0.0);
  std::vector<long> counts(ref_h, 0);
  auto row_sums = [&](long j0, long j1) {
    for (long j = j0; j < j1; ++j) {
      if (!inside(j, sy, k.image_height)) continue;
      double row = 0;
      long n = 0;
      for (long i = 0; i < ref_w; ++i) {
        if (!inside(i, sx, k.image_width)) continue;
        for (int c = 0; c < app.channels; ++c) {
          const double e = double(app.at(i, j, c)) - truth(i, j, c);
          row += e * e;
        }
        n += app.channels;
      }
      rows[j] = row;
      counts[j] = n;
    }
  };
  if (truth_on_any_thread)
    parallel_for(ref_h, threads, row_sums);
  else
    row_sums(0, ref_h);
  double sum = 0;
  long count = 0;
  for (long j = 0; j < ref_h; ++j) {
    if (!counts[j]) continue;
    sum += rows[j];
    count += counts[j];
  }
  if (count == 0) nothing_inside(k, border);
  return rms_of(sum, 0, 0, count);
}


}  // namespace

Grid<double> luminance(const ImageView& image) {
  check_not_empty(image, "luminance");
  Grid<double> y(image.width, image.height, 1);
  const std::size_t n = std::size_t(image.width) * image.height;
  const std::size_t C = image.channels;
  if (C >= 3) {
    for (std::size_t p = 0; p < n; ++p) {
      const float* v = image.data + p * C;
      y.data[p] = 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
    }
  } else {
    for (std::size_t p = 0; p < n; ++p) y.data[p] = image.data[p * C];
  }
  return y;
}

std::vector<double> highpass_energy_shares(const ImageView& image, const std::vector<double>& cutoffs) {
  for (double c : cutoffs)
    if (!std::isfinite(c) || c < 0)
      throw std::invalid_argument("highpass_energy_share(): cutoff " + std::to_string(c) +
                                  " cycles/pixel is not a finite value >= 0");
  check_not_empty(image, "highpass_energy_share");
  if (image.width > INT_MAX || image.height > INT_MAX)
    throw std::invalid_argument("highpass_energy_share(): image " + size_of(image) +
                                " is too large for the DFT");
  std::vector<double> share(cutoffs.size(), 0.0);
  Grid<double> y = luminance(image);
  for (std::size_t p = 0; p < y.data.size(); ++p)
    if (!std::isfinite(y.data[p]))
      throw std::invalid_argument("highpass_energy_share(): non-finite luminance at pixel (" +
                                  std::to_string(p % image.width) + ", " +
                                  std::to_string(p / image.width) + ")");
  if (std::all_of(y.data.begin(), y.data.end(), [&](double v) { return v == y.data[0]; }))
    return share;
  double mean = 0;
  for (double v : y.data) mean += v;
  mean /= double(y.data.size());

  const long W = image.width, H = image.height, Wc = W / 2 + 1;
  std::unique_ptr<double, FftwFree> in(fftw_alloc_real(std::size_t(W) * H));
  std::unique_ptr<fftw_complex, FftwFree> out(fftw_alloc_complex(std::size_t(Wc) * H));
  if (!in || !out) throw std::bad_alloc();
  fftw_plan plan;
  {
    std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
    plan = fftw_plan_dft_r2c_2d(static_cast<int>(H), static_cast<int>(W), in.get(), out.get(),
                                FFTW_ESTIMATE);
  }
  if (!plan) throw std::runtime_error("highpass_energy_share(): FFTW planning failed");
  for (std::size_t p = 0; p < y.data.size(); ++p) in.get()[p] = y.data[p] - mean;
  fftw_execute(plan);
  {
    std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
    fftw_destroy_plan(plan);
  }

  // The r2c output holds kx = 0 .. W/2; every other column stands for its
  // conjugate twin at W - kx too, except kx = 0 and (W even) kx = W/2.
  double total = 0;
  std::vector<double> high(cutoffs.size(), 0.0);
  for (long ky = 0; ky < H; ++ky) {
    const double fy = double(ky <= H / 2 ? ky : ky - H) / double(H);
    const fftw_complex* row = out.get() + std::size_t(ky) * Wc;
    for (long kx = 0; kx < Wc; ++kx) {
      if (kx == 0 && ky == 0) continue;  // DC: the mean, removed
      const double fx = double(kx) / double(W);
      const double twins = (kx == 0 || 2 * kx == W) ? 1.0 : 2.0;
      const double e = twins * (row[kx][0] * row[kx][0] + row[kx][1] * row[kx][1]);
      const double radius = std::hypot(fx, fy);
      total += e;
      for (std::size_t q = 0; q < cutoffs.size(); ++q)
        if (radius > cutoffs[q]) high[q] += e;
    }
  }
  if (total > 0)
    for (std::size_t q = 0; q < cutoffs.size(); ++q) share[q] = std::min(1.0, high[q] / total);
  return share;
}

double highpass_energy_share(const ImageView& image, double cutoff_cycles_per_pixel) {
  return highpass_energy_shares(image, {cutoff_cycles_per_pixel})[0];
}

double rms_difference(const ImageView& a, const ImageView& b, long border) {
  check_same_shape(a, b, "rms_difference");
  check_not_empty(a, "rms_difference");
  check_finite(a, "rms_difference", "first image");
  check_finite(b, "rms_difference", "second image");
  if (border < 0 || 2 * border >= a.width || 2 * border >= a.height)
    throw std::invalid_argument("rms_difference(): border " + std::to_string(border) +
                                " leaves no pixel of " + size_of(a));
  double sum = 0;
  for (long y = border; y < a.height - border; ++y) {
    const float* pa = a.row(y) + std::size_t(border) * a.channels;
    const float* pb = b.row(y) + std::size_t(border) * b.channels;
    const std::size_t n = std::size_t(a.width - 2 * border) * a.channels;
    double row = 0;
    for (std::size_t q = 0; q < n; ++q) {
      const double e = double(pa[q]) - double(pb[q]);
      row += e * e;
    }
    sum += row;
  }
  const double count = double(a.width - 2 * border) * double(a.height - 2 * border) * a.channels;
  return std::sqrt(sum / count);
}

double psnr(const ImageView& a, const ImageView& b, double peak, long border) {
  if (!(peak > 0) || !std::isfinite(peak))
    throw std::invalid_argument("psnr(): peak " + std::to_string(peak) +
                                " is not a finite value > 0");
  const double rms = rms_difference(a, b, border);
  if (rms == 0) return std::numeric_limits<double>::infinity();
  return 20 * std::log10(peak / rms);
}

struct L2Reference::Acquired {
  std::vector<double> key;
  SamplePlan plan;
  AcquiredReference reference;
};

L2Reference::L2Reference(const ImageView& reference, double border_output_pixels, int threads)
    : reference_(reference), border_(border_output_pixels), threads_(threads) {
  check_not_empty(reference, "l2_error");
  check_finite(reference, "l2_error", "reference");
  check_border(border_output_pixels);
}

L2Reference::~L2Reference() = default;
L2Reference::L2Reference(L2Reference&&) noexcept = default;
L2Reference& L2Reference::operator=(L2Reference&&) noexcept = default;

double L2Reference::l2_error(const Coefficients& k) {
  check_coefficients(k);
  const ImageView& f = reference_;
  if (f.channels != k.c.channels)
    throw std::invalid_argument("l2_error(): reference has " + std::to_string(f.channels) +
                                " channels, the coefficients " + std::to_string(k.c.channels));
  if (!sampled_by_axes(k))
    return l2_on_grid(k, f.width, f.height, border_, threads_, true,
                      [&](long i, long j, int c) { return double(f.at(i, j, c)); });
  const std::vector<double> key = space_key(k);
  auto it = std::find_if(acquired_.begin(), acquired_.end(),
                         [&](const auto& q) { return q->key == key; });
  if (it == acquired_.end()) {
    auto q = std::make_unique<Acquired>();
    q->key = key;
    q->plan = sample_plan(k, f.width, f.height, border_);
    const auto xs = q->plan.xs;
    const int C = f.channels;
    q->reference = acquire_reference(q->plan, k.c.width, k.c.height, C, threads_, true,
                                     [&](long j, double* row) {
                                       const float* v = f.row(j) + std::size_t(xs.first) * C;
                                       std::copy(v, v + (xs.second - xs.first) * C, row);
                                     });
    acquired_.push_back(std::move(q));
    it = acquired_.end() - 1;
  }
  const Acquired& q = **it;
  return rms_of(app_energy(q.plan, k.c), dot(k.c, q.reference.a), q.reference.energy,
                q.plan.count(k.c.channels));
}

double l2_error(const Coefficients& coefficients, const ImageView& reference,
                double border_output_pixels, int threads) {
  return L2Reference(reference, border_output_pixels, threads).l2_error(coefficients);
}

double l2_error(const Coefficients& coefficients,
                const std::function<double(double x, double y, int channel)>& truth,
                int samples_per_pixel, double border_output_pixels, int threads,
                bool truth_on_any_thread) {
  check_samples_per_pixel(samples_per_pixel);
  if (!truth) throw std::invalid_argument("l2_error(): no truth function");
  check_coefficients(coefficients);
  check_border(border_output_pixels);
  const Coefficients& k = coefficients;
  const long ref_w = std::max(1L, std::lround(k.image_width * samples_per_pixel));
  const long ref_h = std::max(1L, std::lround(k.image_height * samples_per_pixel));
  const double sx = k.image_width / ref_w, sy = k.image_height / ref_h;
  if (!sampled_by_axes(k))
    return l2_on_grid(k, ref_w, ref_h, border_output_pixels, threads, truth_on_any_thread,
                      [&](long i, long j, int c) { return truth((i + 0.5) * sx, (j + 0.5) * sy, c); });
  const SamplePlan p = sample_plan(k, ref_w, ref_h, border_output_pixels);
  const int C = k.c.channels;
  const AcquiredReference r = acquire_reference(
      p, k.c.width, k.c.height, C, threads, truth_on_any_thread, [&](long j, double* row) {
        for (long i = p.xs.first; i < p.xs.second; ++i)
          for (int c = 0; c < C; ++c) *row++ = truth((i + 0.5) * sx, (j + 0.5) * sy, c);
      });
  return rms_of(app_energy(p, k.c), dot(k.c, r.a), r.energy, p.count(C));
}

OvershootReport overshoot(const ImageView& output, const ImageView& input,
                          const OvershootOptions& options) {
  check_not_empty(output, "overshoot");
  check_not_empty(input, "overshoot");
  if (output.channels != input.channels)
    throw std::invalid_argument("overshoot(): output has " + std::to_string(output.channels) +
                                " channels, the input " + std::to_string(input.channels));
  if (!(options.neighbourhood >= 0) || !std::isfinite(options.neighbourhood))
    throw std::invalid_argument("overshoot(): neighbourhood " +
                                std::to_string(options.neighbourhood) +
                                " output pixels is not a finite value >= 0");
  // Past the output's larger side every window holds the whole input
  // already; far past it the windows' indices overflow.
  const long widest = std::max(output.width, output.height);
  if (options.neighbourhood > double(widest)) {
    std::ostringstream m;
    m << "overshoot(): neighbourhood " << options.neighbourhood << " output pixels: at most "
      << widest << " (the output's larger side, where every pixel's neighbourhood holds the "
      << "whole input)";
    throw std::invalid_argument(m.str());
  }
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance))
    throw std::invalid_argument("overshoot(): tolerance " + std::to_string(options.tolerance) +
                                " is not a finite value >= 0");
  const long B = options.border;
  if (B < 0 || 2 * B >= output.width || 2 * B >= output.height)
    throw std::invalid_argument("overshoot(): border " + std::to_string(B) +
                                " leaves no pixel of " + size_of(output));
  check_finite(output, "overshoot", "output");
  check_finite(input, "overshoot", "input");

  const int C = output.channels;
  const long W = output.width, H = output.height;
  const auto wx = axis_windows(W, input.width, options.neighbourhood);
  const auto wy = axis_windows(H, input.height, options.neighbourhood);

  // Horizontal pass: per input row and output column, the extremes over the
  // column's window. Then the vertical pass per output pixel.
  Grid<float> hmin(W, input.height, C), hmax(W, input.height, C);
  for (long l = 0; l < input.height; ++l)
    for (long i = 0; i < W; ++i)
      for (int c = 0; c < C; ++c) {
        float lo = input.at(wx[i].first, l, c), hi = lo;
        for (long k = wx[i].first + 1; k <= wx[i].second; ++k) {
          const float v = input.at(k, l, c);
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
        hmin.at(i, l, c) = lo;
        hmax.at(i, l, c) = hi;
      }

  OvershootReport r;
  r.min = std::numeric_limits<double>::infinity();
  r.max = -std::numeric_limits<double>::infinity();
  const double tol = options.tolerance;
  auto slack = [&](double bound) { return tol * std::max(1.0, std::abs(bound)); };
  for (long j = B; j < H - B; ++j)
    for (long i = B; i < W - B; ++i) {
      bool out_of_range = false, negative = false;
      for (int c = 0; c < C; ++c) {
        double lo = hmin.at(i, wy[j].first, c), hi = hmax.at(i, wy[j].first, c);
        for (long l = wy[j].first + 1; l <= wy[j].second; ++l) {
          lo = std::min(lo, double(hmin.at(i, l, c)));
          hi = std::max(hi, double(hmax.at(i, l, c)));
        }
        const double v = output.at(i, j, c);
        r.max_overshoot = std::max(r.max_overshoot, v - hi);
        r.max_undershoot = std::max(r.max_undershoot, lo - v);
        if (v > hi + slack(hi) || v < lo - slack(lo)) out_of_range = true;
        if (v < -tol) negative = true;
        if (v < 0) r.negative_energy += v * v;
        r.min = std::min(r.min, v);
        r.max = std::max(r.max, v);
      }
      ++r.pixels;
      r.pixels_out_of_range += out_of_range;
      r.negative_pixels += negative;
    }
  return r;
}

double zoneplate_l2_error(const Coefficients& coefficients, double K, int samples_per_pixel,
                          double border_output_pixels, int threads) {
  check_samples_per_pixel(samples_per_pixel);
  check_finite_number(K, "l2_error", "the zone plate's K");
  check_coefficients(coefficients);
  check_border(border_output_pixels);
  const double W = coefficients.image_width, H = coefficients.image_height;
  const long ref_w = std::max(1L, std::lround(W * samples_per_pixel));
  const long ref_h = std::max(1L, std::lround(H * samples_per_pixel));
  const double sx = W / ref_w, sy = H / ref_h;
  // phase K (u - 1/2)^2 of each column, K (v - 1/2)^2 of each row
  auto table = [K](long n, double s, double extent, std::vector<double>& c, std::vector<double>& si) {
    c.resize(n);
    si.resize(n);
    for (long i = 0; i < n; ++i) {
      const double u = (i + 0.5) * s / extent - 0.5, a = K * u * u;
      c[i] = std::cos(a);
      si[i] = std::sin(a);
    }
  };
  std::vector<double> cx, sx_, cy, sy_;
  table(ref_w, sx, W, cx, sx_);
  table(ref_h, sy, H, cy, sy_);
  const Coefficients& k = coefficients;
  if (!sampled_by_axes(k))
    return l2_on_grid(k, ref_w, ref_h, border_output_pixels, threads, true,
                      [&](long i, long j, int) { return 0.5 + 0.5 * (cx[i] * cy[j] - sx_[i] * sy_[j]); });
  // f = 1/2 + 1/2 (cx cy - sx sy): a = Wy' F Wx is three outer products of
  // per-axis acquisitions, and sum f^2 = N/4 + (1/2) sum cos + (1/4) sum cos^2
  // of per-axis sums.
  const SamplePlan p = sample_plan(k, ref_w, ref_h, border_output_pixels);
  auto acquired = [](const AxisWeights& w, std::pair<long, long> range, const std::vector<double>* v) {
    std::vector<double> out(w.sources, 0.0);
    for (long i = range.first; i < range.second; ++i)
      for (long e = w.begin(i); e < w.end(i); ++e) out[w.index[e]] += w.weight[e] * (v ? (*v)[i] : 1.0);
    return out;
  };
  const auto x1 = acquired(p.wx, p.xs, nullptr), xc = acquired(p.wx, p.xs, &cx),
             xs = acquired(p.wx, p.xs, &sx_);
  const auto y1 = acquired(p.wy, p.ys, nullptr), yc = acquired(p.wy, p.ys, &cy),
             ys = acquired(p.wy, p.ys, &sy_);
  const int C = k.c.channels;
  double cross = 0;
  for (long ky = 0; ky < k.c.height; ++ky)
    for (long kx = 0; kx < k.c.width; ++kx) {
      const double a = 0.5 * (y1[ky] * x1[kx] + yc[ky] * xc[kx] - ys[ky] * xs[kx]);
      for (int c = 0; c < C; ++c) cross += a * k.c.at(kx, ky, c);
    }
  // sums over the inside samples of one axis: cos, sin, cos^2, sin^2, cos sin
  struct Sums {
    double c = 0, s = 0, cc = 0, ss = 0, cs = 0;
  };
  auto sums = [](std::pair<long, long> range, const std::vector<double>& co, const std::vector<double>& si) {
    Sums r;
    for (long i = range.first; i < range.second; ++i) {
      r.c += co[i];
      r.s += si[i];
      r.cc += co[i] * co[i];
      r.ss += si[i] * si[i];
      r.cs += co[i] * si[i];
    }
    return r;
  };
  const Sums X = sums(p.xs, cx, sx_), Y = sums(p.ys, cy, sy_);
  const double n = double(p.xs.second - p.xs.first) * double(p.ys.second - p.ys.first);
  const double sum_cos = X.c * Y.c - X.s * Y.s;
  const double sum_cos2 = X.cc * Y.cc - 2 * X.cs * Y.cs + X.ss * Y.ss;
  const double energy = C * (0.25 * n + 0.5 * sum_cos + 0.25 * sum_cos2);
  return rms_of(app_energy(p, k.c), cross, energy, p.count(C));
}

DiscreteNoiseGain discrete_noise_gain(const std::function<std::vector<double>(const Image&)>& apply,
                                      long N, int s) {
  if (N < 8 || s < 1)
    throw std::invalid_argument("discrete_noise_gain(): frame " + std::to_string(N) +
                                " or factor " + std::to_string(s) + " too small");
  const long L = 12, c = N / 2, reach = std::min(3 * L, N / 2 - 1);
  double sum = 0;
  std::vector<double> R((2 * L + 1) * (2 * L + 1), 0.0);
  for (long b = 0; b < s; ++b)
    for (long a = 0; a < s; ++a) {
      Image impulse(N * s, N * s, 1);
      impulse.at(c * s + a, c * s + b, 0) = 1.0f;
      const std::vector<double> out = apply(impulse);
      if (long(out.size()) != N * N)
        throw std::invalid_argument("discrete_noise_gain(): apply() returned " +
                                    std::to_string(out.size()) + " values, not " +
                                    std::to_string(N * N));
      for (double v : out) sum += v * v;
      auto at = [&](long x, long y) { return out[((y + N) % N) * N + (x + N) % N]; };
      for (long ky = -L; ky <= L; ++ky)
        for (long kx = -L; kx <= L; ++kx) {
          double r = 0;
          for (long y = c - reach; y <= c + reach; ++y)
            for (long x = c - reach; x <= c + reach; ++x) r += at(x, y) * at(x + kx, y + ky);
          R[(ky + L) * (2 * L + 1) + kx + L] += r;
        }
    }
  const double r0 = R[L * (2 * L + 1) + L];
  double rho2 = 0;
  for (double r : R) rho2 += (r / r0) * (r / r0);
  return {double(s) * s * sum, std::sqrt(2 * rho2) / double(N)};
}

double zoneplate(double K, double W, double H, double x, double y) {
  const double u = x / W - 0.5, v = y / H - 0.5;
  return 0.5 + 0.5 * std::cos(K * (u * u + v * v));
}

}  // namespace sis
