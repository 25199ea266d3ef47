#include "sis/box_spline.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sis/generator.h"

namespace sis {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kReciprocal[] = {1.0, 1.0 / 2, 1.0 / 3, 1.0 / 4, 1.0 / 5, 1.0 / 6, 1.0 / 7};
static_assert(sizeof(kReciprocal) / sizeof(double) >= BoxSpline::kPolySize, "antiderivative table");
static_assert(BoxSplineSlice::kMaxCoefficients == BoxSpline::kPolySize, "slice and piece degrees");

double hex_norm(double u1, double u2) {
  return std::max({std::abs(u1), std::abs(u2), std::abs(u1 + u2)});
}

// Solves A x = y (n x n, row-major) by Gaussian elimination with partial pivoting.
std::vector<double> solve(std::vector<double> A, std::vector<double> y) {
  const std::size_t n = y.size();
  for (std::size_t c = 0; c < n; ++c) {
    std::size_t p = c;
    for (std::size_t r = c + 1; r < n; ++r)
      if (std::abs(A[r * n + c]) > std::abs(A[p * n + c])) p = r;
    for (std::size_t k = 0; k < n; ++k) std::swap(A[c * n + k], A[p * n + k]);
    std::swap(y[c], y[p]);
    for (std::size_t r = c + 1; r < n; ++r) {
      const double f = A[r * n + c] / A[c * n + c];
      for (std::size_t k = c; k < n; ++k) A[r * n + k] -= f * A[c * n + k];
      y[r] -= f * y[c];
    }
  }
  std::vector<double> x(n);
  for (std::size_t c = n; c-- > 0;) {
    double s = y[c];
    for (std::size_t k = c + 1; k < n; ++k) s -= A[c * n + k] * x[k];
    x[c] = s / A[c * n + c];
  }
  return x;
}

}  // namespace

void gauss_legendre01(int m, std::vector<double>& nodes, std::vector<double>& weights) {
  if (m < 1) throw std::invalid_argument("gauss_legendre01(): " + std::to_string(m) + " points");
  nodes.resize(m);
  weights.resize(m);
  for (int i = 0; i < m; ++i) {
    // Newton on the Legendre polynomial P_m, from the classical first guess.
    double x = std::cos(kPi * (i + 0.75) / (m + 0.5)), dp = 1;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = x;
      for (int k = 2; k <= m; ++k) {
        const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = m * (x * p1 - p0) / (x * x - 1);
      const double step = p1 / dp;
      x -= step;
      if (std::abs(step) < 1e-16) break;
    }
    double p0 = 1, p1 = x;
    for (int k = 2; k <= m; ++k) {
      const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
      p0 = p1;
      p1 = p2;
    }
    dp = m * (x * p1 - p0) / (x * x - 1);
    nodes[m - 1 - i] = 0.5 * (x + 1);
    weights[m - 1 - i] = 1.0 / ((1 - x * x) * dp * dp);  // 2 / ((1 - x^2) P'^2), halved for [0, 1]
  }
}

double box_spline_exact(int n, double u1, double u2) {
  if (n < 1 || n > 8)
    throw std::invalid_argument("box_spline_exact(): order " + std::to_string(n) +
                                " outside [1, 8]");
  if (!(hex_norm(u1, u2) < n)) return 0.0;
  // Breakpoints in t of N_n(t), N_n(u1 + t) and N_n(u2 + n - t).
  std::vector<double> b;
  for (int k = 0; k <= n; ++k) {
    b.push_back(k);
    b.push_back(k - u1);
    b.push_back(u2 + n - k);
  }
  std::sort(b.begin(), b.end());
  // The integrand is a polynomial of degree 3(n - 1) between breakpoints.
  const int m = (3 * n - 1) / 2;
  std::vector<double> x, w;
  gauss_legendre01(m, x, w);
  auto N = [n](double s) { return bspline(n - 1, s - 0.5 * n); };
  double sum = 0;
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double lo = std::max(b[i], 0.0), hi = std::min(b[i + 1], double(n));
    if (!(hi > lo)) continue;
    for (int q = 0; q < m; ++q) {
      const double t = lo + (hi - lo) * x[q];
      sum += (hi - lo) * w[q] * N(t) * N(u1 + t) * N(u2 + n - t);
    }
  }
  return sum;
}

double BoxSplineSlice::eval(double t) const {
  if (!(std::abs(t) < half_width)) return 0.0;
  return eval_piece(piece(t), t);
}

