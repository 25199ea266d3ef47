#pragma once
// Scattered samples (sis/scattered.h) as the front ends take them: values
// at positions in the frame, from arrays (the Python module's values= and
// positions=) or from an OpenEXR file whose channels include position
// channels (siproject). One sample per pixel of the file's data window, in
// any layout: pFilm.x and pFilm.y give its place in frame coordinates
// (output pixels; pbrt's CameraSample::pFilm, the film position), an
// optional "weight" channel the area it stands for (output pixels^2), the
// other channels are its values. A render of a sample pattern
// (sis/pattern.h) has no position channels: its metadata names the pattern
// (sis:pattern, sis:pattern_seed, sis:pattern_frame, sis:pattern_factor),
// and pixel (i, l) of its data window is sample l * width + i, whose
// position the pattern gives.
#include <optional>
#include <string>
#include <vector>

#include "sis/imageio.h"
#include "sis/pattern.h"
#include "sis/refinement.h"
#include "sis/scattered.h"

namespace sis {

inline constexpr const char* kPositionChannelX = "pFilm.x";
inline constexpr const char* kPositionChannelY = "pFilm.y";
inline constexpr const char* kWeightChannel = "weight";

struct ScatteredInput {
  ScatteredSamples samples;                // values decoded to linear light
  std::vector<std::string> channel_names;  // the values'
  int alpha = -1;                          // among the values (-1: none)
  std::string label = "array";             // how messages name the input
  bool half = false;                       // every channel stored as half (the output's default type)
  int integer_bits = 0;                    // bits of integer values, 0 for float or half
  Transfer transfer;                       // the values' transfer, decoded before projecting
  // How messages name the samples: the arrays (the Python keywords, or the
  // file's channels) and sample i: "row i" where grid_width is 0, else the
  // pixel (grid_x + i % grid_width, grid_y + i / grid_width) of a file's
  // data window.
  std::string positions_name = "positions", values_name = "values", weights_name = "weights";
  long grid_width = 0, grid_x = 0, grid_y = 0;
  std::string sample_name(long i) const;
  // A pattern's render: the pattern, whose frame the positions are in (the
  // output frame may differ: form_scattered scales them onto it).
  std::optional<SamplePattern> pattern;
};

// Values (count x 1 samples of C channels: float, half, uint8 or uint16,
// read where they are), positions (x0, y0, x1, y1...), weights (count, or
// null: the frame's area / count each): copied into an input, the values
// converted to float as a file's are (integers scaled to [0, 1]) and
// decoded by `transfer` (none: default_transfer, integers sRGB).
ScatteredInput scattered_input(const SampleView& values, const double* positions,
                               const double* weights, const std::optional<Transfer>& transfer);

// True when the file has a position channel (pFilm.x or pFilm.y) or names
// a sample pattern in its metadata.
bool is_scattered_file(const ImageReader& reader);
// The value channels of such a file (every channel but the position and
// weight channels) and their alpha; InputError naming the file when a
// position channel is missing or not stored as float or half.
// A pattern's render: InputError naming the file for pattern metadata
// missing a key, naming an unknown pattern, or inconsistent with the file's
// size (read_pattern_metadata), and for position channels beside it.
struct ScatteredLayout {
  int x = -1, y = -1, weight = -1;  // channel indices (x, y: -1 for a pattern's render)
  std::optional<SamplePattern> pattern;
  std::vector<int> values;
  std::vector<std::string> names;
  int alpha = -1;
  int integer_bits = 0;  // of the value channels where every one is an integer, else 0
};
ScatteredLayout scattered_layout(const ImageReader& reader);
// The file's samples (InputError naming the file: unreadable, or no value
// channel), the values decoded by `transfer` (none: the file's own). With
// `expected` (the signature of a reader that read its header first), a file
// that is no longer that file is an InputError.
ScatteredInput read_scattered(const std::string& path, const std::optional<Transfer>& transfer,
                              const FileSignature& expected = {});

// The second pass of an adaptive render (sis/refinement.h): `path`, the
// extra rays' render (sirays assemble --refinement), whose sis:refinement
// attribute holds the refinement's text and whose first extra_count()
// pixels, row-major, are the extra rays' values, added to `base` (a sobol
// render read by read_scattered) by adaptive_samples. InputError naming the
// file: no sis:refinement, a refinement that does not parse, a base pattern
// other than base's, other channels, fewer pixels than rays.
inline constexpr const char* kRefinementKey = "sis:refinement";
void add_refinement(ScatteredInput& base, const std::string& path, const std::optional<Transfer>& transfer);

// The first pass of an adaptive render refined (sirays refine, Python
// refine()): the sobol render at `path` projected (min-error cubic, the fit,
// mirror, on `threads` threads), every tile's estimate, and the tiles the
// budget buys (plan_refinement). InputError naming the file: not a sobol
// render of a whole number of rays in every pixel, unreadable; the plan's
// std::invalid_argument (a budget below the base...) as it is, for the
// caller to name its options.
struct RefinedPlan {
  Refinement refinement;
  std::vector<double> estimate;  // per tile, row-major
};
RefinedPlan refine_render(const std::string& path, double budget, std::optional<long> rays,
                          std::optional<double> share, long tile, Estimator estimator, int threads);

}  // namespace sis
