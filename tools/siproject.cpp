// siproject: forms a final image from any image OpenImageIO reads, treated as
// point samples of a continuous image, by orthogonal projection onto a
// shift-invariant space (min-error) or a conventional filter. The engine
// (sis/engine.h) does the work; this is its command line: the options, the
// request, the messages, the metadata and the writing.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "cli.h"
#include "version.h"
#include "sis/engine.h"
#include "sis/memory.h"
#include "sis/partial.h"
#include "sis/projection.h"
#include "sis/sequence.h"
#include "sis/settings.h"
#include "sis/space.h"
#include "sis/spacetime.h"

namespace fs = std::filesystem;
using namespace sis;

namespace {

// Half holds magnitudes up to 65504; beyond, a half file would hold
// infinities. By default such an output is written as float instead; with
// -d half (format_given) the samples are clamped there, and both are said.
// True when samples were clamped (counted in `clamped`): the caller's range
// is then out of date.
constexpr float kHalfMax = 65504.0f;
bool fit_half(SampleFormat& format, bool format_given, const RangeReport& after,
              const std::vector<Image*>& images, bool quiet, long& clamped) {
  if (format != SampleFormat::Half || !(after.max > kHalfMax || after.min < -kHalfMax)) return false;
  if (!format_given) {
    format = SampleFormat::Float;
    if (!quiet)
      std::fprintf(stderr,
                   "siproject: warning: the output reaches %g, beyond half's largest value "
                   "65504: written as float (-d half clamps instead)\n",
                   std::max(after.max, -after.min));
    return false;
  }
  for (Image* image : images)
    for (float& v : image->data)
      if (std::abs(v) > kHalfMax) v = std::copysign(kHalfMax, v), ++clamped;
  if (!quiet)
    std::fprintf(stderr, "siproject: warning: -d half: %ld samples beyond +-65504 clamped there\n",
                 clamped);
  return true;
}

using sis::cli::kExitUsage;
using sis::cli::kExitInput;
using sis::cli::kExitOutput;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The projection's settings (sis/settings.h, shared with the Python module)
// and what is the tool's own: the files, the output's sample type, messages.
struct Options {
  Settings settings;
  std::vector<std::string> inputs;
  std::string output, coeffs;
  std::string data_format;  // "": the input's
  std::string compression;  // "": the writer's default
  int quality = 0;          // 0: none given
  bool verbose = false, quiet = false;
  // A batch: the inputs' frame range (--frames), the digits of '#' and '@'
  // (--framepadding, 0: theirs), and whether several inputs are row bands
  // of one image (--bands) rather than frames.
  std::string frames;
  int framepadding = 0;
  bool bands = false;
  // --partial: write the partial of the bands the inputs hold (to -o);
  // --merge: the inputs are partial files, added into one projection.
  bool partial = false, merge = false;
  bool display_given = false, clamp_given = false;
  // --mip: a tiled, MIP-mapped OpenEXR of every level (sis/pyramid.h)
  bool mip = false;
  // --fps: space-time projection of sub-frames (sis/spacetime.h)
  std::optional<double> fps;
  std::string shutter = "180:0", shutter_curve = "box", times, time_model = "cubic";
  int time_degree = 3;
  double time_step = 0;
  bool time_given = false;  // a temporal option given (they need --fps)
};

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// A progress line on stderr, for runs over a second, only where stderr is a
// terminal (a log file gets no carriage-return lines). Updated from the
// engine's worker threads.
class Progress {
 public:
  Progress(bool enabled, const char* what)
      : enabled_(enabled && ::isatty(2)), what_(what), start_(Clock::now()) {}
  void update(double fraction) {
    if (!enabled_ || seconds_since(start_) < 1.0) return;
    std::lock_guard<std::mutex> lock(m_);
    const int pct = static_cast<int>(100 * fraction);
    if (pct == last_) return;
    last_ = pct;
    shown_ = true;
    std::fprintf(stderr, "\rsiproject: %s %3d%%", what_, pct);
    std::fflush(stderr);
  }
  ~Progress() {
    if (shown_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  const char* what_;
  Clock::time_point start_;
  std::mutex m_;
  int last_ = -1;
  bool shown_ = false;
};

// True when a and b name one file: the same path however spelt (relative or
// absolute, through links or "..", existing or not), or two names of one
// existing file (hard links).
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::equivalent(a, b, ec) && !ec) return true;
  std::error_code ec1, ec2;
  const fs::path pa = fs::weakly_canonical(fs::absolute(a, ec1), ec1);
  const fs::path pb = fs::weakly_canonical(fs::absolute(b, ec2), ec2);
  return !ec1 && !ec2 && pa == pb;
}


// siproject --partial: the partial of the bands the inputs hold, to -o.
int write_partial_of(const Options& o, const Resolved& r, InputSet set) {
  if (!o.coeffs.empty() || !o.data_format.empty() || !o.compression.empty() || o.quality ||
      o.display_given || o.clamp_given)
    throw UsageError("--partial writes the acquisition of some bands, not an image: --coeffs, -d, "
                     "--compression, --quality, --display and --clamp apply where the partials "
                     "merge (siproject --merge)");
  if (!holds_coefficients(o.output))
    throw UsageError("-o " + o.output + ": partial files are OpenEXR (.exr)");
  const auto t = Clock::now();
  FormRequest fr;
  Progress progress(!o.quiet, "reading and acquiring");
  fr.progress = [&](double f) { progress.update(f); };
  const Partial p = form_partial(o.settings, r, std::move(set), fr);
  if (p.nonfinite.count && !o.quiet)
    std::cerr << "siproject: warning: replaced " << p.nonfinite.count
              << " non-finite samples with 0; first: " << p.nonfinite.where << "\n";
  write_partial(o.output, p);
  if (o.verbose)
    std::fprintf(stderr, "siproject: partial of bands %ld to %ld of %ld (rows of %ld) -> %s, %.3f s\n",
                 p.bands.front(), p.bands.back(), p.band_count, p.band_rows, o.output.c_str(),
                 seconds_since(t));
  return 0;
}

// siproject --mip: every level of the pyramid from one reading, displayed
// at its size, written as one tiled, MIP-mapped OpenEXR (maketx's level
// sizes). The range keys are of all levels together.
int write_mip_of(const Options& o, const Resolved& r, InputSet set, SampleFormat out_format,
                 bool format_given) {
  const auto t_start = Clock::now();
  const std::vector<std::string> names = set.channel_names;
  const std::string input_label = set.label;
  const long win = set.width, hin = set.height;
  const int C = set.channels;
  FormRequest fr;
  fr.keep_coefficients = !o.coeffs.empty();
  fr.coefficient_file = !o.coeffs.empty();
  Progress progress(!o.quiet && !set.coefficient_file, "reading and acquiring");
  fr.progress = [&](double f) { progress.update(f); };
  std::vector<Formed> levels = form_pyramid(o.settings, r, std::move(set), fr);
  for (const std::string& w : levels.front().warnings)
    if (!o.quiet) std::cerr << "siproject: warning: " << w << "\n";
  const Coefficients& k = levels.front().coefficients;
  RangeReport before, after;
  before.min = after.min = HUGE_VAL;
  before.max = after.max = -HUGE_VAL;
  bool own_range = true;
  double acquire = 0, prefilter = 0, resample = 0;
  for (const Formed& f : levels) {
    before.min = std::min(before.min, f.final.before.min);
    before.max = std::max(before.max, f.final.before.max);
    after.min = std::min(after.min, f.final.after.min);
    after.max = std::max(after.max, f.final.after.max);
    before.negative += f.final.before.negative;
    before.out_of_range += f.final.before.out_of_range;
    before.samples += f.final.before.samples;
    own_range = own_range && f.final.own_range;
    acquire = std::max(acquire, f.acquire_seconds);
    prefilter += f.prefilter_seconds;
    resample += f.resample_seconds;
  }
  std::vector<Image*> level_images;
  for (Formed& f : levels) level_images.push_back(&f.final.image);
  long half_clamped = 0;
  if (fit_half(out_format, format_given, after, level_images, o.quiet, half_clamped)) {
    after.min = std::max(after.min, -double(kHalfMax));
    after.max = std::min(after.max, double(kHalfMax));
  }
  const Metadata md = {
      {"sis:method", k.min_error ? "min-error" : "conventional"},
      {"sis:generator", generator_name(k)},
      {"sis:display", levels.front().display.name()},
      {"sis:boundary", boundary_name(k.boundary)},
      {"sis:input", input_label},
      {"sis:input_transfer", k.input.transfer.name()},
      {"sis:highlight_compress", k.highlight_compressed ? "1" : "0"},
      {"sis:clamp", clamp_name(r.clamp)},
      {"sis:output_min", std::to_string(after.min)},
      {"sis:output_max", std::to_string(after.max)},
      {"sis:negative_before_clamp", std::to_string(before.negative)},
      {"sis:out_of_range_before_clamp",
       own_range ? std::to_string(before.out_of_range) : std::string("unknown")},
      {"sis:lattice", space_name(k.space)},
      {"sis:half_clamped", std::to_string(half_clamped)},
      {"sis:mip_levels", std::to_string(levels.size())},
      // the boundary rule the levels were projected under, as texture lookups wrap
      {"wrapmodes", k.boundary == Boundary::Periodic ? "periodic,periodic" : "mirror,mirror"},
      {"Software", "siproject"},
  };
  const auto t = Clock::now();
  // Both outputs are written whole before either replaces a file.
  std::optional<StagedFile> coeffs_file;
  if (!o.coeffs.empty()) {
    std::vector<const Coefficients*> grids;
    for (const Formed& f : levels) grids.push_back(&f.coefficients);
    coeffs_file.emplace(stage_mip_coefficients(o.coeffs, grids));
  }
  std::vector<Image> images;
  for (Formed& f : levels) images.push_back(std::move(f.final.image));
  const int alpha = levels.front().inputs.alpha;
  levels.clear();
  StagedFile file = stage_mip_image(o.output, images, names, md, alpha, out_format);
  if (coeffs_file) coeffs_file->commit();
  file.commit();
  const double t_write = seconds_since(t);
  if (o.verbose) {
    std::fprintf(stderr,
                 "siproject: %ld x %ld x %d -> %zu MIP levels from %ld x %ld, %s %s, display %s, "
                 "boundary %s, %d threads\n"
                 "siproject: read+acquire %.3f s, prefilter %.3f s, resample %.3f s, write %.3f s, "
                 "total %.3f s\n",
                 win, hin, C, images.size(), images.front().width, images.front().height,
                 md[0].second.c_str(), md[1].second.c_str(), md[2].second.c_str(),
                 md[3].second.c_str(), r.threads, acquire,
                 prefilter, resample, t_write, seconds_since(t_start));
    std::fprintf(stderr, "siproject: output range [%g, %g] over every level, %ld negative samples\n",
                 before.min, before.max, before.negative);
  }
  return 0;
}

// -d, --compression and --quality as given for the output `path`: the
// sample type checked against the path's format, the compression parsed.
struct OutputOptions {
  std::optional<SampleFormat> data_format;  // none: the input's (the still path's rule)
  Compression compression;
  std::string compression_option;  // the option that asked for it, as messages name it
};
OutputOptions output_options(const Options& o, const std::string& path) {
  OutputOptions out;
  if (!o.data_format.empty()) {
    try {
      out.data_format = parse_sample_format(o.data_format);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("-d/--data-format: ") + e.what());
    }
    std::string held;
    if (!holds_format(path, *out.data_format, &held))
      throw UsageError("-d/--data-format " + o.data_format + ": " + path + "'s format holds " +
                       held + " samples, not " + o.data_format);
  }
  if (!o.compression.empty()) {
    try {
      out.compression = parse_compression(o.compression);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--compression ") + e.what());
    }
  }
  if (o.quality) {
    if (out.compression.quality && out.compression.quality != o.quality)
      throw UsageError("--compression " + o.compression + " and --quality " +
                       std::to_string(o.quality) + ": give the quality once");
    out.compression.quality = o.quality;
  }
  out.compression_option =
      !o.compression.empty() ? "--compression " + o.compression : "--quality " + std::to_string(o.quality);
  return out;
}

