#pragma once
// The spline smoothness functional of the variational fit (docs/design.md
// section 15), exact for the Cartesian B-spline space of degree n with steps
// hx, hy: f(x, y) = sum_n c_n beta_n((x - x_n) / hx) beta_n((y - y_n) / hy),
//   order 1: J(f) = int |grad f|^2,
//   order 2: J(f) = int f_xx^2 + 2 f_xy^2 + f_yy^2 (thin plate),
// J(f) = c^T R c with R a convolution of the generator's derivative
// autocorrelations A_d[k] = int beta_n^(d)(u) beta_n^(d)(u - k) du
// = (-1)^d beta_{2n+1}^(2d)(k) (lattice units), integrated over the frame:
// the coefficients extended by the boundary rule (mirror: half-sample
// symmetric; periodic), so J is the integral over the frame exactly when the
// lattice's extent is the frame.
#include <vector>

#include "sis/boundary.h"
#include "sis/image.h"

namespace sis {

// A_d for degree n: taps k = -n .. n (2n + 1 values, k = 0 at index n).
// Throws std::invalid_argument unless 0 <= d <= n (beta_n^(d) square
// integrable needs d <= n).
std::vector<double> bspline_derivative_autocorrelation(int degree, int d);

// The functional's operator on a coefficient grid (channels independent).
class SmoothnessOperator {
 public:
  // order 1 or 2 (std::invalid_argument otherwise, or degree < order).
  SmoothnessOperator(int degree, int order, double hx, double hy, Boundary boundary);
  // out = R c, the coefficients extended by the boundary rule.
  void apply(const Grid<double>& c, Grid<double>& out) const;
  // J of the coefficients, per channel: c^T R c.
  std::vector<double> energy(const Grid<double>& c) const;
  // R's eigenvalue at the angular frequencies (wx, wy) of the boundary
  // rule's transform (mirror: DCT-II, w = pi k / n; periodic: DFT,
  // w = 2 pi k / n).
  double spectrum(double wx, double wy) const;
  int order() const { return order_; }

  struct Term {
    double scale;
    std::vector<double> x, y;  // taps, centred
  };
  const std::vector<Term>& terms() const { return terms_; }

 private:
  int order_;
  Boundary boundary_;
  std::vector<Term> terms_;
};

// A symmetric tap vector's transform at angular frequency w:
// t[0] + 2 sum_k t[k] cos(k w).
double taps_spectrum(const std::vector<double>& taps, double w);

}  // namespace sis
