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
#include <sstream>
#include <thread>

#include "cli.h"
#include "version.h"
#include "sis/engine.h"
#include "sis/hex_lattice.h"
#include "sis/memory.h"
#include "sis/projection.h"
#include "sis/settings.h"
#include "sis/space.h"

namespace fs = std::filesystem;
using namespace sis;

namespace {

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
  bool verbose = false, quiet = false;
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


int run(const Options& o) {
  const auto t_start = Clock::now();
  if (o.verbose && o.quiet) throw UsageError("-v and -q exclude each other");
  const Settings& st = o.settings;
  const Resolved r = resolve(st);
  const int threads = r.threads;
  for (const std::string& in : o.inputs) {
    if (same_file(in, o.output)) throw UsageError("-o " + o.output + " is the input file");
    if (!o.coeffs.empty() && same_file(in, o.coeffs))
      throw UsageError("--coeffs " + o.coeffs + " is the input file");
  }
  std::optional<SampleFormat> data_format;
  if (!o.data_format.empty()) {
    try {
      data_format = parse_sample_format(o.data_format);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("-d/--data-format: ") + e.what());
    }
    if (is_8bit_format(o.output))
      throw UsageError("-d/--data-format " + o.data_format + ": " + o.output +
                       " is an 8-bit format; the sample format applies to EXR and other float outputs");
    if (*data_format == SampleFormat::Half && !holds_half(o.output))
      throw UsageError("-d/--data-format half: " + o.output + "'s format holds float samples, not half");
  }
  if (!o.coeffs.empty() && same_file(o.output, o.coeffs))
    throw UsageError("--coeffs " + o.coeffs + " is the output file");
  for (const std::string& path : {o.output, o.coeffs}) {
    if (path.empty()) continue;
    check_output(path);
    if (!o.coeffs.empty() && path == o.coeffs && !holds_coefficients(path))
      throw UsageError("--coeffs " + path + ": coefficient files are OpenEXR (.exr); this format "
                       "cannot hold their metadata and signed float coefficients");
  }

  // Several inputs are row bands of one image: each band's data window
  // spans the full width and the bands tile the display window's rows.
  std::vector<ProjectionInput> inputs;
  for (const std::string& in : o.inputs) inputs.push_back(ProjectionInput::file(in));
  InputSet set = inspect(inputs);
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
  const bool compressed = f.highlight_compressed, srgb = f.inputs.srgb;
  const bool input_half = f.input_half;
  const Clamp clamp = r.clamp;
  // Output samples as the input's (oiiotool's habit): half when every input
  // stores half, float otherwise; a coefficient file records its input's.
  SampleFormat out_format =
      input_half && holds_half(o.output) ? SampleFormat::Half : SampleFormat::Float;
  if (data_format) out_format = *data_format;
  const Display& shown = f.display;
  Image& image = f.final.image;
  const bool own_range = f.final.own_range;
  const RangeReport before = f.final.before;
  RangeReport after = f.final.after;
  // Half holds magnitudes up to 65504; beyond, a half file would hold
  // infinities. By default such an output is written as float instead; with
  // -d half the samples are clamped there, and both are said.
  constexpr float kHalfMax = 65504.0f;
  long half_clamped = 0;
  if (out_format == SampleFormat::Half && !is_8bit_format(o.output) &&
      (after.max > kHalfMax || after.min < -kHalfMax)) {
    if (!data_format) {
      out_format = SampleFormat::Float;
      if (!o.quiet)
        std::fprintf(stderr,
                     "siproject: warning: the output reaches %g, beyond half's largest value "
                     "65504: written as float (-d half clamps instead)\n",
                     std::max(after.max, -after.min));
    } else {
      for (float& v : image.data)
        if (std::abs(v) > kHalfMax) v = std::copysign(kHalfMax, v), ++half_clamped;
      after = report_range(image, nullptr, threads);
      if (!o.quiet)
        std::fprintf(stderr,
                     "siproject: warning: -d half: %ld samples beyond +-65504 clamped there\n",
                     half_clamped);
    }
  }
  const double t_resample = f.resample_seconds;
  f.local_range.reset();  // what is no longer needed goes before the output is written

