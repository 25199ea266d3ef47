#include "sis/lattice.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sis {

Lattice::Lattice(Vec2 origin, std::array<double, 4> matrix) : origin_(origin), L_(matrix) {
  if (!(std::abs(determinant()) > 0))
    throw std::invalid_argument("Lattice(): generating matrix is singular");
}

Lattice Lattice::cartesian(double hx, double hy) {
  if (!(hx > 0) || !(hy > 0))
    throw std::invalid_argument("Lattice::cartesian(): steps must be positive");
  return Lattice({0.5 * hx, 0.5 * hy}, {hx, 0.0, 0.0, hy});
}

Lattice Lattice::hexagonal(double density, Vec2 origin) {
  if (!(density > 0) || !std::isfinite(density))
    throw std::invalid_argument("Lattice::hexagonal(): density " + std::to_string(density) +
                                " must be positive");
  const double h = std::sqrt(2.0 / (std::sqrt(3.0) * density));
  return Lattice(origin, {h, 0.5 * h, 0.0, 0.5 * std::sqrt(3.0) * h});
}

bool Lattice::is_hexagonal() const {
  const double h = L_[0];
  return h > 0 && L_[2] == 0.0 && std::abs(L_[1] - 0.5 * h) <= 1e-12 * h &&
         std::abs(L_[3] - 0.5 * std::sqrt(3.0) * h) <= 1e-12 * h;
}

Vec2 Lattice::position(double n1, double n2) const {
  return {origin_.x + L_[0] * n1 + L_[1] * n2, origin_.y + L_[2] * n1 + L_[3] * n2};
}

Vec2 Lattice::coordinates(Vec2 x) const {
  const double dx = x.x - origin_.x, dy = x.y - origin_.y, det = determinant();
  return {(L_[3] * dx - L_[1] * dy) / det, (-L_[2] * dx + L_[0] * dy) / det};
}

double Lattice::axis_position(int axis, double n) const {
  if (!separable()) throw std::logic_error("Lattice::axis_position(): lattice is not separable");
  return axis == 0 ? origin_.x + L_[0] * n : origin_.y + L_[3] * n;
}

std::array<long, 2> Lattice::extent(double width, double height) const {
  if (!separable()) throw std::logic_error("Lattice::extent(): lattice is not separable");
  const double nx = width / L_[0], ny = height / L_[3];
  const long ix = std::lround(nx), iy = std::lround(ny);
  if (ix < 1 || iy < 1 || std::abs(nx - ix) > 1e-9 * nx || std::abs(ny - iy) > 1e-9 * ny) {
    std::ostringstream m;
    m << "Lattice::extent(): steps (" << L_[0] << ", " << L_[3] << ") do not tile a " << width
      << " x " << height << " image";
    throw std::invalid_argument(m.str());
  }
  return {ix, iy};
}

std::string Lattice::description() const {
  std::ostringstream s;
  s.precision(17);
  s << (separable() ? "cartesian" : is_hexagonal() ? "hexagonal" : "general") << " origin "
    << origin_.x << " " << origin_.y
    << " matrix " << L_[0] << " " << L_[1] << " " << L_[2] << " " << L_[3];
  return s.str();
}

}  // namespace sis
