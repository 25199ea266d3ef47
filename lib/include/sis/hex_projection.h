#pragma once
// The whole method on the hexagonal lattice, on an in-memory image:
// acquisition on the offset-row grid covering the frame plus its margin, then
// the FFT prefilter. The final image is hex_resample() (or resample(), which
// dispatches on the lattice). Streaming callers (siproject) use
// HexAcquisitionPlan / HexAcquisition / prefilter() directly.
#include "sis/hex_acquisition.h"
#include "sis/hex_prefilter.h"
#include "sis/hex_resample.h"

namespace sis {

struct HexProjectionOptions {
  int order = 2;         // 1: hex-hat, 2: hex-quartic
  double density = 1.0;  // lattice points per output pixel
  Boundary boundary = Boundary::Mirror;  // extension of the input beyond the frame
  int margin = -1;       // lattice steps beyond the frame; -1: hex_default_margin(order)
  int threads = 1;
};

// Coefficients of the approximation of `input` (point samples covering a
// frame of image_width x image_height output pixels) on the hexagonal lattice.
Coefficients project_hexagonal(const Image& input, double image_width, double image_height,
                               const HexProjectionOptions& options);
Coefficients project_hexagonal(const Grid<double>& input, double image_width,
                               double image_height, const HexProjectionOptions& options);

}  // namespace sis