  const Metadata md = {
      {"sis:method", k.min_error ? "min-error" : "conventional"},
      {"sis:generator", generator_name(k)},
      {"sis:display", shown.name()},
      {"sis:boundary", boundary_name(k.boundary)},
      {"sis:input", input_label},
      {"sis:input_transfer", srgb ? "srgb" : "linear"},
      {"sis:highlight_compress", compressed ? "1" : "0"},
      {"sis:clamp", clamp_name(clamp)},
      {"sis:output_min", std::to_string(after.min)},
      {"sis:output_max", std::to_string(after.max)},
      {"sis:negative_before_clamp", std::to_string(before.negative)},
      {"sis:out_of_range_before_clamp",
       own_range ? std::to_string(before.out_of_range) : std::string("unknown")},
      {"sis:lattice", space_name(space_of(k))},
      {"sis:half_clamped", std::to_string(half_clamped)},
      {"Software", "siproject"},
  };
  const auto t = Clock::now();
  // Both outputs are written whole before either replaces a file.
  std::optional<StagedFile> coeffs_file;
  if (!o.coeffs.empty())
    coeffs_file.emplace(stage_coefficients(o.coeffs, k, names,
                                           {{"sis:input", md[4].second},
                                            {"sis:input_format", input_half ? "half" : "float"},
                                            {"sis:highlight_compress", compressed ? "1" : "0"}}));
  Buffer<double>().swap(k.c.data);
  StagedFile output_file = stage_image(o.output, image, names, md, f.inputs.alpha, out_format);
  if (coeffs_file) coeffs_file->commit();
  output_file.commit();
  const double t_write = seconds_since(t);
  if (o.verbose) {
    std::fprintf(stderr,
                 "siproject: %ld x %ld x %d -> %ld x %ld, %s %s, display %s, boundary %s, %d threads\n"
                 "siproject: read+acquire %.3f s, prefilter %.3f s, resample %.3f s, write %.3f s, "
                 "total %.3f s\n",
                 win, hin, C, W, H, k.min_error ? "min-error" : "conventional",
                 generator_name(k).c_str(), shown.name().c_str(), boundary_name(k.boundary).c_str(),
                 threads, f.acquire_seconds, f.prefilter_seconds, t_resample, t_write,
                 seconds_since(t_start));
    if (f.estimated_bytes)
      std::fprintf(stderr, "siproject: memory: about %s needed, %s available\n",
                   format_bytes(f.estimated_bytes).c_str(),
                   available_memory() == UINT64_MAX ? "no limit" : format_bytes(available_memory()).c_str());
    if (space_of(k) == SpaceKind::Hexagonal)
      std::fprintf(stderr,
                   "siproject: hexagonal lattice, %.6g points per output pixel (step %.6g), "
                   "%ld x %ld offset-row coefficients over the frame and its margin\n",
                   1.0 / std::abs(k.lattice.determinant()), k.lattice.matrix()[0], k.c.width,
                   k.c.height);
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

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{
      "siproject: form a final image from a supersampled render by projection onto a\n"
      "shift-invariant space of B-splines (min-error), or by a conventional filter.\n"
      "IN is any image OpenImageIO reads (EXR above all), taken as point samples at\n"
      "((i + 1/2) / S, (j + 1/2) / S) output pixels; every channel is processed as it\n"
      "is (EXR alpha is premultiplied, so it is filtered with the colour); integer\n"
      "inputs tagged sRGB (PNG, JPEG...) are decoded to linear first. EXR output\n"
      "keeps the input's sample type (half or float; -d), with the method in its\n"
      "metadata; every format but EXR, HDR, PFM and FITS is written 8-bit,\n"
      "sRGB-encoded and clamped to [0, 1]. S < 1 upsamples (the input's cubic\n"
      "interpolant is projected). If IN is a coefficient file (--coeffs), the stored\n"
      "approximation is evaluated instead: at its own size, --size or --factor, with\n"
      "any --display. Outputs replace a file only once written whole.\n"
      "Exit status: 0 success, 1 out of memory, 2 usage, 3 input, 4 output.",
      "siproject"};
  app.add_option("IN", o.inputs,
                 "input image, or a coefficient file written by --coeffs; several inputs are row "
                 "bands of one image (by their data windows, e.g. partial renders cropped with "
                 "oiiotool --crop), projected as one")->required();
  app.add_option("-o,--output", o.output, "output image (.exr half or float, see -d; .png, .jpg, .tif... 8-bit sRGB)")->required();
  double factor = 0;
  auto* fac = app.add_option("--factor", factor,
                             "supersampling factor per axis: output = input / S (any real S > 0; "
                             "S < 1 upsamples: the input's cubic interpolant is projected)");
  app.add_option("--size", o.settings.size, "output size WxH (any ratio to the input)");
  auto* g = app.add_option("--generator", o.settings.generator,
                           "box, tent, quadratic, cubic, bspline:N (N = 0..7), mitchell, gaussian, "
                           "catmull-rom, lanczos3; with --lattice hex: hex-hat or hex-quartic "
                           "(the default there)")->capture_default_str();
  auto* lat = app.add_option("--lattice", o.settings.lattice,
                             "cartesian (coefficients on the output pixels) or hex (a hexagonal "
                             "lattice, min-error, resampled to the output pixels)")
                  ->capture_default_str();
  auto* dens = app.add_option("--density", o.settings.density,
                              "--lattice hex: lattice points per output pixel (at most one "
                              "per input sample)")
                   ->capture_default_str();
  auto* m = app.add_option("--method", o.settings.method,
                           "min-error (orthogonal projection, B-spline generators) or conventional "
                           "(normalised weighted average, any generator)")->capture_default_str();
  app.add_option("--display", o.settings.display,
                 "how the continuous approximation is sampled: centred, 2x2 (off-centre "
                 "antialiasing at +-1/4), pixel (exact pixel average) or offsets:DX,DY;DX,DY;... "
                 "[default: 2x2 for min-error, centred (the filtered pixels) for conventional]");
  auto* b = app.add_option("--boundary", o.settings.boundary,
                           "mirror (half-sample symmetric) or periodic")->capture_default_str();
  app.add_option("--coeffs", o.coeffs, "also write the coefficients as a float EXR with their metadata");
  app.add_option("-d,--data-format", o.data_format,
                 "sample type of an EXR (or other float) output: half or float [default: the "
                 "input's, as oiiotool does: half when the input stores half, float where the "
                 "output passes half's largest value 65504; -d half clamps there instead]");
  app.add_option("--nonfinite", o.settings.nonfinite,
                 "NaN/Inf samples: error, or zero to replace them with 0")->capture_default_str();
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
  remove_staged_files_on_signals();
  Settings& st = o.settings;
  st.generator_given = g->count() > 0;
  st.method_given = m->count() > 0;
  st.boundary_given = b->count() > 0;
  st.lattice_given = lat->count() > 0;
  st.density_given = dens->count() > 0;
  if (fac->count() > 0) {
    st.factor = factor;
    st.factor_spelling = fac->as<std::string>();
  }
  if (st.density_given) st.density_spelling = dens->as<std::string>();
  try {
    return run(o);
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
}