double BoxSplineSlice::integrate(double a, double b) const {
  if (b < a) return -integrate(b, a);
  a = std::max(a, -half_width);
  b = std::min(b, half_width);
  if (!(b > a)) return 0.0;
  double sum = 0;
  for (int p = piece(a); p < pieces && lo[p] < b; ++p) {
    const double x0 = std::max(a, lo[p]) - shift[p], x1 = std::min(b, lo[p + 1]) - shift[p];
    if (!(x1 > x0)) continue;
    double s1 = 0, s0 = 0;  // antiderivative sum_a coef_a x^(a+1) / (a+1), by Horner
    for (int k = degree; k >= 0; --k) {
      s1 = s1 * x1 + coef[p][k] * kReciprocal[k];
      s0 = s0 * x0 + coef[p][k] * kReciprocal[k];
    }
    sum += s1 * x1 - s0 * x0;
  }
  return sum;
}

BoxSpline::BoxSpline(int order) : n_(order) {
  const int n = n_, p = degree();
  // Interpolation at the principal lattice of each triangle: (p+1)(p+2)/2
  // points, unisolvent for degree p. Monomials w1^a w2^b, a + b <= p.
  std::vector<std::pair<int, int>> mono;
  for (int a = 0; a <= p; ++a)
    for (int b = 0; a + b <= p; ++b) mono.push_back({a, b});
  const std::size_t m = mono.size();
  pieces_.assign(std::size_t(2 * n) * (2 * n) * 2, Poly{});
  for (int k1 = -n; k1 < n; ++k1)
    for (int k2 = -n; k2 < n; ++k2)
      for (int upper = 0; upper < 2; ++upper) {
        std::vector<double> V(m * m), f(m);
        bool nonzero = false;
        std::size_t r = 0;
        for (int i = 0; i <= p; ++i)
          for (int j = 0; i + j <= p; ++j, ++r) {
            double w1 = double(i) / p, w2 = double(j) / p;
            if (upper) w1 = 1 - w1, w2 = 1 - w2;
            f[r] = box_spline_exact(n, k1 + w1, k2 + w2);
            nonzero = nonzero || f[r] != 0;
            for (std::size_t c = 0; c < m; ++c)
              V[r * m + c] = std::pow(w1, mono[c].first) * std::pow(w2, mono[c].second);
          }
        if (!nonzero) continue;
        const std::vector<double> coef = solve(V, f);
        Poly& P = pieces_[(std::size_t(k1 + n) * 2 * n + (k2 + n)) * 2 + upper];
        for (std::size_t c = 0; c < m; ++c) P[mono[c].first][mono[c].second] = coef[c];
      }

  // Autocorrelation: on each mesh triangle both factors are polynomials in the
  // same local coordinates; the conical product rule of q x q Gauss points,
  // w = (s, t (1 - s)) with Jacobian 1 - s, is exact to degree 2q - 2.
  const int q = p + 1;  // exact for the product, degree 2p
  std::vector<double> gx, gw;
  gauss_legendre01(q, gx, gw);
  auto poly_at = [p](const Poly& P, double w1, double w2) {
    double s = 0;
    for (int a = p; a >= 0; --a) {
      double inner = 0;
      for (int b = p - a; b >= 0; --b) inner = inner * w2 + P[a][b];
      s = s * w1 + inner;
    }
    return s;
  };
  const int K = 2 * n - 1;
  for (int k1 = -K; k1 <= K; ++k1)
    for (int k2 = -K; k2 <= K; ++k2) {
      if (hex_norm(k1, k2) > K) continue;
      double sum = 0;
      for (int c1 = -n; c1 < n; ++c1)
        for (int c2 = -n; c2 < n; ++c2)
          for (int upper = 0; upper < 2; ++upper) {
            const Poly& P = piece(c1, c2, upper);
            const Poly& Q = piece(c1 - k1, c2 - k2, upper);
            if (&P == &zero_ || &Q == &zero_) continue;
            for (int i = 0; i < q; ++i)
              for (int j = 0; j < q; ++j) {
                double w1 = gx[i], w2 = gx[j] * (1 - gx[i]);
                const double wt = gw[i] * gw[j] * (1 - gx[i]);
                if (upper) w1 = 1 - w1, w2 = 1 - w2;
                sum += wt * poly_at(P, w1, w2) * poly_at(Q, w1, w2);
              }
          }
      a_.push_back({k1, k2, sum});
    }
}

const BoxSpline& BoxSpline::hexagonal(int order) {
  static const BoxSpline hat(1), quartic(2);
  if (order == 1) return hat;
  if (order == 2) return quartic;
  throw std::invalid_argument("BoxSpline::hexagonal(): order " + std::to_string(order) +
                              " outside [1, " + std::to_string(kMaxBoxSplineOrder) + "]");
}

const BoxSpline& BoxSpline::parse(const std::string& s) {
  if (s == "hex-hat") return hexagonal(1);
  if (s == "hex-quartic") return hexagonal(2);
  throw std::invalid_argument("unknown hexagonal generator '" + s +
                              "' (expected hex-hat or hex-quartic)");
}

