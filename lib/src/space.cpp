#include "sis/space.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "sis/box_spline.h"
#include "sis/coefficients.h"
#include "sis/engine.h"
#include "sis/hex_acquisition.h"
#include "sis/hex_lattice.h"
#include "sis/memory.h"
#include "space_sinks.h"
#include "sis/hex_prefilter.h"
#include "sis/hex_resample.h"

namespace sis {

const Kernel& Coefficients::kernel() const {
  const auto* cartesian = std::get_if<CartesianSpace>(&space);
  if (!cartesian)
    throw std::invalid_argument("Coefficients::kernel(): coefficients of the " + space_name(space) +
                                " space have a box spline, not a Kernel");
  return cartesian->generator;
}

std::string space_name(const Space& space) {
  return visit_space(space, [](const auto& s) { return std::string(s.lattice_name); });
}

namespace {
const auto number = metadata_number;

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

std::string CartesianSpace::implied_method(const std::string& method, bool generator_given,
                                           bool method_given) const {
  return generator_given && !method_given && !generator.is_bspline() ? "conventional" : method;
}
void CartesianSpace::check(const SpaceRequest& rq) const { check_options(rq.method, rq.prefilter); }
void CartesianSpace::check_options(Method method, PrefilterMethod) const {
  if (method == Method::MinError && !generator.is_bspline())
    throw RequestError("--method min-error needs a B-spline generator (box, tent, quadratic, cubic, "
                       "bspline:N), not " + generator.name() + "; use --method conventional");
}
SpaceBudget CartesianSpace::budget(const SpaceRequest& rq) const {
  const long W = rq.width, H = rq.height;
  return {std::uint64_t(W) * std::uint64_t(H),
          table_bytes(W, rq.input_width, H, rq.input_height, generator.radius())};
}
std::unique_ptr<CartesianSink> CartesianSpace::sink(const SpaceRequest& rq) const {
  return std::make_unique<CartesianSink>(rq.input_width, rq.input_height, rq.channels, rq.width,
                                         rq.height, generator, rq.boundary, rq.method, rq.threads);
}
Metadata CartesianSpace::parameters() const { return {{"sis:generator", generator.name()}}; }
void CartesianSpace::read_metadata(const Attributes& attribute, Coefficients& k) {
  const auto& L = k.lattice.matrix();
  if (!k.lattice.separable() || !(L[0] > 0) || !(L[3] > 0) || attribute("sis:storage") != "rows")
    throw std::invalid_argument("sis:lattice cartesian needs a diagonal sis:lattice_matrix of "
                                "positive steps and sis:storage rows");
  k.space = CartesianSpace{Kernel::parse(attribute("sis:generator"))};
  const std::string degree = attribute("sis:degree");
  if (degree != std::to_string(k.kernel().degree()))
    throw std::invalid_argument("sis:degree '" + degree + "' is not the degree of generator " +
                                attribute("sis:generator"));
}
void CartesianSpace::check_grid(const Coefficients& k) {
  std::array<long, 2> e{0, 0};
  try {
    e = k.lattice.extent(k.image_width, k.image_height);
  } catch (const std::invalid_argument& ex) {
    throw std::invalid_argument(std::string("coefficient file metadata: ") + ex.what());
  }
  if (e[0] != k.c.width || e[1] != k.c.height)
    throw std::invalid_argument("coefficient grid size does not match its lattice and frame");
}
std::string CartesianSpace::describe(const Coefficients&) { return ""; }

std::string CartesianSpace::generator_name(const Coefficients& k) { return k.kernel().name(); }
double CartesianSpace::radius(const Coefficients& k) { return k.kernel().radius(); }
std::pair<long, long> CartesianSpace::frame(const Coefficients& k) { return {k.c.width, k.c.height}; }
Metadata CartesianSpace::metadata(const Coefficients& k) {
  Metadata md = lattice_metadata(k, k.lattice.separable() ? "cartesian" : "general", "rows");
  md.push_back({"sis:generator", k.kernel().name()});
  md.push_back({"sis:degree", std::to_string(k.kernel().degree())});
  return md;
}

void HexagonalSpace::check_options(Method method, PrefilterMethod prefilter) const {
  if (method != Method::MinError) throw RequestError("--lattice hex has the min-error method only");
  if (prefilter != PrefilterMethod::FFT) throw RequestError("--lattice hex has the fft prefilter only");
}
void HexagonalSpace::check(const SpaceRequest& rq) const {
  check_options(rq.method, rq.prefilter);
  if (!(std::isfinite(density) && density > 0)) {
    std::ostringstream m;
    m << "--density " << density << ": expected a finite number above 0";
    throw RequestError(m.str());
  }
  // The hexagonal acquisition sums samples under each lattice point: it
  // needs at least one sample per lattice step (it has no interpolation
  // model of the input, as the Cartesian one has where it upsamples), and
  // a lattice step no larger than the frame. Checked before the layout,
  // whose search for a transform size would run on an absurd grid.
  const long W = rq.width, H = rq.height;
  const double h = Lattice::hexagonal(density).matrix()[0];
  const double spacing =
      std::max(double(W) / double(rq.input_width), double(H) / double(rq.input_height));
  std::ostringstream m;
  m.precision(4);
  if (h < spacing) {
    m << "--lattice hex: the lattice's step (" << h << " output pixels at --density " << density
      << ") is finer than the input's sample spacing (" << spacing
      << " output pixels); the hexagonal acquisition needs a sample per lattice step: use "
         "--density at most "
      << 2 / (std::sqrt(3.0) * spacing * spacing) << ", or a smaller output";
    throw RequestError(m.str());
  }
  if (h > double(std::min(W, H))) {
    m << "--density " << density << ": the hexagonal lattice's step (" << h
      << " output pixels) is larger than the " << W << " x " << H << " frame";
    throw RequestError(m.str());
  }
}
SpaceBudget HexagonalSpace::budget(const SpaceRequest& rq) const {
  const long W = rq.width, H = rq.height;
  const HexLayout layout = hex_layout(density, double(W), double(H), hex_default_margin(order));
  SpaceBudget b;
  b.coefficients = std::uint64_t(layout.columns) * std::uint64_t(layout.rows);
  // its table grows with the input's samples per lattice cell
  b.tables = hex_acquisition_bytes(rq.input_width, rq.input_height, rq.channels, double(W),
                                   double(H), layout, order, rq.threads, 0, sizeof(float));
  const std::uint64_t available = available_memory();
  if (b.tables > double(available))
    throw RequestError("--lattice hex: the hexagonal acquisition of " +
                       std::to_string(rq.input_width) + " x " + std::to_string(rq.input_height) +
                       " samples onto a " + std::to_string(W) + " x " + std::to_string(H) +
                       " output needs about " + format_bytes(std::uint64_t(b.tables)) +
                       " of memory, more than the " + format_bytes(available) +
                       " available (its weight table grows with the samples per output pixel); "
                       "ask for a larger output (--size or --factor) or use --lattice cartesian");
  return b;
}
std::unique_ptr<HexagonalSink> HexagonalSpace::sink(const SpaceRequest& rq) const {
  const HexLayout layout =
      hex_layout(density, double(rq.width), double(rq.height), hex_default_margin(order));
  return std::make_unique<HexagonalSink>(rq.input_width, rq.input_height, rq.channels, rq.width,
                                         rq.height, layout, order, rq.boundary, rq.threads);
}
Metadata HexagonalSpace::parameters() const {
  return {{"sis:generator", BoxSpline::hexagonal(order).name()}, {"sis:density", number(density)}};
}
void HexagonalSpace::read_metadata(const Attributes& attribute, Coefficients& k) {
  if (!k.lattice.is_hexagonal() || attribute("sis:storage") != "offset-rows")
    throw std::invalid_argument("sis:lattice hexagonal needs a hexagonal sis:lattice_matrix "
                                "and sis:storage offset-rows");
  const int order = BoxSpline::parse(attribute("sis:generator")).order();
  k.space = HexagonalSpace{order, 1.0 / std::abs(k.lattice.determinant())};
  const std::string degree = attribute("sis:degree");
  if (degree != std::to_string(3 * order - 2))
    throw std::invalid_argument("sis:degree '" + degree + "' is not the degree of generator " +
                                attribute("sis:generator"));
}
void HexagonalSpace::check_grid(const Coefficients& k) { hex_layout(k); }
std::string HexagonalSpace::describe(const Coefficients& k) {
  char line[256];
  std::snprintf(line, sizeof line,
                "siproject: hexagonal lattice, %.6g points per output pixel (step %.6g), "
                "%ld x %ld offset-row coefficients over the frame and its margin\n",
                1.0 / std::abs(k.lattice.determinant()), k.lattice.matrix()[0], k.c.width,
                k.c.height);
  return line;
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

Space parse_space(const std::string& lattice, const std::string& generator, bool generator_given,
                  double density, bool density_given) {
  const bool hex = lattice == "hex" || lattice == HexagonalSpace::lattice_name;
  if (!hex && lattice != CartesianSpace::lattice_name)
    throw RequestError("--lattice '" + lattice + "': expected cartesian or hex (hexagonal)");
  if (!hex && density_given) throw RequestError("--density applies to --lattice hex only");
  if (!hex && generator.rfind("hex-", 0) == 0)
    throw RequestError("--generator " + generator + " needs --lattice hex");
  try {
    if (hex) return HexagonalSpace{BoxSpline::parse(generator_given ? generator : "hex-quartic").order(),
                                   density};
  } catch (const std::invalid_argument& e) {
    throw RequestError(std::string("--lattice hex: ") + e.what());
  }
  try {
    return CartesianSpace{Kernel::parse(generator)};
  } catch (const std::invalid_argument& e) {
    throw RequestError(std::string("--generator: ") + e.what());
  }
}

std::string generator_name(const Coefficients& k) {
  return visit_space(k, [&](auto space) { return space.generator_name(k); });
}

}  // namespace sis
