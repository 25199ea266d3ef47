#pragma once
// The projection engine: the whole method from samples to coefficients and
// from coefficients to a final image, for every front end (siproject, the
// studies' tools, scripts). A request names the inputs, the output frame,
// the space (a lattice with a generator), the method, the boundary rule and
// the remedies; the engine reads the inputs as it needs them (in bands on
// every core where it can), checks them, projects, prefilters and reports
// what it saw. Its errors are InputError (a file), RequestError (what was
// asked cannot be done: sizes, densities, memory) and OutputError.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "sis/coefficients.h"
#include "sis/acquisition.h"
#include "sis/hex_acquisition.h"
#include "sis/imageio.h"
#include "sis/prefilter.h"
#include "sis/range.h"
#include "sis/resample.h"
#include "sis/space.h"

namespace sis {

// The largest output side (OpenImageIO's image sides are int).
inline constexpr long kMaxOutputSide = 2147483647;

// A request the engine cannot carry out as asked. The message names the
// request's field by siproject's option and the problem.
struct RequestError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// One input: a region of the frame's sample grid, from a file (any image
// OpenImageIO reads) or from samples in memory (read where they are, never
// copied whole). Today a region is a band of whole rows: a file's rows are
// placed by its data window within its display window, an image's at `row`.
struct ProjectionInput {
  std::string path;
  SampleView image;  // in-memory: the samples (float or half)
  long row = 0;      // in-memory: the band's first row in the grid
  long rows = 0;     // in-memory: the grid's height (0: the image's own)
  std::string name;  // in-memory: how messages name it ("array")
  std::vector<std::string> channel_names;  // in-memory (default R, G, B, A or c0...)
  int alpha = -1;                          // in-memory: the alpha channel (-1: none)
  std::optional<Transfer> transfer;        // in-memory: the samples' own (none: default_transfer)

