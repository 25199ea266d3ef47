// simetrics: the measures of docs/design.md section 8 for one final image, for the
// comparison scripts: high-pass energy share, RMS / PSNR against a reference,
// overshoot of the supersampled input's local range.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <thread>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cli.h"
#include "version.h"
#include "sis/engine.h"
#include "sis/imageio.h"
#include "sis/metrics.h"

using namespace sis;

namespace {

using sis::cli::kExitUsage;
using sis::cli::kExitInput;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  std::string image, reference, input, coeffs, truth;
  double zoneplate = 0;
  int samples_per_pixel = 8;
  double factor = 0;
  std::vector<double> cutoffs{0.125, 0.25};
  long border = 0;
  double peak = 1.0;
  double neighbourhood = OvershootOptions{}.neighbourhood;
  double tolerance = OvershootOptions{}.tolerance;
  bool json = false;
};

// Shortest %g spelling that reads back as the same double: 0.125, not
// 0.12500000000000000.
std::string shortest(double v) {
  char buf[40];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (unsigned char ch : s) {
    if (ch == '"' || ch == '\\') {
      q += '\\';
      q += char(ch);
    } else if (ch < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", ch);
      q += buf;
    } else {
      q += char(ch);
    }
  }
  return q + "\"";
}

// Measures in order, written as one JSON object or as "key value" lines
// (nested objects as "outer.key value").
class Report {
 public:
  // NaN and the infinities are null in JSON, which cannot spell them.
  void number(const std::string& key, double v) {
    const bool finite = std::isfinite(v);
    add(key, finite ? shortest(v) : "null",
        finite ? shortest(v) : (std::isnan(v) ? "nan" : v > 0 ? "inf" : "-inf"));
  }
  void integer(const std::string& key, long v) { add(key, std::to_string(v), std::to_string(v)); }
  void string(const std::string& key, const std::string& v) { add(key, quoted(v), v); }
  void object(const std::string& key, const Report& inner) {
    items_.push_back({key, inner.json(), inner.text(key + "."), true});
  }
  std::string json() const {
    std::string s = "{";
    for (std::size_t i = 0; i < items_.size(); ++i)
      s += (i ? ", " : "") + quoted(items_[i].key) + ": " + items_[i].json;
    return s + "}";
  }
  std::string text(const std::string& prefix = "") const {
    std::string s;
    for (const Item& item : items_)
      s += item.nested ? item.text : prefix + item.key + " " + item.text + "\n";
    return s;
  }

 private:
  struct Item {
    std::string key, json, text;
    bool nested;
  };
  std::vector<Item> items_;
  void add(const std::string& key, const std::string& json, const std::string& text) {
    items_.push_back({key, json, text, false});
  }
};

// CLI11's own range validators print the whole double range in their message.
CLI::Validator at_least_zero(bool strictly) {
  return CLI::Validator(
      [strictly](std::string& s) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (end == s.c_str() || *end != '\0' || !std::isfinite(v) || v < 0 || (strictly && v == 0))
          return "'" + s + "' is not a number " + (strictly ? "> 0" : ">= 0");
        return "";
      },
      strictly ? "POSITIVE" : "NONNEGATIVE");
}

std::string size_of(const Image& a) {
  return std::to_string(a.width) + " x " + std::to_string(a.height) + " x " +
         std::to_string(a.channels);
}

// Reads an image whose every value is finite.
Image read_finite(const std::string& path) {
  Image image = read_image(path);
  for (std::size_t q = 0; q < image.data.size(); ++q)
    if (!std::isfinite(image.data[q])) {
      const std::size_t p = q / image.channels;
      throw InputError(path + ": non-finite value (NaN or Inf) at x " +
                       std::to_string(p % image.width) + ", y " + std::to_string(p / image.width) +
                       ", channel " + std::to_string(q % image.channels));
    }
  return image;
}

