#include "sis/hex_projection.h"

namespace sis {

namespace {
template <typename T>
Coefficients project_grid(const Grid<T>& input, double W, double H, const HexProjectionOptions& o) {
  const int margin = o.margin >= 0 ? o.margin : hex_default_margin(o.order);
  const HexAcquisitionPlan plan(input.width, input.height, input.channels, W, H,
                                hex_layout(o.density, W, H, margin), o.order, o.boundary);
  Coefficients k = acquire(input, plan, o.threads);
  hex_prefilter(k, o.threads);
  return k;
}
}  // namespace

Coefficients project_hexagonal(const Image& input, double W, double H,
                               const HexProjectionOptions& o) {
  return project_grid(input, W, H, o);
}

Coefficients project_hexagonal(const Grid<double>& input, double W, double H,
                               const HexProjectionOptions& o) {
  return project_grid(input, W, H, o);
}

}  // namespace sis