const BoxSpline::Poly& BoxSpline::piece(int k1, int k2, bool upper) const {
  if (k1 < -n_ || k1 >= n_ || k2 < -n_ || k2 >= n_) return zero_;
  const Poly& P = pieces_[(std::size_t(k1 + n_) * 2 * n_ + (k2 + n_)) * 2 + (upper ? 1 : 0)];
  return P;
}

double BoxSpline::eval(double u1, double u2) const {
  if (!(hex_norm(u1, u2) < n_)) return 0.0;
  const double f1 = std::floor(u1), f2 = std::floor(u2);
  const double w1 = u1 - f1, w2 = u2 - f2;
  const Poly& P = piece(int(f1), int(f2), w1 + w2 > 1);
  const int p = degree();
  double s = 0;
  for (int a = p; a >= 0; --a) {
    double inner = 0;
    for (int b = p - a; b >= 0; --b) inner = inner * w2 + P[a][b];
    s = s * w1 + inner;
  }
  return s;
}

void BoxSpline::slice(double v, BoxSplineSlice& out) const {
  const int p = degree();
  out.degree = p;
  out.half_width = n_ - 0.5 * std::abs(v);
  out.pieces = 0;
  if (!(out.half_width > 0) || !(std::abs(v) < n_)) {
    out.half_width = 0;
    return;
  }
  const double hw = out.half_width;
  // Breakpoints: the knot lines u1 in Z (t = k + v/2) and u1 + u2 in Z
  // (t = k - v/2), two increasing sequences merged, strictly inside (-hw, hw).
  double b[2 * BoxSplineSlice::kMaxPieces + 4];
  int nb = 0;
  b[nb++] = -hw;
  double ta = std::ceil(-hw - 0.5 * v) + 0.5 * v, tb = std::ceil(-hw + 0.5 * v) - 0.5 * v;
  if (ta <= -hw) ta += 1;
  if (tb <= -hw) tb += 1;
  for (;;) {
    const double t = std::min(ta, tb);
    if (!(t < hw)) break;
    if (t > b[nb - 1]) b[nb++] = t;
    if (ta == t) ta += 1;
    if (tb == t) tb += 1;
  }
  b[nb++] = hw;
  const double f2 = std::floor(v), w2 = v - f2;
  double pw[kPolySize];  // powers of w2
  pw[0] = 1;
  for (int c = 1; c < kPolySize; ++c) pw[c] = pw[c - 1] * w2;
  for (int i = 0; i + 1 < nb; ++i) {
    const int q = out.pieces++;
    out.lo[q] = b[i];
    const double u1 = 0.5 * (b[i] + b[i + 1]) - 0.5 * v;
    const double f1 = std::floor(u1);
    const Poly& P = piece(int(f1), int(f2), (u1 - f1) + w2 > 1);
    out.shift[q] = 0.5 * v + f1;
    for (int a = 0; a < kPolySize; ++a) {  // entries beyond the degree are zero
      double inner = 0;
      for (int c = 0; c < kPolySize; ++c) inner += P[a][c] * pw[c];
      out.coef[q][a] = inner;
    }
  }
  out.lo[out.pieces] = b[nb - 1];
}

namespace {

constexpr double kGauss3x[3] = {0.1127016653792583, 0.5, 0.8872983346207417};  // on [0, 1]
constexpr double kGauss3w[3] = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};

// Chebyshev nodes on [-1, 1], where monomials are well conditioned.
double chebyshev(int q, int m) { return -std::cos(kPi * (q + 0.5) / m); }

// Inverse of the monomial Vandermonde matrix at the m Chebyshev nodes:
// coefficient r = sum_q inv[r m + q] value_q.
std::vector<double> invert_vandermonde(int m) {
  std::vector<double> A(std::size_t(m) * 2 * m, 0.0);  // [V | I], Gauss-Jordan
  for (int q = 0; q < m; ++q) {
    for (int r = 0; r < m; ++r) A[q * 2 * m + r] = std::pow(chebyshev(q, m), r);
    A[q * 2 * m + m + q] = 1;
  }
  for (int c = 0; c < m; ++c) {
    int piv = c;
    for (int r = c + 1; r < m; ++r)
      if (std::abs(A[r * 2 * m + c]) > std::abs(A[piv * 2 * m + c])) piv = r;
    for (int k = 0; k < 2 * m; ++k) std::swap(A[c * 2 * m + k], A[piv * 2 * m + k]);
    const double d = A[c * 2 * m + c];
    for (int k = 0; k < 2 * m; ++k) A[c * 2 * m + k] /= d;
    for (int r = 0; r < m; ++r) {
      if (r == c) continue;
      const double f = A[r * 2 * m + c];
      for (int k = 0; k < 2 * m; ++k) A[r * 2 * m + k] -= f * A[c * 2 * m + k];
    }
  }
  std::vector<double> inv(std::size_t(m) * m);
  for (int r = 0; r < m; ++r)
    for (int q = 0; q < m; ++q) inv[r * m + q] = A[r * 2 * m + m + q];
  return inv;
}

