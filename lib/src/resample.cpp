#include "sis/resample.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>
#include <stdexcept>

#include "sis/coefficients.h"
#include "sis/space.h"
#include "sis/weights.h"

namespace sis {

Display Display::parse(const std::string& s) {
  if (s == "centred" || s == "centered" || s == "centre" || s == "center") return centred();
  if (s == "2x2") return antialiased_2x2();
  if (s == "pixel") return pixel();
  const std::string prefix = "offsets:";
  if (s.rfind(prefix, 0) == 0) {
    Display d{Mode::Points, {}};
    std::stringstream list(s.substr(prefix.size()));
    std::string item;
    while (std::getline(list, item, ';')) {
      double dx, dy;
      char comma, extra;
      std::istringstream p(item);
      if (!(p >> dx >> comma >> dy) || comma != ',' || (p >> extra) || !std::isfinite(dx) ||
          !std::isfinite(dy))
        throw std::invalid_argument("display '" + s + "': offset '" + item +
                                    "' is not DX,DY (final pixels)");
      if (std::abs(dx) > kMaxDisplayOffset || std::abs(dy) > kMaxDisplayOffset)
        throw std::invalid_argument("display '" + s + "': offset '" + item +
                                    "' lies outside [-1, 1] final pixels");
      d.offsets.push_back({dx, dy});
    }
    if (d.offsets.empty())
      throw std::invalid_argument("display '" + s + "': no offsets after 'offsets:'");
    if (d.offsets.size() > kMaxDisplayOffsets)
      throw std::invalid_argument("display '" + s + "': " + std::to_string(d.offsets.size()) +
                                  " offsets, more than " + std::to_string(kMaxDisplayOffsets));
    return d;
  }
  throw std::invalid_argument("unknown display '" + s +
                              "' (expected centred, 2x2, pixel or offsets:DX,DY;DX,DY;...)");
}

std::string Display::name() const {
  if (mode == Mode::PixelAverage) return "pixel";
  if (offsets.size() == 1 && offsets[0].x == 0 && offsets[0].y == 0) return "centred";
  const Display aa = antialiased_2x2();
  if (offsets.size() == aa.offsets.size() &&
      std::equal(offsets.begin(), offsets.end(), aa.offsets.begin(),
                 [](Vec2 a, Vec2 b) { return a.x == b.x && a.y == b.y; }))
    return "2x2";
  std::string s = "offsets:";
  char buf[64];
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.17g,%.17g", i ? ";" : "", offsets[i].x, offsets[i].y);
    s += buf;
  }
  return s;
}

namespace {

void check_separable(const Coefficients& k, const char* fn) {
  if (!k.lattice.separable())
    throw std::invalid_argument(std::string(fn) + "(): only separable lattices are supported");
}

// Weights from the coefficients to final pixels along one axis, for the
// given per-axis offsets (averaged) or the exact pixel average.
AxisWeights display_axis(const Coefficients& k, int axis, long out_count,
                         const std::vector<double>& offsets, bool pixel_average) {
  const long ncoef = axis == 0 ? k.c.width : k.c.height;
  const double extent = axis == 0 ? k.image_width : k.image_height;
  const double w = extent / out_count;  // final pixel size, output pixels
  const double h = k.lattice.axis_step(axis);
  const double o = k.lattice.axis_position(axis, 0);
  const Kernel& phi = k.kernel();
  double lo = 0, hi = 0;
  if (pixel_average) {
    lo = -0.5;
    hi = 0.5;
  } else {
    lo = *std::min_element(offsets.begin(), offsets.end());
    hi = *std::max_element(offsets.begin(), offsets.end());
  }
  auto range = [&](long i) {
    const double t = (i + 0.5) * w;
    return std::pair<long, long>(
        static_cast<long>(std::floor((t + lo * w - o) / h - phi.radius())),
        static_cast<long>(std::ceil((t + hi * w - o) / h + phi.radius())));
  };
  auto weight = [&](long i, long n) {
    const double t = (i + 0.5) * w, p = o + h * n;
    if (pixel_average)
      return (h / w) * phi.integrate((t - 0.5 * w - p) / h, (t + 0.5 * w - p) / h);
    double s = 0;
    for (double d : offsets) s += phi.eval((t + d * w - p) / h);
    return s / offsets.size();
  };
  return make_axis_weights(out_count, ncoef, k.boundary, range, weight);
}

// acc += weight * separable application of (wx, wy) to the coefficients;
// with `assign`, acc = 0 + that, the same bits as added to a zeroed acc, so
// that acc may start unset.
template <typename T>
void apply_separable(const Grid<double>& c, const AxisWeights& wx, const AxisWeights& wy,
                     double scale, Grid<T>& acc, int threads, bool assign = false) {
  const int C = c.channels;
  parallel_for(acc.height, threads, [&](long j0, long j1) {
    std::vector<double> tmp(c.row_size()), row(std::size_t(acc.width) * C);
    for (long j = j0; j < j1; ++j) {
      double* sums = tmp.data();
      if (wy.begin(j) == wy.end(j)) std::fill(tmp.begin(), tmp.end(), 0.0);
      for (long e = wy.begin(j); e < wy.end(j); ++e)  // the first term assigned: no zeroing
        add_scaled_rows(&sums, &wy.weight[e], 1, 0, c.row(wy.index[e]), long(tmp.size()),
                        e == wy.begin(j));
      apply_weights(wx, tmp.data(), C, 0, acc.width, row.data());
      T* out = acc.row(j);
      if (assign)
        for (std::size_t q = 0; q < row.size(); ++q) out[q] = static_cast<T>(0.0 + scale * row[q]);
      else
        for (std::size_t q = 0; q < row.size(); ++q) out[q] = static_cast<T>(out[q] + scale * row[q]);
    }
  });
}

}  // namespace

