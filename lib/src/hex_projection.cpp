#include "sis/hex_projection.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

namespace sis {

namespace {
template <typename T>
Coefficients project_grid(const Grid<T>& input, double W, double H, const HexProjectionOptions& o) {
  const int margin = o.margin >= 0 ? o.margin : hex_default_margin(o.order);
  const HexAcquisitionPlan plan(input.width, input.height, input.channels, W, H,
                                hex_layout(o.density, W, H, margin), o.order, o.boundary);
  Coefficients k = acquire(input, plan, o.threads);
  hex_prefilter(k, o.threads);
  return k;
}
}  // namespace

Coefficients project_hexagonal(const Image& input, double W, double H,
                               const HexProjectionOptions& o) {
  return project_grid(input, W, H, o);
}

Coefficients project_hexagonal(const Grid<double>& input, double W, double H,
                               const HexProjectionOptions& o) {
  return project_grid(input, W, H, o);
}

HexNoiseGain hex_noise_gain(int order, double density, long N, int s, long border) {
  if (N < 16 || s < 1 || border < 0 || 2 * border >= N || !(density > 0) || !std::isfinite(density))
    throw std::invalid_argument("hex_noise_gain(): frame " + std::to_string(N) + ", factor " +
                                std::to_string(s) + ", border " + std::to_string(border) +
                                " or density " + std::to_string(density) + " out of range");
  const HexLayout L = hex_layout(density, double(N), double(N), hex_default_margin(order));
  // An impulse's acquisition reaches the support's radius, the Lagrange taps
  // and one aligned step: impulses P pixels apart, P the smallest divisor of
  // N above twice that, so that each coefficient touched is nearest to its
  // own impulse.
  const double reach = order * L.step() + 2.0 / s + L.step() / 2;
  long Ppx = 0;
  for (long d = 1; d <= N && !Ppx; ++d)
    if (N % d == 0 && d > 2 * reach) Ppx = d;
  if (!Ppx)
    throw std::invalid_argument("hex_noise_gain(): frame " + std::to_string(N) +
                                " is too small for the acquisition's reach");
  const long D = Ppx * s, per = N * s / D;
  const HexAcquisitionPlan plan(N * s, N * s, 1, double(N), double(N), L, order, Boundary::Periodic);
  const long Q = L.columns, R = L.rows, count = Q * R;
  // G = sum_q w_q w_q', w_q the acquisition of an impulse at sample q
  std::unordered_map<long long, double> G;
  std::unordered_map<long, std::vector<std::pair<long, double>>> columns;
  auto nearest = [&](double pos, long first) {  // impulse index modulo the frame
    const long m = std::lround((pos - (first + 0.5) / double(s)) / (double(D) / s));
    return ((m % per) + per) % per;
  };
  for (long b = 0; b < D; ++b)
    for (long a = 0; a < D; ++a) {
      Grid<double> in(N * s, N * s, 1);
      for (long y = b; y < N * s; y += D)
        for (long x = a; x < N * s; x += D) in.at(x, y, 0) = 1.0;
      const Coefficients k = acquire(in, plan, 1);
      columns.clear();
      for (long j = 0; j < R; ++j)
        for (long i = 0; i < Q; ++i) {
          const double v = k.c.at(i, j, 0);
          if (v == 0) continue;
          const Vec2 p = L.position(i, j);
          columns[nearest(p.y, b) * per + nearest(p.x, a)].emplace_back(j * Q + i, v);
        }
      for (const auto& [q, w] : columns)
        for (const auto& [kk, vk] : w)
          for (const auto& [ll, vl] : w) G[(long long)kk * count + ll] += vk * vl;
    }
  std::vector<std::tuple<long, long, double>> Gs;
  Gs.reserve(G.size());
  for (const auto& [key, g] : G) Gs.emplace_back(long(key / count), long(key % count), g);
  // x_n = P r_n for the pixels inside the border, y_n = G x_n
  const BoxSpline& B = BoxSpline::hexagonal(order);
  const HexPrefilterPlan prefilter(order, Q, R);
  std::vector<std::vector<double>> x, y;
  for (long pj = border; pj < N - border; ++pj)
    for (long pi = border; pi < N - border; ++pi) {
      Grid<double> r(Q, R, 1);
      const Vec2 uc = L.lattice.coordinates({pi + 0.5, pj + 0.5});
      for (long j = 0; j < R; ++j)
        for (long i = 0; i < Q; ++i) {
          const Vec2 u = L.lattice.coordinates(L.position(i, j));
          if (std::abs(uc.y - u.y) > order + 1 || std::abs(uc.x - u.x) > 2 * order + 2) continue;
          r.at(i, j, 0) = B.eval(uc.x - u.x, uc.y - u.y);
        }
      prefilter.execute(r, 1);
      std::vector<double> gx(count, 0.0);
      for (const auto& [kk, ll, g] : Gs) gx[kk] += g * r.data[ll];
      x.emplace_back(r.data.begin(), r.data.end());
      y.push_back(std::move(gx));
    }
  const long P = long(x.size()), side = N - 2 * border;
  double mean = 0, cov2 = 0;
  for (long a = 0; a < P; ++a)
    for (long b = 0; b < P; ++b) {
      if (std::abs(a % side - b % side) > 6 || std::abs(a / side - b / side) > 6) continue;
      double c = 0;
      for (long q = 0; q < count; ++q) c += x[b][q] * y[a][q];
      if (a == b) mean += c;
      cov2 += c * c;
    }
  mean /= P;
  return {double(s) * s * mean, std::sqrt(2 * cov2) / (P * mean)};
}

}  // namespace sis
