// Projects a 64 x 64 ramp onto the cubic B-spline space at factor 4 and
// prints the middle of its centre row: 0.5 for the ramp (x + 0.5) / 64.
#include <cstdio>

#include "sis/projection.h"
#include "sis/resample.h"

int main() {
  sis::Image ramp(64, 64, 1);
  for (long y = 0; y < 64; ++y)
    for (long x = 0; x < 64; ++x) ramp.at(x, y, 0) = float((x + 0.5) / 64);
  sis::ProjectionOptions options;
  const sis::Coefficients k = sis::project(ramp, 16, 16, options);
  const sis::Image out = sis::final_image(k, sis::Display::centred(), 16, 16);
  std::printf("%.6f\n", 0.5 * (out.at(7, 8, 0) + out.at(8, 8, 0)));
}