int run(const Options& o) {
  const auto t_start = Clock::now();
  if (o.verbose && o.quiet) throw UsageError("-v and -q exclude each other");
  if (o.mip) {
    if (!holds_coefficients(o.output))
      throw UsageError("--mip: -o " + o.output + ": a MIP-mapped texture is written as OpenEXR "
                       "(.exr), as maketx writes them");
    if (o.partial) throw UsageError("--mip and --partial exclude each other");
    if (!o.compression.empty() || o.quality)
      throw UsageError("--mip: the texture's tiles are zip-compressed, as maketx writes them; "
                       "--compression and --quality are not taken with --mip");
  }
  const Settings& st = o.settings;
  const Resolved r = resolve(st);
  const int threads = r.threads;
  for (const std::string& in : o.inputs) {
    if (same_file(in, o.output)) throw UsageError("-o " + o.output + " is the input file");
    if (!o.coeffs.empty() && same_file(in, o.coeffs))
      throw UsageError("--coeffs " + o.coeffs + " is the input file");
  }
  const OutputOptions out = output_options(o, o.output);
  const std::optional<SampleFormat>& data_format = out.data_format;
  const Compression& compression = out.compression;
  const std::string& compression_option = out.compression_option;
  if (!o.coeffs.empty() && same_file(o.output, o.coeffs))
    throw UsageError("--coeffs " + o.coeffs + " is the output file");
  for (const std::string& path : {o.output, o.coeffs}) {
    if (path.empty()) continue;
    check_output(path);
    if (!o.coeffs.empty() && path == o.coeffs && !holds_coefficients(path))
      throw UsageError("--coeffs " + path + ": coefficient files are OpenEXR (.exr); this format "
                       "cannot hold their metadata and signed float coefficients");
  }

  // Several inputs (--bands) are row bands of one image: each band's data
  // window spans the full width and the bands tile the display window's rows.
  std::vector<ProjectionInput> inputs;
  for (const std::string& in : o.inputs) inputs.push_back(ProjectionInput::file(in));
  InputSet set = inspect(inputs, o.partial);
  if (o.partial) return write_partial_of(o, r, std::move(set));
  if (o.merge && !set.partial_files)
    throw UsageError("--merge: " + set.label + " is not a partial file (siproject --partial)");
  for (const auto& r : set.readers) {
    if (r->parts() > 1 && !o.quiet)
      std::fprintf(stderr, "siproject: warning: %s has %d parts; its first is projected\n",
                   r->path().c_str(), r->parts());
    if (r->levels() > 1 && o.verbose)
      std::fprintf(stderr, "siproject: %s: level 0 of %d (a multi-resolution file)\n",
                   r->path().c_str(), r->levels());
    if (r->luminance_chroma() && o.verbose)
      std::fprintf(stderr, "siproject: %s: luminance-chroma, read as RGB by OpenEXR\n",
                   r->path().c_str());
  }
  const int C = set.channels;
  try {
    check_output_image(o.output, C);
  } catch (const OutputError& e) {
    throw UsageError(std::string("-o ") + e.what());
  }
  // Output samples as the input's (oiiotool's habit): in float formats half
  // when every input stores half, else float; in integer formats 16-bit
  // where the input's integer samples have 16 bits or more and the format
  // holds them, else 8-bit. A coefficient file records its input's half.
  SampleFormat out_format = data_format ? *data_format
                                        : default_sample_format(o.output, set.half, set.integer_bits);
  if (!compression.name.empty() || compression.quality) {
    try {
      check_write_options(o.output, C, out_format, compression);
    } catch (const std::invalid_argument& e) {
      throw UsageError(compression_option + ": " + o.output + ": " + e.what());
    }
  }
  if (!data_format && is_integer(out_format) && set.integer_bits > 0 && !o.quiet) {
    const int bits = out_format == SampleFormat::UInt16 ? 16 : 8;
    if (set.integer_bits > bits)
      std::fprintf(stderr,
                   "siproject: warning: the input's %d-bit samples are written %d-bit: %s's format "
                   "holds no more (%s keeps them)\n",
                   set.integer_bits, bits, o.output.c_str(),
                   set.integer_bits > 16 ? "-d float with .tif or .exr" : ".png, .tif or -d float");
  }
  if (o.mip) return write_mip_of(o, r, std::move(set), out_format, data_format.has_value());
  const std::vector<std::string> names = set.channel_names;
  const std::string input_label = set.label;
  const long win = set.width, hin = set.height;

  FormRequest fr;
  fr.keep_coefficients = !o.coeffs.empty();
  fr.coefficient_file = !o.coeffs.empty();
  Progress progress(!o.quiet && !set.coefficient_file, "reading and acquiring");
  fr.progress = [&](double f) { progress.update(f); };
  Formed f = form(st, r, std::move(set), fr);
  for (const std::string& w : f.warnings)
    if (!o.quiet) std::cerr << "siproject: warning: " << w << "\n";
  Coefficients& k = f.coefficients;
  const long W = f.width, H = f.height;
  const bool compressed = k.highlight_compressed;
  const bool input_half = k.input.half;
  const Clamp clamp = r.clamp;
  if (f.from_coefficient_file && !data_format)
    out_format = default_sample_format(o.output, input_half, 0);
  const Display& shown = f.display;
  Image& image = f.final.image;
  const bool own_range = f.final.own_range;
  const RangeReport before = f.final.before;
  RangeReport after = f.final.after;
  long half_clamped = 0;
  if (fit_half(out_format, bool(data_format), after, {&image}, o.quiet, half_clamped))
    after = report_range(image, nullptr, threads);
  const double t_resample = f.resample_seconds;
  f.local_range.reset();  // what is no longer needed goes before the output is written

  const Metadata md = {
      {"sis:method", k.min_error ? "min-error" : "conventional"},
      {"sis:generator", generator_name(k)},
      {"sis:display", shown.name()},
      {"sis:boundary", boundary_name(k.boundary)},
      {"sis:input", input_label},
      {"sis:input_transfer", k.input.transfer.name()},
      {"sis:highlight_compress", compressed ? "1" : "0"},
      {"sis:clamp", clamp_name(clamp)},
      {"sis:output_min", std::to_string(after.min)},
      {"sis:output_max", std::to_string(after.max)},
      {"sis:negative_before_clamp", std::to_string(before.negative)},
      {"sis:out_of_range_before_clamp",
       own_range ? std::to_string(before.out_of_range) : std::string("unknown")},
      {"sis:lattice", space_name(k.space)},
      {"sis:half_clamped", std::to_string(half_clamped)},
      {"Software", "siproject"},
  };
  const auto t = Clock::now();
  // Both outputs are written whole before either replaces a file.
  std::optional<StagedFile> coeffs_file;
  if (!o.coeffs.empty())
    coeffs_file.emplace(stage_coefficients(o.coeffs, k));
  Buffer<double>().swap(k.c.data);
  WriteOptions how(out_format);
  how.compression = compression;
  StagedFile output_file = stage_image(o.output, image, names, md, f.inputs.alpha, how);
  if (coeffs_file) coeffs_file->commit();
  output_file.commit();
  const double t_write = seconds_since(t);
  if (o.verbose) {
    // scattered: the samples projected (a refined render's both passes)
    const long samples = f.scattered ? f.inputs.width * f.inputs.height : win * hin;
    const std::string from = f.scattered ? std::to_string(samples) + " scattered samples x " + std::to_string(C)
                                         : std::to_string(win) + " x " + std::to_string(hin) + " x " + std::to_string(C);
    std::fprintf(stderr,
                 "siproject: %s -> %ld x %ld, %s %s, display %s, boundary %s, %d threads\n"
                 "siproject: read+acquire %.3f s, prefilter %.3f s, resample %.3f s, write %.3f s, "
                 "total %.3f s\n",
                 from.c_str(), W, H, k.min_error ? "min-error" : "conventional",
                 generator_name(k).c_str(), shown.name().c_str(), boundary_name(k.boundary).c_str(),
                 threads, f.acquire_seconds, f.prefilter_seconds, t_resample, t_write,
                 seconds_since(t_start));
    if (f.estimated_bytes)
      std::fprintf(stderr, "siproject: memory: about %s needed, %s available\n",
                   format_bytes(f.estimated_bytes).c_str(),
                   available_memory() == UINT64_MAX ? "no limit" : format_bytes(available_memory()).c_str());
    std::fputs(visit_space(k, [&](auto space) { return space.describe(k); }).c_str(), stderr);
    if (f.scattered) {
      const ScatteredReport& sr = *f.scattered;
      std::fprintf(stderr, "siproject: %ld scattered samples, rule %s: %ld passes", samples,
                   scattered_rule_name(r.scattered.rule), sr.passes);
      if (r.scattered.rule == ScatteredRule::LeastSquares) {
        std::fprintf(stderr, ", %d iterations, residual", sr.iterations);
        for (double v : sr.residual) std::fprintf(stderr, " %.3g", v);
      }
      if (r.scattered.rule == ScatteredRule::Variational)
        std::fprintf(stderr, ", lambda %.6g%s, %d iterations", sr.lambda,
                     r.scattered.lambda ? "" : " (gcv)", sr.iterations);
      std::fprintf(stderr, ", %s of working grids\n", format_bytes(sr.bytes).c_str());
    }
    std::fprintf(stderr, "siproject: output range [%g, %g], %ld negative samples", before.min,
                 before.max, before.negative);
    if (own_range)
      std::fprintf(stderr, ", %ld of %ld outside the input range under their pixel",
                   before.out_of_range, before.samples);
    std::fprintf(stderr, "%s\n", compressed ? " (highlight compression on)" : "");
    if (clamp != Clamp::None)
      std::fprintf(stderr, "siproject: after --clamp %s: range [%g, %g]\n", clamp_name(clamp).c_str(),
                   after.min, after.max);
  }
  return 0;
}

