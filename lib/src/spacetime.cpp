#include "sis/spacetime.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include <OpenImageIO/imageio.h>

#include "image_input.h"
#include "sis/imageio.h"

namespace sis {

namespace {
// A number in a message: as a metadata value writes it (17 digits).
std::string num(double x) { return metadata_number(x); }
}  // namespace

double subframe_time(const std::string& path) {
  ImageReader reader(path);
  {
    // a number-typed attribute (oiiotool --attrib types numbers) read as
    // its number: its text holds 6 digits only
    std::string why;
    auto in = open_input(path, &why);
    const OIIO::ParamValue* p = in ? in->spec().find_attribute("sis:time") : nullptr;
    if (p && (p->type() == OIIO::TypeDesc::FLOAT || p->type() == OIIO::TypeDesc::DOUBLE ||
              p->type() == OIIO::TypeDesc::INT)) {
      const double v = p->type() == OIIO::TypeDesc::DOUBLE ? p->get<double>()
                       : p->type() == OIIO::TypeDesc::INT  ? double(p->get_int())
                                                           : double(p->get_float());
      if (!std::isfinite(v)) throw InputError(path + ": sis:time is not finite");
      return v;
    }
  }
  const std::string text = reader.attribute("sis:time");
  if (text.empty())
    throw InputError(path + ": no sis:time attribute (the sub-frame's time in seconds); give "
                     "--times t0,t1,... instead");
  double v = 0;
  std::size_t used = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  while (used < text.size() && std::isspace(static_cast<unsigned char>(text[used]))) ++used;
  if (used == 0 || used != text.size())
    throw InputError(path + ": sis:time '" + text + "' is not a number");
  if (!std::isfinite(v)) throw InputError(path + ": sis:time " + text + " is not finite");
  return v;
}

SpaceTimePlan plan_frames(const std::vector<std::string>& paths, std::vector<double> times,
                          const SpaceTimeOptions& options, const Resolved& resolved) {
  SpaceTimePlan p;
  p.paths = paths;
  p.options = options;
  p.conventional = resolved.method == Method::Conventional;
  if (!(options.fps > 0) || !std::isfinite(options.fps))
    throw RequestError("--fps " + num(options.fps) + ": the output frame rate is a positive number");
  try {
    options.shutter.check();
  } catch (const std::invalid_argument& e) {
    throw RequestError(std::string("--shutter: ") + e.what());
  }
  if (options.degree < 0 || options.degree > kMaxTimeDegree)
    throw RequestError("--time-degree " + std::to_string(options.degree) + ": outside [0, 3]");
  if (options.step != 0 && (!(options.step > 0) || !std::isfinite(options.step)))
    throw RequestError("--time-step " + num(options.step) + ": a positive number of seconds");
  if (paths.size() < 2)
    throw RequestError("--fps: " + std::to_string(paths.size()) +
                       " sub-frame; space-time projection needs at least two");
  if (!times.empty() && times.size() != paths.size())
    throw RequestError("--times: " + std::to_string(times.size()) + " times for " +
                       std::to_string(paths.size()) + " sub-frames");
  const bool from_metadata = times.empty();
  // every sub-frame inspected: its size and channels the first's
  InputSet first;
  for (std::size_t k = 0; k < paths.size(); ++k) {
    InputSet set = inspect({ProjectionInput::file(paths[k])});
    if (k == 0) {
      first = std::move(set);
    } else if (set.width != first.width || set.height != first.height) {
      throw InputError(paths[k] + ": " + std::to_string(set.width) + " x " +
                       std::to_string(set.height) + " samples; " + paths[0] + " has " +
                       std::to_string(first.width) + " x " + std::to_string(first.height));
    } else if (set.channels != first.channels || set.channel_names != first.channel_names) {
      throw InputError(paths[k] + ": " + std::to_string(set.channels) + " channels, not " +
                       paths[0] + "'s " + std::to_string(first.channels) + " of the same names");
    }
    if (from_metadata) times.push_back(subframe_time(paths[k]));
  }
  const std::string source = from_metadata ? "sis:time" : "--times";
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k]))
      throw RequestError(source + ": " + paths[k] + "'s time is not finite");
    if (k > 0 && times[k] == times[k - 1])
      throw RequestError(source + ": " + paths[k - 1] + " and " + paths[k] + " have the same time " +
                         num(times[k]));
    if (k > 0 && times[k] < times[k - 1])
      throw RequestError(source + ": " + paths[k] + "'s time " + num(times[k]) + " is before " +
                         paths[k - 1] + "'s " + num(times[k - 1]) + " (sub-frames in time order)");
  }
  p.times = times;
  // the default step: the sub-frames' mean spacing (their own spacing when
  // regular), the finest lattice they determine
  p.options.step = options.step > 0 ? options.step
                                    : (times.back() - times.front()) / double(times.size() - 1);
  const Shutter& s = options.shutter;
  double a, b;
  time_span(times, a, b);
  if (options.frames.empty()) {
    int f0, f1;
    default_frames(times, s, options.fps, f0, f1);
    if (f0 > f1)
      throw RequestError("--fps " + num(options.fps) + ": no whole frame's shutter lies inside the "
                         "sub-frames' span [" + num(a) + ", " + num(b) + "] s");
    for (long f = f0; f <= f1; ++f) p.frames.push_back(f);
  } else {
    p.frames = options.frames;
  }
  // the temporal projection (the conventional method needs none)
  std::optional<TimeProjection> tp;
  if (!p.conventional) {
    try {
      tp.emplace(times, options.degree, p.options.step, options.model);
    } catch (const std::invalid_argument& e) {
      throw RequestError(e.what());
    }
    p.options.step = tp->step();  // the interpolating models round it to whole steps across the span
  }
  for (long f : p.frames) {
    const double T = f / options.fps;
    std::vector<double> u;
    try {
      u = p.conventional ? conventional_frame_weights(times, s, T, options.fps)
                         : frame_weights(*tp, s, T, options.fps);
    } catch (const std::invalid_argument& e) {
      throw RequestError("--frames: frame " + std::to_string(f) + ": " + e.what());
    }
    double big = 0;
    for (double x : u) big = std::max(big, std::abs(x));
    long lo = 0, hi = static_cast<long>(u.size()) - 1;
    while (std::abs(u[lo]) < kWeightFloor * big) u[lo++] = 0;
    while (std::abs(u[hi]) < kWeightFloor * big) u[hi--] = 0;
    p.frame_times.push_back(T);
    p.weights.emplace_back(u.begin() + lo, u.begin() + hi + 1);  // the window alone
    p.lo.push_back(lo);
    p.hi.push_back(hi);
  }
  return p;
}

