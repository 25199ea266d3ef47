#include "sis/settings.h"
#include "sis/pyramid.h"

#include "sis/partial.h"

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <thread>

#include "sis/projection.h"
#include "sis/scattered_input.h"

namespace sis {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string spelling(const std::string& given, double value) {
  if (!given.empty()) return given;
  std::ostringstream s;
  s << value;
  return s.str();
}

bool is_auto(const std::string& s) {
  return s.size() == 4 && std::tolower(s[0]) == 'a' && std::tolower(s[1]) == 'u' &&
         std::tolower(s[2]) == 't' && std::tolower(s[3]) == 'o';
}

// Runs f, its std::invalid_argument a RequestError prefixed by `option`.
template <typename F>
auto as_request(const std::string& option, F&& f) {
  try {
    return f();
  } catch (const std::invalid_argument& e) {
    throw RequestError(option + e.what());
  }
}

}  // namespace

SizeSpec parse_size(const std::string& s) {
  const auto bad = [&] {
    return RequestError("--size '" + s +
                        "': expected WxH in pixels (0 for a side keeps the input's aspect), W alone, "
                        "or a percentage P% or P%xQ%, e.g. 1000x750, 960, 0x540, 50%");
  };
  // One side: a whole number of pixels, or a positive percentage.
  const auto side = [&](const std::string& t, long& pixels, double& scale) {
    if (t.empty()) throw bad();
    if (t.back() == '%') {
      const std::string n = t.substr(0, t.size() - 1);
      if (n.empty() || n.find_first_not_of("0123456789.") != std::string::npos) throw bad();
      char* end = nullptr;
      const double p = std::strtod(n.c_str(), &end);
      if (*end || !std::isfinite(p) || !(p > 0)) throw bad();
      scale = p / 100;
      return;
    }
    if (t.find_first_not_of("0123456789") != std::string::npos || t.size() > 12) throw bad();
    pixels = std::stol(t);
    if (pixels > kMaxOutputSide)
      throw RequestError("--size '" + s + "': more than " + std::to_string(kMaxOutputSide) +
                         " pixels per side");
  };
  SizeSpec z;
  const std::size_t x = s.find_first_of("xX");
  if (x == std::string::npos) {
    side(s, z.width, z.width_scale);
    if (z.width_scale) z.height_scale = z.width_scale;  // P%: both sides
  } else {
    side(s.substr(0, x), z.width, z.width_scale);
    side(s.substr(x + 1), z.height, z.height_scale);
  }
  if (!z.given()) throw bad();  // 0, 0x0
  return z;
}

