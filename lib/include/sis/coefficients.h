#pragma once
// Coefficients of an approximation f_app(x) = sum_n c[n] phi((x - x_n)/h)
// on a lattice covering a frame of image_width x image_height output pixels,
// in the space (sis/space.h) they were projected into, and what they are
// of: the channels, the remedies applied to the samples, the input's format
// and transfer. They describe themselves: a coefficient file records every
// field (imageio.h), and the final image needs nothing else of the caller.
// For the conventional methods c[n] are the filtered pixel values p[n] and
// phi is the filter.
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "sis/boundary.h"
#include "sis/image.h"
#include "sis/imageio.h"
#include "sis/lattice.h"
#include "sis/space.h"

namespace sis {

// The samples the coefficients were projected from, as a coefficient file
// records them (sis:input, sis:input_format, sis:input_transfer).
struct CoefficientInput {
  std::string label;  // "render.exr and 2 more bands"; messages name it
  bool half = false;  // every input stored half (the output's default sample type)
  Transfer transfer;  // the samples' transfer, decoded before projecting
};

struct Coefficients {
  Grid<double> c;
  Lattice lattice = Lattice::cartesian();
  // The space, with its generator: CartesianSpace{kernel} or
  // HexagonalSpace{order, density}. visit_space() dispatches on it.
  Space space;
  Boundary boundary = Boundary::Mirror;
  bool min_error = true;  // false: conventional normalised weighted average
  double image_width = 0, image_height = 0;

  std::vector<std::string> channel_names;  // one per channel of c ({}: default_channel_names)
  int alpha = -1;                          // the alpha channel (-1: none): not highlight-expanded
  bool highlight_compressed = false;       // c holds highlight-compressed values
  CoefficientInput input;

  // The Cartesian space's generator; std::invalid_argument in another space.
  const Kernel& kernel() const;
};

// f(space) on the space the coefficients live in.
template <typename F>
decltype(auto) visit_space(const Coefficients& k, F&& f) {
  return std::visit(std::forward<F>(f), k.space);
}

}  // namespace sis
