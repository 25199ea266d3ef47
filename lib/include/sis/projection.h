#pragma once
// The whole method on an in-memory image: acquisition on the Cartesian
// output lattice, then (min-error) the digital prefilter. Streaming callers
// (siproject) use AcquisitionPlan / Acquisition / prefilter() directly.
#include "sis/coefficients.h"
#include "sis/acquisition.h"
#include "sis/prefilter.h"
#include "sis/resample.h"

namespace sis {

struct ProjectionOptions {
  Kernel generator = Kernel::bspline(3);
  Method method = Method::MinError;
  Boundary boundary = Boundary::Mirror;
  PrefilterMethod prefilter = PrefilterMethod::FFT;
  int threads = 1;
};

std::string method_name(Method m);  // "min-error" | "conventional"
Method parse_method(const std::string& spelling);

// Coefficients of the approximation of `input` (point samples covering an
// image of out_width x out_height output pixels) on the output lattice.
Coefficients project(const Image& input, long out_width, long out_height,
                     const ProjectionOptions& options);

// The final image. Min-error: f_app sampled by the display. Conventional:
// the filtered pixels p[n] themselves when the display is centred at the
// lattice's own size (what pbrt and oiiotool show); otherwise
// f_app = sum_n p[n] FILTER(x - x_n) sampled by the display.
Image final_image(const Coefficients& coefficients, const Display& display, long out_width,
                  long out_height, int threads = 1);

}  // namespace sis
