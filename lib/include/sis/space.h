#pragma once
// The spaces: a lattice with a generator, from a closed set. The Cartesian
// tensor space (the generator a Kernel: B-splines and the conventional
// filters, on the output pixels or any separable lattice) and the hexagonal
// box-spline space (the generator a three-directional box spline, on a
// hexagonal lattice stored in offset rows). Each is a type that holds its
// own parameters (a request's Space is one of them) and has the same small
// interface, before the coefficients exist (its checks, its memory
// estimate, its acquisition sink) and after (prefilter, resample, evaluate,
// the coefficient file's metadata written and read). visit_space()
// dispatches once per call, on a request's space or on the space the
// coefficients live in, and no other code asks which lattice it has.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <variant>

#include "sis/acquisition.h"
#include "sis/boundary.h"
#include "sis/generator.h"
#include "sis/image.h"
#include "sis/imageio.h"
#include "sis/prefilter.h"
#include "sis/resample.h"
#include "sis/weights.h"

namespace sis {

struct Coefficients;  // sis/coefficients.h: they hold their space

// What a projection into a space costs before it runs: its coefficients
// (values per channel) and the bytes of its acquisition's tables.
struct SpaceBudget {
  std::uint64_t coefficients = 0;
  double tables = 0;
};
// The frame and the samples a projection asks a space for.
struct SpaceRequest {
  long input_width = 0, input_height = 0;  // the sample grid
  int channels = 0;
  long width = 0, height = 0;              // the output frame, in pixels
  Method method = Method::MinError;
  PrefilterMethod prefilter = PrefilterMethod::FFT;
  Boundary boundary = Boundary::Mirror;
  int threads = 1;
};
// A coefficient file's attributes by name ("" where absent).
using Attributes = std::function<std::string(const std::string&)>;

class CartesianSink;  // the acquisition sinks (lib/src/space_sinks.h)
class HexagonalSink;

struct CartesianSpace {
  static constexpr const char* lattice_name = "cartesian";  // sis:lattice
  Kernel generator = Kernel::bspline(3);

  // Before the coefficients: what of the request this space cannot do, as
  // RequestError (sis/engine.h) naming the option; what it costs (and
  // RequestError where that cannot fit); its acquisition.
  // The method a request means: a conventional filter named alone means
  // the conventional method.
  std::string implied_method(const std::string& method, bool generator_given,
                             bool method_given) const;
  void check_options(Method method, PrefilterMethod prefilter) const;
  void check(const SpaceRequest& rq) const;  // check_options, then the frame and samples
  SpaceBudget budget(const SpaceRequest& rq) const;
  using Sink = CartesianSink;
  std::unique_ptr<CartesianSink> sink(const SpaceRequest& rq) const;
  // Its parameters as metadata (sis:generator; a partial's request), as
  // parse_space reads them back.
  Metadata parameters() const;

  // c = r * a^{-1} (min-error; nothing for the conventional methods and degree 0)
  static void prefilter(Coefficients& k, int threads, PrefilterMethod method);
  static Image resample(const Coefficients& k, const Display& display, long W, long H, int threads);
  static double evaluate(const Coefficients& k, Vec2 x, int channel);
  // f_app along one axis at `count` points (i + 1/2) extent / count: the
  // table from coefficients to those points, the centred display's (the
  // continuous L2 error's plan).
  static AxisWeights sample_weights(const Coefficients& k, int axis, long count);
  // f_app at a grid of points is a product of per-axis tables
  // (sample_weights): the metrics' separable plans apply.
  static constexpr bool sampled_by_axes = true;
  static std::string generator_name(const Coefficients& k);
  static double radius(const Coefficients& k);  // of the generator, in lattice steps
  // The frame's own size in output pixels (its coefficient grid's, here).
  static std::pair<long, long> frame(const Coefficients& k);
  // sis:lattice, sis:storage, sis:generator, sis:degree of a coefficient file.
  static Metadata metadata(const Coefficients& k);
  // The generator of a file whose sis:lattice is lattice_name, into k (its
  // lattice already read), and the check of the grid read against its
  // metadata: std::invalid_argument saying what is wrong.
  static void read_metadata(const Attributes& attribute, Coefficients& k);
  static void check_grid(const Coefficients& k);
  // The lines siproject --verbose adds for coefficients in this space.
  static std::string describe(const Coefficients& k);
};

struct HexagonalSpace {
  static constexpr const char* lattice_name = "hexagonal";
  int order = 2;         // of the box spline: 1 hex-hat, 2 hex-quartic
  double density = 1.0;  // lattice points per output pixel

  std::string implied_method(const std::string& method, bool, bool) const { return method; }
  void check_options(Method method, PrefilterMethod prefilter) const;
  void check(const SpaceRequest& rq) const;
  SpaceBudget budget(const SpaceRequest& rq) const;
  using Sink = HexagonalSink;
  std::unique_ptr<HexagonalSink> sink(const SpaceRequest& rq) const;
  Metadata parameters() const;  // sis:generator, sis:density

  static void prefilter(Coefficients& k, int threads, PrefilterMethod method);  // FFT only
  static Image resample(const Coefficients& k, const Display& display, long W, long H, int threads);
  static double evaluate(const Coefficients& k, Vec2 x, int channel);
  static constexpr bool sampled_by_axes = false;  // the metrics evaluate f_app on the grid
  static std::string generator_name(const Coefficients& k);
  static double radius(const Coefficients& k);
  static std::pair<long, long> frame(const Coefficients& k);  // the grid also covers a margin
  static Metadata metadata(const Coefficients& k);
  static void read_metadata(const Attributes& attribute, Coefficients& k);
  static void check_grid(const Coefficients& k);
  static std::string describe(const Coefficients& k);
};

// A request's space.
using Space = std::variant<CartesianSpace, HexagonalSpace>;

// "hex-hat" / "hex-quartic" in the hexagonal space, the Kernel's name in
// the Cartesian one.
std::string generator_name(const Coefficients& k);

// visit_space(coefficients, f): sis/coefficients.h.
template <typename F>
decltype(auto) visit_space(const Space& space, F&& f) {
  return std::visit(std::forward<F>(f), space);
}
// f(S{}) for the space type S whose sis:lattice is `name`; false when none is.
template <typename F>
bool visit_lattice_name(const std::string& name, F&& f) {
  if (name == CartesianSpace::lattice_name) return f(CartesianSpace{}), true;
  if (name == HexagonalSpace::lattice_name) return f(HexagonalSpace{}), true;
  return false;
}
std::string space_name(const Space& space);
// The space siproject's --lattice, --generator and --density name (given:
// whether the user gave the option); RequestError naming the option.
Space parse_space(const std::string& lattice, const std::string& generator, bool generator_given,
                  double density, bool density_given);

}  // namespace sis
