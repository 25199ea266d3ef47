#pragma once
// Three-directional box splines, the generators of the hexagonal lattice
// (docs/design.md section 7).
//
// Lattice coordinates u = L^{-1} (x - x_n): on the hexagonal lattice the
// directions e1 = (1, 0), e2 = (1/2, sqrt(3)/2) and e3 = e2 - e1 are (1, 0),
// (0, 1) and (-1, 1) in u. M_n has each direction n times and is centred on 0:
//   M_n(u) = int N_n(t) N_n(u1 + t) N_n(u2 + n - t) dt,
// N_n the cardinal B-spline of order n on [0, n]. Integral 1 in u; partition
// of unity sum_k M_n(u - k) = 1 over the lattice; polynomial of degree 3n - 2
// on each triangle of the mesh cut by the lines u1, u2, u1 + u2 in Z; C^(2n-2);
// support the hexagon max(|u1|, |u2|, |u1 + u2|) <= n (radius n steps).
// n = 1 is the hexagonal hat (1 at 0, 0 at the six neighbours, linear on each
// triangle), n = 2 the C2 quartic. In output pixels phi(x) = M_n(L^{-1} x),
// whose integral is |det L|.
#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace sis {

constexpr int kMaxBoxSplineOrder = 2;

// M_n(u) by the integral above: Gauss-Legendre between the breakpoints of the
// piecewise polynomial integrand, so exact to rounding. Slow: a reference and
// the source of the piecewise polynomial form. n in [1, 8].
double box_spline_exact(int order, double u1, double u2);

// One tap of a lattice sequence: offset k (lattice indices) and value.
struct HexTap {
  int k1, k2;
  double value;
};

// M_n along a horizontal line, as a function of the horizontal offset
// t = (x - x_n) / h in lattice steps, at the height v = (y - y_n) / (h sqrt(3)/2)
// in rows: s(t) = M_n(t - v/2, v). A piecewise polynomial of degree 3n - 2,
// zero outside (-half_width, half_width), half_width = n - |v|/2. Even in t.
struct BoxSplineSlice {
  static constexpr int kMaxPieces = 4 * kMaxBoxSplineOrder + 2;
  static constexpr int kMaxCoefficients = 3 * kMaxBoxSplineOrder - 1;
  int pieces = 0, degree = 0;
  double half_width = 0;
  // piece p covers [lo[p], lo[p+1]) with value sum_a coef[p][a] (t - shift[p])^a
  std::array<double, kMaxPieces + 1> lo{};
  std::array<double, kMaxPieces> shift{};
  std::array<std::array<double, kMaxCoefficients>, kMaxPieces> coef{};

  double eval(double t) const;
  // Integral of s over [a, b], exact (antiderivative of each piece).
  double integrate(double a, double b) const;
  // Piece holding t (t inside the support); callers stepping along
  // increasing t pass the previous piece as a hint.
  int piece(double t, int hint = 0) const {
    while (hint + 1 < pieces && t >= lo[hint + 1]) ++hint;
    while (hint > 0 && t < lo[hint]) --hint;
    return hint;
  }
  double eval_piece(int p, double t) const {
    const double w = t - shift[p];
    double s = coef[p][degree];
    for (int a = degree - 1; a >= 0; --a) s = s * w + coef[p][a];
    return s;
  }
};

// The box spline M_n in piecewise polynomial form (computed once from
// box_spline_exact, by interpolation at the degree-(3n-2) principal lattice of
// each mesh triangle), with its autocorrelation on the lattice.
class BoxSpline {
 public:
  // The shared instance of order n: 1 = hex-hat, 2 = hex-quartic.
  static const BoxSpline& hexagonal(int order);
  // "hex-hat" | "hex-quartic"; throws std::invalid_argument naming the spelling.
  static const BoxSpline& parse(const std::string& spelling);

  int order() const { return n_; }
  int degree() const { return 3 * n_ - 2; }
  double radius() const { return n_; }  // lattice steps, to the hexagon's corners
  std::string name() const { return n_ == 1 ? "hex-hat" : "hex-quartic"; }

