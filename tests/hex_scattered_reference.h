#pragma once
// Slow direct references for scattered samples on the hexagonal lattice
// (tests/test_hex_scattered.cpp, tests/test_hex_variational.cpp): the box
// spline at a lattice point, every image of a sample, the fit's dense normal
// equations on the periodic grid.
#include <cmath>
#include <variant>
#include <vector>

#include "sis/box_spline.h"
#include "sis/hex_lattice.h"
#include "sis/scattered.h"

namespace sis::test {

inline HexLayout layout_of(const ScatteredTarget& t) {
  const auto& hex = std::get<HexagonalSpace>(t.space);
  return hex_layout(hex.density, t.width, t.height,
                    t.margin >= 0 ? t.margin : hex_default_margin(hex.order));
}

inline int order_of(const ScatteredTarget& t) { return std::get<HexagonalSpace>(t.space).order; }

inline double weight_of(const ScatteredSamples& s, const ScatteredTarget& t, long i) {
  return s.weights.empty() ? t.width * t.height / s.count() : s.weights[i];
}

// Every image of coordinate x of a frame of extent E, far beyond any grid
// the tests make (mirror: x + 2 k E and -x + 2 k E; periodic: x + k E).
inline std::vector<double> all_images(double x, double E, Boundary b) {
  std::vector<double> v;
  for (int k = -40; k <= 40; ++k) {
    if (b == Boundary::Mirror) {
      v.push_back(x + 2 * E * k);
      v.push_back(-x + 2 * E * k);
    } else {
      v.push_back(x + E * k);
    }
  }
  return v;
}

// M_n((x - p)) in output pixels: the box spline at lattice coordinates.
inline double phi(const BoxSpline& B, const HexLayout& L, double x, double y, Vec2 p) {
  const double h = L.step(), hy = L.row_step();
  const double u2 = (y - p.y) / hy, u1 = (x - p.x) / h - 0.5 * u2;
  return B.eval(u1, u2);
}

// The fit's normal equations on the periodic grid: the images inside one
// period D = [o.x - h/4, o.x - h/4 + Q h) x [o.y - hy/2, o.y - hy/2 + R hy),
// each weighing its sample's weight, against M_n of every lattice point,
// its stored index wrapped (the grid's periodic rule).
inline void normal_equations(const ScatteredSamples& s, const ScatteredTarget& t,
                             std::vector<std::vector<double>>& G, std::vector<double>& b) {
  const HexLayout L = layout_of(t);
  const BoxSpline& B = BoxSpline::hexagonal(order_of(t));
  const long Q = L.columns, R = L.rows, n = Q * R;
  const double h = L.step(), hy = L.row_step();
  const Vec2 o = L.lattice.origin();
  const double x0 = o.x - h / 4, y0 = o.y - hy / 2;
  G.assign(n, std::vector<double>(n, 0.0));
  b.assign(n, 0.0);
  std::vector<double> row(n);
  for (long i = 0; i < s.count(); ++i) {
    const double w = weight_of(s, t, i);
    for (double y : all_images(s.positions[2 * i + 1], t.height, t.boundary)) {
      if (y < y0 || y >= y0 + R * hy) continue;
      for (double x : all_images(s.positions[2 * i], t.width, t.boundary)) {
        if (x < x0 || x >= x0 + Q * h) continue;
        std::fill(row.begin(), row.end(), 0.0);
        for (long j = -R; j < 2 * R; ++j)
          for (long c = -Q; c < 2 * Q; ++c) {
            const Vec2 p = L.position(c, j);
            if (std::abs(p.x - x) > 2.1 * h || std::abs(p.y - y) > 2.1 * hy) continue;
            row[L.wrap_row(j) * Q + L.wrap_column(c)] += phi(B, L, x, y, p);
          }
        for (long a = 0; a < n; ++a) {
          if (row[a] == 0) continue;
          b[a] += w * s.values[i] * row[a];
          for (long m = 0; m < n; ++m) G[a][m] += w * row[a] * row[m];
        }
      }
    }
  }
}

}  // namespace sis::test
