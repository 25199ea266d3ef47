#pragma once
// Resampling: samples the continuous approximation
// f_app(x) = sum_n c[n] phi((x - x_n) / h) for a final image of any size.
// Final pixel (i, j) of a W x H image over an image of image_width x
// image_height output pixels has centre ((i + 1/2) sx, (j + 1/2) sy),
// sx = image_width / W. Offsets are in final pixels. Coefficients beyond the
// lattice's extent follow the coefficients' boundary rule.
#include <string>
#include <vector>

#include "sis/image.h"

namespace sis {

// A display's offsets reach at most the neighbouring pixels' centres (a
// pixel's own samples lie within half a pixel; an offset beyond one pixel
// samples another pixel's content), and a pixel averages at most 1024 of
// them (each one costs a full resampling pass).
inline constexpr double kMaxDisplayOffset = 1.0;
inline constexpr std::size_t kMaxDisplayOffsets = 1024;

struct Display {
  enum class Mode {
    Points,        // mean of f_app at centre + each offset
    PixelAverage,  // exact average of f_app over the pixel's square
  };
  Mode mode = Mode::Points;
  std::vector<Vec2> offsets{{0, 0}};

  static Display centred() { return {}; }
  static Display antialiased_2x2() {  // off-centre antialiasing at (+-1/4, +-1/4)
    return {Mode::Points, {{-0.25, -0.25}, {0.25, -0.25}, {-0.25, 0.25}, {0.25, 0.25}}};
  }
  static Display pixel() { return {Mode::PixelAverage, {}}; }
  // "centred" (also centered, centre, center), "2x2", "pixel" or
  // "offsets:DX,DY;DX,DY;..." (each offset
  // within kMaxDisplayOffset of the centre, at most kMaxDisplayOffsets of
  // them); throws std::invalid_argument naming the spelling.
  static Display parse(const std::string& spelling);
  std::string name() const;
};

// f_app at one point (direct evaluation; slow, for tests and probes).
double evaluate(const Coefficients& coefficients, Vec2 x, int channel = 0);

// The final image of out_width x out_height pixels.
Image resample(const Coefficients& coefficients, const Display& display, long out_width,
               long out_height, int threads = 1);

}  // namespace sis
