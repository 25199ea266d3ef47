#include "sis/smoothness.h"

#include <cmath>
#include <map>
#include <utility>
#include <stdexcept>
#include <string>

#include "sis/generator.h"
#include "sis/parallel.h"

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
// Per channel, sum over the grid of c times R c: the energy c^T R c.
std::vector<double> quadratic_form(const Grid<double>& c, const Grid<double>& rc) {
  std::vector<double> e(c.channels, 0.0);
  for (std::size_t i = 0; i < c.data.size(); ++i) e[i % c.channels] += c.data[i] * rc.data[i];
  return e;
}

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
  return quadratic_form(c, r);
}

double SmoothnessOperator::spectrum(double wx, double wy) const {
  double s = 0;
  for (const Term& t : terms_) s += t.scale * taps_spectrum(t.x, wx) * taps_spectrum(t.y, wy);
  return s;
}

namespace {

// The derivatives of a piece at w (lattice coordinates): g[0..1] the
// gradient, H[0..2] the Hessian's (11, 12, 22).
void piece_derivatives(const BoxSpline::Poly& P, int p, double w1, double w2, double* g, double* H) {
  double pw1[BoxSpline::kPolySize + 1], pw2[BoxSpline::kPolySize + 1];
  pw1[0] = pw2[0] = 1;
  for (int a = 1; a <= p; ++a) pw1[a] = pw1[a - 1] * w1, pw2[a] = pw2[a - 1] * w2;
  g[0] = g[1] = H[0] = H[1] = H[2] = 0;
  for (int a = 0; a <= p; ++a)
    for (int b = 0; a + b <= p; ++b) {
      const double c = P[a][b];
      if (c == 0) continue;
      if (a >= 1) g[0] += c * a * pw1[a - 1] * pw2[b];
      if (b >= 1) g[1] += c * b * pw1[a] * pw2[b - 1];
      if (a >= 2) H[0] += c * a * (a - 1) * pw1[a - 2] * pw2[b];
      if (a >= 1 && b >= 1) H[1] += c * a * b * pw1[a - 1] * pw2[b - 1];
      if (b >= 2) H[2] += c * b * (b - 1) * pw1[a] * pw2[b - 2];
    }
}

bool is_zero(const BoxSpline::Poly& P) {
  for (const auto& row : P)
    for (double v : row)
      if (v != 0.0) return false;
  return true;
}

}  // namespace

