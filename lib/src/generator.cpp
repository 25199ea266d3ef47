#include "sis/generator.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>

namespace sis {

namespace {

constexpr double kPi = 3.14159265358979323846;

void check_degree(const char* fn, int degree, int max_degree) {
  if (degree < 0 || degree > max_degree)
    throw std::invalid_argument(std::string(fn) + "(): degree " + std::to_string(degree) +
                                " outside [0, " + std::to_string(max_degree) + "]");
}

double sinc(double x) {
  if (std::abs(x) < 1e-8) return 1.0;
  const double px = kPi * x;
  return std::sin(px) / px;
}

// 8-point Gauss-Legendre nodes and weights on [-1, 1].
constexpr double kGLx[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                            -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                            0.7966664774136267,  0.9602898564975363};
constexpr double kGLw[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                            0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                            0.2223810344533745, 0.1012285362903763};

}  // namespace

double bspline(int degree, double x) {
  check_degree("bspline", degree, 2 * kMaxDegree + 1);
  if (degree > 0) x = -std::abs(x);  // exactly even (b_0 is half-open)
  // Shift to the cardinal B-spline N_d(t), support [0, d+1].
  const double t = x + 0.5 * (degree + 1);
  if (t < 0.0 || t >= degree + 1) return 0.0;  // b_0 is 1 on [-1/2, 1/2)
  const int k = std::min(static_cast<int>(std::floor(t)), degree);
  const double u = t - k;
  // v[i] = N_j(u + i), i = 0..j, by the recurrence
  // N_j(t) = (t N_{j-1}(t) + (j + 1 - t) N_{j-1}(t - 1)) / j.
  double v[2 * kMaxDegree + 2] = {1.0};
  for (int j = 1; j <= degree; ++j) {
    for (int i = j; i >= 0; --i) {
      const double left = (i < j) ? (u + i) * v[i] : 0.0;
      const double right = (i > 0) ? (j + 1 - u - i) * v[i - 1] : 0.0;
      v[i] = (left + right) / j;
    }
  }
  return v[k];
}

double bspline_cumulative(int degree, double x) {
  check_degree("bspline_cumulative", degree, 2 * kMaxDegree);
  const double r = 0.5 * (degree + 1);
  if (x <= -r) return 0.0;
  if (x >= r) return 1.0;
  // Integral of b_d up to x = (b_d * H)(x), H = sum_{k>=0} box(. - 1/2 - k),
  // and b_d * box = b_{d+1}.
  double sum = 0.0;
  const double r1 = 0.5 * (degree + 2);
  for (int k = 0; x - 0.5 - k > -r1; ++k) sum += bspline(degree + 1, x - 0.5 - k);
  return sum;
}

std::vector<double> bspline_autocorrelation(int degree) {
  check_degree("bspline_autocorrelation", degree, kMaxDegree);
  std::vector<double> a(degree + 1);
  for (int k = 0; k <= degree; ++k) a[k] = bspline(2 * degree + 1, k);
  return a;
}

double bspline_autocorrelation_spectrum(int degree, double omega) {
  return bspline_autocorrelation_spectrum(bspline_autocorrelation(degree), omega);
}

double bspline_autocorrelation_spectrum(const std::vector<double>& a, double omega) {
  double s = a[0];
  for (std::size_t k = 1; k < a.size(); ++k) s += 2.0 * a[k] * std::cos(double(k) * omega);
  return s;
}

std::vector<double> bspline_prefilter_poles(int degree) {
  check_degree("bspline_prefilter_poles", degree, kMaxDegree);
  if (degree == 0) return {};
  // A(Z) = a0 + sum_k a_k (Z^k + Z^-k) = a0 + 2 sum_k a_k T_k(X), X = (Z + 1/Z)/2.
  // Its roots in X are real and below -1; each gives the pole z = X + sqrt(X^2 - 1).
  const std::vector<double> a = bspline_autocorrelation(degree);
  const int d = degree;
  std::vector<std::vector<double>> T(d + 1, std::vector<double>(d + 1, 0.0));
  T[0][0] = 1.0;
  if (d >= 1) T[1][1] = 1.0;
  for (int k = 2; k <= d; ++k)
    for (int i = 0; i <= k; ++i)
      T[k][i] = (i > 0 ? 2.0 * T[k - 1][i - 1] : 0.0) - T[k - 2][i];
  std::vector<double> p(d + 1, 0.0);  // monomial coefficients in X
  for (int i = 0; i <= d; ++i) p[i] = a[0] * T[0][i];
  for (int k = 1; k <= d; ++k)
    for (int i = 0; i <= d; ++i) p[i] += 2.0 * a[k] * T[k][i];
  // Durand-Kerner on the monic polynomial.
  using cd = std::complex<double>;
  std::vector<cd> roots(d);
  for (int i = 0; i < d; ++i) roots[i] = std::pow(cd(0.4, 0.9), i) * 3.0 - 2.0;
  auto eval = [&](cd x) {
    cd s = 0;
    for (int i = d; i >= 0; --i) s = s * x + p[i] / p[d];
    return s;
  };
  for (int it = 0; it < 2000; ++it) {
    double change = 0;
    for (int i = 0; i < d; ++i) {
      cd den = 1;
      for (int j = 0; j < d; ++j)
        if (j != i) den *= roots[i] - roots[j];
      const cd step = eval(roots[i]) / den;
      roots[i] -= step;
      change = std::max(change, std::abs(step));
    }
    if (change < 1e-15) break;
  }
  std::vector<double> poles;
  for (const cd& r : roots) {
    const double X = r.real();
    if (!(X < -1.0) || std::abs(r.imag()) > 1e-8)
      throw std::runtime_error("bspline_prefilter_poles(): root finding failed for degree " +
                               std::to_string(degree));
    poles.push_back(X + std::sqrt(X * X - 1.0));
  }
  std::sort(poles.begin(), poles.end());  // most negative (largest |z|) first
  return poles;
}

Kernel Kernel::bspline(int degree) {
  check_degree("Kernel::bspline", degree, kMaxDegree);
  Kernel k;
  k.kind_ = KernelKind::BSpline;
  k.degree_ = degree;
  k.radius_ = 0.5 * (degree + 1);
  return k;
}

Kernel Kernel::mitchell(double B, double C) {
  Kernel k;
  k.kind_ = KernelKind::Mitchell;
  k.degree_ = -1;
  k.radius_ = 2.0;
  k.p_[0] = B;
  k.p_[1] = C;
  return k;
}

Kernel Kernel::gaussian(double sigma, double radius) {
  if (!(sigma > 0) || !(radius > 0))
    throw std::invalid_argument("Kernel::gaussian(): sigma " + std::to_string(sigma) +
                                " and radius " + std::to_string(radius) + " must be positive");
  Kernel k;
  k.kind_ = KernelKind::Gaussian;
  k.degree_ = -1;
  k.radius_ = radius;
  k.p_[0] = sigma;
  k.p_[1] = std::exp(-radius * radius / (2 * sigma * sigma));
  return k;
}

Kernel Kernel::lanczos(int lobes) {
  if (lobes < 1)
    throw std::invalid_argument("Kernel::lanczos(): lobes " + std::to_string(lobes) + " < 1");
  Kernel k;
  k.kind_ = KernelKind::Lanczos;
  k.degree_ = -1;
  k.radius_ = lobes;
  k.p_[0] = lobes;
  return k;
}

Kernel Kernel::parse(const std::string& s) {
  if (s == "box") return bspline(0);
  if (s == "tent" || s == "linear" || s == "triangle") return bspline(1);  // triangle: oiiotool's name
  if (s == "quadratic") return bspline(2);
  if (s == "cubic") return bspline(3);
  if (s.rfind("bspline:", 0) == 0) {
    const std::string n = s.substr(8);
    if (n.size() == 1 && n[0] >= '0' && n[0] <= '0' + kMaxDegree) return bspline(n[0] - '0');
    throw std::invalid_argument("generator '" + s + "': degree must be 0 to " +
                                std::to_string(kMaxDegree));
  }
  if (s == "mitchell") return mitchell();
  if (s == "catmull-rom") return catmull_rom();
  if (s == "gaussian") return gaussian();
  if (s == "lanczos3") return lanczos(3);
  throw std::invalid_argument(
      "unknown generator '" + s +
      "' (expected box, tent, quadratic, cubic, bspline:N, mitchell, gaussian, catmull-rom, "
      "lanczos3)");
}

double Kernel::eval(double x) const {
  const double ax = std::abs(x);
  if (x < -radius_ || x >= radius_) return 0.0;  // half-open, as pixels are
  switch (kind_) {
    case KernelKind::BSpline:
      return sis::bspline(degree_, x);
    case KernelKind::Mitchell: {
      const double B = p_[0], C = p_[1];
      const double x2 = ax * ax, x3 = x2 * ax;
      if (ax < 1.0)
        return ((12 - 9 * B - 6 * C) * x3 + (-18 + 12 * B + 6 * C) * x2 + (6 - 2 * B)) / 6.0;
      return ((-B - 6 * C) * x3 + (6 * B + 30 * C) * x2 + (-12 * B - 48 * C) * ax +
              (8 * B + 24 * C)) /
             6.0;
    }
    case KernelKind::Gaussian:
      return std::max(0.0, std::exp(-x * x / (2 * p_[0] * p_[0])) - p_[1]);
    case KernelKind::Lanczos:
      return sinc(x) * sinc(x / p_[0]);
  }
  return 0.0;
}

double Kernel::integrate(double a, double b) const {
  if (b < a) return -integrate(b, a);
  a = std::max(a, -radius_);
  b = std::min(b, radius_);
  if (b <= a) return 0.0;
  if (kind_ == KernelKind::BSpline)
    return bspline_cumulative(degree_, b) - bspline_cumulative(degree_, a);
  // Piecewise smooth between integers: 8-point Gauss-Legendre on each piece
  // (exact for Mitchell's cubics).
  double sum = 0.0;
  double lo = a;
  while (lo < b) {
    const double hi = std::min(b, std::floor(lo) + 1.0);
    const double half = 0.5 * (hi - lo), mid = 0.5 * (hi + lo);
    for (int i = 0; i < 8; ++i) sum += half * kGLw[i] * eval(mid + half * kGLx[i]);
    lo = hi;
  }
  return sum;
}

std::string Kernel::name() const {
  switch (kind_) {
    case KernelKind::BSpline:
      switch (degree_) {
        case 0: return "box";
        case 1: return "tent";
        case 2: return "quadratic";
        case 3: return "cubic";
        default: return "bspline:" + std::to_string(degree_);
      }
    case KernelKind::Mitchell:
      if (p_[0] == 0.0 && p_[1] == 0.5) return "catmull-rom";
      return "mitchell";
    case KernelKind::Gaussian:
      return "gaussian";
    case KernelKind::Lanczos:
      return "lanczos" + std::to_string(static_cast<int>(p_[0]));
  }
  return "?";
}

}  // namespace sis
