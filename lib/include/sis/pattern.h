#pragma once
// Sample patterns: where the rays of a render go (docs/design.md section 13).
// A pattern is a pure function of (kind, seed, frame, density, sample
// index), so positions are never stored: a render names its pattern in its
// metadata and the reader computes the positions again.
//
// Every pattern has the sample grid of an ordinary supersampled render: a
// frame of W x H output pixels and a per-axis factor s (any positive real)
// give grid_width x grid_height = floor(W s + 1/2) x floor(H s + 1/2)
// samples (what the Makefile's RES x FACTOR render has), s^2 rays per output
// pixel. Sample k = l * grid_width + i is pixel (i, l) of the render. Its
// position, in frame coordinates (output pixels, row 0 on top):
//   regular  ((i + 1/2) W / gw, (l + 1/2) H / gh): today's grid, one ray at
//            each pixel centre of the s-times render;
//   jitter   ((i + u) W / gw, (l + v) H / gh), u, v uniform in [0, 1) from a
//            hash of (seed, k): one uniform sample in each cell of the grid
//            (the s x s cells of a pixel at whole s);
//   sobol    per output pixel, as pbrt-v4's PaddedSobolSampler: pixel q
//            (row-major) holds samples [c(q), c(q + 1)), c(q) = floor(q N / P)
//            of the N samples over P = W H pixels (counts differ by at most
//            one, any density), and sample c(q) + j is (qx + x_j, qy + y_j),
//            point j of the Sobol' (0, 2)-sequence (dimensions 0 and 1)
//            Owen-scrambled by a hash of (seed, q, dimension) (pbrt-v4's
//            FastOwenScrambler): a pixel's first 2^m samples form a
//            (0, m, 2)-net, every elementary interval of area 2^-m of the
//            pixel holding exactly one.
#include <cstdint>
#include <string>
#include <vector>

#include "sis/lattice.h"

namespace sis {

class ImageReader;

enum class PatternKind { Regular, Jitter, Sobol };
const char* pattern_name(PatternKind kind);  // "regular" | "jitter" | "sobol"
// Throws std::invalid_argument naming the spelling and the known names.
PatternKind parse_pattern(const std::string& spelling);

struct SamplePattern {
  PatternKind kind = PatternKind::Regular;
  std::uint64_t seed = 0;
  long width = 0, height = 0;  // the frame, output pixels
  double factor = 1;           // samples per output pixel along each axis
  long grid_width() const;
  long grid_height() const;
  long count() const { return grid_width() * grid_height(); }
  double rays_per_pixel() const { return factor * factor; }
};

// A checked pattern: std::invalid_argument for a frame side < 1, a factor
// not finite and > 0, a grid side < 1 or a count past 2^32.
SamplePattern make_pattern(PatternKind kind, std::uint64_t seed, long width, long height,
                           double factor);

// The position of sample k (0 <= k < count()), frame coordinates.
Vec2 sample_position(const SamplePattern& pattern, long k);
// Samples [k0, k1) as x0, y0, x1, y1, ... into `xy` (2 (k1 - k0) doubles);
// the same values as sample_position, on `threads` threads.
void sample_positions(const SamplePattern& pattern, long k0, long k1, double* xy, int threads = 1);

// Point j (0 <= j < 2^32) of output pixel q's (row-major in a frame `width`
// pixels wide) own Owen-scrambled Sobol' sequence under `seed`: the sobol
// pattern's sample c(q) + j at any density, so a pixel's first n points are
// the same at every density that gives it at least n (sis/refinement.h adds
// points n, n + 1, ... to a pixel of a sobol render).
Vec2 sobol_pixel_point(std::uint64_t seed, long width, long q, long j);

// The render's metadata that names its pattern (string attributes of the
// file; sis/scattered_input.h reads a render that has them).
inline constexpr const char* kPatternKey = "sis:pattern";
inline constexpr const char* kPatternSeedKey = "sis:pattern_seed";
inline constexpr const char* kPatternFrameKey = "sis:pattern_frame";    // "WxH"
inline constexpr const char* kPatternFactorKey = "sis:pattern_factor";  // per axis, 17 digits
struct PatternAttribute {
  std::string name, value;
};
std::vector<PatternAttribute> pattern_metadata(const SamplePattern& pattern);
// True when the file carries any of the keys above.
bool has_pattern_metadata(const ImageReader& reader);
// The pattern the file names, checked against its size (its data window is
// the pattern's grid). InputError naming the file and the key: a key
// missing, an unknown pattern, a value that does not parse, a size other
// than the grid.
SamplePattern read_pattern_metadata(const ImageReader& reader);

}  // namespace sis
