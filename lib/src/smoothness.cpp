#include "sis/smoothness.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "sis/generator.h"

namespace sis {

std::vector<double> bspline_derivative_autocorrelation(int degree, int d) {
  if (degree < 0 || d < 0 || d > degree)
    throw std::invalid_argument("smoothness: the derivative order " + std::to_string(d) +
                                " of a degree-" + std::to_string(degree) +
                                " B-spline is not square integrable (needs 0 <= d <= degree)");
  // (-1)^d beta_{2n+1}^(2d)(k) = (-1)^d sum_j (-1)^j C(2d, j) beta_{2n+1-2d}(k + d - j).
  const int p = 2 * degree + 1 - 2 * d;
  std::vector<double> a(2 * degree + 1, 0.0);
  for (int k = -degree; k <= degree; ++k) {
    double s = 0, binom = 1;
    for (int j = 0; j <= 2 * d; ++j) {
      s += ((j % 2) ? -binom : binom) * bspline(p, double(k + d - j));
      binom = binom * (2 * d - j) / (j + 1);
    }
    a[k + degree] = (d % 2) ? -s : s;
  }
  return a;
}

double taps_spectrum(const std::vector<double>& taps, double w) {
  const int r = int(taps.size() / 2);
  double s = taps[r];
  for (int k = 1; k <= r; ++k) s += 2 * taps[r + k] * std::cos(k * w);
  return s;
}

SmoothnessOperator::SmoothnessOperator(int degree, int order, double hx, double hy,
                                       Boundary boundary)
    : order_(order), boundary_(boundary) {
  if (order != 1 && order != 2)
    throw std::invalid_argument("smoothness: the order must be 1 or 2, not " +
                                std::to_string(order));
  if (degree < order)
    throw std::invalid_argument("smoothness: order " + std::to_string(order) +
                                " needs a B-spline of degree " + std::to_string(order) +
                                " or more, not " + std::to_string(degree));
  const auto A0 = bspline_derivative_autocorrelation(degree, 0);
  const auto A1 = bspline_derivative_autocorrelation(degree, 1);
  // d/dx = (1/hx) d/du and dx dy = hx hy du dv.
  if (order == 1) {
    terms_.push_back({hy / hx, A1, A0});
    terms_.push_back({hx / hy, A0, A1});
  } else {
    const auto A2 = bspline_derivative_autocorrelation(degree, 2);
    terms_.push_back({hy / (hx * hx * hx), A2, A0});
    terms_.push_back({2 / (hx * hy), A1, A1});
    terms_.push_back({hx / (hy * hy * hy), A0, A2});
  }
}

namespace {
long fold(long i, long n, Boundary b) {
  if (b == Boundary::Periodic) {
    i %= n;
    return i < 0 ? i + n : i;
  }
  const long p = 2 * n;
  i %= p;
  if (i < 0) i += p;
  return i < n ? i : p - 1 - i;
}
}  // namespace

void SmoothnessOperator::apply(const Grid<double>& c, Grid<double>& out) const {
  const long nx = c.width, ny = c.height;
  const int C = c.channels;
  std::fill(out.data.begin(), out.data.end(), 0.0);
  Grid<double> t(nx, ny, C);
  for (const Term& term : terms_) {
    const int rx = int(term.x.size() / 2), ry = int(term.y.size() / 2);
    // Along x, then along y, each in a fixed order (the same bits at any
    // thread count: this runs on one).
    for (long y = 0; y < ny; ++y)
      for (long x = 0; x < nx; ++x)
        for (int ch = 0; ch < C; ++ch) {
          double s = 0;
          for (int k = -rx; k <= rx; ++k)
            s += term.x[k + rx] * c.data[(std::size_t(y) * nx + fold(x + k, nx, boundary_)) * C + ch];
          t.data[(std::size_t(y) * nx + x) * C + ch] = s;
        }
    for (long y = 0; y < ny; ++y)
      for (long x = 0; x < nx; ++x)
        for (int ch = 0; ch < C; ++ch) {
          double s = 0;
          for (int k = -ry; k <= ry; ++k)
            s += term.y[k + ry] * t.data[(std::size_t(fold(y + k, ny, boundary_)) * nx + x) * C + ch];
          out.data[(std::size_t(y) * nx + x) * C + ch] += term.scale * s;
        }
  }
}

std::vector<double> SmoothnessOperator::energy(const Grid<double>& c) const {
  Grid<double> r(c.width, c.height, c.channels);
  apply(c, r);
  std::vector<double> e(c.channels, 0.0);
  for (std::size_t i = 0; i < c.data.size(); ++i) e[i % c.channels] += c.data[i] * r.data[i];
  return e;
}

double SmoothnessOperator::spectrum(double wx, double wy) const {
  double s = 0;
  for (const Term& t : terms_) s += t.scale * taps_spectrum(t.x, wx) * taps_spectrum(t.y, wy);
  return s;
}

}  // namespace sis
