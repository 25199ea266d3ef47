#pragma once
// Scattered samples on the hexagonal lattice (internal to the library; the
// public interface is sis/scattered.h, which dispatches here for a
// HexagonalSpace target). docs/design.md section 11.
//
// The stored coefficients are the grid acquisition's (sis/hex_lattice.h):
// the offset-row grid of hex_layout(density, W, H, margin), margin
// included. A sample's images are the extended image's copies of it:
// mirror, x + 2 k W and -x + 2 k W (likewise in y); periodic, x + k W. Two
// rules of which images count, and where their taps go:
//   Grid:   every image whose support reaches a stored coefficient, its
//           taps added to the stored coefficients they reach (none wraps):
//           the grid acquisition's inner products with the extended image.
//   Period: the images inside one period of the coefficients' periodic
//           rule, D = [o.x - h/4, o.x - h/4 + Q h) x [o.y - hy/2, o.y - hy/2 + R hy),
//           their taps wrapped on the grid (hex_evaluate's rule): the model
//           the prefilter and the evaluation assume, which the fit fits;
//   Sample: the sample's own place only, taps wrapped (f_app at the samples).
#include <cstddef>
#include <vector>

#include "sis/hex_lattice.h"
#include "sis/scattered.h"

namespace sis {
namespace detail {

enum class HexImages { Grid, Period, Sample };

struct HexScatteredGrid {
  HexLayout layout;
  const BoxSpline* spline = nullptr;
  double width = 0, height = 0;
  Boundary boundary = Boundary::Mirror;
};

// The target's grid; std::invalid_argument for a target the hexagonal
// space cannot take (a conventional method, a frame that is not finite and
// positive, a bad density or margin).
HexScatteredGrid hex_scattered_grid(const ScatteredTarget& target);

// acc[n] += sum_i w_i sum_{images x' of x_i} M_n(x') (v_i, then 1 where
// acc holds width + 1 values a coefficient), v_i the `width` values of
// sample i (values: channel fastest). With `per_image`, v is the values of
// each image in the order the images are met (hex_image_count's), not of
// each sample. Threads split the coefficient rows; each coefficient's
// terms are added in sample order, images in a fixed order: the same bits
// for any thread count.
void hex_splat(const HexScatteredGrid& g, const ScatteredSamples& s, const double* values,
               int width, bool per_image, HexImages images, Grid<double>& acc, int threads);

// f_app (c periodic on its grid) at every image the rule counts, in
// order (out: c.channels values each, hex_image_count of them).
void hex_evaluate_images(const HexScatteredGrid& g, const ScatteredSamples& s,
                         const Grid<double>& c, HexImages images, double* out, int threads);

// The number of images the rule counts, over all samples.
long hex_image_count(const HexScatteredGrid& g, const ScatteredSamples& s, HexImages images);

// The sample each image the rule counts belongs to, in hex_image_count's
// order (the variational rule's per-image values and weights).
std::vector<long> hex_image_owners(const HexScatteredGrid& g, const ScatteredSamples& s,
                                   HexImages images);

// Coefficients on the target's grid holding c (the grid acquisition's record).
Coefficients hex_scattered_coefficients(const HexScatteredGrid& g, Grid<double> c);

}  // namespace detail
}  // namespace sis
