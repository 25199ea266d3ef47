// sistability: where the methods fail, measured on synthetic inputs with
// known answers (docs/design.md section 6), as JSON for the report:
//   noise     output noise variance over input noise variance per method and
//             display, seeded white noise on the samples of a flat image, in
//             units of sigma^2 / s^2 (a box average of a pixel's s^2 rays),
//             with the theory of docs/design.md section 6 beside it;
//   step      overshoot and undershoot of a unit step edge per method;
//   numerics  per degree 0..7: condition numbers, how much the prefilter
//             amplifies a float rounding of its input, FFT against recursive.
#include <CLI/CLI.hpp>

#include <cmath>
#include <complex>
#include <cstdio>
#include <iostream>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "sis/engine.h"
#include "sis/hex_projection.h"
#include "sis/metrics.h"
#include "sis/projection.h"
#include "sis/range.h"

using namespace sis;

namespace {

const double kPi = std::acos(-1.0);

struct MethodSpec {
  std::string name;
  Kernel kernel;
  Method method;
  Display display;
};

// The projection of samples in memory by the engine, the coefficients kept
// in double (the measures here are of the method, not of float storage).
Coefficients project_noise(const Image& in, long W, long H, const MethodSpec& m, Boundary rule) {
  ProjectionRequest rq;
  rq.inputs = {ProjectionInput::memory(in, "noise")};
  rq.width = W;
  rq.height = H;
  rq.space = CartesianSpace{m.kernel};
  rq.method = m.method;
  rq.boundary = rule;
  rq.float_coefficients = false;
  return project(rq).coefficients;
}

std::vector<MethodSpec> methods() {
  const Display c = Display::centred(), aa = Display::antialiased_2x2(), px = Display::pixel();
  return {{"box", Kernel::bspline(0), Method::Conventional, c},
          {"conv-tent", Kernel::bspline(1), Method::Conventional, c},
          {"mitchell", Kernel::mitchell(), Method::Conventional, c},
          {"me-tent", Kernel::bspline(1), Method::MinError, c},
          {"me-tent-2x2", Kernel::bspline(1), Method::MinError, aa},
          {"me-tent-pixel", Kernel::bspline(1), Method::MinError, px},
          {"me-cubic", Kernel::bspline(3), Method::MinError, c},
          {"me-cubic-2x2", Kernel::bspline(3), Method::MinError, aa},
          {"me-cubic-pixel", Kernel::bspline(3), Method::MinError, px}};
}

// Per-axis noise gain of a min-error display: (1/pi) int_0^pi |D(w)|^2 / A(w)
// with D the display's transfer function; squared for 2-D.
double min_error_theory(int d, const Display& display) {
  const int n = 4096;
  double s = 0;
  for (int i = 0; i < n; ++i) {
    const double w = (i + 0.5) * kPi / n;
    std::complex<double> D = 0;
    if (display.mode == Display::Mode::PixelAverage) {
      for (int k = -d - 2; k <= d + 2; ++k) D += bspline(d + 1, k) * std::polar(1.0, -w * k);
    } else {
      std::vector<double> dx;
      for (const Vec2& o : display.offsets) dx.push_back(o.x);
      std::sort(dx.begin(), dx.end());
      dx.erase(std::unique(dx.begin(), dx.end()), dx.end());
      for (double o : dx)
        for (int k = -d - 2; k <= d + 2; ++k)
          D += bspline(d, k + o) * std::polar(1.0, -w * k) / double(dx.size());
    }
    s += std::norm(D) / bspline_autocorrelation_spectrum(d, w);
  }
  return std::pow(s / n, 2);
}

// Conventional: s sum w^2 / (sum w)^2 per axis for the actual sample offsets.
double conventional_theory(const Kernel& k, int s) {
  double sw = 0, sw2 = 0;
  for (int i = -8 * s; i < 8 * s; ++i) {
    const double w = k.eval((i + 0.5) / s - 0.5);
    sw += w;
    sw2 += w * w;
  }
  return std::pow(s * sw2 / (sw * sw), 2);
}

double variance(const std::vector<double>& v) {
  double m = 0, q = 0;
  for (double x : v) m += x;
  m /= double(v.size());
  for (double x : v) q += (x - m) * (x - m);
  return q / double(v.size() - 1);
}

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

// The study at N x N output pixels, factor s, printed as JSON.
int run(long N, int s, unsigned seed) {
  // Noise: a flat 0.5 image plus N(0, sigma^2) on every sample.
  const double sigma = 0.1;
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0, float(sigma));
  Image in(N * s, N * s, 1);
  for (float& v : in.data) v = 0.5f + noise(rng);
  const double unit = sigma * sigma / (s * s);
  std::string out = "{\"noise\": {\"size\": " + std::to_string(N) + ", \"factor\": " + std::to_string(s) +
                    ", \"seed\": " + std::to_string(seed) + ", \"sigma\": " + num(sigma) + ", \"methods\": [";
  bool first = true;
  for (const MethodSpec& m : methods()) {
    auto apply = [&](const Image& samples) {
      const Image p = final_image(project_noise(samples, N, N, m, Boundary::Periodic), m.display, N, N);
      return std::vector<double>(p.data.begin(), p.data.end());
    };
    const double gain = variance(apply(in)) / unit;
    const DiscreteNoiseGain exact = discrete_noise_gain(apply, N, s);
    const double theory = m.method == Method::MinError ? min_error_theory(m.kernel.degree(), m.display)
                                                       : conventional_theory(m.kernel, s);
    out += std::string(first ? "" : ", ") + "{\"method\": \"" + m.name + "\", \"gain\": " + num(gain) +
           ", \"discrete\": " + num(exact.gain) + ", \"measurement_sd\": " +
           num(exact.relative_sd * exact.gain) + ", \"theory\": " + num(theory) + "}";
    first = false;
  }
  // The hexagonal lattice (density 1, centred display): its pixels are not
  // lattice points, so the gain varies from pixel to pixel; measured as the
  // mean over 16 noise images of a 32 x 32 frame's variance inside a
  // 4-pixel border, against the exact mean over those pixels
  // (hex_noise_gain) and the continuous theory, the density: the projection
  // of white noise onto a space of D basis functions per unit area has mean
  // variance D times the noise's density.
  {
    const long HN = 32, HB = 4;
    const int HK = 16;
    for (int order : {1, 2}) {
      std::mt19937 hrng(seed + order);
      std::normal_distribution<double> hnoise(0, 1);
      HexProjectionOptions ho;
      ho.order = order;
      ho.boundary = Boundary::Periodic;
      double gain = 0;
      for (int t = 0; t < HK; ++t) {
        Grid<double> samples(HN * s, HN * s, 1);
        for (double& v : samples.data) v = hnoise(hrng);
        const Image p = resample(project_hexagonal(samples, double(HN), double(HN), ho),
                                 Display::centred(), HN, HN);
        std::vector<double> inside;
        for (long j = HB; j < HN - HB; ++j)
          for (long i = HB; i < HN - HB; ++i) inside.push_back(p.at(i, j, 0));
        gain += s * s * variance(inside) / HK;
      }
      const HexNoiseGain exact = hex_noise_gain(order, 1.0, HN, s, HB);
      out += std::string(", {\"method\": \"") + (order == 1 ? "hex-hat" : "hex-quartic") +
             "\", \"gain\": " + num(gain) + ", \"discrete\": " + num(exact.gain) +
             ", \"measurement_sd\": " + num(exact.relative_sd * exact.gain / std::sqrt(double(HK))) +
             ", \"theory\": 1}";
    }
  }
  out += "]}, \"step\": [";
  // Step: conventional filters measured on a densely sampled step (s = 16,
  // the edge on a pixel boundary); min-error from the exact step response.
  first = true;
  {
    const long W = 64, S = 16;
    Image step(W * S, 4 * S, 1);
    for (long j = 0; j < step.height; ++j)
      for (long i = 0; i < step.width; ++i) step.at(i, j, 0) = i >= W * S / 2 ? 1.0f : 0.0f;
    for (const MethodSpec& m : methods()) {
      double over = 0, under = 0;
      if (m.method == Method::MinError) {
        const StepResponse r = step_response(m.kernel.degree(), m.display);
        over = r.overshoot;
        under = r.undershoot;
      } else {
        const Image p = final_image(project_noise(step, W, 4, m, Boundary::Mirror), m.display, W, 4);
        for (long x = 0; x < W; ++x) {
          over = std::max(over, double(p.at(x, 2, 0)) - 1);
          under = std::max(under, -double(p.at(x, 2, 0)));
        }
      }
      out += std::string(first ? "" : ", ") + "{\"method\": \"" + m.name + "\", \"overshoot\": " + num(over) +
             ", \"undershoot\": " + num(under) + "}";
      first = false;
    }
  }
  out += "], \"numerics\": [";
  // Numerics: zero-mean random r of a 256 x 256 grid (every frequency
  // excited, the worst case for the conditioning); c from r in double, from
  // r rounded to float, and by the recursive form.
  for (int d = 0; d <= kMaxDegree; ++d) {
    const long n = 256;
    Grid<double> r(n, n, 1);
    std::uniform_real_distribution<double> u(-1, 1);
    for (double& v : r.data) v = u(rng);
    Grid<double> rf = r, rec = r, c = r;
    for (double& v : rf.data) v = static_cast<float>(v);
    PrefilterPlan(d, n, n, Boundary::Mirror).execute(c);
    PrefilterPlan(d, n, n, Boundary::Mirror).execute(rf);
    PrefilterPlan(d, n, n, Boundary::Mirror, PrefilterMethod::Recursive).execute(rec);
    double peak = 0, ef = 0, er = 0;
    for (std::size_t q = 0; q < c.data.size(); ++q) {
      peak = std::max(peak, std::abs(c.data[q]));
      ef = std::max(ef, std::abs(rf.data[q] - c.data[q]));
      er = std::max(er, std::abs(rec.data[q] - c.data[q]));
    }
    const double cond1 = 1 / bspline_autocorrelation_spectrum(d, kPi);
    out += std::string(d ? ", " : "") + "{\"degree\": " + std::to_string(d) + ", \"condition_1d\": " + num(cond1) +
           ", \"condition_2d\": " + num(cond1 * cond1) +
           ", \"float_input_rel_error\": " + num(ef / peak) +
           ", \"float_amplification\": " + num(ef / peak / std::ldexp(1.0, -24)) +
           ", \"fft_vs_recursive_rel\": " + num(er / peak) + "}";
  }
  out += "]}\n";
  std::fputs(out.c_str(), stdout);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  long N = 192;
  int s = 4;
  unsigned seed = 2026;
  CLI::App app{"sistability: noise gain, step response and numerics of every method, as JSON",
               "sistability"};
  app.add_option("--size", N, "output size of the noise image (N x N)")->capture_default_str()->check(CLI::Range(16, 4096));
  app.add_option("--factor", s, "supersampling factor of the noise image")->capture_default_str()->check(CLI::Range(1, 16));
  app.add_option("--seed", seed, "noise seed")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    return run(N, s, seed);
  } catch (const std::bad_alloc&) {
    std::cerr << "sistability: out of memory (--size " << N << " --factor " << s << ": a noise image of "
              << N * s << " x " << N * s << " samples and its projections; try a smaller --size or --factor)\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "sistability: " << e.what() << "\n";
    return 1;
  }
}
