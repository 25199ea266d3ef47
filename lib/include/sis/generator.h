#pragma once
// Generators: centred B-splines (the generators of the shift-invariant space)
// and the conventional reconstruction filters used for comparison.
// All kernels are 1-D, even, and used as tensor products in 2-D.
// Units: lattice steps (one output pixel on the Cartesian output lattice).
#include <string>
#include <vector>

namespace sis {

constexpr int kMaxDegree = 7;

// Centred B-spline of degree d, b_d(x): d+1 unit boxes convolved.
// Support radius (d+1)/2; integral 1. Stable O(d^2) evaluation. d in [0, 15].
double bspline(int degree, double x);

// Integral of b_d from -infinity to x (a piecewise polynomial of degree d+1).
double bspline_cumulative(int degree, double x);

// Autocorrelation of b_d on the integer lattice: a[k] = b_{2d+1}(k), k = 0..d
// (a[-k] = a[k]; zero for |k| > d).
std::vector<double> bspline_autocorrelation(int degree);

// Fourier transform of the autocorrelation sequence,
// A_d(w) = a[0] + 2 sum_k a[k] cos(k w). Positive for every w.
double bspline_autocorrelation_spectrum(int degree, double omega);
// The same from the autocorrelation a = bspline_autocorrelation(degree),
// computed once for many frequencies.
double bspline_autocorrelation_spectrum(const std::vector<double>& a, double omega);

// Poles z_i in (-1, 0) of 1/A_d (the interpolation prefilter of the degree
// 2d+1 B-spline), so that 1/A_d(Z) = G prod_i 1/((1 - z_i Z)(1 - z_i/Z)),
// with G = prod_i (1 - z_i)^2. Empty for d = 0. Sorted by |z| decreasing.
std::vector<double> bspline_prefilter_poles(int degree);

enum class KernelKind { BSpline, Mitchell, Gaussian, Lanczos };

// A closed set of 1-D kernels behind one small interface.
class Kernel {
 public:
  static Kernel bspline(int degree);  // box = 0, tent = 1, cubic = 3
  static Kernel mitchell(double B = 1.0 / 3.0, double C = 1.0 / 3.0);
  static Kernel catmull_rom() { return mitchell(0.0, 0.5); }
  // pbrt-v4's Gaussian: exp(-x^2 / (2 sigma^2)) minus its value at the radius.
  static Kernel gaussian(double sigma = 0.5, double radius = 1.5);
  static Kernel lanczos(int lobes = 3);  // sinc(x) sinc(x / lobes), |x| < lobes

  // Parses box, tent (also linear, and triangle as oiiotool names it),
  // quadratic, cubic, bspline:N, mitchell, catmull-rom, gaussian, lanczos3;
  // name() gives the first spelling. Throws std::invalid_argument naming
  // the spelling.
  static Kernel parse(const std::string& spelling);

  KernelKind kind() const { return kind_; }
  bool is_bspline() const { return kind_ == KernelKind::BSpline; }
  int degree() const { return degree_; }  // B-spline degree; -1 otherwise
  double radius() const { return radius_; }
  double eval(double x) const;
  // Integral of the kernel from a to b (exact for B-splines and Mitchell,
  // Gauss-Legendre to about 1e-12 otherwise).
  double integrate(double a, double b) const;
  double integral() const { return integrate(-radius_, radius_); }
  std::string name() const;
  double param(int i) const { return p_[i]; }

 private:
  KernelKind kind_ = KernelKind::BSpline;
  int degree_ = 3;
  double radius_ = 2;
  double p_[3] = {0, 0, 0};
};

}  // namespace sis
