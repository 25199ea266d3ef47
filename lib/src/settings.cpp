#include "sis/settings.h"

#include <cctype>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "sis/box_spline.h"
#include "sis/projection.h"

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

// "WxH" with positive integers.
std::pair<long, long> parse_size(const std::string& s) {
  long w = 0, h = 0;
  char x = 0, extra = 0;
  std::istringstream in(s);
  if (!(in >> w >> x >> h) || (x != 'x' && x != 'X') || (in >> extra) || w < 1 || h < 1)
    throw RequestError("--size '" + s + "': expected WxH with positive whole numbers, e.g. 1000x750");
  if (w > kMaxOutputSide || h > kMaxOutputSide)
    throw RequestError("--size '" + s + "': more than " + std::to_string(kMaxOutputSide) +
                       " pixels per side");
  return {w, h};
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
  if (o.factor && !o.size.empty()) throw RequestError("give --factor or --size, not both");
  if (!o.size.empty()) r.size = parse_size(o.size);
  const bool hex = o.lattice == "hex";
  r.hexagonal = hex;
  if (!hex && o.lattice != "cartesian")
    throw RequestError("--lattice '" + o.lattice + "': expected cartesian or hex");
  if (!hex && o.density_given) throw RequestError("--density applies to --lattice hex only");
  if (!hex && o.generator.rfind("hex-", 0) == 0)
    throw RequestError("--generator " + o.generator + " needs --lattice hex");
  if (hex) {
    r.space.kind = SpaceKind::Hexagonal;
    r.space.hex_order = as_request("--lattice hex: ", [&] {
      return BoxSpline::parse(o.generator_given ? o.generator : "hex-quartic").order();
    });
    r.space.density = o.density;
  } else {
    r.space.generator = as_request("--generator: ", [&] { return Kernel::parse(o.generator); });
  }
  // A conventional filter named alone means the conventional method.
  std::string method = o.method;
  if (!hex && o.generator_given && !o.method_given && !r.space.generator.is_bspline())
    method = "conventional";
  as_request("", [&] {
    r.method = parse_method(method);
    r.boundary = parse_boundary(o.boundary);
    if (!o.display.empty()) r.display = Display::parse(o.display);
    return 0;
  });
  if (!hex && r.method == Method::MinError && !r.space.generator.is_bspline())
    throw RequestError("--method min-error needs a B-spline generator (box, tent, quadratic, cubic, "
                       "bspline:N), not " + r.space.generator.name() + "; use --method conventional");
  r.clamp = as_request("--clamp: ", [&] { return parse_clamp(o.clamp); });
  if (o.nonfinite != "error" && o.nonfinite != "zero")
    throw RequestError("--nonfinite '" + o.nonfinite + "': expected error or zero");
  if (o.prefilter != "fft" && o.prefilter != "recursive")
    throw RequestError("--prefilter '" + o.prefilter + "': expected fft or recursive");
  if (hex && r.method != Method::MinError)
    throw RequestError("--lattice hex has the min-error method only");
  if (hex && o.prefilter != "fft") throw RequestError("--lattice hex has the fft prefilter only");
  r.prefilter = o.prefilter == "fft" ? PrefilterMethod::FFT : PrefilterMethod::Recursive;
  if (!is_auto(o.input_transfer))
    try {
      r.input_transfer = parse_transfer(o.input_transfer);
    } catch (const std::invalid_argument&) {
      throw RequestError("--input-transfer '" + o.input_transfer +
                         "': expected auto, srgb, linear or gammaG (G > 0, e.g. gamma2.2)");
    }
  r.zero_nonfinite = o.nonfinite == "zero";
  r.highlight_compress = o.highlight_compress;
  return r;
}