double evaluate(const Coefficients& k, Vec2 x, int channel) {
  return visit_space(k, [&](auto space) { return space.evaluate(k, x, channel); });
}

Image resample(const Coefficients& k, const Display& display, long out_width, long out_height,
               int threads) {
  return visit_space(k, [&](auto space) {
    return space.resample(k, display, out_width, out_height, threads);
  });
}

double CartesianSpace::evaluate(const Coefficients& k, Vec2 x, int channel) {
  check_separable(k, "evaluate");
  const Kernel& phi = k.kernel();
  const double hx = k.lattice.axis_step(0), hy = k.lattice.axis_step(1);
  const Vec2 u = k.lattice.coordinates(x);
  const long x0 = static_cast<long>(std::floor(u.x - phi.radius()));
  const long x1 = static_cast<long>(std::ceil(u.x + phi.radius()));
  const long y0 = static_cast<long>(std::floor(u.y - phi.radius()));
  const long y1 = static_cast<long>(std::ceil(u.y + phi.radius()));
  double s = 0;
  for (long m = y0; m <= y1; ++m) {
    const double wy = phi.eval(x.y / hy - (k.lattice.axis_position(1, m)) / hy);
    if (wy == 0) continue;
    const long mm = extend_index(m, k.c.height, k.boundary);
    for (long n = x0; n <= x1; ++n) {
      const double wx = phi.eval(x.x / hx - (k.lattice.axis_position(0, n)) / hx);
      if (wx == 0) continue;
      s += wx * wy * k.c.at(extend_index(n, k.c.width, k.boundary), mm, channel);
    }
  }
  return s;
}

AxisWeights CartesianSpace::sample_weights(const Coefficients& k, int axis, long count) {
  check_separable(k, "l2_error");
  return display_axis(k, axis, count, {0.0}, false);
}

Image CartesianSpace::resample(const Coefficients& k, const Display& display, long out_width,
                              long out_height, int threads) {
  check_separable(k, "resample");
  if (out_width < 1 || out_height < 1) {
    std::ostringstream m;
    m << "resample(): output size " << out_width << " x " << out_height << " is empty";
    throw std::invalid_argument(m.str());
  }
  // One pass (pixel, or a product set of offsets such as 2x2) writes the
  // float image directly; other offset lists accumulate in double.
  Image out(out_width, out_height, k.c.channels, kUnset);  // every path writes all of it
  if (display.mode == Display::Mode::PixelAverage) {
    const AxisWeights wx = display_axis(k, 0, out_width, {}, true);
    const AxisWeights wy = display_axis(k, 1, out_height, {}, true);
    apply_separable(k.c, wx, wy, 1.0, out, threads, true);
    return out;
  }
  if (display.offsets.empty()) throw std::invalid_argument("resample(): display has no offsets");
  std::set<double> xs, ys;
  std::set<std::pair<double, double>> pairs;
  for (const Vec2& d : display.offsets) {
    xs.insert(d.x);
    ys.insert(d.y);
    pairs.insert({d.x, d.y});
  }
  if (pairs.size() == display.offsets.size() && pairs.size() == xs.size() * ys.size()) {
    const AxisWeights wx = display_axis(k, 0, out_width, std::vector<double>(xs.begin(), xs.end()), false);
    const AxisWeights wy = display_axis(k, 1, out_height, std::vector<double>(ys.begin(), ys.end()), false);
    apply_separable(k.c, wx, wy, 1.0, out, threads, true);
    return out;
  }
  Grid<double> acc(out_width, out_height, k.c.channels);
  const double scale = 1.0 / display.offsets.size();
  for (const Vec2& d : display.offsets) {
    const AxisWeights wx = display_axis(k, 0, out_width, {d.x}, false);
    const AxisWeights wy = display_axis(k, 1, out_height, {d.y}, false);
    apply_separable(k.c, wx, wy, scale, acc, threads);
  }
  for (std::size_t q = 0; q < out.data.size(); ++q) out.data[q] = static_cast<float>(acc.data[q]);
  return out;
}

}  // namespace sis