int run(const Options& o) {
  if (o.factor != 0 && o.input.empty()) throw UsageError("--factor needs --input");
  const Image image = read_finite(o.image);
  Report report;
  report.string("image", o.image);
  report.integer("width", image.width);
  report.integer("height", image.height);
  report.integer("channels", image.channels);
  std::vector<double> cutoffs;  // each once, in the order given
  for (double c : o.cutoffs)
    if (std::find(cutoffs.begin(), cutoffs.end(), c) == cutoffs.end()) cutoffs.push_back(c);
  const std::vector<double> shares = highpass_energy_shares(image, cutoffs);
  for (std::size_t q = 0; q < cutoffs.size(); ++q)
    report.number("hp_" + shortest(cutoffs[q]), shares[q]);

  if (2 * o.border >= image.width || 2 * o.border >= image.height) {
    throw UsageError("--border " + std::to_string(o.border) + " leaves no pixel of " + o.image +
                     " (" + size_of(image) + ")");
  }
  if (!o.reference.empty()) {
    const Image reference = read_finite(o.reference);
    if (reference.width != image.width || reference.height != image.height ||
        reference.channels != image.channels)
      throw UsageError("--reference " + o.reference + " is " + size_of(reference) + ", " +
                       o.image + " is " + size_of(image) + ": they must match");
    report.string("reference", o.reference);
    report.integer("border", o.border);
    report.number("rms", rms_difference(image, reference, o.border));
    report.number("peak", o.peak);
    report.number("psnr", psnr(image, reference, o.peak, o.border));
  }
  if (!o.input.empty()) {
    const Image input = read_finite(o.input);
    if (input.channels != image.channels)
      throw UsageError("--input " + o.input + " has " + std::to_string(input.channels) +
                       " channels, " + o.image + " " + std::to_string(image.channels));
    if (o.factor != 0 && (std::lround(input.width / o.factor) != image.width ||
                          std::lround(input.height / o.factor) != image.height)) {
      std::ostringstream m;
      m << "--input " << o.input << " is " << input.width << " x " << input.height
        << ": at --factor " << o.factor << " it does not cover " << o.image << " ("
        << image.width << " x " << image.height << ")";
      throw UsageError(m.str());
    }
    OvershootOptions options;
    options.neighbourhood = o.neighbourhood;
    options.tolerance = o.tolerance;
    options.border = o.border;
    const OvershootReport r = overshoot(image, input, options);
    Report inner;
    inner.string("input", o.input);
    inner.number("factor_x", double(input.width) / image.width);
    inner.number("factor_y", double(input.height) / image.height);
    inner.number("neighbourhood", options.neighbourhood);
    inner.number("tolerance", options.tolerance);
    inner.integer("border", options.border);
    inner.integer("pixels", r.pixels);
    inner.number("max_overshoot", r.max_overshoot);
    inner.number("max_undershoot", r.max_undershoot);
    inner.integer("pixels_out_of_range", r.pixels_out_of_range);
    inner.integer("negative_pixels", r.negative_pixels);
    inner.number("negative_energy", r.negative_energy);
    inner.number("min", r.min);
    inner.number("max", r.max);
    report.object("overshoot", inner);
  }
  if (!o.coeffs.empty()) {
    if (o.truth.empty() == (o.zoneplate == 0))
      throw UsageError("--coeffs needs exactly one truth: --truth REF or --zoneplate K");
    ImageReader reader(o.coeffs);
    if (!is_coefficient_file(reader))
      throw UsageError("--coeffs " + o.coeffs + " is not a coefficient file (siproject --coeffs)");
    if (reader.attribute("sis:highlight_compress") == "1")
      throw UsageError("--coeffs " + o.coeffs + " holds a highlight-compressed approximation: its "
                       "continuous error is not measured");
    reader.release();
    const Coefficients k = load_coefficients(o.coeffs, false, nullptr, reader.signature());
    Report inner;
    inner.string("coeffs", o.coeffs);
    inner.string("method", k.min_error ? "min-error" : "conventional");
    inner.string("generator", generator_name(k));
    inner.number("border", o.border);
    if (!o.truth.empty()) {
      const Image truth = read_finite(o.truth);
      if (truth.channels != k.c.channels)
        throw UsageError("--truth " + o.truth + " has " + std::to_string(truth.channels) +
                         " channels, the coefficients " + std::to_string(k.c.channels));
      inner.string("truth", o.truth);
      inner.integer("truth_width", truth.width);
      inner.integer("truth_height", truth.height);
      inner.number("l2_error", l2_error(k, truth, double(o.border)));
    } else {
      const double K = o.zoneplate;
      inner.number("zoneplate_k", K);
      inner.integer("samples_per_pixel", o.samples_per_pixel);
      inner.number("l2_error", zoneplate_l2_error(k, K, o.samples_per_pixel, double(o.border),
                                                  int(std::max(1u, std::thread::hardware_concurrency()))));
    }
    report.object("continuous", inner);
  }
  std::cout << (o.json ? report.json() + "\n" : report.text());
  std::cout.flush();
  return std::cout ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{
      "simetrics: measures of one final image (docs/design.md section 8).\n"
      "  hp_C: share of the luminance's DFT energy (mean removed) at radial\n"
      "        frequency strictly above C cycles/pixel, over the whole image;\n"
      "  rms, psnr: against --reference, same size, inside the --border band;\n"
      "  overshoot: how far IMAGE leaves [min, max] of the --input samples under\n"
      "        each pixel (its square plus --neighbourhood output pixels), the\n"
      "        pixels out of that range or negative, and the negative energy\n"
      "        (sum of squares of the negative values), inside the --border band.\n"
      "Luminance is Rec. 709 of the first three channels (channel 0 for grey).\n"
      "PSNR of equal images is infinite: null in JSON. Images are read as float.\n"
      "Exit status: 0 success, 2 usage, 3 input.",
      "simetrics"};
  app.add_option("IMAGE", o.image, "final image to measure")->required();
  app.add_option("--reference", o.reference, "reference image of the same size for rms and psnr");
  app.add_option("--input", o.input,
                 "the supersampled input IMAGE was formed from, covering the same frame "
                 "(sample k at (k + 1/2) W / W_in output pixels): enables overshoot");
  app.add_option("--factor", o.factor,
                 "supersampling factor of --input, checked against the sizes "
                 "(round(input size / S) must equal IMAGE's size)")
      ->check(at_least_zero(true));
  app.add_option("--cutoff", o.cutoffs, "high-pass cutoffs in cycles/pixel, one or more")
      ->check(at_least_zero(false))
      ->capture_default_str();
  app.add_option("--border", o.border, "pixels left out along each edge (rms, psnr, overshoot)")
      ->check(at_least_zero(false))
      ->capture_default_str();
  app.add_option("--peak", o.peak, "peak value for psnr")->check(at_least_zero(true))->capture_default_str();
  app.add_option("--neighbourhood", o.neighbourhood,
                 "overshoot: output pixels added around each pixel's square")
      ->check(at_least_zero(false))
      ->capture_default_str();
  app.add_option("--tolerance", o.tolerance,
                 "overshoot: a value counts as out of range past its bound by more than "
                 "T * max(1, |bound|); the extremes are reported exactly")
      ->check(at_least_zero(false))
      ->capture_default_str();
  app.add_option("--coeffs", o.coeffs,
                 "coefficient file of the approximation (siproject --coeffs): report its "
                 "continuous L2 error against --truth or --zoneplate");
  app.add_option("--truth", o.truth,
                 "render of the same frame at a much higher factor: the truth for --coeffs");
  app.add_option("--zoneplate", o.zoneplate,
                 "closed-form truth of scenes/zoneplate.pov with ZP_K = K, for --coeffs")
      ->check(at_least_zero(true));
  app.add_option("--samples-per-pixel", o.samples_per_pixel,
                 "points per output pixel and axis where the closed form is compared")
      ->check(CLI::PositiveNumber)->capture_default_str();
  app.add_flag("--json", o.json, "print one JSON object instead of 'key value' lines");
  app.set_version_flag("--version", std::string("simetrics ") + SIS_VERSION + " (git " + SIS_GIT_REVISION + ")",
                       "print the version and the git revision built");
  if (const auto code = sis::cli::parse(app, argc, argv)) return *code;
  try {
    return run(o);
  } catch (const UsageError& e) {
    std::cerr << "simetrics: " << e.what() << "\n";
    return kExitUsage;
  } catch (const RequestError& e) {
    std::cerr << "simetrics: " << e.what() << "\n";
    return kExitUsage;
  } catch (const InputError& e) {
    std::cerr << "simetrics: " << e.what() << "\n";
    return kExitInput;
  } catch (const std::invalid_argument& e) {  // the measures' refusal of an option's value
    std::cerr << "simetrics: " << e.what() << "\n";
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    std::cerr << "simetrics: out of memory (the images, or --samples-per-pixel's points)\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "simetrics: " << e.what() << "\n";
    return 1;
  }
}
