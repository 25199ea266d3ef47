#pragma once
// Measures of a result (docs/design.md section 8): high-pass energy share,
// differences against a reference, the continuous L2 error of an
// approximation, and overshoot of the input's local range. Sums run in
// double precision. Units are output pixels; pixel (i, j) covers
// [i, i+1) x [j, j+1) and its centre is (i + 1/2, j + 1/2).
#include <functional>
#include <memory>
#include <vector>

#include "sis/coefficients.h"
#include "sis/image.h"

namespace sis {

// Luminance of every pixel, one channel: Rec. 709 weights
// 0.2126 R + 0.7152 G + 0.0722 B of the first three channels when there are
// three or more (linear RGB; further channels such as alpha are ignored);
// channel 0 itself for one or two channels (grey, grey + alpha).
Grid<double> luminance(const ImageView& image);

// Share in [0, 1] of the luminance's DFT energy sum |F(k)|^2 at radial
// frequency sqrt(fx^2 + fy^2) strictly greater than the cutoff (cycles per
// pixel; fx = kx / W with kx folded into [-W/2, W/2], likewise fy), so a
// component exactly at the cutoff counts as low-pass. The mean is removed:
// the DC term is left out of both sums. 0 for a constant image. The DFT is
// periodic: the image's edges meet, and a jump between them adds high-pass
// energy. Cutoffs must be finite and >= 0, and so must every luminance
// value (throws std::invalid_argument otherwise); one DFT serves every cutoff.
std::vector<double> highpass_energy_shares(const ImageView& image, const std::vector<double>& cutoffs);
double highpass_energy_share(const ImageView& image, double cutoff_cycles_per_pixel);

// RMS over every channel of a - b, leaving out a band of `border` pixels
// along each edge. The images must have equal sizes and channel counts.
double rms_difference(const ImageView& a, const ImageView& b, long border = 0);

// 20 log10(peak / rms_difference(a, b, border)) in dB; +infinity when the
// images are equal inside the border.
double psnr(const ImageView& a, const ImageView& b, double peak = 1.0, long border = 0);

// Continuous L2 error of f_app against a reference render f of the same
// image_width x image_height frame at a much higher factor: f's sample (i, j)
// sits at ((i + 1/2) image_width / ref_w, (j + 1/2) image_height / ref_h).
// Returns sqrt(mean of (f_app - f)^2) over every channel and every sample
// whose position lies in [border, image_width - border] x [border,
// image_height - border], the RMS estimate of the normalised L2 norm of
// f_app - f. In the Cartesian space the sum is formed in double precision
// without evaluating f_app (docs/design.md section 8): sum f_app^2 = c' G c
// with G the Gram matrix of the generator's samples (one per axis), sum
// f_app f = c' a with a the reference acquired by the same samples, and
// sum f^2 (a difference of sums of size N f^2: errors below about 1e-8 of
// the RMS of f are not resolved); in the hexagonal space f_app is evaluated
// at every sample
// (resample() with the centred display; the values pass through float, a
// relative rounding of about 6e-8).
double l2_error(const Coefficients& coefficients, const ImageView& reference,
                double border_output_pixels = 0, int threads = 1);

// The same error of many approximations against one reference: the
// reference is acquired once per Cartesian space met (generator, lattice,
// boundary and frame) and kept, so that each further error costs a pass
// over the coefficients only. The same value as l2_error(coefficients,
// reference, border, threads), bit for bit. The reference's pixels must
// outlive the object.
class L2Reference {
 public:
  L2Reference(const ImageView& reference, double border_output_pixels = 0, int threads = 1);
  ~L2Reference();
  L2Reference(L2Reference&&) noexcept;
  L2Reference& operator=(L2Reference&&) noexcept;
  double l2_error(const Coefficients& coefficients);
  const ImageView& reference() const { return reference_; }
  double border() const { return border_; }

