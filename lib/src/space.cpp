#include "sis/space.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "sis/box_spline.h"
#include "sis/hex_lattice.h"
#include "sis/hex_prefilter.h"
#include "sis/hex_resample.h"

namespace sis {

SpaceKind space_of(const Coefficients& k) {
  if (k.box_spline) {
    if (!k.lattice.is_hexagonal())
      throw std::invalid_argument("space_of(): a box spline on a lattice that is not hexagonal (" +
                                  k.lattice.description() + ")");
    return SpaceKind::Hexagonal;
  }
  if (k.lattice.is_hexagonal())
    throw std::invalid_argument("space_of(): a hexagonal lattice without its box spline");
  return SpaceKind::Cartesian;
}

std::string space_name(SpaceKind kind) {
  return kind == SpaceKind::Hexagonal ? "hexagonal" : "cartesian";
}

namespace {
std::string number(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

Metadata lattice_metadata(const Coefficients& k, const char* lattice, const char* storage) {
  const Vec2 o = k.lattice.origin();
  const auto& L = k.lattice.matrix();
  return {
      {"sis:lattice", lattice},
      // rows: c(i, j) at o + L (i, j); offset-rows (sis/hex_lattice.h): at
      // o + h (i + (j mod 2)/2, (sqrt(3)/2) j), periodic on the grid
      {"sis:storage", storage},
      {"sis:lattice_origin", number(o.x) + " " + number(o.y)},
      {"sis:lattice_matrix",
       number(L[0]) + " " + number(L[1]) + " " + number(L[2]) + " " + number(L[3])},
  };
}
}  // namespace

std::string CartesianSpace::generator_name(const Coefficients& k) { return k.generator.name(); }
double CartesianSpace::radius(const Coefficients& k) { return k.generator.radius(); }
std::pair<long, long> CartesianSpace::frame(const Coefficients& k) { return {k.c.width, k.c.height}; }
Metadata CartesianSpace::metadata(const Coefficients& k) {
  Metadata md = lattice_metadata(k, k.lattice.separable() ? "cartesian" : "general", "rows");
  md.push_back({"sis:generator", k.generator.name()});
  md.push_back({"sis:degree", std::to_string(k.generator.degree())});
  return md;
}

void HexagonalSpace::prefilter(Coefficients& k, int threads, PrefilterMethod method) {
  if (method != PrefilterMethod::FFT)
    throw std::invalid_argument("prefilter(): the hexagonal lattice has the FFT prefilter only");
  hex_prefilter(k, threads);
}
Image HexagonalSpace::resample(const Coefficients& k, const Display& display, long W, long H,
                               int threads) {
  return hex_resample(k, display, W, H, threads);
}
double HexagonalSpace::evaluate(const Coefficients& k, Vec2 x, int channel) {
  return hex_evaluate(k, x, channel);
}
std::string HexagonalSpace::generator_name(const Coefficients& k) { return hex_generator(k).name(); }
double HexagonalSpace::radius(const Coefficients& k) {
  return hex_generator(k).radius() * k.lattice.matrix()[0];
}
std::pair<long, long> HexagonalSpace::frame(const Coefficients& k) {
  return {std::lround(k.image_width), std::lround(k.image_height)};
}
Metadata HexagonalSpace::metadata(const Coefficients& k) {
  Metadata md = lattice_metadata(k, "hexagonal", "offset-rows");
  md.push_back({"sis:generator", hex_generator(k).name()});
  // the degree of its polynomial pieces, 3n - 2
  md.push_back({"sis:degree", std::to_string(3 * hex_generator(k).order() - 2)});
  return md;
}

std::string generator_name(const Coefficients& k) {
  return visit_space(k, [&](auto space) { return space.generator_name(k); });
}

}  // namespace sis