Resolved resolve(const Settings& o) {
  Resolved r;
  if (o.threads < 0)
    throw RequestError("--threads " + std::to_string(o.threads) + ": expected 0 (all cores) or more");
  if (o.threads > kMaxThreads)
    throw RequestError("--threads " + std::to_string(o.threads) + ": at most " +
                       std::to_string(kMaxThreads));
  r.threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  if (o.factor && !(std::isfinite(*o.factor) && *o.factor > 0))
    throw RequestError("--factor " + spelling(o.factor_spelling, *o.factor) +
                       ": expected a finite number above 0");
  if (!(std::isfinite(o.density) && o.density > 0))
    throw RequestError("--density " + spelling(o.density_spelling, o.density) +
                       ": expected a finite number above 0");
  if (o.scale && !(std::isfinite(*o.scale) && *o.scale > 0))
    throw RequestError("--scale " + spelling(o.scale_spelling, *o.scale) +
                       ": expected a finite number above 0");
  if (int(bool(o.factor)) + int(!o.size.empty()) + int(bool(o.scale)) > 1)
    throw RequestError("give one of --factor, --size and --scale, not several");
  if (!o.size.empty()) r.size = parse_size(o.size);
  r.space = parse_space(o.lattice, o.generator, o.generator_given, o.density, o.density_given);
  const std::string method = visit_space(r.space, [&](const auto& space) {
    return space.implied_method(o.method, o.generator_given, o.method_given);
  });
  as_request("", [&] {
    r.method = parse_method(method);
    r.boundary = parse_boundary(o.boundary);
    if (!o.display.empty()) r.display = Display::parse(o.display);
    return 0;
  });
  r.clamp = as_request("--clamp: ", [&] { return parse_clamp(o.clamp); });
  if (o.nonfinite != "error" && o.nonfinite != "zero")
    throw RequestError("--nonfinite '" + o.nonfinite + "': expected error or zero");
  if (o.prefilter != "fft" && o.prefilter != "recursive")
    throw RequestError("--prefilter '" + o.prefilter + "': expected fft or recursive");
  r.prefilter = o.prefilter == "fft" ? PrefilterMethod::FFT : PrefilterMethod::Recursive;
  visit_space(r.space, [&](const auto& space) { space.check_options(r.method, r.prefilter); });
  if (!is_auto(o.input_transfer))
    try {
      r.input_transfer = parse_transfer(o.input_transfer);
    } catch (const std::invalid_argument&) {
      throw RequestError("--input-transfer '" + o.input_transfer +
                         "': expected auto, srgb, linear or gammaG (G > 0, e.g. gamma2.2)");
    }
  r.zero_nonfinite = o.nonfinite == "zero";
  r.highlight_compress = o.highlight_compress;
  try {
    r.scattered.rule = parse_scattered_rule(o.rule);
  } catch (const std::invalid_argument&) {
    throw RequestError("--rule '" + o.rule + "': expected fit, normalised, plain or variational");
  }
  if ((o.lambda_given || o.smoothness_given) && r.scattered.rule != ScatteredRule::Variational)
    throw RequestError(std::string(o.lambda_given ? "--lambda" : "--smoothness") +
                       " applies to --rule variational");
  if (o.lambda != "gcv") {
    double v = 0;
    std::size_t used = 0;
    try {
      v = std::stod(o.lambda, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != o.lambda.size() || o.lambda.empty() || !std::isfinite(v) || v < 0)
      throw RequestError("--lambda '" + o.lambda + "': expected gcv or a finite number >= 0");
    r.scattered.lambda = v;
  }
  if (o.smoothness != 1 && o.smoothness != 2)
    throw RequestError("--smoothness " + std::to_string(o.smoothness) +
                       ": expected 1 (gradient) or 2 (thin plate)");
  r.scattered.smoothness = o.smoothness;
  if (r.scattered.rule == ScatteredRule::Variational && r.scattered.smoothness == 2)
    if (const auto* hex = std::get_if<HexagonalSpace>(&r.space); hex && hex->order < 2)
      throw RequestError("--rule variational --smoothness 2 (the thin plate, the default) needs "
                         "square-integrable second derivatives, which --generator hex-hat (C0) "
                         "does not have: use --smoothness 1 or --generator hex-quartic");
  // the conventional methods take the normalised average
  if (r.method == Method::Conventional && !o.rule_given) r.scattered.rule = ScatteredRule::NormalisedSum;
  if (o.iterations < 0)
    throw RequestError("--iterations " + std::to_string(o.iterations) + ": expected 0 or more");
  r.scattered.iterations = o.iterations;
  return r;
}

std::pair<long, long> output_size(const Settings& o, const Resolved& r, long w, long h) {
  if (!r.size.given() && !o.scale && !o.factor) return {w, h};
  std::string option;  // for messages
  double dw = 0, dh = 0;
  if (r.size.given()) {
    const SizeSpec& z = r.size;
    option = "--size " + o.size;
    dw = z.width ? double(z.width) : w * z.width_scale;
    dh = z.height ? double(z.height) : h * z.height_scale;
    if (!dw) dw = dh * w / h;  // the input's aspect
    if (!dh) dh = dw * h / w;
  } else if (o.scale) {
    option = "--scale " + spelling(o.scale_spelling, *o.scale);
    dw = w * *o.scale, dh = h * *o.scale;
  } else {
    option = "--factor " + spelling(o.factor_spelling, *o.factor);
    dw = w / *o.factor, dh = h / *o.factor;
  }
  dw = std::round(dw), dh = std::round(dh);
  if (!(dw <= kMaxOutputSide && dh <= kMaxOutputSide)) {
    std::ostringstream m;
    m << option << ": the output would be " << dw << " x " << dh << " pixels, more than "
      << kMaxOutputSide << " per side";
    throw RequestError(m.str());
  }
  const long ow = long(dw), oh = long(dh);
  if (ow < 1 || oh < 1) {
    std::ostringstream m;
    if (o.factor && !r.size.given())
      m << "--factor " << *o.factor << " is larger than the image (" << w << " x " << h << ")";
    else
      m << option << ": the output of the " << w << " x " << h << " image would be " << dw << " x "
        << dh << " pixels";
    throw RequestError(m.str());
  }
  return {ow, oh};
}

namespace {
// The options a coefficient file or partial records (what: "X is a
// coefficient file"): RequestError when given.
void refuse_recorded(const Settings& o, const Resolved& r, const std::string& what) {
  if (o.generator_given || o.method_given || o.boundary_given || o.highlight_compress)
    throw RequestError(what + ": the generator, method, boundary and highlight compression are "
                       "recorded there; drop --generator, --method, --boundary and "
                       "--highlight-compress");
  if (o.lattice_given || o.density_given)
    throw RequestError(what + ": the lattice is recorded there; drop --lattice and --density");
  if (r.input_transfer)
    throw RequestError(what + ": the input's transfer was decoded before projecting; drop "
                       "--input-transfer");
}

ProjectionRequest projection_request(const Settings& o, const Resolved& r, const InputSet& set,
                                     const FormRequest& fr, long* width, long* height) {
  if (!o.factor && !o.scale && !r.size.given())
    throw RequestError("give the output size: --factor S (output = input / S), --size WxH "
                       "(or W, 0xH, P%) or --scale M (output = input x M)");
  std::tie(*width, *height) = output_size(o, r, set.width, set.height);
  ProjectionRequest rq;
  static_cast<ProjectionTerms&>(rq) = r;
  rq.width = *width;
  rq.height = *height;
  rq.coefficient_file = fr.coefficient_file;
  rq.float_coefficients = fr.float_coefficients;
  rq.progress = fr.progress;
  rq.interrupt = fr.interrupt;
  return rq;
}
}  // namespace

// --rule and --iterations: scattered samples only.
void refuse_scattered_options(const Settings& o, const std::string& label) {
  if (!o.refined.empty())
    throw RequestError("--refined " + o.refined + ": the second pass refines a sobol render's "
                       "samples; " + label + " is a grid of samples");
  if (o.rule_given || o.iterations_given || o.lambda_given || o.smoothness_given)
    throw RequestError(std::string(o.rule_given ? "--rule" : o.iterations_given ? "--iterations" : o.lambda_given ? "--lambda" : "--smoothness") +
                       " applies to scattered samples (a file with position channels " +
                       kPositionChannelX + ", " + kPositionChannelY + ", or positions= in Python); " +
                       label + " is a grid of samples");
}

Partial form_partial(const Settings& o, const Resolved& r, InputSet set, const FormRequest& fr) {
  if (set.scattered_file)
    throw RequestError(set.label + ": a file of scattered samples has no row bands; --partial "
                       "takes a grid's bands");
  refuse_scattered_options(o, set.label);
  if (set.coefficient_file || set.partial_files)
    throw RequestError(set.label + ": a partial is made of samples, not of " +
                       (set.coefficient_file ? "a coefficient file" : "partial files"));
  long W = 0, H = 0;
  const ProjectionRequest rq = projection_request(o, r, set, fr, &W, &H);
  return project_partial(rq, std::move(set));
}

namespace {
// A coefficient file's level `level` into f (its coefficients, its frame,
// the output's size and the memory check), as form() evaluates one.
void load_level(const Settings& o, const Resolved& r, const InputSet& set, int level, Formed& f) {
  const int threads = r.threads;
  Coefficients& k = f.coefficients;
  const ImageReader& reader = *set.readers.front();
  if (set.bands.size() > 1)
    throw RequestError("a coefficient file is evaluated alone, not with other inputs");
  if (o.generator_given || o.method_given || o.boundary_given || o.highlight_compress)
    throw RequestError(reader.path() + " is a coefficient file: its generator, method, boundary and "
                       "highlight compression are recorded in it; drop --generator, --method, "
                       "--boundary and --highlight-compress");
  if (r.clamp == Clamp::Local)
    throw RequestError("--clamp local needs the input samples; " + reader.path() +
                       " is a coefficient file");
  if (o.lattice_given || o.density_given)
    throw RequestError(reader.path() + " is a coefficient file: its lattice is recorded in it; "
                       "drop --lattice and --density");
  if (r.input_transfer)
    throw RequestError(reader.path() + " is a coefficient file: its input's transfer was decoded "
                       "before projecting; drop --input-transfer");
  f.from_coefficient_file = true;
  const auto t = Clock::now();
  k = load_coefficients(reader.path(), r.zero_nonfinite, &f.nonfinite, reader.signature(), level);
  f.acquire_seconds = seconds_since(t);
  if (f.nonfinite.count)
    f.warnings.push_back("replaced " + std::to_string(f.nonfinite.count) +
                         " non-finite coefficients with 0; first: " + f.nonfinite.where);
  // its own size is its frame's (a hexagonal grid also covers a margin)
  const auto [fw, fh] = visit_space(k, [&](auto space) { return space.frame(k); });
  std::tie(f.width, f.height) = output_size(o, r, fw, fh);
  const double radius = visit_space(k, [&](auto space) { return space.radius(k); });
  f.estimated_bytes =
      projection_bytes(f.width, f.height, set.channels,
                       std::uint64_t(k.c.width) * std::uint64_t(k.c.height), false, false, threads,
                       table_bytes(f.width, k.c.width, f.height, k.c.height, radius));
  check_memory(f.estimated_bytes, "a " + std::to_string(f.width) + " x " +
                                      std::to_string(f.height) + " x " +
                                      std::to_string(set.channels) + " output");
}
}  // namespace

Formed form(const Settings& o, const Resolved& r, InputSet set, const FormRequest& fr) {
  if (set.scattered_file) {
    const ImageReader& reader = *set.readers.front();
    ScatteredInput in = read_scattered(reader.path(), r.input_transfer, reader.signature());
    if (!o.refined.empty()) add_refinement(in, o.refined, r.input_transfer);
    return form_scattered(o, r, std::move(in), fr);
  }
  refuse_scattered_options(o, set.label);
  Formed f;
  const int threads = r.threads;
  Coefficients& k = f.coefficients;
  if (set.coefficient_file) {
    load_level(o, r, set, 0, f);
    f.inputs = std::move(set);
  } else {
    Projection& p = f;
    if (set.partial_files) {
      refuse_recorded(o, r, set.label + " are partial files");
      std::vector<Partial> parts;
      for (const ProjectionInput& in : set.bands) parts.push_back(read_partial(in.path));
      p = merge(parts, threads, fr.float_coefficients);
      std::tie(f.width, f.height) = output_size(o, r, parts.front().width, parts.front().height);
    } else {
      const ProjectionRequest rq = projection_request(o, r, set, fr, &f.width, &f.height);
      p = project(rq, std::move(set));
    }
    if (p.nonfinite.count)
      f.warnings.push_back("replaced " + std::to_string(p.nonfinite.count) +
                           " non-finite samples with 0; first: " + p.nonfinite.where);
  }
  f.display = r.display ? *r.display : (k.min_error ? Display::antialiased_2x2() : Display::centred());
  if (!fr.final_image) return f;
  if (fr.interrupt) fr.interrupt();
  const auto t = Clock::now();
  f.final = final_image(k, f.display, f.width, f.height, r.clamp, f.local_range.get(), threads);
  f.resample_seconds = seconds_since(t);
  if (!fr.keep_coefficients) {
    Buffer<double>().swap(k.c.data);
  }
  return f;
}

namespace {
// A pyramid's coefficient file (siproject --mip --coeffs): every level
// evaluated at its own frame.
std::vector<Formed> evaluate_pyramid(const Settings& o, const Resolved& r, InputSet set,
                                     const FormRequest& fr) {
  const ImageReader& reader = *set.readers.front();
  const int levels = coefficient_levels(reader);
  if (levels < 2)
    throw RequestError("--mip: " + set.label + " is a coefficient file of one level; a pyramid's "
                       "levels are projected from the samples, or evaluated from the coefficient "
                       "file of a pyramid (siproject --mip --coeffs)");
  if (o.factor || o.scale || r.size.given())
    throw RequestError("--mip: " + set.label + " holds a pyramid's levels, each at its own size; "
                       "drop --factor, --scale and --size");
  std::vector<Formed> formed(static_cast<std::size_t>(levels));
  for (int j = 0; j < levels; ++j) {
    Formed& f = formed[std::size_t(j)];
    load_level(o, r, set, j, f);
    f.display = r.display ? *r.display
                          : (f.coefficients.min_error ? Display::antialiased_2x2() : Display::centred());
    if (!fr.final_image) continue;
    if (fr.interrupt) fr.interrupt();
    const auto t = Clock::now();
    f.final = final_image(f.coefficients, f.display, f.width, f.height, r.clamp, nullptr, r.threads);
    f.resample_seconds = seconds_since(t);
    if (!fr.keep_coefficients) Buffer<double>().swap(f.coefficients.c.data);
  }
  formed.front().inputs = std::move(set);
  return formed;
}
}  // namespace

std::vector<Formed> form_pyramid(const Settings& o, const Resolved& r, InputSet set,
                                 const FormRequest& fr) {
  if (set.coefficient_file) return evaluate_pyramid(o, r, std::move(set), fr);
  if (set.partial_files)
    throw RequestError("--mip: " + set.label + " are partial files; a pyramid is projected "
                       "from the samples (merge them first, or give the render)");
  if (set.scattered_file)
    throw RequestError("--mip: " + set.label + " holds scattered samples; a pyramid is "
                       "projected from a grid of samples");
  refuse_scattered_options(o, set.label);
  long W = 0, H = 0;
  ProjectionRequest rq = projection_request(o, r, set, fr, &W, &H);
  rq.inputs = set.bands;
  std::vector<Projection> levels = project_pyramid(rq);
  std::vector<Formed> formed(levels.size());
  const auto sizes = pyramid_sizes(W, H);
  for (std::size_t j = 0; j < levels.size(); ++j) {
    Formed& f = formed[j];
    static_cast<Projection&>(f) = std::move(levels[j]);
    f.width = sizes[j].first;
    f.height = sizes[j].second;
    if (j == 0 && f.nonfinite.count)
      f.warnings.push_back("replaced " + std::to_string(f.nonfinite.count) +
                           " non-finite samples with 0; first: " + f.nonfinite.where);
    f.display = r.display ? *r.display
                          : (f.coefficients.min_error ? Display::antialiased_2x2() : Display::centred());
    if (!fr.final_image) continue;
    if (fr.interrupt) fr.interrupt();
    const auto t = Clock::now();
    f.final = final_image(f.coefficients, f.display, f.width, f.height, r.clamp,
                          f.local_range.get(), r.threads);
    f.resample_seconds = seconds_since(t);
    f.local_range.reset();
    if (!fr.keep_coefficients) Buffer<double>().swap(f.coefficients.c.data);
  }
  return formed;
}

namespace {
std::string number(double v) {
  std::ostringstream m;
  m << v;
  return m.str();
}

// The samples checked as the input names them: positions finite and in
// the frame, weights finite and > 0, values finite (or replaced by 0).
void check_scattered(ScatteredInput& in, double W, double H, bool zero_nonfinite,
                     NonFiniteReport& replaced) {
  ScatteredSamples& s = in.samples;
  const long n = s.count();
  const int C = s.channels;
  for (long i = 0; i < n; ++i) {
    const double x = s.positions[2 * i], y = s.positions[2 * i + 1];
    if (!(std::isfinite(x) && std::isfinite(y)))
      throw InputError(in.positions_name + ": " + in.sample_name(i) + ": position (" + number(x) +
                       ", " + number(y) + ") is not finite");
    if (!(x >= 0 && x <= W && y >= 0 && y <= H))
      throw InputError(in.positions_name + ": " + in.sample_name(i) + ": position (" + number(x) +
                       ", " + number(y) + ") lies outside the frame [0, " + number(W) + "] x [0, " +
                       number(H) + "] (output pixels, --size)");
  }
  if (!s.weights.empty())
    for (long i = 0; i < n; ++i)
      if (!(std::isfinite(s.weights[i]) && s.weights[i] > 0))
        throw InputError(in.weights_name + ": " + in.sample_name(i) + ": weight " +
                         number(s.weights[i]) + " (the area a sample stands for: finite and > 0)");
  const long bad = first_nonfinite(s.values.data(), s.values.size());
  if (bad < 0) return;
  const long i = bad / C;
  const int c = int(bad % C);
  replaced.file = in.label;
  replaced.channel = c;
  replaced.x = in.grid_width > 0 ? in.grid_x + i % in.grid_width : i;
  replaced.y = in.grid_width > 0 ? in.grid_y + i / in.grid_width : 0;
  replaced.where = in.values_name + ": " + in.sample_name(i) + ": non-finite value (NaN or Inf) in channel " +
                   (c < int(in.channel_names.size()) ? in.channel_names[c] : std::to_string(c));
  if (!zero_nonfinite) throw InputError(replaced.where + "; use --nonfinite zero to replace them with 0");
  for (double& v : s.values)
    if (!std::isfinite(v)) v = 0, ++replaced.count;
}
}  // namespace

Formed form_scattered(const Settings& o, const Resolved& r, ScatteredInput in, const FormRequest& fr) {
  std::pair<long, long> f_size;
  const std::string& label = in.label;
  if (in.pattern) {
    // a pattern's render: its grid is the input's size (--factor, --scale,
    // --size of any spelling, as a grid's), the positions scaled onto the output
    std::tie(f_size.first, f_size.second) =
        output_size(o, r, in.pattern->grid_width(), in.pattern->grid_height());
    const double sx = double(f_size.first) / double(in.pattern->width),
                 sy = double(f_size.second) / double(in.pattern->height);
    if (sx != 1 || sy != 1) {
      for (std::size_t q = 0; q < in.samples.positions.size(); q += 2)
        in.samples.positions[q] *= sx, in.samples.positions[q + 1] *= sy;
      for (double& w : in.samples.weights) w *= sx * sy;  // areas, in the output's pixels^2
    }
  } else if (o.factor || o.scale)
    throw RequestError(std::string(o.factor ? "--factor" : "--scale") + ": " + label +
                       ": scattered samples have no grid to divide or scale; give the frame with "
                       "--size WxH (output pixels, the positions' coordinates)");
  else if (!r.size.given() || !r.size.width || !r.size.height)
    throw RequestError((o.size.empty() ? std::string("--size") : "--size " + o.size) + ": " + label +
                       ": scattered samples need the frame as --size WxH in pixels (the "
                       "positions' coordinates; no side from an aspect or a percentage)");
  if (r.clamp == Clamp::Local)
    throw RequestError("--clamp local: " + label +
                       ": scattered samples have no local range (the range of a grid's samples "
                       "under each pixel); --clamp zero or none");
  if (r.method == Method::Conventional && r.scattered.rule != ScatteredRule::NormalisedSum)
    throw RequestError(std::string("--rule ") + scattered_rule_name(r.scattered.rule) +
                       ": the conventional method takes the normalised weighted average (--rule "
                       "normalised)");
  Formed f;
  const int threads = r.threads;
  f.width = in.pattern ? f_size.first : r.size.width;
  f.height = in.pattern ? f_size.second : r.size.height;
  const int C = in.samples.channels;
  if (C < 1) throw InputError(label + ": no value channel");
  const long n = in.samples.count();
  if (n < 1) throw InputError(label + ": no sample");
  ScatteredTarget target;
  target.width = double(f.width);
  target.height = double(f.height);
  target.space = r.space;
  target.boundary = r.boundary;
  target.method = r.method;
  target.prefilter = r.prefilter;
  // the coefficients (the space's grid: on the hexagonal lattice its margin
  // too), the rule's working grids and values, the output
  std::pair<long, long> extent;
  std::uint64_t working = 0;
  try {
    extent = scattered_grid(target);
    working = scattered_bytes(target, in.samples, r.scattered);
  } catch (const std::invalid_argument& e) {
    throw RequestError(label + ": " + e.what());
  }
  f.estimated_bytes = projection_bytes(f.width, f.height, C,
                                       std::uint64_t(extent.first) * std::uint64_t(extent.second),
                                       false, fr.coefficient_file, threads) +
                      working;
  try {
    check_memory(f.estimated_bytes, "the projection of " + std::to_string(n) + " scattered samples to " +
                                        std::to_string(f.width) + " x " + std::to_string(f.height) +
                                        " x " + std::to_string(C));
  } catch (const RequestError& e) {
    // the samples, not the output, fill the variational rule's memory
    if (r.scattered.rule != ScatteredRule::Variational) throw;
    throw RequestError(std::string(e.what()) +
                       (r.scattered.lambda ? "" : ", or give --lambda (no GCV probes: fewer channels)") +
                       ", or --rule fit (its working set is a few grids)");
  }
  check_scattered(in, target.width, target.height, r.zero_nonfinite, f.nonfinite);
  if (f.nonfinite.count)
    f.warnings.push_back("replaced " + std::to_string(f.nonfinite.count) +
                         " non-finite values with 0; first: " + f.nonfinite.where);
  if (r.highlight_compress) {
    for (std::size_t q = 0; q < in.samples.values.size(); ++q)
      if (int(q % C) != in.alpha) in.samples.values[q] = highlight_compress(in.samples.values[q]);
  }
  if (fr.interrupt) fr.interrupt();
  const auto t = Clock::now();
  ScatteredReport report;
  Coefficients& k = f.coefficients;
  try {
    k = project_scattered(in.samples, target, r.scattered, &report);
  } catch (const std::invalid_argument& e) {
    throw InputError(label + ": " + e.what());
  }
  f.acquire_seconds = seconds_since(t);
  f.scattered = report;
  in.samples = ScatteredSamples();  // the copies, before the final image
  if (fr.float_coefficients)
    for (std::size_t q = 0; q < k.c.data.size(); ++q) k.c.data[q] = static_cast<float>(k.c.data[q]);
  const long overflow = first_nonfinite(k.c.data.data(), k.c.data.size());
  if (overflow >= 0)
    throw InputError(label + ": the values are too large: the coefficients pass float's largest "
                     "value (3.4e38) at coefficient " +
                     value_position(overflow, k.c.width, in.channel_names) + "; nothing written");
  InputSet& set = f.inputs;
  set.width = n;
  set.height = set.rows = 1;
  set.channels = C;
  set.channel_names = in.channel_names;
  set.alpha = in.alpha;
  set.half = in.half;
  set.transfer = in.transfer;
  set.srgb = in.transfer.kind == Transfer::SRGB;
  set.integer_bits = in.integer_bits;
  set.label = label;
  k.channel_names = in.channel_names;
  k.alpha = in.alpha;
  k.highlight_compressed = r.highlight_compress;
  k.input = {label, in.half, in.transfer};
  f.display = r.display ? *r.display : (k.min_error ? Display::antialiased_2x2() : Display::centred());
  if (!fr.final_image) return f;
  if (fr.interrupt) fr.interrupt();
  const auto t2 = Clock::now();
  f.final = final_image(k, f.display, f.width, f.height, r.clamp, nullptr, threads);
  f.resample_seconds = seconds_since(t2);
  if (!fr.keep_coefficients) Buffer<double>().swap(k.c.data);
  return f;
}

Formed form(const Settings& o, const std::vector<ProjectionInput>& inputs, const FormRequest& fr) {
  const Resolved r = resolve(o);
  return form(o, r, inspect(inputs), fr);
}

}  // namespace sis
