#include "sis/hex_resample.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "sis/weights.h"

namespace sis {

double hex_evaluate(const Coefficients& k, Vec2 x, int channel) {
  const HexLayout L = hex_layout(k);
  const BoxSpline& B = hex_generator(k);
  const double n = B.radius(), h = L.step(), hy = L.row_step();
  const Vec2 o = L.lattice.origin();
  const double u2 = (x.y - o.y) / hy;
  double s = 0;
  for (long j = static_cast<long>(std::ceil(u2 - n)); j <= static_cast<long>(std::floor(u2 + n));
       ++j) {
    const double v = u2 - j;
    if (!(std::abs(v) < n)) continue;
    const double t0 = (x.x - o.x) / h - 0.5 * double(j & 1);
    const double hw = n - 0.5 * std::abs(v);
    const long jj = L.wrap_row(j);
    const long i0 = static_cast<long>(std::ceil(t0 - hw));
    const long i1 = static_cast<long>(std::floor(t0 + hw));
    for (long i = i0; i <= i1; ++i) {
      const double t = t0 - i;
      const double m = B.eval(t - 0.5 * v, v);
      if (m != 0) s += m * k.c.at(L.wrap_column(i), jj, channel);
    }
  }
  return s;
}

namespace {

// acc[i] (C channels) += weight * f_app at (x_i, y) for final pixels
// x_i = (i + 1/2 + dxo) sx and each horizontal offset dxo, by one slice per
// coefficient row. CC > 0 fixes the channel count at compile time.
template <int CC>
void add_row_points(const Coefficients& k, const HexLayout& L, const BoxSpline& B, double y,
                    const std::vector<double>& dxos, double sx, double weight, double* acc,
                    long width, BoxSplineSlice& s) {
  const int C = CC > 0 ? CC : k.c.channels;
  const double n = B.radius(), h = L.step(), hy = L.row_step();
  const Vec2 o = L.lattice.origin();
  const double u2 = (y - o.y) / hy;
  for (long j = static_cast<long>(std::ceil(u2 - n)); j <= static_cast<long>(std::floor(u2 + n));
       ++j) {
    const double v = u2 - j;
    if (!(std::abs(v) < n)) continue;
    B.slice(v, s);
    const long jj = L.wrap_row(j);
    const double xj = o.x + 0.5 * h * double(j & 1);
    for (const double dxo : dxos)
      for (long px = 0; px < width; ++px) {
        const double t0 = ((px + 0.5 + dxo) * sx - xj) / h;
        double* a = acc + std::size_t(px) * C;
        const long i0 = static_cast<long>(std::ceil(t0 - s.half_width));
        const long i1 = static_cast<long>(std::floor(t0 + s.half_width));
        int p = s.pieces - 1;  // t = t0 - i decreases along i
        for (long i = i0; i <= i1; ++i) {
          const double t = t0 - i;
          if (!(std::abs(t) < s.half_width)) continue;
          p = s.piece(t, p);
          const double w = weight * s.eval_piece(p, t);
          const double* c = k.c.row(jj) + std::size_t(L.wrap_column(i)) * C;
          for (int ch = 0; ch < C; ++ch) a[ch] += w * c[ch];
        }
      }
  }
}

}  // namespace

Image hex_resample(const Coefficients& k, const Display& display, long out_width,
                   long out_height, int threads) {
  if (out_width < 1 || out_height < 1) {
    std::ostringstream m;
    m << "hex_resample(): output size " << out_width << " x " << out_height << " is empty";
    throw std::invalid_argument(m.str());
  }
  const HexLayout L = hex_layout(k);
  const BoxSpline& B = hex_generator(k);
  const int C = k.c.channels;
  const double sx = k.image_width / out_width, sy = k.image_height / out_height;
  if (display.mode == Display::Mode::Points && display.offsets.empty())
    throw std::invalid_argument("hex_resample(): display has no offsets");
  // The offsets grouped by their vertical offset, in order of first use: one
  // set of slices per group (2x2 has two).
  std::vector<std::pair<double, std::vector<double>>> groups;
  for (const Vec2& d : display.offsets) {
    auto g = std::find_if(groups.begin(), groups.end(),
                          [&](const auto& e) { return e.first == d.y; });
    if (g == groups.end()) {
      groups.push_back({d.y, {}});
      g = groups.end() - 1;
    }
    g->second.push_back(d.x);
  }
  Image out(out_width, out_height, C);
  parallel_for(out_height, threads, [&](long r0, long r1) {
    BoxSplineSlice s;
    BoxSplineBand band;
    std::vector<double> acc(std::size_t(out_width) * C);
    for (long r = r0; r < r1; ++r) {
      std::fill(acc.begin(), acc.end(), 0.0);
      if (display.mode == Display::Mode::PixelAverage) {
        // Exact: per coefficient row j, the band integral of M over the final
        // row's heights; the pixel's weight for c[i, j] is
        // h hy (Y(tb - i) - Y(ta - i)) / (sx sy).
        const double n = B.radius(), h = L.step(), hy = L.row_step(), area = sx * sy;
        const Vec2 o = L.lattice.origin();
        const double U0 = (r * sy - o.y) / hy, U1 = ((r + 1) * sy - o.y) / hy;
        const long j0 = static_cast<long>(std::floor(U0 - n));
        const long j1 = static_cast<long>(std::ceil(U1 + n));
        for (long j = j0; j <= j1; ++j) {
          band.build(B, U0 - j, U1 - j);
          if (band.empty()) continue;
          const long jj = L.wrap_row(j);
          const double xj = o.x + 0.5 * h * double(j & 1), scale = h * hy / area;
          for (long px = 0; px < out_width; ++px) {
            const double ta = (px * sx - xj) / h, tb = ((px + 1) * sx - xj) / h;
            double* a = acc.data() + std::size_t(px) * C;
            std::size_t ha = 0, hb = 0;
            const long i0 = static_cast<long>(std::floor(ta - n));
            for (long i = static_cast<long>(std::ceil(tb + n)); i >= i0; --i) {
              const double w = scale * (band.antiderivative(tb - i, hb) - band.antiderivative(ta - i, ha));
              if (w == 0) continue;
              const double* cf = k.c.row(jj) + std::size_t(L.wrap_column(i)) * C;
              for (int ch = 0; ch < C; ++ch) a[ch] += w * cf[ch];
            }
          }
        }
      } else {
        const double weight = 1.0 / display.offsets.size();
        for (const auto& [dy, dxs] : groups) {
          const double y = (r + 0.5 + dy) * sy;
          switch (C) {
            case 1: add_row_points<1>(k, L, B, y, dxs, sx, weight, acc.data(), out_width, s); break;
            case 3: add_row_points<3>(k, L, B, y, dxs, sx, weight, acc.data(), out_width, s); break;
            case 4: add_row_points<4>(k, L, B, y, dxs, sx, weight, acc.data(), out_width, s); break;
            default: add_row_points<0>(k, L, B, y, dxs, sx, weight, acc.data(), out_width, s);
          }
        }
      }
      float* o = out.row(r);
      for (std::size_t q = 0; q < acc.size(); ++q) o[q] = static_cast<float>(acc[q]);
    }
  });
  return out;
}

}  // namespace sis