// One projection of a batch: its inputs (one image, or the row bands of
// one), its outputs.
struct Job {
  std::vector<std::string> inputs;
  std::string output, coeffs;
};

// What -o or --coeffs names: a file, a folder (each frame keeps its input's
// file name) or a pattern with a frame wildcard (each frame's number).
struct Target {
  enum Kind { File, Folder, Pattern } kind = File;
  std::string path;
  std::optional<FramePattern> pattern;
};

Target target_of(const std::string& path, const std::string& option, int framepadding) {
  Target t;
  t.path = path;
  if (path.empty()) return t;
  std::error_code ec;
  if (path.back() == '/' || fs::is_directory(path, ec)) {
    if (!fs::is_directory(path, ec)) throw OutputError(option + " " + path + ": no such folder");
    t.kind = Target::Folder;
    return t;
  }
  if (fs::exists(fs::symlink_status(path, ec))) return t;  // a file of that name, whatever it holds
  try {
    t.pattern = parse_frame_pattern(path, framepadding);
  } catch (const std::invalid_argument& e) {
    throw UsageError(option + ": " + e.what());
  }
  if (t.pattern) t.kind = Target::Pattern;
  return t;
}

// An input frame: its file, and its number where a pattern gave it.
struct Frame {
  std::string path;
  std::optional<long> number;
};

