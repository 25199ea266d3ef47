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

// The exact noise gain of the hexagonal method with the centred display on
// a periodic N x N frame at integer factor s, white
// noise of variance 1 on the samples: pixel n's variance is
// ||(R P W)^T e_n||^2 = x_n' G x_n, x_n = P r_n the prefiltered resampling
// weights of pixel n (P = a^{-1} on the periodic grid, symmetric) and
// G = W W' the Gram of the acquisition weights over the samples, W's columns
// from impulse images (impulses further apart than twice the acquisition's
// reach, each coefficient touched belonging to the impulse nearest to it
// modulo the frame). gain: s^2 times the mean of x_n' G x_n over the pixels
// at least `border` from the edges (relative to 1 / s^2, a box average's
// variance); relative_sd: the relative standard deviation of that mean
// measured on one noise image, sqrt(2 sum_{n,m} Cov_nm^2) / (count mean),
// Cov_nm = x_m' G x_n over pairs at most 6 pixels apart (the rest below
// 1e-3 of the variance). Slow: seconds at N = 32.
struct HexNoiseGain {
  double gain = 0, relative_sd = 0;
};
HexNoiseGain hex_noise_gain(int order, double density, long N, int s, long border);

}  // namespace sis
