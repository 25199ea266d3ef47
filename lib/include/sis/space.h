#pragma once
// The spaces: a lattice with a generator, from a closed set. The Cartesian
// tensor space (the generator a Kernel: B-splines and the conventional
// filters, on the output pixels or any separable lattice) and the hexagonal
// box-spline space (the generator a three-directional box spline, on a
// hexagonal lattice stored in offset rows). Each is a type with the same
// small interface; visit_space() dispatches once per call on the space the
// coefficients live in, and no other code asks which lattice it has.
#include <string>
#include <utility>

#include "sis/image.h"
#include "sis/imageio.h"
#include "sis/prefilter.h"
#include "sis/resample.h"
#include "sis/weights.h"

namespace sis {

enum class SpaceKind { Cartesian, Hexagonal };

SpaceKind space_of(const Coefficients& k);
std::string space_name(SpaceKind kind);  // "cartesian" | "hexagonal"

struct CartesianSpace {
  static constexpr SpaceKind kind = SpaceKind::Cartesian;
  // c = r * a^{-1} (min-error; nothing for the conventional methods and degree 0)
  static void prefilter(Coefficients& k, int threads, PrefilterMethod method);
  static Image resample(const Coefficients& k, const Display& display, long W, long H, int threads);
  static double evaluate(const Coefficients& k, Vec2 x, int channel);
  // f_app along one axis at `count` points (i + 1/2) extent / count: the
  // table from coefficients to those points, the centred display's (the
  // continuous L2 error's plan).
  static AxisWeights sample_weights(const Coefficients& k, int axis, long count);
  static std::string generator_name(const Coefficients& k);
  static double radius(const Coefficients& k);  // of the generator, in lattice steps
  // The frame's own size in output pixels (its coefficient grid's, here).
  static std::pair<long, long> frame(const Coefficients& k);
  // sis:lattice, sis:storage, sis:generator, sis:degree of a coefficient file.
  static Metadata metadata(const Coefficients& k);
};

struct HexagonalSpace {
  static constexpr SpaceKind kind = SpaceKind::Hexagonal;
  static void prefilter(Coefficients& k, int threads, PrefilterMethod method);  // FFT only
  static Image resample(const Coefficients& k, const Display& display, long W, long H, int threads);
  static double evaluate(const Coefficients& k, Vec2 x, int channel);
  static std::string generator_name(const Coefficients& k);
  static double radius(const Coefficients& k);
  static std::pair<long, long> frame(const Coefficients& k);  // the grid also covers a margin
  static Metadata metadata(const Coefficients& k);
};

// "hex-hat" / "hex-quartic" in the hexagonal space, the Kernel's name in
// the Cartesian one.
std::string generator_name(const Coefficients& k);

template <typename F>
decltype(auto) visit_space(const Coefficients& k, F&& f) {
  if (space_of(k) == SpaceKind::Hexagonal) return f(HexagonalSpace{});
  return f(CartesianSpace{});
}

}  // namespace sis