// int_{v0}^{v1} M(t - v/2, v) dv: the vertical line at t meets the knot
// lines at v in Z, v = 2(t - k) and v = 2(k - t); between them the integrand
// has degree 3n - 2 <= 4, which 3-point Gauss-Legendre integrates exactly.
double column_integral(const BoxSpline& B, double t, double v0, double v1) {
  double b[64];
  int nb = 0;
  b[nb++] = v0;
  b[nb++] = v1;
  for (double v = std::floor(v0) + 1; v < v1; v += 1) b[nb++] = v;
  for (double k = std::floor(t - 0.5 * v1); k <= t - 0.5 * v0 + 1; k += 1) {
    const double v = 2 * (t - k);
    if (v > v0 && v < v1) b[nb++] = v;
  }
  for (double k = std::floor(t + 0.5 * v0); k <= t + 0.5 * v1 + 1; k += 1) {
    const double v = 2 * (k - t);
    if (v > v0 && v < v1) b[nb++] = v;
  }
  std::sort(b, b + nb);
  double s = 0;
  for (int i = 0; i + 1 < nb; ++i) {
    const double len = b[i + 1] - b[i];
    if (!(len > 0)) continue;
    for (int g = 0; g < 3; ++g) {
      const double v = b[i] + len * kGauss3x[g];
      s += len * kGauss3w[g] * B.eval(t - 0.5 * v, v);
    }
  }
  return s;
}

}  // namespace

void BoxSplineBand::build(const BoxSpline& B, double v0, double v1) {
  const int n = B.order(), m = 3 * n;  // Z has degree 3n - 1
  static const std::vector<double> inverse[kMaxBoxSplineOrder + 1] = {
      {}, invert_vandermonde(3), invert_vandermonde(6)};
  lo_.clear();
  y_.clear();
  total_ = 0;
  degree_ = m;
  v0 = std::max(v0, -double(n));
  v1 = std::min(v1, double(n));
  if (!(v1 > v0)) return;
  for (int k = -2 * n; k <= 2 * n; ++k) lo_.push_back(0.5 * k);
  for (int k = -n - 1; k <= n + 1; ++k)
    for (const double e : {0.5 * v0, -0.5 * v0, 0.5 * v1, -0.5 * v1})
      if (std::abs(k + e) < n) lo_.push_back(k + e);
  std::sort(lo_.begin(), lo_.end());
  lo_.erase(std::unique(lo_.begin(), lo_.end()), lo_.end());
  const std::vector<double>& inv = inverse[n];
  double z[kMaxY], value[kMaxY];
  double cum = 0;
  for (std::size_t p = 0; p + 1 < lo_.size(); ++p) {
    const double a = lo_[p], len = lo_[p + 1] - a;
    for (int q = 0; q < m; ++q)
      value[q] = column_integral(B, a + 0.5 * len * (chebyshev(q, m) + 1), v0, v1);
    for (int r = 0; r < m; ++r) {
      z[r] = 0;
      for (int q = 0; q < m; ++q) z[r] += inv[r * m + q] * value[q];
    }
    // Z = sum_r z_r s^r, s = 2 (t - a) / len - 1 in [-1, 1]; on the piece
    // Y = cum + (len/2) (P(s) - P(-1)), P(s) = sum_r z_r s^(r+1) / (r+1).
    std::array<double, kMaxY> y{};
    double p_minus = 0, p_plus = 0;
    for (int r = 0; r < m; ++r) {
      y[r + 1] = 0.5 * len * z[r] / (r + 1);
      p_minus += (r % 2 == 0 ? 1 : -1) * y[r + 1];  // (len/2) P(-1): (-1)^(r+1) terms
      p_plus += y[r + 1];
    }
    y[0] = cum + p_minus;
    y_.push_back(y);
    cum += p_plus + p_minus;
  }
  total_ = cum;
}

double BoxSpline::autocorrelation_spectrum(double w1, double w2) const {
  double s = 0;
  for (const HexTap& t : a_) s += t.value * std::cos(w1 * t.k1 + w2 * t.k2);
  return s;
}

double BoxSpline::condition_number() const {
  const int N = 192;
  double lo = 1e300, hi = -1e300;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) {
      const double A = autocorrelation_spectrum(2 * kPi * i / N, 2 * kPi * j / N);
      lo = std::min(lo, A);
      hi = std::max(hi, A);
    }
  return hi / lo;
}

}  // namespace sis