HexSmoothnessOperator::HexSmoothnessOperator(const BoxSpline& spline, int order,
                                             const std::array<double, 4>& L)
    : order_(order) {
  if (order != 1 && order != 2)
    throw std::invalid_argument("smoothness: the order must be 1 or 2, not " +
                                std::to_string(order));
  if (order == 2 && spline.order() < 2)
    throw std::invalid_argument(
        "smoothness: --smoothness 2 (the thin plate) needs second derivatives that are square "
        "integrable, which " + spline.name() +
        " (C0) does not have: use --smoothness 1 or --generator hex-quartic");
  const double det = L[0] * L[3] - L[1] * L[2];
  if (!(det != 0) || !std::isfinite(det))
    throw std::invalid_argument("smoothness: the lattice's matrix is singular");
  // B = L^{-1}, row-major.
  const double B[4] = {L[3] / det, -L[1] / det, -L[2] / det, L[0] / det};
  const double area = std::abs(det);
  // grad_x f = B^T grad_u f: (B^T g)_i = sum_r B[r][i] g_r.
  auto grad_x = [&](const double* g, double* out) {
    out[0] = B[0] * g[0] + B[2] * g[1];
    out[1] = B[1] * g[0] + B[3] * g[1];
  };
  // Hessian_x = B^T H B, symmetric: (xx, xy, yy).
  auto hess_x = [&](const double* h, double* out) {
    const double H[2][2] = {{h[0], h[1]}, {h[1], h[2]}};
    double M[2][2];
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) {
        double s = 0;
        for (int r = 0; r < 2; ++r)
          for (int q = 0; q < 2; ++q) s += B[r * 2 + i] * H[r][q] * B[q * 2 + j];
        M[i][j] = s;
      }
    out[0] = M[0][0];
    out[1] = 0.5 * (M[0][1] + M[1][0]);
    out[2] = M[1][1];
  };
  const int n = spline.order(), p = spline.degree();
  constexpr int m = 8;  // exact to degree 15 per axis of the collapsed square
  std::vector<double> gx, gw;
  gauss_legendre01(m, gx, gw);
  // The quadrature points of both triangles of the unit square, local w, and weights.
  struct Point {
    double w1, w2, weight;
  };
  std::vector<Point> lower, upper;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      const double s1 = gx[i], t = gx[j], w1 = s1, w2 = (1 - s1) * t, wt = gw[i] * gw[j] * (1 - s1);
      lower.push_back({w1, w2, wt});
      upper.push_back({1 - w1, 1 - w2, wt});
    }
  std::map<std::pair<int, int>, double> R;
  const int K = 2 * n;
  for (int d1 = -K; d1 <= K; ++d1)
    for (int d2 = -K; d2 <= K; ++d2) {
      double sum = 0;
      bool touched = false;
      for (int k1 = -n; k1 < n; ++k1)
        for (int k2 = -n; k2 < n; ++k2)
          for (int up = 0; up < 2; ++up) {
            const BoxSpline::Poly& P = spline.piece(k1, k2, up != 0);
            const BoxSpline::Poly& Q = spline.piece(k1 - d1, k2 - d2, up != 0);
            if (is_zero(P) || is_zero(Q)) continue;
            touched = true;
            for (const Point& q : up ? upper : lower) {
              double ga[2], ha[3], gb[2], hb[3];
              piece_derivatives(P, p, q.w1, q.w2, ga, ha);
              piece_derivatives(Q, p, q.w1, q.w2, gb, hb);
              double v;
              if (order == 1) {
                double xa[2], xb[2];
                grad_x(ga, xa);
                grad_x(gb, xb);
                v = xa[0] * xb[0] + xa[1] * xb[1];
              } else {
                double xa[3], xb[3];
                hess_x(ha, xa);
                hess_x(hb, xb);
                v = xa[0] * xb[0] + 2 * xa[1] * xb[1] + xa[2] * xb[2];
              }
              sum += q.weight * v;
            }
          }
      if (touched) R[{d1, d2}] = area * sum;
    }
  // Symmetrise, and make the taps sum to 0 exactly (constants: no energy).
  double off = 0;
  for (auto& [d, v] : R) {
    if (d.first == 0 && d.second == 0) continue;
    const auto it = R.find({-d.first, -d.second});
    const double sym = it == R.end() ? 0.5 * v : 0.5 * (v + it->second);
    taps_.push_back({d.first, d.second, sym});
    off += sym;
  }
  taps_.push_back({0, 0, -off});
}

void HexSmoothnessOperator::apply(const Grid<double>& c, Grid<double>& out, int threads) const {
  const long Q = c.width, Rw = c.height;
  const int C = c.channels;
  if (Rw % 2 != 0 || out.width != Q || out.height != Rw || out.channels != C)
    throw std::logic_error("HexSmoothnessOperator::apply(): not an offset-row grid, or sizes differ");
  auto floor_half = [](long m) { return m >= 0 ? m / 2 : -((1 - m) / 2); };
  parallel_for(Rw, threads, [&](long j0, long j1) {
    std::vector<double> acc(C);
    for (long j = j0; j < j1; ++j)
      for (long i = 0; i < Q; ++i) {
        std::fill(acc.begin(), acc.end(), 0.0);
        const long n1 = i - floor_half(j);
        for (const HexTap& t : taps_) {
          const long jj = j + t.k2, ii = n1 + t.k1 + floor_half(jj);
          const long wj = ((jj % Rw) + Rw) % Rw, wi = ((ii % Q) + Q) % Q;
          const double* v = c.data.data() + (std::size_t(wj) * Q + wi) * C;
          for (int ch = 0; ch < C; ++ch) acc[ch] += t.value * v[ch];
        }
        double* o = out.data.data() + (std::size_t(j) * Q + i) * C;
        for (int ch = 0; ch < C; ++ch) o[ch] = acc[ch];
      }
  });
}

std::vector<double> HexSmoothnessOperator::energy(const Grid<double>& c) const {
  Grid<double> r(c.width, c.height, c.channels);
  apply(c, r);
  return quadratic_form(c, r);
}

}  // namespace sis
