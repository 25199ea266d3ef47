#pragma once
// Lattices: x_n = o + L n, in output-pixel units (x right, y down; output pixel
// (i, j) covers [i, i+1) x [j, j+1)). Nothing outside this header assumes
// where coefficients sit: callers ask the lattice.
#include <array>
#include <string>

namespace sis {

struct Vec2 {
  double x = 0, y = 0;
};

class Lattice {
 public:
  // Rows of L are (L00, L01), (L10, L11); x_n = o + L (n1, n2)^T.
  Lattice(Vec2 origin, std::array<double, 4> matrix);

  // The Cartesian lattice with steps (hx, hy), origin at the centre of the
  // first cell: (hx/2, hy/2). With hx = hy = 1 coefficient n sits on pixel
  // centre n + 1/2.
  static Lattice cartesian(double hx = 1.0, double hy = 1.0);
  // The hexagonal lattice of `density` points per output pixel:
  // L = h [[1, 1/2], [0, sqrt(3)/2]], h = sqrt(2 / (sqrt(3) density)), so
  // det L = 1 / density. Rows of points are horizontal; each row is shifted
  // by h/2 from the one above. hex_layout() (sis/hex_lattice.h) places it on a
  // frame.
  static Lattice hexagonal(double density = 1.0, Vec2 origin = {0.0, 0.0});

  Vec2 origin() const { return origin_; }
  const std::array<double, 4>& matrix() const { return L_; }
  double determinant() const { return L_[0] * L_[3] - L_[1] * L_[2]; }

  // Position of coefficient (n1, n2).
  Vec2 position(double n1, double n2) const;
  // Continuous lattice coordinates of a point: L^{-1} (x - o).
  Vec2 coordinates(Vec2 x) const;

  // True when L is diagonal: positions factor per axis.
  bool separable() const { return L_[1] == 0.0 && L_[2] == 0.0; }
  // True when L has the form of hexagonal(): L10 = 0, L01 = L00/2,
  // L11 = L00 sqrt(3)/2 (to 1e-12 relative).
  bool is_hexagonal() const;
  // Per-axis position of index n (separable lattices only; axis 0 = x).
  double axis_position(int axis, double n) const;
  double axis_step(int axis) const { return axis == 0 ? L_[0] : L_[3]; }

  // Number of coefficients per axis covering an image of the given size
  // (output pixels). Throws when the lattice does not tile it exactly.
  std::array<long, 2> extent(double width, double height) const;

  std::string description() const;  // "cartesian 1 1" style, for metadata
 private:
  Vec2 origin_;
  std::array<double, 4> L_;
};

}  // namespace sis
