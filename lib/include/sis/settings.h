#pragma once
// A projection as its users spell it: the settings of siproject's options
// and of the Python module's keywords, with the same names, defaults and
// messages in both. resolve() checks them and turns them into the engine's
// terms; form() projects the inputs (or evaluates a coefficient file) and
// resamples the final image. What a front end adds is its own: messages,
// metadata, writing.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sis/engine.h"
#include "sis/scattered.h"

namespace sis {

// More worker threads than this are refused (each has a stack and buffers;
// the output is the same for every count).
inline constexpr int kMaxThreads = 1024;

struct Settings {
  std::optional<double> factor;  // output = input / factor
  std::string factor_spelling;   // as given, for messages ("" : the number)
  std::string size;              // as oiiotool's --resize spells it (parse_size; "" : none)
  std::optional<double> scale;   // output = input x scale
  std::string scale_spelling;    // as given ("" : the number)
  std::string generator = "cubic", method = "min-error", display, boundary = "mirror";
  std::string nonfinite = "error", prefilter = "fft", clamp = "none";
  std::string lattice = "cartesian";
  double density = 1.0;
  std::string density_spelling;  // as given ("" : the number)
  bool highlight_compress = false;
  // The inputs' transfer: auto (integer samples sRGB unless tagged
  // otherwise, float linear: default_transfer), srgb, linear or gammaG.
  std::string input_transfer = "auto";
  int threads = 0;  // 0: every core
  // Scattered samples (sis/scattered_input.h): the rule (fit, normalised or
  // plain) and the fit's iterations.
  std::string rule = "fit";
  int iterations = 5;
  // --rule variational: lambda (a number >= 0, or gcv) and the smoothness
  // functional's order (1 or 2).
  std::string lambda = "gcv";
  int smoothness = 2;
  // The second pass of an adaptive render (sis/refinement.h): its extra
  // rays' render, projected with the sobol input's samples ("" : none).
  std::string refined;
  // Which were given (a coefficient file refuses them; a conventional
  // filter named alone means the conventional method).
  bool generator_given = false, method_given = false, boundary_given = false;
  bool lattice_given = false, density_given = false;
  bool rule_given = false, iterations_given = false;  // a grid input refuses them
  bool lambda_given = false, smoothness_given = false;
};

// An output size as oiiotool's --resize spells it: "WxH", "W" (the height
// keeps the input's aspect), "Wx0" or "0xH" (0: that side keeps the aspect),
// "P%" (both sides) or "P%xQ%" (a side may be a percentage and the other
// pixels or 0). Per side: pixels, or a fraction of the input's side, or
// neither (from the other side and the input's aspect).
struct SizeSpec {
  long width = 0, height = 0;                // pixels (0: not given in pixels)
  double width_scale = 0, height_scale = 0;  // fraction of the input's side (0: not given so)
  bool given() const { return width || height || width_scale || height_scale; }
};
// Throws RequestError naming --size and the spelling.
SizeSpec parse_size(const std::string& spelling);

// The settings in the engine's terms. Throws RequestError with the message
// siproject prints ("--generator: unknown generator 'x' ...").
// The engine's terms (threads resolved: at least 1), and what the front
// ends add.
struct Resolved : ProjectionTerms {
  std::optional<Display> display;  // none: the method's default
  Clamp clamp = Clamp::None;
  SizeSpec size;                     // --size (none: not given)
  ScatteredOptions scattered;        // --rule, --iterations
};
Resolved resolve(const Settings& settings);

// The output size of an input of w x h samples: --size, w x scale or
// w / factor, each side rounded to the nearest pixel (halves up, as oiiotool
// rounds). Throws RequestError where neither is given or the result is empty.
std::pair<long, long> output_size(const Settings& settings, const Resolved& r, long w, long h);

struct FormRequest {
  bool keep_coefficients = false;   // Formed::coefficients (else dropped once resampled)
  bool coefficient_file = false;    // the caller also writes them (the memory estimate)
  bool float_coefficients = true;   // as a coefficient file keeps them
  bool final_image = true;          // false: stop after the coefficients
  std::function<void(double)> progress;
  std::function<void()> interrupt;  // ProjectionRequest::interrupt; also called before resampling
};

// A projection (engine.h: the coefficients, which describe themselves, the
// inputs, the local range, the non-finite samples or coefficients replaced
// by 0, the times) and its final image.
struct Formed : Projection {
  FinalImage final;
  Display display;           // the one used (or that would be: the method's default)
  long width = 0, height = 0;
  bool from_coefficient_file = false;
  std::vector<std::string> warnings;  // for the user, without the tool's name
  double resample_seconds = 0;
  std::optional<ScatteredReport> scattered;  // scattered samples: what the rule did
};

// Projects (or evaluates a coefficient file, or merges partial files) and
// resamples, as siproject does. The inputs inspected first by the caller, or by form().
Formed form(const Settings& settings, const Resolved& resolved, InputSet inputs,
            const FormRequest& request = {});
Formed form(const Settings& settings, const std::vector<ProjectionInput>& inputs,
            const FormRequest& request = {});

// A pyramid's levels (sis/pyramid.h) as siproject --mip forms them:
// level 0 the frame form() gives, every level projected from one reading
// of the inputs onto the space at its own frame and displayed at its size
// by the display (element j: level j). Refused (RequestError naming
// --mip): a coefficient file, partial files, scattered samples and the
// hexagonal lattice.
std::vector<Formed> form_pyramid(const Settings& settings, const Resolved& resolved, InputSet inputs,
                                 const FormRequest& request = {});

// Projects scattered samples (docs/design.md section 11) onto the Cartesian
// space of the frame --size gives (width and height in pixels; --factor,
// --scale, --lattice hex and --clamp local are refused) by the rule, then
// forms the final image as form() does. Positions outside the frame or not
// finite, weights not finite and > 0 are an InputError naming the input's
// arrays and the sample; non-finite values too, or replaced by 0 with
// --nonfinite zero. form() calls it for a file of scattered samples.
struct ScatteredInput;
Formed form_scattered(const Settings& settings, const Resolved& resolved, ScatteredInput input,
                      const FormRequest& request = {});

// The partial (sis/partial.h) of the bands the inputs hold
// (inspect(inputs, true)), as siproject --partial makes it.
struct Partial;
Partial form_partial(const Settings& settings, const Resolved& resolved, InputSet inputs,
                     const FormRequest& request = {});

}  // namespace sis
