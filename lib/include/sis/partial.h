#pragma once
// Partials that merge (docs/design.md section 12): the acquisition of some
// of the grid's bands, computed anywhere (another process, another
// machine), written to a file in double, and added to the other bands'
// partials by merge(), which checks that they tile the grid with the same
// request and prefilters once. Every band's sums are kept as the single run
// keeps them (sis/bands.h), so a merge of any split, in any order of
// arrival, gives the single run's bits.
#include <string>
#include <vector>

#include "sis/engine.h"

namespace sis {

struct Partial {
  // The request, which every partial of a merge shares.
  Space space;
  long input_width = 0, input_height = 0;  // the whole sample grid
  long width = 0, height = 0;              // the output frame, in pixels
  std::vector<std::string> channel_names;
  int alpha = -1;
  Method method = Method::MinError;
  Boundary boundary = Boundary::Mirror;
  PrefilterMethod prefilter = PrefilterMethod::FFT;
  Transfer transfer;              // the samples' own, decoded before projecting
  bool highlight_compressed = false;
  bool zero_nonfinite = false;
  int integer_bits = 0;           // the input's format (the outputs' default)
  bool half = false;
  long band_rows = 0, band_count = 0;  // the grid's bands
  // What this partial holds: its bands (ascending), where they came from,
  // the non-finite samples replaced in them, the space's and the local
  // range's sums.
  std::vector<long> bands;
  std::string label;
  NonFiniteReport nonfinite;
  BandPartial<double> acquisition;
  BandPartial<float> range;
};

// The request's keys as a partial file records them (sis:partial:...), in
// a fixed order: two partials merge only where every key agrees.
Metadata partial_request(const Partial& p);

// The acquisition of the bands the inputs hold: whole bands of the grid
// (inspect(inputs, true)), rows from a multiple of the band rows to one or
// to the grid's end; RequestError otherwise, naming the rows.
Partial project_partial(const ProjectionRequest& request);
Partial project_partial(const ProjectionRequest& request, InputSet inspected);

// Adds partials (any order) and prefilters once: the single run's
// projection. RequestError (naming the partials' labels) when they were
// made by other requests, overlap or leave a gap.
Projection merge(const std::vector<Partial>& parts, int threads = 1,
                 bool float_coefficients = true);

// The rows of a grid of `rows` cut into `parts` runs of whole bands (as
// even as bands allow): parts + 1 row numbers from 0 to rows. RequestError
// when there are fewer bands than parts.
std::vector<long> band_cuts(long rows, long parts, long band_rows = kBandRows);

// Partial files: an OpenEXR of two parts (the space's sums as the bits of
// doubles, two uint channels a value; the local range in float) whose
// metadata holds the request, the bands and the report. Staged: never a
// file at `path` that is not whole.
void write_partial(const std::string& path, const Partial& p);
bool is_partial_file(const ImageReader& reader);
// InputError naming the file for a file that is not a whole partial.
// values = false: its metadata only (the sums and ranges left empty).
Partial read_partial(const std::string& path, bool values = true);

}  // namespace sis
