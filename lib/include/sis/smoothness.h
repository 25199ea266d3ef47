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
#include "sis/box_spline.h"
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

// The functional on the hexagonal lattice (docs/design.md section 15), for
// f(x) = sum_k c_k phi(x - x_k), phi(x) = M_n(L^{-1} x) the three-directional
// box spline (sis/box_spline.h), L the lattice's matrix (output pixels):
// J(f) = c^T R c with R the shift-invariant stencil
//   R_d = int D phi(x) . D phi(x - x_d) dx
// over lattice offsets d, D the gradient (order 1) or the Hessian with the
// Frobenius product (order 2: f_xx^2 + 2 f_xy^2 + f_yy^2). With B = L^{-1}:
// grad_x = B^T grad_u, Hessian_x = B^T H_u B, dx = |det L| du.
//
// How computed: on every triangle of the box spline's mesh both phi(u) and
// phi(u - d) are polynomials (BoxSpline::piece, d an integer offset maps the
// mesh to itself); their derivatives are differentiated analytically from
// the pieces' coefficients and the products integrated over the triangle by
// a Gauss-Legendre product rule in collapsed (Duffy) coordinates,
// w1 = s, w2 = (1 - s) t, of 8 x 8 points: exact for the degree 6n - 6
// (order 1) or 6n - 8 (order 2) products (degree + 1 in s after the
// Jacobian 1 - s). So R is exact to rounding; it is then symmetrised
// (R_d = R_-d) and R_0 set to minus the sum of the others, so that
// constants have no energy to the last bit.
//
// The coefficients are those of the offset-row grid (sis/hex_lattice.h),
// periodic on it (the hexagonal fit's model), so c^T R c is the functional
// integrated over one period of the grid: the frame and its margin.
// Order 2 needs phi in H^2: the hex-quartic (n = 2, C2); the hexagonal hat
// (n = 1, C0) is refused for order 2 (its second derivatives are line
// deltas on the mesh's edges).
class HexSmoothnessOperator {
 public:
  // order 1 or 2; matrix: the lattice's (row-major, x = L u), as Lattice::matrix().
  HexSmoothnessOperator(const BoxSpline& spline, int order, const std::array<double, 4>& matrix);
  // out = R c, c periodic on its offset-row grid (rows even). Threads split
  // the rows, each output summed in a fixed order: the same bits for any
  // thread count.
  void apply(const Grid<double>& c, Grid<double>& out, int threads = 1) const;
  // J of the coefficients, per channel: c^T R c.
  std::vector<double> energy(const Grid<double>& c) const;
  // The stencil R_d, d over the hexagon of radius 2n - 1 (nonzero taps).
  const std::vector<HexTap>& taps() const { return taps_; }
  int order() const { return order_; }

 private:
  int order_;
  std::vector<HexTap> taps_;
};

// A symmetric tap vector's transform at angular frequency w:
// t[0] + 2 sum_k t[k] cos(k w).
double taps_spectrum(const std::vector<double>& taps, double w);

}  // namespace sis