  // M_n at lattice coordinates u.
  double eval(double u1, double u2) const;
  // The horizontal slice at height v rows (see BoxSplineSlice).
  void slice(double v, BoxSplineSlice& out) const;

  // a[k] = int M_n(u) M_n(u - k) du over the lattice, k in the hexagon of
  // radius 2n - 1, by a triangle rule exact for the degree 6n - 4 product on
  // each mesh triangle. In output pixels <phi, phi(. - x_k)> = |det L| a[k].
  const std::vector<HexTap>& autocorrelation() const { return a_; }
  // A(w) = sum_k a[k] cos(w1 k1 + w2 k2), w the frequency in lattice
  // coordinates. Positive; A(0) = 1.
  double autocorrelation_spectrum(double w1, double w2) const;
  // max A / min A over w on a 192 x 192 grid of the period (holding the
  // extremes: 0 and the K points w = +-(2 pi/3, -2 pi/3)).
  double condition_number() const;

  // Coefficients of the polynomial on the triangle of the unit square at
  // corner (k1, k2), lower (w1 + w2 < 1) or upper, in local coordinates
  // w = u - (k1, k2): p(w) = sum_{a+b<=d} poly[a][b] w1^a w2^b. Zero outside
  // the support.
  static constexpr int kPolySize = 3 * kMaxBoxSplineOrder - 1;
  using Poly = std::array<std::array<double, kPolySize>, kPolySize>;
  const Poly& piece(int k1, int k2, bool upper) const;

 private:
  explicit BoxSpline(int order);
  int n_;
  std::vector<Poly> pieces_;  // (k1 + n, k2 + n, upper), k in [-n, n)
  std::vector<HexTap> a_;
  Poly zero_{};
};

// The band integral of M_n between heights v0 < v1 (rows), as a function of
// the horizontal offset t (steps): Z(t) = int_{v0}^{v1} M_n(t - v/2, v) dv,
// and its antiderivative Y(t) = int_{-inf}^t Z, so that the integral of M_n
// over the rectangle [t0, t1] x [v0, v1] of (t, v) is Y(t1) - Y(t0). Z is a
// polynomial of degree 3n - 1 between t in Z/2 and t = k +- v0/2, k +- v1/2
// (where the knot lines' crossings with the vertical line at t pass a row or
// an end of the band); each piece is interpolated from 3n exact values of Z
// (vertical line integrals, each exact by 3-point Gauss-Legendre between
// that line's knots), so Y is exact to rounding.
class BoxSplineBand {
 public:
  void build(const BoxSpline& spline, double v0, double v1);
  bool empty() const { return lo_.empty(); }
  // Y(t). Callers stepping along increasing t pass the same hint each time.
  double antiderivative(double t, std::size_t& hint) const {
    if (lo_.empty() || t <= lo_.front()) return 0.0;
    if (t >= lo_.back()) return total_;
    while (hint + 2 < lo_.size() && t >= lo_[hint + 1]) ++hint;
    while (hint > 0 && t < lo_[hint]) --hint;
    const double s = 2 * (t - lo_[hint]) / (lo_[hint + 1] - lo_[hint]) - 1;
    const auto& y = y_[hint];
    double v = y[degree_];
    for (int r = degree_ - 1; r >= 0; --r) v = v * s + y[r];
    return v;
  }
  double total() const { return total_; }  // int Z

 private:
  static constexpr int kMaxY = 3 * kMaxBoxSplineOrder + 1;
  std::vector<double> lo_;                   // piece p covers [lo_[p], lo_[p+1])
  std::vector<std::array<double, kMaxY>> y_;  // Y on piece p, in s = 2 (t - lo) / length - 1
  double total_ = 0;
  int degree_ = 0;
};

// Gauss-Legendre rule of m points on [0, 1] (nodes, weights), exact to degree 2m - 1.
void gauss_legendre01(int m, std::vector<double>& nodes, std::vector<double>& weights);

}  // namespace sis