  static ProjectionInput file(const std::string& path) {
    ProjectionInput in;
    in.path = path;
    return in;
  }
  static ProjectionInput memory(SampleView image, std::string name = "array") {
    ProjectionInput in;
    in.image = image;
    in.name = std::move(name);
    return in;
  }
};

// What the inputs hold, checked as one image (every band of one grid).
struct InputSet {
  long width = 0, height = 0;  // the sample grid
  long first_row = 0, rows = 0;  // the grid's rows the inputs hold (a partial's: some; else all)
  int channels = 0;
  std::vector<std::string> channel_names;
  int alpha = -1;
  bool half = false;   // every input stores half
  bool srgb = false;   // the inputs' own transfer is sRGB (transfer.kind == SRGB)
  Transfer transfer;   // the inputs' own (default_transfer: integer samples sRGB unless tagged)
  int integer_bits = 0;  // bits of integer samples (8, 16...), 0 for float or half
  bool coefficient_file = false;
  bool partial_files = false;  // every input a partial file (sis/partial.h): merged, not read in bands
  // A file of scattered samples (sis/scattered_input.h): its data window's
  // samples (width x height), `channels` the value channels; projected by
  // form(), not read in bands.
  bool scattered_file = false;
  std::string label;   // "render.exr and 2 more bands"
  std::vector<ProjectionInput> bands;  // in row order
  // The files' readers, in the inputs' order: open until the reading is
  // done where there are few (a decoder freed before the reading raises
  // glibc's dynamic mmap threshold: a higher peak), closed at once where
  // there are many (the descriptor limit).
  std::vector<std::shared_ptr<ImageReader>> readers;
};
// Reads the inputs' headers (each file closed again unless few) and checks
// that they tile one grid (some of its rows, one run of them, where
// `partial`: the grid is then a file's display window, or an in-memory
// band's `rows`). Throws InputError naming the file.
InputSet inspect(const std::vector<ProjectionInput>& inputs, bool partial = false);

// A projection's terms: the space, method, boundary and prefilter, the
// sample stages and the threads. A request holds them (with its inputs and
// frame), and so do the settings resolved (settings.h).
struct ProjectionTerms {
  Space space;  // sis/space.h: CartesianSpace{generator} or HexagonalSpace{order, density}
  Method method = Method::MinError;
  Boundary boundary = Boundary::Mirror;
  PrefilterMethod prefilter = PrefilterMethod::FFT;
  bool zero_nonfinite = false;     // NaN/Inf samples: replaced by 0, else an InputError
  bool highlight_compress = false;
  // The inputs' transfer as the user states it (none: their own, InputSet::transfer).
  std::optional<Transfer> input_transfer;
  int threads = 1;
};

struct ProjectionRequest : ProjectionTerms {
  std::vector<ProjectionInput> inputs;
  long width = 0, height = 0;  // the output frame, in pixels
  bool coefficient_file = false;   // the caller will also write the coefficients (memory estimate)
  // The sample type the coefficients are kept in: float (as a coefficient
  // file stores them, so that evaluating one reproduces the run exactly) or
  // double (the prefilter's own precision).
  bool float_coefficients = true;
  std::function<void(double)> progress;  // fraction of the input read, from the worker threads
  // Called at every strip read, from the reading threads (the caller's
  // among them): an exception it throws abandons the projection and comes
  // out of project() (a front end's cancellation: Ctrl-C in Python).
  std::function<void()> interrupt;
};

struct NonFiniteReport {
  long count = 0, x = -1, y = -1;
  int channel = -1;
  std::string file;
  std::string where;  // "FILE: non-finite sample (NaN or Inf) at x X, y Y, channel C"
};

struct Projection {
  Coefficients coefficients;  // kept in the request's sample type
  InputSet inputs;
  std::unique_ptr<LocalRange> local_range;  // of the samples under each output pixel
  NonFiniteReport nonfinite;                // those replaced by 0
  double acquire_seconds = 0, prefilter_seconds = 0;
  std::uint64_t estimated_bytes = 0;
};

// Projects the inputs onto the space (inspected here, or by the caller
// first). Throws RequestError before reading when the request cannot fit in
// memory (available_memory) or the space cannot be built on these samples.
Projection project(const ProjectionRequest& request);
Projection project(const ProjectionRequest& request, InputSet inspected);

// Several targets from one reading of the inputs (a pyramid's levels, two
// spaces): each request has its own frame, space, method, boundary,
// prefilter and coefficient type; the first's inputs, sample stages
// (input_transfer, highlight_compress, zero_nonfinite), threads, progress
// and interrupt serve all, and the later requests leave their inputs empty
// (RequestError otherwise). The samples are read and pass the stages once;
// each Projection holds the bits project() gives its request alone. The
// memory check is of all the targets together.
std::vector<Projection> project(const std::vector<ProjectionRequest>& requests);

// A coefficient file, read and checked (its input's label: `path`, which
// messages name): non-finite coefficients are an
// InputError, or replaced by 0 (counted in `replaced`). With `expected`
// (the signature of a reader that read its header first), a file that is
// no longer that file is an InputError. `level`: of a pyramid's file
// (coefficient_levels), at that level's frame.
Coefficients load_coefficients(const std::string& path, bool zero_nonfinite,
                               NonFiniteReport* replaced = nullptr,
                               const FileSignature& expected = {}, int level = 0);

struct FinalImage {
  Image image;
  RangeReport before, after;  // before and after the clamp
  bool own_range = false;     // the local range was the image's own (out_of_range is known)
};

// The final image of W x H pixels: f_app sampled by the display (the
// conventional methods' own pixels where centred at the lattice's size),
// highlights expanded where the coefficients hold compressed values (every
// channel but their alpha), ranges reported, clamped. A value that passes
// float's range is an InputError naming the coefficients' input and
// channel. `local` may be null.
FinalImage final_image(const Coefficients& k, const Display& display, long W, long H, Clamp clamp,
                       const LocalRange* local, int threads);

// The peak bytes a projection to W x H x C needs (coefficients, local range,
// image, write copies, weight tables, per-thread buffers), and the refusal
// of what does not fit (RequestError naming --size and --factor).
std::uint64_t projection_bytes(long W, long H, int C, std::uint64_t coefficients, bool local,
                               bool coefficient_file, int threads, double tables = 0);
double table_bytes(long coefficients_x, long samples_x, long coefficients_y, long samples_y,
                   double radius);
void check_memory(std::uint64_t needed, const std::string& what);

// Channel names of samples in memory: Y; R, G, B; R, G, B, A; else c0, c1...
std::vector<std::string> default_channel_names(int channels);

// The index of the first value that is NaN or infinite, or -1.
long first_nonfinite(const double* v, std::size_t n);
long first_nonfinite(const float* v, std::size_t n);
// "x 3, y 7, channel G" of value q of interleaved rows of `width` pixels.
std::string value_position(long q, long width, const std::vector<std::string>& names);

}  // namespace sis