void form_frames(const Settings& settings, const Resolved& resolved, const SpaceTimePlan& plan,
                 const std::function<void(SpaceTimeFrame&)>& sink) {
  if (resolved.clamp == Clamp::Local)
    throw RequestError("--clamp local: not taken with --fps (a frame's samples are several "
                       "sub-frames'); --clamp zero or none");
  std::map<long, Formed> window;  // sub-frame -> its projection
  for (std::size_t j = 0; j < plan.frames.size(); ++j) {
    // drop what no frame from here on reads
    long keep_from = plan.lo[j];
    for (std::size_t i = j; i < plan.frames.size(); ++i) keep_from = std::min(keep_from, plan.lo[i]);
    while (!window.empty() && window.begin()->first < keep_from) window.erase(window.begin());
    for (long k = plan.lo[j]; k <= plan.hi[j]; ++k) {
      if (plan.weights[j][k - plan.lo[j]] == 0 || window.count(k)) continue;
      FormRequest fr;
      fr.keep_coefficients = true;
      fr.final_image = false;
      window.emplace(k, form(settings, resolved, inspect({ProjectionInput::file(plan.paths[k])}), fr));
    }
    SpaceTimeFrame out;
    out.number = plan.frames[j];
    out.time = plan.frame_times[j];
    const Formed* any = nullptr;
    for (long k = plan.lo[j]; k <= plan.hi[j]; ++k) {
      const double u = plan.weights[j][k - plan.lo[j]];
      if (u == 0) continue;
      const Formed& f = window.at(k);
      if (!any) {
        any = &f;
        out.coefficients = f.coefficients;
        for (double& c : out.coefficients.c.data) c *= u;
      } else {
        const auto& src = f.coefficients.c.data;
        auto& dst = out.coefficients.c.data;
        for (std::size_t i = 0; i < dst.size(); ++i) dst[i] += u * src[i];
      }
    }
    out.display = any->display;
    out.alpha = any->inputs.alpha;
    out.channel_names = any->inputs.channel_names;
    out.final = final_image(out.coefficients, out.display, any->width, any->height, resolved.clamp,
                            nullptr, resolved.threads);
    sink(out);
  }
}

}  // namespace sis