 private:
  struct Acquired;
  ImageView reference_;
  double border_;
  int threads_;
  std::vector<std::unique_ptr<Acquired>> acquired_;
};

// The same against a closed-form truth f(x, y, channel) (output-pixel
// coordinates), on a grid of samples_per_pixel x samples_per_pixel points per
// output pixel placed as the reference samples above. truth is called from
// the calling thread only, or from the worker threads at once where
// truth_on_any_thread (a pure function). The same result either way.
double l2_error(const Coefficients& coefficients,
                const std::function<double(double x, double y, int channel)>& truth,
                int samples_per_pixel, double border_output_pixels = 0, int threads = 1,
                bool truth_on_any_thread = false);

// The closed-form image of scenes/zoneplate.pov with ZP_K = K over a frame
// of W x H output pixels: 1/2 + 1/2 cos(K ((x/W - 1/2)^2 + (y/H - 1/2)^2)),
// every channel alike (a truth for l2_error).
double zoneplate(double K, double W, double H, double x, double y);

// l2_error against zoneplate(K, ...) over the coefficients' frame, on the
// grid of samples_per_pixel^2 points per output pixel. The plate's phase is
// a sum of a column's and a row's, so the truth is cos a cos b - sin a sin b
// from one table per axis; in the Cartesian space every sum then factors
// per axis as well, and the error costs a pass over the coefficients.
double zoneplate_l2_error(const Coefficients& coefficients, double K, int samples_per_pixel,
                          double border_output_pixels = 0, int threads = 1);

// The exact noise gain of a linear method at integer factor s on a periodic
// width x width frame (apply: samples (width s)^2 -> the width^2 outputs, the
// coefficients or a display): with white noise of variance sigma^2 on the
// samples each output's variance is sigma^2 sum_q A[n, q]^2, the same for
// every n, and as q runs over the samples of one phase (of the s^2 within a
// pixel) A[n, q] runs over that phase's impulse response. gain = s^2 times
// the sum over phases of the responses' squares (relative to sigma^2 / s^2,
// a box average's variance). relative_sd: the relative standard deviation
// of a variance measured over the width^2 outputs of one noise image,
// sqrt(2 sum_k rho_k^2) / width, rho the outputs' correlation (the sum of
// the responses' autocorrelations, lags up to 12 pixels, each summed over
// 36 pixels around the impulse: the responses of the methods here decay
// below 1e-6 of their peak within that).
struct DiscreteNoiseGain {
  double gain = 0, relative_sd = 0;
};
DiscreteNoiseGain discrete_noise_gain(const std::function<std::vector<double>(const Image&)>& apply,
                                      long width, int s);

struct OvershootOptions {
  // The input samples "under" output pixel (i, j) are those whose position
  // falls in [i - r, i + 1 + r) x [j - r, j + 1 + r), r = neighbourhood in
  // output pixels. The default r = 1 (the 3 x 3 block of output pixels)
  // covers the tent's support and the main lobe of wider kernels, as a local
  // min/max clamp would. When no sample falls there (an output finer than
  // the input and a small r), the nearest sample is used.
  double neighbourhood = 1.0;
  // A value is out of range (or negative) when it passes its bound by more
  // than tolerance * max(1, |bound|): float rounding of a reproduced flat
  // area is not overshoot. The reported extremes use no tolerance.
  double tolerance = 1e-6;
  // Output pixels within this many pixels of an edge are left out.
  long border = 0;
};

struct OvershootReport {
  double max_overshoot = 0;   // max of output - local max, over pixels and channels; >= 0
  double max_undershoot = 0;  // max of local min - output; >= 0
  long pixels = 0;            // output pixels measured (inside the border)
  long pixels_out_of_range = 0;  // pixels with some channel outside [local min, local max]
  long negative_pixels = 0;      // pixels with some channel below 0
  double negative_energy = 0;    // sum over pixels and channels of min(v, 0)^2
  double min = 0, max = 0;       // extremes of the measured output values
};

// How far an output leaves the range of the input samples under it
// (docs/design.md sections 6 and 8), channel by channel. Output and input cover
// the same frame: input sample (k, l) sits at ((k + 1/2) W / W_in,
// (l + 1/2) H / H_in) in the output's pixels, any ratio per axis. The
// channel counts must match.
OvershootReport overshoot(const ImageView& output, const ImageView& input,
                          const OvershootOptions& options = {});

}  // namespace sis
