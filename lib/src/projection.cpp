#include "sis/projection.h"

#include <stdexcept>

namespace sis {

std::string method_name(Method m) { return m == Method::MinError ? "min-error" : "conventional"; }

Method parse_method(const std::string& s) {
  if (s == "min-error") return Method::MinError;
  if (s == "conventional") return Method::Conventional;
  throw std::invalid_argument("unknown method '" + s + "' (expected min-error or conventional)");
}

Coefficients project(const Image& input, long out_width, long out_height,
                     const ProjectionOptions& o) {
  const AcquisitionPlan plan(input.width, input.height, input.channels, double(out_width),
                             double(out_height), Lattice::cartesian(), o.generator, o.boundary,
                             o.method);
  Coefficients k = acquire(input, plan, o.threads);
  prefilter(k, o.threads, o.prefilter);
  return k;
}

Image final_image(const Coefficients& k, const Display& display, long out_width,
                  long out_height, int threads) {
  const bool own_size = out_width == k.c.width && out_height == k.c.height &&
                        k.image_width == k.c.width && k.image_height == k.c.height;
  if (!k.min_error && own_size && display.name() == "centred") {
    Image out(out_width, out_height, k.c.channels);
    for (std::size_t q = 0; q < out.data.size(); ++q) out.data[q] = static_cast<float>(k.c.data[q]);
    return out;
  }
  return resample(k, display, out_width, out_height, threads);
}

}  // namespace sis