std::pair<long, long> output_size(const Settings& o, const Resolved& r, long w, long h) {
  if (r.size.first) return r.size;
  if (!o.factor) return {w, h};
  const double dw = std::round(w / *o.factor), dh = std::round(h / *o.factor);
  if (!(dw <= kMaxOutputSide && dh <= kMaxOutputSide)) {
    std::ostringstream m;
    m << "--factor " << spelling(o.factor_spelling, *o.factor) << ": the output would be " << dw
      << " x " << dh << " pixels, more than " << kMaxOutputSide << " per side";
    throw RequestError(m.str());
  }
  const long ow = long(dw), oh = long(dh);
  if (ow < 1 || oh < 1) {
    std::ostringstream m;
    m << "--factor " << *o.factor << " is larger than the image (" << w << " x " << h << ")";
    throw RequestError(m.str());
  }
  return {ow, oh};
}

Formed form(const Settings& o, const Resolved& r, InputSet set, const FormRequest& fr) {
  Formed f;
  const int threads = r.threads;
  Coefficients& k = f.coefficients;
  if (set.coefficient_file) {
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
    f.input_half = reader.attribute("sis:input_format") == "half";
    try {
      const std::string recorded = reader.attribute("sis:input_transfer");
      f.input_transfer = recorded.empty() ? Transfer::linear() : parse_transfer(recorded);
    } catch (const std::invalid_argument& e) {
      throw InputError(reader.path() + ": coefficient file metadata: sis:input_transfer " + e.what());
    }
    const auto t = Clock::now();
    k = load_coefficients(reader.path(), r.zero_nonfinite, &f.replaced);
    f.highlight_compressed = reader.attribute("sis:highlight_compress") == "1";
    f.acquire_seconds = seconds_since(t);
    if (f.replaced.count)
      f.warnings.push_back("replaced " + std::to_string(f.replaced.count) +
                           " non-finite coefficients with 0; first: " + f.replaced.where);
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
    f.inputs = std::move(set);
  } else {
    if (!o.factor && !r.size.first)
      throw RequestError("give the output size: --factor S (output = input / S) or --size WxH");
    std::tie(f.width, f.height) = output_size(o, r, set.width, set.height);
    f.input_half = set.half;
    ProjectionRequest rq;
    rq.width = f.width;
    rq.height = f.height;
    rq.space = r.space;
    rq.method = r.method;
    rq.boundary = r.boundary;
    rq.prefilter = r.prefilter;
    rq.zero_nonfinite = r.zero_nonfinite;
    rq.highlight_compress = r.highlight_compress;
    rq.input_transfer = r.input_transfer;
    rq.threads = threads;
    rq.coefficient_file = fr.coefficient_file;
    rq.float_coefficients = fr.float_coefficients;
    rq.progress = fr.progress;
    Projection p = project(rq, std::move(set));
    f.replaced = p.nonfinite;
    if (p.nonfinite.count)
      f.warnings.push_back("replaced " + std::to_string(p.nonfinite.count) +
                           " non-finite samples with 0; first: " + p.nonfinite.where);
    k = std::move(p.coefficients);
    f.local_range = std::move(p.local_range);
    f.inputs = std::move(p.inputs);
    f.highlight_compressed = r.highlight_compress;
    f.input_transfer = p.transfer;
    f.acquire_seconds = p.acquire_seconds;
    f.prefilter_seconds = p.prefilter_seconds;
    f.estimated_bytes = p.estimated_bytes;
  }
  f.display = r.display ? *r.display : (k.min_error ? Display::antialiased_2x2() : Display::centred());
  if (!fr.final_image) return f;
  const auto t = Clock::now();
  f.final = final_image(k, f.display, f.width, f.height, f.highlight_compressed, r.clamp,
                        f.local_range.get(), threads, f.inputs.label, f.inputs.channel_names,
                        f.inputs.alpha);
  f.resample_seconds = seconds_since(t);
  if (!fr.keep_coefficients) {
    Buffer<double>().swap(k.c.data);
  }
  return f;
}

Formed form(const Settings& o, const std::vector<ProjectionInput>& inputs, const FormRequest& fr) {
  const Resolved r = resolve(o);
  return form(o, r, inspect(inputs), fr);
}

}  // namespace sis