// The inputs as frames: patterns expanded (their range, --frames, or the
// files on disk), every frame checked to exist before anything runs.
std::vector<Frame> expand_inputs(const Options& o) {
  std::vector<Frame> frames;
  bool any_pattern = false;
  std::vector<long> given;
  if (!o.frames.empty()) {
    try {
      given = parse_frame_range(o.frames);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--frames: ") + e.what());
    }
  }
  for (const std::string& in : o.inputs) {
    std::error_code ec;
    std::optional<FramePattern> p;
    if (!fs::exists(fs::symlink_status(in, ec))) {
      try {
        p = parse_frame_pattern(in, o.framepadding);
      } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
      }
    }
    if (!p) {
      if (o.inputs.size() > 1 && !fs::exists(fs::symlink_status(in, ec)))
        throw InputError(in + ": no such file");  // before any frame runs
      frames.push_back({in, std::nullopt});
      continue;
    }
    any_pattern = true;
    std::vector<long> numbers;
    if (!p->range.empty()) {
      if (!o.frames.empty())
        throw UsageError(in + ": a frame range in the name and --frames " + o.frames + ": give one");
      numbers = parse_frame_range(p->range);
    } else if (!o.frames.empty()) {
      numbers = given;
    } else {
      numbers = frames_on_disk(*p);
      if (numbers.empty()) throw InputError(in + ": no file matches the frame pattern");
    }
    for (long n : numbers) {
      const std::string name = p->name(n);
      std::error_code e2;
      if (!fs::exists(name, e2))
        throw InputError(name + ": no such file (frame " + std::to_string(n) + " of " + in + ")");
      frames.push_back({name, n});
    }
  }
  if (!o.frames.empty() && !any_pattern)
    throw UsageError("--frames " + o.frames + ": no input has a frame wildcard (#, @, %0Nd)");
  return frames;
}

