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

// RMS of f_app - f over the centred reference grid of ref_w x ref_h samples
// inside the border; truth(i, j, c) is f at sample (i, j).
template <typename Truth>
double l2_on_grid(const Coefficients& k, long ref_w, long ref_h, double border, int threads,
                  bool truth_on_any_thread, const Truth& truth) {
  if (k.c.width < 1 || k.c.height < 1 || k.c.channels < 1 || !(k.image_width > 0) ||
      !(k.image_height > 0)) {
    std::ostringstream m;
    m << "l2_error(): coefficients " << k.c.width << " x " << k.c.height << " x " << k.c.channels
      << " over an image of " << k.image_width << " x " << k.image_height << " are empty";
    throw std::invalid_argument(m.str());
  }
  if (!(border >= 0) || !std::isfinite(border))
    throw std::invalid_argument("l2_error(): border " + std::to_string(border) +
                                " is not a finite value >= 0");
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
  if (count == 0) {
    std::ostringstream m;
    m << "l2_error(): border " << border << " leaves no sample of the " << k.image_width << " x "
      << k.image_height << " image";
    throw std::invalid_argument(m.str());
  }
  return std::sqrt(sum / count);
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

double l2_error(const Coefficients& coefficients, const ImageView& reference,
                double border_output_pixels, int threads) {
  check_not_empty(reference, "l2_error");
  if (reference.channels != coefficients.c.channels)
    throw std::invalid_argument("l2_error(): reference has " + std::to_string(reference.channels) +
                                " channels, the coefficients " +
                                std::to_string(coefficients.c.channels));
  return l2_on_grid(coefficients, reference.width, reference.height, border_output_pixels, threads,
                    true,
                    [&](long i, long j, int c) { return double(reference.at(i, j, c)); });
}

double l2_error(const Coefficients& coefficients,
                const std::function<double(double x, double y, int channel)>& truth,
                int samples_per_pixel, double border_output_pixels, int threads,
                bool truth_on_any_thread) {
  if (samples_per_pixel < 1)
    throw std::invalid_argument("l2_error(): samples_per_pixel " +
                                std::to_string(samples_per_pixel) + " < 1");
  if (!truth) throw std::invalid_argument("l2_error(): no truth function");
  const long ref_w = std::max(1L, std::lround(coefficients.image_width * samples_per_pixel));
  const long ref_h = std::max(1L, std::lround(coefficients.image_height * samples_per_pixel));
  const double sx = coefficients.image_width / ref_w, sy = coefficients.image_height / ref_h;
  return l2_on_grid(coefficients, ref_w, ref_h, border_output_pixels, threads, truth_on_any_thread,
                    [&](long i, long j, int c) { return truth((i + 0.5) * sx, (j + 0.5) * sy, c); });
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
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance))
    throw std::invalid_argument("overshoot(): tolerance " + std::to_string(options.tolerance) +
                                " is not a finite value >= 0");
  const long B = options.border;
  if (B < 0 || 2 * B >= output.width || 2 * B >= output.height)
    throw std::invalid_argument("overshoot(): border " + std::to_string(B) +
                                " leaves no pixel of " + size_of(output));

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
  if (samples_per_pixel < 1)
    throw std::invalid_argument("l2_error(): samples_per_pixel " +
                                std::to_string(samples_per_pixel) + " < 1");
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
  return l2_on_grid(coefficients, ref_w, ref_h, border_output_pixels, threads, true,
                    [&](long i, long j, int) { return 0.5 + 0.5 * (cx[i] * cy[j] - sx_[i] * sy_[j]); });
}

double zoneplate(double K, double W, double H, double x, double y) {
  const double u = x / W - 0.5, v = y / H - 0.5;
  return 0.5 + 0.5 * std::cos(K * (u * u + v * v));
}

}  // namespace sis
