#pragma once
// Adaptive rays (docs/design.md section 17): a first pass of a sobol
// pattern everywhere, an estimate of where the projection's error is, made
// from that pass's samples and coefficients alone, and a second pass of
// extra rays in the tiles the estimate ranks worst, projected with the first
// pass's rays as one set of scattered samples (sis/scattered.h), each
// weighing the area it stands for.
//
// The base is a sobol render with the same whole number b of rays in every
// output pixel (sis/pattern.h: the grid's count is W H b). A refined tile's
// pixels hold r > b rays: the base's b and points b .. r - 1 of the pixel's
// own scrambled Sobol' sequence (sobol_pixel_point), so a refined pixel's
// rays are exactly those of a uniform sobol render of r rays per pixel, and
// with nothing refined the samples are the base render's, bit for bit.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sis/coefficients.h"
#include "sis/pattern.h"
#include "sis/scattered.h"

namespace sis {

// Estimators of a tile's squared projection error (sums over the tile, in
// value^2 x output pixels^2; only their ranking is used):
//   halves    the samples split in two by the parity of their index (for a
//             sobol render of an even count per pixel: each pixel's even and
//             odd points), each half projected by the same rule, and the
//             squared difference of the two approximations integrated over
//             the tile (4 x 4 points a pixel). Its expectation is four times
//             the full set's variance: the sampling error rays can lower.
//   contrast  per pixel and channel, (max - min)^2 of the samples in the
//             pixel, summed (POV-Ray's +AM compares neighbouring samples'
//             colours in the same spirit).
//   residual  sum of w_i (f_i - f_app(x_i))^2 over the tile's samples: the
//             misfit of the projection at its own samples.
//   highpass  sum over the tile's coefficients of the squared difference
//             between the coefficients and their 3 x 3 binomial blur.
enum class Estimator { Halves, Contrast, Residual, HighPass };
const char* estimator_name(Estimator e);  // "halves" | "contrast" | "residual" | "highpass"
// std::invalid_argument naming the spelling and the known names.
Estimator parse_estimator(const std::string& spelling);

// The tiles of a W x H frame: tile x tile output pixels, the last column
// and row cut by the frame; tile t = ty * columns + tx.
struct TileGrid {
  long width = 0, height = 0, tile = 8;
  long columns() const { return (width + tile - 1) / tile; }
  long rows() const { return (height + tile - 1) / tile; }
  long count() const { return columns() * rows(); }
  long pixels(long t) const;  // output pixels in tile t (fewer at the frame's far edges)
};

// The estimate of every tile of the target's frame (Cartesian space),
// row-major. `samples` the first pass's (weights empty: the frame's area / N
// each), `k` their projection onto the target by `options`' rule.
// std::invalid_argument for a tile < 1, samples without a position in the
// frame, coefficients of another frame.
std::vector<double> estimate_tile_error(const ScatteredSamples& samples, const Coefficients& k,
                                        const ScatteredTarget& target, const ScatteredOptions& options,
                                        Estimator estimator, long tile);

// Where the second pass's rays go.
struct Refinement {
  SamplePattern base;       // the first pass: sobol, `base_rays()` rays in every pixel
  long tile = 8;            // output pixels a side
  long rays = 0;            // rays per pixel in a refined tile, > base_rays()
  std::vector<long> tiles;  // the refined tiles (TileGrid index), increasing
  TileGrid grid() const { return {base.width, base.height, tile}; }
  long base_rays() const;   // the base's rays per pixel (count / (W H))
  long extra_count() const; // the second pass's rays
  double rays_per_pixel() const;  // both passes' rays over the frame's pixels
};

// A checked refinement (std::invalid_argument with the reason): the base
// not sobol or without the same whole number of rays in every pixel, a tile
// < 1, rays <= the base's or past 2^20, a tile index outside the frame's
// tile grid (a refinement outside the frame), tiles not increasing.
Refinement make_refinement(const SamplePattern& base, long tile, long rays, std::vector<long> tiles);

// The tiles to refine for a budget of `budget` rays per output pixel over
// the whole frame: tiles by decreasing estimate (ties: the lower index)
// while both passes' rays fit the budget. rays: the refined tiles' rays per
// pixel, or none: given share (the fraction of the frame's pixels refined,
// (0, 1]) as base + (budget - base) / share rounded down, or with neither
// the r in (base, max(64, budget)] whose tiles leave the least estimate
// under the model that a tile's error falls as 1 / its rays (sum of the
// unrefined tiles' estimates plus base / r times the refined ones'; ties:
// the smaller r; docs/design.md section 17 says why).
// std::invalid_argument: a budget below the base's rays per pixel or not
// finite, a share outside (0, 1], both rays and share given, an estimate of
// another tile count or not finite.
Refinement plan_refinement(const SamplePattern& base, const std::vector<double>& estimate, long tile,
                           double budget, std::optional<long> rays = {},
                           std::optional<double> share = {});

// The refinement as text (the file sirays refine writes, and the
// sis:refinement attribute of the second pass's render):
//   sis-refinement 1
//   pattern sobol
//   seed S
//   frame WxH
//   factor F          (the base's, 17 digits)
//   tile T
//   rays R
//   tiles N
//   t0 t1 ...         (N indices, up to 16 a line)
std::string refinement_text(const Refinement& r);
// std::invalid_argument naming `label` and the line for anything else.
Refinement parse_refinement(const std::string& text, const std::string& label);

// Extra ray k's position (0 <= k < extra_count()): the refined tiles in
// order, each tile's pixels row-major, each pixel's points base .. rays - 1.
// Positions [k0, k1) into xy (x0, y0, x1, y1, ...).
void extra_positions(const Refinement& r, long k0, long k1, double* xy);

// The base's samples (its pattern's, in its order, weights empty) and the
// second pass's values (extra_count() x channels, channel fastest) as one
// set: the extra rays' positions computed again, and, where a tile is
// refined, every sample weighing its pixel's area over its count (1 / rays
// in refined pixels, 1 / base elsewhere). With no tile refined the base's
// samples are returned as they are (the uniform render's result, bit for
// bit). std::invalid_argument for counts that do not match.
ScatteredSamples adaptive_samples(ScatteredSamples base, const Refinement& r,
                                  const std::vector<double>& extra_values);

}  // namespace sis