// Where frame f goes under target t (a folder or a pattern).
std::string destination(const Target& t, const Frame& f, const std::string& option,
                        const std::vector<Frame>& all) {
  if (t.kind == Target::Folder) return (fs::path(t.path) / fs::path(f.path).filename()).string();
  if (!f.number)
    throw UsageError(option + " " + t.path + ": a pattern numbers frames from numbered inputs "
                     "(e.g. frame.#.exr or frame.1-10#.exr); " + f.path + " has no number "
                     "(" + option + " FOLDER/ keeps each input's name)");
  if (!t.pattern->range.empty()) {
    std::vector<long> numbers;
    for (const Frame& g : all) numbers.push_back(g.number.value_or(-1));
    if (parse_frame_range(t.pattern->range) != numbers)
      throw UsageError(option + " " + t.path + ": its frame range is not the inputs' frames");
  }
  return t.pattern->name(*f.number);
}

// The projections the command line asks for: one image, the row bands of
// one (--bands), or a batch of frames each projected alone.
std::vector<Job> plan_jobs(const Options& o) {
  const std::vector<Frame> frames = expand_inputs(o);
  const Target out = target_of(o.output, "-o", o.framepadding);
  const Target coeffs = target_of(o.coeffs, "--coeffs", o.framepadding);
  if (o.bands && o.merge) throw UsageError("--bands and --merge exclude each other");
  if (o.partial && o.merge) throw UsageError("--partial and --merge exclude each other");
  if (o.bands || o.merge) {
    if (out.kind != Target::File || coeffs.kind != Target::File)
      throw UsageError(std::string(o.bands ? "--bands" : "--merge") +
                       " makes one image of its inputs: -o and --coeffs name files");
    Job j{{}, o.output, o.coeffs};
    for (const Frame& f : frames) j.inputs.push_back(f.path);
    return {j};
  }
  if (frames.size() == 1 && out.kind == Target::File && coeffs.kind == Target::File)
    return {Job{{frames[0].path}, o.output, o.coeffs}};
  if (frames.size() > 1 && out.kind == Target::File)
    throw UsageError(std::to_string(frames.size()) + " input frames and one output file " + o.output +
                     ": give -o a folder (each frame keeps its input's name) or a pattern "
                     "(out.#.exr); row bands of one image: --bands");
  if (frames.size() > 1 && coeffs.kind == Target::File && !o.coeffs.empty())
    throw UsageError(std::to_string(frames.size()) + " input frames and one coefficient file " +
                     o.coeffs + ": give --coeffs a folder or a pattern");
  std::vector<Job> jobs;
  std::set<std::string> written, read;
  for (const Frame& f : frames) {
    std::error_code ec;
    read.insert(fs::weakly_canonical(fs::absolute(f.path, ec), ec).string());
  }
  for (const Frame& f : frames) {
    Job j{{f.path}, out.kind == Target::File ? o.output : destination(out, f, "-o", frames), ""};
    if (!o.coeffs.empty())
      j.coeffs = coeffs.kind == Target::File ? o.coeffs : destination(coeffs, f, "--coeffs", frames);
    for (const std::string& w : {j.output, j.coeffs}) {
      if (w.empty()) continue;
      std::error_code ec;
      const std::string c = fs::weakly_canonical(fs::absolute(w, ec), ec).string();
      if (read.count(c)) throw UsageError(w + " would be written over an input frame");
      if (!written.insert(c).second)
        throw UsageError(w + " would be written twice (frames of one name)");
    }
    jobs.push_back(std::move(j));
  }
  return jobs;
}

// siproject --fps: the sub-frames (the inputs, patterns expanded) projected
// in space and time; every output frame (--frames, else every whole frame
// inside the sub-frames' span) written to -o's pattern or folder. Everything
// is checked before a sample is read; a failure while forming removes the
// frames already written.
int run_spacetime(const Options& o) {
  if (o.verbose && o.quiet) throw UsageError("-v and -q exclude each other");
  if (o.bands || o.merge || o.partial || o.mip || !o.coeffs.empty())
    throw UsageError("--fps: --bands, --merge, --partial, --mip and --coeffs are not taken with "
                     "sub-frames");
  Options in = o;
  in.frames.clear();  // --frames numbers the output frames here
  std::vector<std::string> paths;
  for (const Frame& f : expand_inputs(in)) paths.push_back(f.path);
  SpaceTimeOptions so;
  so.fps = *o.fps;
  try {
    so.shutter = parse_shutter(o.shutter, o.shutter_curve);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  so.degree = o.time_degree;
  so.step = o.time_step;
  try {
    so.model = parse_time_model(o.time_model);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  if (!o.frames.empty()) {
    try {
      so.frames = parse_frame_range(o.frames);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--frames: ") + e.what());
    }
  }
  std::vector<double> times;
  if (!o.times.empty()) {
    std::stringstream list(o.times);
    std::string item;
    while (std::getline(list, item, ',')) {
      std::size_t used = 0;
      double v = 0;
      try {
        v = std::stod(item, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != item.size())
        throw UsageError("--times: '" + item + "' is not a number");
      times.push_back(v);
    }
  }
  const Resolved r = resolve(o.settings);
  const SpaceTimePlan plan = plan_frames(paths, times, so, r);
  // where each frame goes, decided (and checked) before anything is formed
  const Target out = target_of(o.output, "-o", o.framepadding);
  std::vector<std::string> dest;
  for (long f : plan.frames) {
    if (out.kind == Target::Pattern) {
      dest.push_back(out.pattern->name(f));
    } else if (out.kind == Target::Folder) {
      char name[64];
      std::snprintf(name, sizeof name, "frame.%04ld.exr", f);
      dest.push_back((fs::path(out.path) / name).string());
    } else if (plan.frames.size() == 1) {
      dest.push_back(o.output);
    } else {
      throw UsageError("-o " + o.output + ": " + std::to_string(plan.frames.size()) +
                       " output frames: give a pattern with a frame wildcard (out.#.exr) or a "
                       "folder (its frame.NNNN.exr)");
    }
  }
  for (const std::string& d : dest) {
    check_output(d);
    for (const std::string& p : paths)
      if (same_file(p, d)) throw UsageError("-o: " + d + " would be written over a sub-frame");
  }
  const OutputOptions options = output_options(o, dest.front());
  std::vector<std::string> written;
  try {
    std::size_t j = 0;
    form_frames(o.settings, r, plan, [&](SpaceTimeFrame& f) {
      const std::string& path = dest[j++];
      SampleFormat format = options.data_format ? *options.data_format : default_sample_format(path, false, 0);
      if (!options.compression.name.empty() || options.compression.quality) {
        try {
          check_write_options(path, int(f.channel_names.size()), format, options.compression);
        } catch (const std::invalid_argument& e) {
          throw UsageError(options.compression_option + ": " + path + ": " + e.what());
        }
      }
      long half_clamped = 0;
      RangeReport after = f.final.after;
      if (fit_half(format, bool(options.data_format), after, {&f.final.image}, o.quiet, half_clamped))
        after = report_range(f.final.image, nullptr, r.threads);
      const Metadata md = {
          {"sis:method", f.coefficients.min_error ? "min-error" : "conventional"},
          {"sis:generator", generator_name(f.coefficients)},
          {"sis:display", f.display.name()},
          {"sis:boundary", boundary_name(f.coefficients.boundary)},
          {"sis:lattice", space_name(f.coefficients.space)},
          {"sis:input_transfer", f.coefficients.input.transfer.name()},
          {"sis:highlight_compress", f.coefficients.highlight_compressed ? "1" : "0"},
          {"sis:clamp", clamp_name(r.clamp)},
          {"sis:output_min", std::to_string(after.min)},
          {"sis:output_max", std::to_string(after.max)},
          {"sis:negative_before_clamp", std::to_string(f.final.before.negative)},
          {"sis:out_of_range_before_clamp", f.final.own_range
                                                 ? std::to_string(f.final.before.out_of_range)
                                                 : std::string("unknown")},
          {"sis:half_clamped", std::to_string(half_clamped)},
          {"sis:time", metadata_number(f.time)},
          {"sis:fps", metadata_number(so.fps)},
          {"sis:shutter", o.shutter},
          {"sis:shutter_curve", o.shutter_curve},
          {"sis:time_degree", std::to_string(so.degree)},
          {"sis:time_model", time_model_name(so.model)},
          {"sis:time_step", metadata_number(plan.options.step)},
          {"sis:input", paths.front() + " and " + std::to_string(paths.size() - 1) + " more sub-frames"},
          {"Software", "siproject"},
      };
      WriteOptions how(format);
      how.compression = options.compression;
      StagedFile file = stage_image(path, f.final.image, f.channel_names, md, f.alpha, how);
      file.commit();
      written.push_back(path);
      if (o.verbose)
        std::fprintf(stderr, "siproject: frame %ld (t = %g s) -> %s\n", f.number, f.time,
                     path.c_str());
    });
  } catch (...) {
    std::error_code ec;
    for (const std::string& w : written) fs::remove(w, ec);
    throw;
  }
  return 0;
}

// Runs the jobs one after another, each on every thread (the engine's
// bands), stopping at the first that fails (the frames before it are
// written whole; the failing one leaves nothing).
int run_jobs(const Options& o) {
  if (o.fps) return run_spacetime(o);
  if (o.time_given)
    throw UsageError("--shutter, --shutter-curve, --time-degree, --time-step, --time-model and --times need "
                     "--fps (the output frame rate of a space-time projection)");
  const std::vector<Job> jobs = plan_jobs(o);
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    Options one = o;
    one.inputs = jobs[i].inputs;
    one.output = jobs[i].output;
    one.coeffs = jobs[i].coeffs;
    if (o.verbose && jobs.size() > 1)
      std::fprintf(stderr, "siproject: frame %zu of %zu: %s -> %s\n", i + 1, jobs.size(),
                   one.inputs.front().c_str(), one.output.c_str());
    if (const int status = run(one)) return status;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) try {
  Options o;
  CLI::App app{
      "siproject: form a final image from a supersampled render by projection onto a\n"
      "shift-invariant space of B-splines (min-error), or by a conventional filter.\n"
      "IN is any image OpenImageIO reads (EXR above all), taken as point samples at\n"
      "((i + 1/2) / S, (j + 1/2) / S) output pixels; every channel is processed as it\n"
      "is (EXR alpha is premultiplied, so it is filtered with the colour); integer\n"
      "inputs tagged sRGB (PNG, JPEG...) are decoded to linear first. EXR output\n"
      "keeps the input's sample type (half or float; -d), with the method in its\n"
      "metadata; every format but EXR, HDR, PFM, FITS and Zfile is written as integers\n"
      "(8-bit, or 16-bit from 16-bit inputs where it holds them; -d), sRGB-encoded\n"
      "and clamped to [0, 1]; -d half or float gives linear samples. S < 1 upsamples (the input's cubic\n"
      "interpolant is projected). If IN is a coefficient file (--coeffs), the stored\n"
      "approximation is evaluated instead: at its own size, --size or --factor, with\n"
      "any --display. An OpenEXR file with position channels pFilm.x, pFilm.y holds\n"
      "scattered samples, one per pixel in any layout: each at its (x, y) in output\n"
      "pixels, weighing its \"weight\" channel (else the frame's area / N), the other\n"
      "channels its values, projected onto the frame --size WxH gives (--rule). A\n"
      "render whose metadata names a sample pattern (sis:pattern, written by sirays\n"
      "assemble) holds scattered samples at that pattern's positions, and takes\n"
      "--factor, --scale and --size as a grid does.\n"
      "Outputs replace a file only once written whole.\n"
      "Exit status: 0 success, 1 out of memory, 2 usage, 3 input, 4 output.",
      "siproject"};
  app.add_option("IN", o.inputs,
                 "input image, or a coefficient file written by --coeffs; several inputs, or a "
                 "frame pattern as oiiotool spells it (frame.#.exr: 4 digits per #, frame.@@.exr: "
                 "1 per @, frame.%04d.exr; a range before the wildcard, frame.1-10#.exr, or "
                 "--frames), are frames projected one after another; with --bands they are row "
                 "bands of one image")->required();
  app.add_option("-o,--output", o.output,
                 "output image (.exr half or float, see -d; .png, .jpg, .tif... 8- or 16-bit sRGB, "
                 "or float with -d float); for "
                 "frames a folder (each keeps its input's file name) or a pattern (out.#.png)")
      ->required();
  app.add_option("--frames", o.frames,
                 "frames of the input patterns without a range in their name, as oiiotool: "
                 "1-10, 10-1, 1-10x2 (every 2nd), 1-10y2 (the others), 3,4,10-20x2 [default: the "
                 "files on disk that match]; with --fps the output frames' numbers [default: every "
                 "whole frame whose shutter lies inside the sub-frames' span]");
  app.add_option("--framepadding", o.framepadding,
                 "digits of the frame numbers of # and @ patterns [default: 4 per #, 1 per @]")
      ->check(CLI::Range(1, 18));
  auto* fps = app.add_option("--fps", o.fps,
                             "space-time projection: the inputs are sub-frames (times from their "
                             "sis:time attribute or --times), projected onto spatial x temporal "
                             "B-splines; output frames at this rate (frame k at k/R s), --frames "
                             "their numbers, -o a pattern (out.#.exr) or folder");
  auto* t1 = app.add_option("--shutter", o.shutter,
                            "with --fps: shutter ANGLE[:PHASE] in degrees, open on "
                            "[T + P/360/R, T + (P+A)/360/R)")->capture_default_str();
  auto* t2 = app.add_option("--shutter-curve", o.shutter_curve,
                            "with --fps: box, tent, cubic, or FILE of two columns (time in [0, 1] "
                            "across the open shutter, weight)")->capture_default_str();
  auto* t3 = app.add_option("--time-degree", o.time_degree,
                            "with --fps: degree 0..3 of the temporal B-spline")->capture_default_str();
  auto* t4 = app.add_option("--time-step", o.time_step,
                            "with --fps: temporal lattice step in seconds [default: the sub-frames' mean "
                            "spacing]")
                ->check([](const std::string& v) {
                  double x = 0;
                  try {
                    x = std::stod(v);
                  } catch (const std::exception&) {
                  }
                  return x > 0 && std::isfinite(x)
                             ? std::string()
                             : "expected a positive number of seconds, not '" + v + "'";
                });
  auto* t6 = app.add_option("--time-model", o.time_model,
                            "with --fps: how the sub-frames stand for the scene between their "
                            "times in the temporal acquisition: hold (each over its own cell), "
                            "linear or cubic (interpolated)")->capture_default_str();
  auto* t5 = app.add_option("--times", o.times,
                            "with --fps: the sub-frames' times t0,t1,... in seconds (one per input), "
                            "instead of their sis:time attributes");
  (void)fps;
  app.add_flag("--mip", o.mip,
               "write -o (.exr) as a tiled, MIP-mapped OpenEXR texture: every level (maketx's "
               "sizes, each halving, down to 1x1) projected from the samples onto the space at "
               "its own size, displayed by --display (Cartesian lattice)");
  app.add_flag("--bands", o.bands,
               "the inputs are row bands of one image, projected as one (placed by their data "
               "windows, e.g. partial renders cropped with oiiotool --crop)");
  app.add_flag("--partial", o.partial,
               "write to -o (.exr) the partial acquisition of the row bands the inputs hold (a "
               "band render's rows, cut at siproject --band-cuts), for --merge; the other "
               "options as the single run's");
  app.add_flag("--merge", o.merge,
               "the inputs are partial files (--partial) of one image: added, in any order, into "
               "the single run's projection and its final image");
  app.add_option_function<std::string>(
      "--band-cuts",
      [](const std::string& v) {
        // ROWS,PARTS: printed as the parts' first rows and ROWS, then done
        const auto comma = v.find(',');
        long rows = 0, parts = 0;
        std::size_t used_rows = 0, used_parts = 0;
        try {
          rows = std::stol(v.substr(0, comma), &used_rows);
          parts = std::stol(v.substr(comma + 1), &used_parts);
        } catch (const std::exception&) {
          used_rows = 0;
        }
        if (comma == std::string::npos || used_rows != comma || used_parts != v.size() - comma - 1)
          throw CLI::ValidationError("--band-cuts", "'" + v + "': expected ROWS,PARTS (whole numbers)");
        std::vector<long> cuts;
        try {
          cuts = band_cuts(rows, parts);
        } catch (const RequestError& e) {
          throw CLI::ValidationError("--band-cuts", e.what());
        }
        for (std::size_t k = 0; k < cuts.size(); ++k) std::cout << (k ? " " : "") << cuts[k];
        std::cout << "\n";
        throw CLI::Success();
      },
      "ROWS,PARTS: print where to cut a grid of ROWS rows into PARTS runs of whole bands "
      "(the rows --partial inputs start at, then ROWS), and exit");
  double factor = 0;
  auto* fac = app.add_option("--factor", factor,
                             "supersampling factor per axis: output = input / S (any real S > 0; "
                             "S < 1 upsamples: the input's cubic interpolant is projected)");
  app.add_option("--size,--resize", o.settings.size,
                 "output size as oiiotool's --resize: WxH, W or Wx0 (the height keeps the "
                 "input's aspect), 0xH, P% or P%xQ% (percentages of the input's sides); any "
                 "ratio to the input");
  double scale = 0;
  auto* sca = app.add_option("--scale", scale,
                             "scale per axis: output = input x M (0.5 = --size 50% = --factor 2)");
  auto* g = app.add_option("--generator,--filter", o.settings.generator,
                           "box, tent (or triangle), quadratic, cubic, bspline:N (N = 0..7), mitchell, gaussian, "
                           "catmull-rom, lanczos3; with --lattice hex: hex-hat or hex-quartic "
                           "(the default there)")->capture_default_str();
  auto* lat = app.add_option("--lattice", o.settings.lattice,
                             "cartesian (coefficients on the output pixels) or hex, also "
                             "hexagonal (a hexagonal "
                             "lattice, min-error, resampled to the output pixels)")
                  ->capture_default_str();
  auto* dens = app.add_option("--density", o.settings.density,
                              "--lattice hex: lattice points per output pixel (at most one "
                              "per input sample)")
                   ->capture_default_str();
  auto* rule = app.add_option(
      "--rule", o.settings.rule,
      "scattered samples (an EXR with position channels pFilm.x, pFilm.y): fit (weighted "
      "least squares by preconditioned conjugate gradients), normalised (the sum normalised by "
      "the weight sums, one pass), plain (the weighted sum, for comparison) or variational (the "
      "smoothing spline: least squares plus --lambda times the --smoothness functional) [default: "
      "fit; normalised for --method conventional]");
  auto* lambda = app.add_option("--lambda", o.settings.lambda,
                                "--rule variational: the smoothness weight, a number >= 0 (frame "
                                "units, output pixels), or gcv (generalised cross-validation)")
                     ->capture_default_str();
  auto* smoothness = app.add_option("--smoothness", o.settings.smoothness,
                                    "--rule variational: the functional's order, 1 (|grad f|^2) or "
                                    "2 (thin plate, f_xx^2 + 2 f_xy^2 + f_yy^2)")
                         ->capture_default_str();
  app.add_option("--refined", o.settings.refined,
                 "the second pass of an adaptive render: the extra rays' render (sirays assemble "
                 "--refinement; the refinement in its sis:refinement attribute), projected with IN, "
                 "the sobol render it refines, as one set of samples each weighing its area");
  auto* iterations = app.add_option("--iterations", o.settings.iterations,
                                    "--rule fit: at most this many conjugate-gradient iterations")
                         ->capture_default_str();
  auto* m = app.add_option("--method", o.settings.method,
                           "min-error (orthogonal projection, B-spline generators) or conventional "
                           "(normalised weighted average, any generator)")->capture_default_str();
  app.add_option("--display", o.settings.display,
                 "how the continuous approximation is sampled: centred (or centered, "
                 "centre, center), 2x2 (off-centre "
                 "antialiasing at +-1/4), pixel (exact pixel average) or offsets:DX,DY;DX,DY;... "
                 "[default: 2x2 for min-error, centred (the filtered pixels) for conventional]");
  auto* b = app.add_option("--boundary", o.settings.boundary,
                           "mirror (half-sample symmetric) or periodic")->capture_default_str();
  app.add_option("--coeffs", o.coeffs, "also write the coefficients as a float EXR with their metadata");
  app.add_option("-d,--data-format", o.data_format,
                 "sample type of the output: uint8 or uint16 (sRGB-encoded, clamped to [0, 1]; "
                 "PNG, TIFF, SGI, DPX, IFF, RLA hold uint16), half or float (linear: EXR, "
                 "TIFF; float also DPX, RLA) [default: the input's, as oiiotool does: EXR half "
                 "when the input stores half (float where the output passes half's largest "
                 "value 65504; -d half clamps there instead), else float; integer formats 16-bit "
                 "for 16-bit integer inputs where the format holds it, else 8-bit]");
  app.add_option("--compression", o.compression,
                 "the writer's compression as oiiotool spells it, NAME or NAME:QUALITY: EXR zip "
                 "(default), zips, piz, pxr24, rle, b44, b44a, dwaa, dwab, none (zip:1-9, "
                 "dwaa:45); TIFF zip (default), lzw, packbits, jpeg, none; JPEG jpeg:Q; WebP "
                 "webp:Q or lossless; HEIF heic:Q or none; PNG default, filtered, huffman, rle, "
                 "fixed; Targa and IFF rle or none; names a writer would ignore are refused");
  app.add_option("--quality", o.quality,
                 "compression quality 1..100 (oiiotool's CompressionQuality): JPEG, WebP, HEIF, "
                 "TIFF jpeg; the level 1..9 of EXR and TIFF zip")
      ->check(CLI::Range(1, 100));
  app.add_option("--nonfinite", o.settings.nonfinite,
                 "NaN/Inf samples: error, or zero to replace them with 0")->capture_default_str();
  auto* transfer = app.add_option(
      "--input-transfer", o.settings.input_transfer,
      "how the input's samples encode light: auto (integer samples, 8 or 16 bits, are sRGB unless "
      "the file is tagged linear or with a gamma, as viewers take them; float samples linear), "
      "srgb, linear or gammaG (e.g. gamma2.2); decoded to linear before projecting")
                      ->capture_default_str();
  std::string iscolorspace;
  auto* ics = app.add_option("--iscolorspace", iscolorspace,
                             "oiiotool's spelling of --input-transfer: sRGB or linear")
                  ->excludes(transfer);
  app.add_flag("--highlight-compress", o.settings.highlight_compress,
               "compress the samples' range with OpenImageIO's log curve (identity below 0.18) "
               "before projecting, expand after: far less HDR ringing, at a cost in energy");
  app.add_option("--clamp", o.settings.clamp,
                 "clamp displayed samples: none, zero (at 0), local (to the min/max of the input "
                 "samples under each output pixel)")->capture_default_str();
  app.add_option("--prefilter", o.settings.prefilter, "fft or recursive (same result to rounding)")->capture_default_str();
  app.add_option("--threads", o.settings.threads, "worker threads (0: all cores); output is bit-identical for any N")
      ->capture_default_str();
  app.add_flag("-v,--verbose", o.verbose, "print sizes and the time of each stage");
  app.add_flag("-q,--quiet", o.quiet, "print nothing but errors");
  app.set_version_flag("--version", std::string("siproject ") + SIS_VERSION + " (git " + SIS_GIT_REVISION + ")",
                       "print the version and the git revision built");
  if (const auto code = sis::cli::parse(app, argc, argv)) return *code;
  o.display_given = app.count("--display") > 0;
  o.clamp_given = app.count("--clamp") > 0;
  o.time_given = t1->count() + t2->count() + t3->count() + t4->count() + t5->count() +
                 t6->count() > 0;
  remove_staged_files_on_signals();
  Settings& st = o.settings;
  st.generator_given = g->count() > 0;
  st.method_given = m->count() > 0;
  st.boundary_given = b->count() > 0;
  st.lattice_given = lat->count() > 0;
  st.density_given = dens->count() > 0;
  st.rule_given = rule->count() > 0;
  st.iterations_given = iterations->count() > 0;
  st.lambda_given = lambda->count() > 0;
  st.smoothness_given = smoothness->count() > 0;
  if (fac->count() > 0) {
    st.factor = factor;
    st.factor_spelling = fac->as<std::string>();
  }
  if (sca->count() > 0) {
    st.scale = scale;
    st.scale_spelling = sca->as<std::string>();
  }
  if (st.density_given) st.density_spelling = dens->as<std::string>();
  if (ics->count() > 0) st.input_transfer = iscolorspace;
  try {
    return run_jobs(o);
  } catch (const UsageError& e) {
    std::cerr << "siproject: " << e.what() << "\n";
    return kExitUsage;
  } catch (const RequestError& e) {
    std::cerr << "siproject: " << e.what() << "\n";
    return kExitUsage;
  } catch (const InputError& e) {
    std::cerr << "siproject: " << e.what() << "\n";
    return kExitInput;
  } catch (const OutputError& e) {
    std::cerr << "siproject: " << e.what() << "\n";
    return kExitOutput;
  } catch (const std::bad_alloc&) {
    std::cerr << "siproject: out of memory (see -v for the estimate of what the request needs)\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "siproject: " << e.what() << "\n";
    return 1;
  }
} catch (const std::bad_alloc&) {  // the options' own allocations
  std::cerr << "siproject: out of memory\n";
  return 1;
}
