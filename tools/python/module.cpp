// siproject._core: the engine for Python. The public API, its defaults and
// its documentation are in siproject/__init__.py; this file maps it onto
// sis/settings.h (the same settings, checks and messages as siproject's
// options) and sis/metrics.h, with the GIL released while the engine works.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <new>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sis/engine.h"
#include "sis/metrics.h"
#include "sis/parallel.h"
#include "sis/partial.h"
#include "sis/pattern.h"
#include "sis/scattered_input.h"
#include "sis/settings.h"
#include "sis/space.h"
#include "sis/staged_file.h"
#include "sis/time.h"

namespace py = pybind11;
using namespace sis;

namespace {

// The engine's errors as Python's: a bad request ValueError, a file OSError
// (an array's content ValueError), the rest RuntimeError; MemoryError for
// allocations. Raised with the message siproject prints, without its name.
struct Raised {
  PyObject* type;
  std::string message;
};

template <typename F>
auto translated(bool array_input, F&& f) -> decltype(f()) {
  std::optional<Raised> raised;
  try {
    return f();
  } catch (const RequestError& e) {
    raised = Raised{PyExc_ValueError, e.what()};
  } catch (const InputError& e) {
    raised = Raised{array_input ? PyExc_ValueError : PyExc_OSError, e.what()};
  } catch (const OutputError& e) {
    raised = Raised{PyExc_OSError, e.what()};
  } catch (const std::invalid_argument& e) {
    raised = Raised{PyExc_ValueError, e.what()};
  } catch (const std::bad_alloc&) {
    raised = Raised{PyExc_MemoryError,
                    "out of memory (the request needs more than the machine has available)"};
  } catch (const py::error_already_set&) {
    throw;
  } catch (const std::exception& e) {
    raised = Raised{PyExc_RuntimeError, e.what()};
  }
  PyErr_SetString(raised->type, raised->message.c_str());
  throw py::error_already_set();
}

// Ctrl-C while the engine works: the engine calls poll() at every strip it
// reads, from its threads. On the thread that called (the one where Python
// runs signal handlers), at most every kPollEvery, poll() takes the GIL
// and runs the handlers of signals that arrived (PyErr_CheckSignals). An
// exception from one (KeyboardInterrupt) is kept and poll() throws
// Interrupted on every thread from then on, which abandons the projection;
// the caller raises the kept exception once the engine has let go.
struct Interrupted : std::exception {
  const char* what() const noexcept override { return "interrupted"; }
};

class SignalPoll {
 public:
  SignalPoll() : caller_(std::this_thread::get_id()) {}
  SignalPoll(const SignalPoll&) = delete;
  SignalPoll& operator=(const SignalPoll&) = delete;
  ~SignalPoll() {
    if (type_ || value_ || trace_) {
      py::gil_scoped_acquire gil;
      Py_XDECREF(type_);
      Py_XDECREF(value_);
      Py_XDECREF(trace_);
    }
  }

  std::function<void()> hook() {
    return [this] { poll(); };
  }
  bool raised() const { return raised_.load(); }
  // With the GIL held, after the engine let go: the kept exception set
  // again as Python's error, raised by the throw.
  [[noreturn]] void raise() {
    PyErr_Restore(type_, value_, trace_);
    type_ = value_ = trace_ = nullptr;
    throw py::error_already_set();
  }

 private:
  static constexpr auto kPollEvery = std::chrono::milliseconds(20);
  void poll() {
    if (raised_.load()) throw Interrupted();
    if (std::this_thread::get_id() != caller_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now < next_) return;
    next_ = now + kPollEvery;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return;
    PyErr_Fetch(&type_, &value_, &trace_);
    raised_.store(true);
    throw Interrupted();
  }

  std::thread::id caller_;
  std::chrono::steady_clock::time_point next_{};
  std::atomic<bool> raised_{false};
  PyObject *type_ = nullptr, *value_ = nullptr, *trace_ = nullptr;
};

// An array's channel count (the library's views hold int).
int channel_count(py::ssize_t c, const std::string& what) {
  if (c > INT_MAX)
    throw py::value_error(what + ": " + std::to_string(c) + " channels: at most " +
                          std::to_string(INT_MAX));
  return int(c);
}

// A float32 array of shape (H, W, C) that owns the image's samples (moved,
// not copied).
py::array_t<float> to_array(Image&& image) {
  auto* owned = new Image(std::move(image));
  py::capsule free_when_done(owned, [](void* p) { delete static_cast<Image*>(p); });
  const py::ssize_t H = owned->height, W = owned->width, C = owned->channels;
  return py::array_t<float>({H, W, C},
                            {W * C * py::ssize_t(sizeof(float)), C * py::ssize_t(sizeof(float)),
                             py::ssize_t(sizeof(float))},
                            owned->data.data(), free_when_done);
}

// Coefficients with what a final image or a coefficient file needs of them.
struct PyCoefficients {
  Coefficients k;  // describe themselves: channels, alpha, remedies, input
  int threads = 1;
  std::optional<ScatteredReport> report;  // of scattered samples
  ScatteredRule rule = ScatteredRule::LeastSquares;
};

// The sample type of a C-contiguous array the wrapper made so (float32,
// float16, uint8, uint16).
SampleType array_type(const py::array& array, const char* what) {
  const char kind = array.dtype().kind();
  const auto size = array.itemsize();
  const std::optional<SampleType> type =
      kind == 'f' && size == 4   ? std::optional(SampleType::Float)
      : kind == 'f' && size == 2 ? std::optional(SampleType::Half)
      : kind == 'u' && size == 1 ? std::optional(SampleType::UInt8)
      : kind == 'u' && size == 2 ? std::optional(SampleType::UInt16)
                                 : std::nullopt;
  if (!(array.flags() & py::array::c_style) || !type)
    throw std::logic_error(std::string(what) + ": the array is not C-contiguous float32, float16, "
                           "uint8 or uint16");
  return *type;
}

// Positions with values (and weights) as the wrapper checked them: values
// (N, C) of array_type()'s types, positions (N, 2) and weights (N,) float64
// C-contiguous.
struct ScatteredArrays {
  py::array values;
  py::array_t<double, py::array::c_style> positions;
  std::optional<py::array_t<double, py::array::c_style>> weights;
};

int resolved_threads(int threads) {
  Settings s;
  s.threads = threads;
  return translated(false, [&] { return resolve(s).threads; });
}

// Runs form() on a path or an array (float32 or float16, C-contiguous,
// (H, W, C): the caller's wrapper makes it so), the GIL released.
// Returns (image or None, coefficients or None, warnings).
py::tuple run_form(py::object input, const Settings& s, bool coefficients_only,
                   const std::optional<ScatteredArrays>& scattered, bool pyramid) {
  const bool is_array = py::isinstance<py::array>(input);
  std::vector<ProjectionInput> inputs;
  py::array array;
  std::string path;
  if (scattered) {
    if (scattered->values.ndim() != 2 || scattered->positions.ndim() != 2 ||
        scattered->positions.shape(1) != 2 || scattered->positions.shape(0) != scattered->values.shape(0) ||
        (scattered->weights && scattered->weights->size() != scattered->values.shape(0)))
      throw std::logic_error("run_form(): scattered arrays of the wrong shapes");
    array_type(scattered->values, "run_form()");
    channel_count(scattered->values.shape(1), "values");
  } else if (is_array) {
    array = py::reinterpret_borrow<py::array>(input);
    const SampleType type = array_type(array, "run_form()");
    if (array.ndim() != 3)
      throw std::logic_error("run_form(): the array is not (H, W, C)");
    inputs.push_back(ProjectionInput::memory(
        SampleView(array.data(), long(array.shape(1)), long(array.shape(0)),
                   channel_count(array.shape(2), "array"), type),
        "array"));
  } else {
    path = py::str(input);
    inputs.push_back(ProjectionInput::file(path));
  }
  return translated(is_array || scattered, [&] {
    const Resolved r = resolve(s);
    FormRequest fr;
    fr.keep_coefficients = coefficients_only;
    fr.final_image = !coefficients_only;
    SignalPoll signals;
    fr.interrupt = signals.hook();
    if (pyramid) {  // every level's final image (siproject --mip)
      if (scattered || coefficients_only)
        throw std::logic_error("run_form(): a pyramid of scattered samples or of coefficients");
      std::vector<Formed> levels;
      try {
        py::gil_scoped_release free;
        levels = form_pyramid(s, r, inspect(inputs), fr);
      } catch (...) {
        if (signals.raised()) signals.raise();
        throw;
      }
      py::list out, warnings;
      for (Formed& f : levels) {
        for (const std::string& w : f.warnings) warnings.append(w);
        out.append(to_array(std::move(f.final.image)));
      }
      return py::make_tuple(out, py::none(), warnings);
    }
    Formed f;
    SampleView values;
    const double *positions = nullptr, *weights = nullptr;
    if (scattered) {
      const py::array& v = scattered->values;
      values = SampleView(v.data(), long(v.shape(0)), 1, int(v.shape(1)), array_type(v, "values"));
      positions = scattered->positions.data();
      if (scattered->weights) weights = scattered->weights->data();
    }
    try {
      py::gil_scoped_release free;
      if (scattered) {
        ScatteredInput in = scattered_input(values, positions, weights, r.input_transfer);
        in.label = "values";
        f = form_scattered(s, r, std::move(in), fr);
      } else {
        f = form(s, r, inspect(inputs), fr);
      }
    } catch (...) {
      // whatever the abandoned engine threw (a band given up), the interruption
      if (signals.raised()) signals.raise();
      throw;
    }
    py::list warnings;
    for (const std::string& w : f.warnings) warnings.append(w);
    if (!coefficients_only)
      return py::make_tuple(to_array(std::move(f.final.image)), py::none(), warnings);
    auto k = std::make_unique<PyCoefficients>();
    k->k = std::move(f.coefficients);
    k->threads = r.threads;
    k->report = f.scattered;
    k->rule = r.scattered.rule;
    return py::make_tuple(py::none(), py::cast(std::move(k)), warnings);
  });
}

// The keywords as siproject's options (None: not given).
Settings settings_of(const std::string& size, std::optional<double> factor,
                     const std::string& factor_spelling, std::optional<std::string> generator,
                     std::optional<std::string> method, const std::string& display,
                     const std::string& boundary, const std::string& lattice,
                     std::optional<double> density, const std::string& density_spelling,
                     const std::string& nonfinite, const std::string& prefilter,
                     const std::string& clamp, bool highlight_compress, int threads,
                     const std::string& input_transfer) {
  Settings s;
  s.size = size;
  s.factor = factor;
  s.factor_spelling = factor_spelling;
  if (generator) s.generator = *generator, s.generator_given = true;
  if (method) s.method = *method, s.method_given = true;
  s.display = display;
  s.boundary = boundary;
  s.boundary_given = boundary != "mirror";
  s.lattice = lattice;
  s.lattice_given = lattice != "cartesian";
  if (density) s.density = *density, s.density_given = true, s.density_spelling = density_spelling;
  s.nonfinite = nonfinite;
  s.prefilter = prefilter;
  s.clamp = clamp;
  s.highlight_compress = highlight_compress;
  s.input_transfer = input_transfer;
  s.threads = threads;
  return s;
}

// _form: project() and coefficients() with their keywords as siproject's
// options (None: not given).
py::tuple form_with(py::object input, const std::string& size, std::optional<double> factor,
                    const std::string& factor_spelling, std::optional<std::string> generator,
                    std::optional<std::string> method, const std::string& display,
                    const std::string& boundary, const std::string& lattice,
                    std::optional<double> density, const std::string& density_spelling,
                    const std::string& nonfinite,
                    const std::string& prefilter, const std::string& clamp,
                    bool highlight_compress, int threads, bool coefficients_only,
                    const std::string& input_transfer, std::optional<py::array> positions,
                    std::optional<py::array> weights, std::optional<std::string> rule,
                    std::optional<int> iterations, std::optional<std::string> lambda,
                    std::optional<int> smoothness, bool pyramid, const std::string& refined) {
  Settings s = settings_of(size, factor, factor_spelling, generator, method, display, boundary,
                           lattice, density, density_spelling, nonfinite, prefilter, clamp,
                           highlight_compress, threads, input_transfer);
  if (rule) s.rule = *rule, s.rule_given = true;
  if (iterations) s.iterations = *iterations, s.iterations_given = true;
  if (lambda) s.lambda = *lambda, s.lambda_given = true;
  if (smoothness) s.smoothness = *smoothness, s.smoothness_given = true;
  s.refined = refined;
  std::optional<ScatteredArrays> scattered;
  if (positions) {
    scattered = ScatteredArrays{py::reinterpret_borrow<py::array>(input),
                                py::array_t<double, py::array::c_style>::ensure(*positions), std::nullopt};
    if (weights) scattered->weights = py::array_t<double, py::array::c_style>::ensure(*weights);
    if (!scattered->positions || (weights && !*scattered->weights))
      throw std::logic_error("_form(): positions or weights not float64");
  }
  return run_form(input, s, coefficients_only, scattered, pyramid);
}

std::string pair_text(const std::pair<long, long>& p) {
  return "(" + std::to_string(p.first) + ", " + std::to_string(p.second) + ")";
}

// _partial: siproject --partial of the input's rows (a file's data window)
// or of the rows bands= or rows= names, to `out`. Returns the warnings.
py::list partial_to(py::object input, const std::string& out,
                    std::optional<std::pair<long, long>> bands,
                    std::optional<std::pair<long, long>> rows, std::optional<long> grid_rows,
                    const Settings& s) {
  const bool is_array = py::isinstance<py::array>(input);
  SampleView view;
  std::string path;
  if (is_array) {
    const py::array array = py::reinterpret_borrow<py::array>(input);
    const SampleType type = array_type(array, "_partial()");
    if (array.ndim() != 3) throw std::logic_error("_partial(): the array is not (H, W, C)");
    view = SampleView(array.data(), long(array.shape(1)), long(array.shape(0)),
                      channel_count(array.shape(2), "array"), type);
  } else {
    path = py::str(input);
  }
  return translated(is_array, [&] {
    check_output(out);
    if (!holds_coefficients(out))
      throw RequestError("out=" + out + ": partial files are OpenEXR (.exr)");
    std::error_code same;
    if (!is_array && std::filesystem::equivalent(path, out, same))
      throw RequestError("out=" + out + " is the input file");
    const Resolved r = resolve(s);
    std::unique_ptr<ImageReader> reader;
    long grid = 0;  // the grid's rows
    if (is_array) {
      grid = grid_rows ? *grid_rows : view.height;
    } else {
      if (grid_rows)
        throw RequestError("grid_rows=: a file's display window gives its grid; grid_rows= is for "
                           "an array of some rows");
      reader = std::make_unique<ImageReader>(path);
      grid = reader->full_height();
    }
    if (grid_rows && !(bands || rows))
      throw RequestError("grid_rows=" + std::to_string(*grid_rows) +
                         ": the array holds the rows bands= or rows= names; give one");
    std::optional<std::pair<long, long>> span;  // first row, rows
    const BandPartition partition(grid, kBandRows);
    if (bands) {
      const auto [b0, n] = *bands;
      if (b0 < 0 || n < 1 || b0 > partition.count() - n)
        throw RequestError("bands=" + pair_text(*bands) + ": the grid of " + std::to_string(grid) +
                           " rows has " + std::to_string(partition.count()) + " bands of " +
                           std::to_string(partition.band_rows()) + " rows (0 to " +
                           std::to_string(partition.count() - 1) + "); (first, count) of them");
      span = std::pair{partition.begin(b0), partition.end(b0 + n - 1) - partition.begin(b0)};
    }
    if (rows) {
      const auto [y0, n] = *rows;
      if (y0 < 0 || n < 1 || y0 > grid - n)
        throw RequestError("rows=" + pair_text(*rows) + ": the grid has " + std::to_string(grid) +
                           " rows; (first, count) of them");
      span = rows;
    }
    ProjectionInput in;
    std::vector<unsigned char> held;  // a file's rows read for bands= or rows=
    if (is_array) {
      if (grid_rows) {
        if (view.height != span->second)
          throw RequestError("grid_rows=" + std::to_string(*grid_rows) + ": the array holds " +
                             std::to_string(view.height) + " rows, not the " +
                             std::to_string(span->second) + " of " +
                             (bands ? "bands=" + pair_text(*bands) : "rows=" + pair_text(*rows)));
        in = ProjectionInput::memory(view, "array");
      } else if (span) {
        in = ProjectionInput::memory(SampleView(view.row(span->first), view.width, span->second,
                                                view.channels, view.type),
                                     "array");
      } else {
        in = ProjectionInput::memory(view, "array");
      }
      in.row = span ? span->first : 0;
      in.rows = grid;
    } else if (!span) {
      in = ProjectionInput::file(path);
    } else {
      ImageReader& rd = *reader;
      if (is_partial_file(rd) || is_coefficient_file(rd) || is_scattered_file(rd))
        throw RequestError(path + ": a partial is made of a grid's samples, not of " +
                           (is_partial_file(rd)       ? "a partial file"
                            : is_coefficient_file(rd) ? "a coefficient file"
                                                      : "scattered samples"));
      if (rd.data_x() != rd.full_x() || rd.width() != rd.full_width() || rd.data_y() < rd.full_y())
        throw InputError(path + ": not a row band of its display window (its data window must "
                                "span the full width, within the display window)");
      const long have = rd.data_y() - rd.full_y();
      if (span->first < have || span->first + span->second > have + rd.height())
        throw RequestError(path + ": " + (bands ? "bands=" + pair_text(*bands) : "rows=" + pair_text(*rows)) +
                           " names rows " + std::to_string(span->first) + " to " +
                           std::to_string(span->first + span->second - 1) + "; the file holds rows " +
                           std::to_string(have) + " to " + std::to_string(have + rd.height() - 1) +
                           " of its grid of " + std::to_string(grid));
      const bool half = rd.stores_half();
      const std::size_t values = std::size_t(span->second) * rd.width() * rd.channels();
      check_memory(values * (half ? 2 : 4), path + "'s " + std::to_string(span->second) + " rows");
      held.resize(values * (half ? 2 : 4));
      {
        py::gil_scoped_release free;
        const long y0 = span->first - have, y1 = y0 + span->second;
        if (half)
          rd.read_rows_half(y0, y1, reinterpret_cast<std::uint16_t*>(held.data()));
        else
          rd.read_rows(y0, y1, reinterpret_cast<float*>(held.data()));
      }
      in = ProjectionInput::memory(
          SampleView(held.data(), rd.width(), span->second, rd.channels(),
                     half ? SampleType::Half : SampleType::Float),
          std::filesystem::path(path).filename().string() + " rows " + std::to_string(span->first) +
              " to " + std::to_string(span->first + span->second - 1));
      in.row = span->first;
      in.rows = grid;
      in.channel_names = rd.channel_names();
      in.alpha = rd.alpha_channel();
      in.transfer = rd.transfer();
    }
    reader.reset();
    FormRequest fr;
    SignalPoll signals;
    fr.interrupt = signals.hook();
    Partial p;
    try {
      py::gil_scoped_release free;
      p = form_partial(s, r, inspect({in}, true), fr);
      StagedFileSignals cleanup;  // SIGTERM, SIGHUP... remove the staged file
      write_partial(out, p);
    } catch (...) {
      if (signals.raised()) signals.raise();
      throw;
    }
    py::list warnings;
    if (p.nonfinite.count)
      warnings.append("replaced " + std::to_string(p.nonfinite.count) +
                      " non-finite samples with 0; first: " + p.nonfinite.where);
    return warnings;
  });
}

// _merge: partial files added into the single run's coefficients.
py::tuple merge_from(const std::vector<std::string>& paths, int threads) {
  std::vector<ProjectionInput> inputs;
  for (const std::string& p : paths) inputs.push_back(ProjectionInput::file(p));
  return translated(false, [&] {
    Settings s;
    s.threads = threads;
    const Resolved r = resolve(s);
    FormRequest fr;
    fr.keep_coefficients = true;
    fr.final_image = false;
    Formed f;
    {
      py::gil_scoped_release free;
      InputSet set = inspect(inputs);
      if (!set.partial_files)
        throw RequestError(set.label + " is not a partial file (siproject.partial() or siproject "
                           "--partial)");
      f = form(s, r, std::move(set), fr);
    }
    py::list warnings;
    for (const std::string& w : f.warnings) warnings.append(w);
    auto k = std::make_unique<PyCoefficients>();
    k->k = std::move(f.coefficients);
    k->threads = r.threads;
    return py::make_tuple(py::cast(std::move(k)), warnings);
  });
}

PyCoefficients load_file(const std::string& path, bool zero_nonfinite, int threads) {
  return translated(false, [&] {
    PyCoefficients out;
    ImageReader reader(path);
    if (!is_coefficient_file(reader))
      throw InputError(path + ": not a coefficient file (write one with coefficients(...).save() "
                              "or siproject --coeffs)");
    reader.release();
    out.threads = resolved_threads(threads);
    py::gil_scoped_release free;
    out.k = load_coefficients(path, zero_nonfinite, nullptr, reader.signature());
    return out;
  });
}

// size: as siproject's --size spells it ("" : the frame's), resolved against
// the frame as --size is against the input (960: the width, the aspect kept).
py::array_t<float> resample_to(const PyCoefficients& c, const std::string& size,
                            const std::string& display, const std::string& clamp) {
  return translated(false, [&] {
    const Clamp cl = [&] {
      try {
        return parse_clamp(clamp);
      } catch (const std::invalid_argument& e) {
        throw RequestError(std::string("--clamp: ") + e.what());
      }
    }();
    if (cl == Clamp::Local)
      throw RequestError("--clamp local needs the input samples; resample() has the coefficients only");
    const Display shown = display.empty()
                              ? (c.k.min_error ? Display::antialiased_2x2() : Display::centred())
                              : Display::parse(display);
    const auto frame = visit_space(c.k, [&](auto space) { return space.frame(c.k); });
    Settings asked;
    asked.size = size;
    const auto [W, H] = output_size(asked, resolve(asked), frame.first, frame.second);
    FinalImage f;
    {
      py::gil_scoped_release free;
      f = final_image(c.k, shown, W, H, cl, nullptr, c.threads);
    }
    return to_array(std::move(f.image));
  });
}

// f_app at the points (x[i], y[i]), every channel: shape (N, C).
py::array_t<double> evaluate_at(const PyCoefficients& c, py::array_t<double, py::array::c_style> x,
                             py::array_t<double, py::array::c_style> y) {
  if (x.size() != y.size()) throw py::value_error("evaluate(): x and y differ in size");
  const py::ssize_t n = x.size();
  const int C = c.k.c.channels;
  const double* px = x.data();
  const double* py_ = y.data();
  // A NaN or a point far beyond any frame would overflow the lattice's
  // indices; the approximation is defined (extended by the boundary rule)
  // out to the largest output side.
  for (const auto& [v, name] : {std::pair{px, "x"}, std::pair{py_, "y"}})
    for (py::ssize_t i = 0; i < n; ++i)
      if (!(std::abs(v[i]) <= double(kMaxOutputSide))) {
        std::ostringstream m;
        m << "evaluate(): " << name << " " << v[i] << " (point " << i
          << "): expected a finite coordinate within +-" << kMaxOutputSide << " output pixels";
        throw py::value_error(m.str());
      }
  py::array_t<double> out({n, py::ssize_t(C)});
  double* o = out.mutable_data();
  {
    py::gil_scoped_release free;
    visit_space(c.k, [&](auto space) {
      for (py::ssize_t i = 0; i < n; ++i)
        for (int ch = 0; ch < C; ++ch) o[i * C + ch] = space.evaluate(c.k, Vec2{px[i], py_[i]}, ch);
      return 0;
    });
  }
  return out;
}

void save_to(const PyCoefficients& c, const std::string& path) {
  translated(false, [&] {
    check_output(path);
    StagedFileSignals cleanup;  // SIGTERM, SIGHUP... remove the staged file
    if (!holds_coefficients(path))
      throw RequestError("--coeffs " + path + ": coefficient files are OpenEXR (.exr); this format "
                         "cannot hold their metadata and signed float coefficients");
    stage_coefficients(path, c.k)
        .commit();
    return 0;
  });
}

py::array_t<double> grid_array(const PyCoefficients& c) {
  const Grid<double>& g = c.k.c;
  py::array_t<double> out({py::ssize_t(g.height), py::ssize_t(g.width), py::ssize_t(g.channels)});
  std::memcpy(out.mutable_data(), g.data.data(), g.data.size() * sizeof(double));
  return out;
}

// An image array (H, W, C) as the measures' view: read where it is (the
// array argument, float32 C-contiguous or made so by pybind11, outlives the
// call).
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
ImageView view_of(const FloatArray& a, const char* what) {
  if (a.ndim() != 3) throw py::value_error(std::string(what) + ": expected an array (H, W, C)");
  return ImageView(a.data(), long(a.shape(1)), long(a.shape(0)), channel_count(a.shape(2), what));
}

// A reference prepared for many L2 errors: the pixels it reads (the
// caller's array, or pybind11's float32 copy of it) held with it; one error
// at a time (the acquisitions it keeps are shared).
struct PyL2Reference {
  PyL2Reference(FloatArray a, L2Reference r) : pixels(std::move(a)), reference(std::move(r)) {}
  FloatArray pixels;
  L2Reference reference;
  std::mutex busy;
};

// Image copies, for write_image (which takes an Image).
Image image_of(const FloatArray& a, const char* what) {
  const ImageView v = view_of(a, what);
  Image im(v.width, v.height, v.channels, kUnset);
  std::memcpy(im.data.data(), v.data, im.data.size() * sizeof(float));
  return im;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  keep_fork_safe();  // a child of os.fork() projects again and exits
  m.doc() = "The engine of siproject (see the siproject package for the documented API).";
  m.attr("__version__") = SIS_PYTHON_VERSION;  // the project's (CMakeLists.txt)
  py::class_<PyCoefficients>(m, "Coefficients")
      .def_property_readonly("lattice", [](const PyCoefficients& c) { return space_name(c.k.space); })
      .def_property_readonly("generator", [](const PyCoefficients& c) { return generator_name(c.k); })
      .def_property_readonly("method", [](const PyCoefficients& c) {
        return std::string(c.k.min_error ? "min-error" : "conventional");
      })
      .def_property_readonly("boundary", [](const PyCoefficients& c) { return boundary_name(c.k.boundary); })
      .def_property_readonly("frame", [](const PyCoefficients& c) {
        return visit_space(c.k, [&](auto space) { return space.frame(c.k); });
      })
      .def_property_readonly("channel_names", [](const PyCoefficients& c) { return c.k.channel_names; })
      .def_property_readonly("highlight_compressed", [](const PyCoefficients& c) { return c.k.highlight_compressed; })
      .def_property_readonly("report", [](const PyCoefficients& c) -> py::object {
        if (!c.report) return py::none();
        py::dict d;
        d["rule"] = scattered_rule_name(c.rule);
        d["iterations"] = c.report->iterations;
        d["residual"] = c.report->residual;
        d["passes"] = c.report->passes;
        d["bytes"] = c.report->bytes;
        if (c.rule == ScatteredRule::Variational) d["lambda"] = c.report->lambda;
        return d;
      })
      .def_property_readonly("array", &grid_array)
      .def("_evaluate", &evaluate_at)
      .def("_resample", &resample_to)
      .def("_save", &save_to);
  // The keywords by name (siproject/__init__.py checks their types first).
  m.def("_form", &form_with, py::arg("input"), py::kw_only(), py::arg("size"), py::arg("factor"),
        py::arg("factor_spelling"), py::arg("generator"), py::arg("method"), py::arg("display"),
        py::arg("boundary"), py::arg("lattice"), py::arg("density"), py::arg("density_spelling"),
        py::arg("nonfinite"), py::arg("prefilter"), py::arg("clamp"),
        py::arg("highlight_compress"), py::arg("threads"), py::arg("coefficients_only"),
        py::arg("input_transfer"), py::arg("positions"), py::arg("weights"), py::arg("rule"),
        py::arg("iterations"), py::arg("lambda_"), py::arg("smoothness"),
        py::arg("pyramid") = false, py::arg("refined") = "");
  // refine(): an adaptive render's first pass refined (refine_render);
  // errors of the plan name the keywords.
  m.def("_refine", [](const std::string& path, double rays, std::optional<long> refine_rays,
                      std::optional<double> share, long tile, const std::string& estimator, int threads) {
    RefinedPlan plan = translated(false, [&] {
      Estimator e;
      try {
        e = parse_estimator(estimator);
      } catch (const std::invalid_argument& x) {
        throw RequestError(std::string("estimator=: ") + x.what());
      }
      if (tile < 1) throw RequestError("tile=" + std::to_string(tile) + ": expected a whole number >= 1");
      py::gil_scoped_release release;
      try {
        return refine_render(path, rays, refine_rays, share, tile, e,
                             threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency())));
      } catch (const std::invalid_argument& x) {
        throw RequestError("refine(rays=" + metadata_number(rays) +
                           (refine_rays ? ", refine_rays=" + std::to_string(*refine_rays) : std::string()) +
                           (share ? ", share=" + metadata_number(*share) : std::string()) + "): " + x.what());
      }
    });
    const Refinement& r = plan.refinement;
    const TileGrid g = r.grid();
    py::array_t<double> est({py::ssize_t(g.rows()), py::ssize_t(g.columns())});
    std::memcpy(est.mutable_data(), plan.estimate.data(), plan.estimate.size() * sizeof(double));
    py::dict d;
    d["text"] = refinement_text(r);
    d["tiles"] = r.tiles;
    d["tile"] = r.tile;
    d["rays"] = r.rays;
    d["base_rays"] = r.base_rays();
    d["extra_rays"] = r.extra_count();
    d["rays_per_pixel"] = r.rays_per_pixel();
    d["estimates"] = est;
    return d;
  });
  m.def("_partial",
        [](py::object input, const std::string& out, std::optional<std::pair<long, long>> bands,
           std::optional<std::pair<long, long>> rows, std::optional<long> grid_rows,
           const std::string& size, std::optional<double> factor, const std::string& factor_spelling,
           std::optional<std::string> generator, std::optional<std::string> method,
           const std::string& boundary, const std::string& lattice, std::optional<double> density,
           const std::string& density_spelling, const std::string& nonfinite,
           const std::string& prefilter, bool highlight_compress, int threads,
           const std::string& input_transfer) {
          const Settings s = settings_of(size, factor, factor_spelling, generator, method, "",
                                         boundary, lattice, density, density_spelling, nonfinite,
                                         prefilter, "none", highlight_compress, threads,
                                         input_transfer);
          return partial_to(input, out, bands, rows, grid_rows, s);
        },
        py::arg("input"), py::arg("out"), py::kw_only(), py::arg("bands"), py::arg("rows"),
        py::arg("grid_rows"), py::arg("size"), py::arg("factor"), py::arg("factor_spelling"),
        py::arg("generator"), py::arg("method"), py::arg("boundary"), py::arg("lattice"),
        py::arg("density"), py::arg("density_spelling"), py::arg("nonfinite"),
        py::arg("prefilter"), py::arg("highlight_compress"), py::arg("threads"),
        py::arg("input_transfer"));
  m.def("_merge", &merge_from);
  m.def("_band_cuts", [](long rows, long parts) {
    return translated(false, [&] { return band_cuts(rows, parts); });
  });
  m.attr("band_rows") = kBandRows;
  m.def("_sample_positions", [](const std::string& pattern, std::uint64_t seed, long width, long height,
                                double factor, int threads) {
    const SamplePattern p = translated(false, [&] {
      return make_pattern(parse_pattern(pattern), seed, width, height, factor);
    });
    py::array_t<double> out({py::ssize_t(p.count()), py::ssize_t(2)});
    double* xy = out.mutable_data();
    {
      py::gil_scoped_release release;
      sample_positions(p, 0, p.count(), xy,
                       threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency())));
    }
    return out;
  });
  m.def("_frame_weights", [](std::vector<double> times, double fps, double T,
                             const std::string& shutter, const std::string& curve, int degree,
                             double step, const std::string& model, bool conventional) {
    return translated(false, [&] {
      const Shutter s = parse_shutter(shutter, curve);
      const TimeModel tm = parse_time_model(model);
      if (conventional) return conventional_frame_weights(times, s, T, fps);
      check_times(times);  // before the default step (their mean spacing) is taken
      if (!(step > 0)) step = (times.back() - times.front()) / double(times.size() - 1);
      const TimeProjection p(times, degree, step, tm);
      return frame_weights(p, s, T, fps);
    });
  });
  m.def("_load", &load_file);
  m.def("_highpass_shares", [](FloatArray a, std::vector<double> cutoffs) {
    const ImageView im = view_of(a, "highpass_share()");
    return translated(true, [&] {
      py::gil_scoped_release free;
      return highpass_energy_shares(im, cutoffs);
    });
  });
  m.def("_rms_difference", [](FloatArray a, FloatArray b, long border) {
    const ImageView va = view_of(a, "rms_difference()"), vb = view_of(b, "rms_difference()");
    return translated(true, [&] { return rms_difference(va, vb, border); });
  });
  m.def("_psnr", [](FloatArray a, FloatArray b, double peak, long border) {
    const ImageView va = view_of(a, "psnr()"), vb = view_of(b, "psnr()");
    return translated(true, [&] { return psnr(va, vb, peak, border); });
  });
  m.def("_l2_error", [](const PyCoefficients& c,
                        std::optional<FloatArray> truth,
                        std::optional<double> zone_k, int samples_per_pixel, double border) {
    return translated(true, [&] {
      if (truth) {
        const ImageView ref = view_of(*truth, "l2_error()");
        if (ref.channels != c.k.c.channels)
          throw RequestError("l2_error(): the truth has " + std::to_string(ref.channels) +
                             " channels, the coefficients " + std::to_string(c.k.c.channels));
        py::gil_scoped_release free;
        return l2_error(c.k, ref, border, c.threads);
      }
      const double K = *zone_k;
      py::gil_scoped_release free;
      return zoneplate_l2_error(c.k, K, samples_per_pixel, border, c.threads);
    });
  });
  py::class_<PyL2Reference>(m, "L2Reference")
      .def(py::init([](FloatArray a, double border, int threads) {
        const ImageView v = view_of(a, "Reference()");
        const int n = resolved_threads(threads);
        return translated(true, [&] {
          return std::make_unique<PyL2Reference>(a, L2Reference(v, border, n));
        });
      }))
      .def_property_readonly("border", [](const PyL2Reference& r) { return r.reference.border(); })
      .def_property_readonly("array", [](const PyL2Reference& r) { return r.pixels; })
      .def("_l2_error", [](PyL2Reference& r, const PyCoefficients& c) {
        return translated(true, [&] {
          py::gil_scoped_release free;
          std::lock_guard<std::mutex> one(r.busy);
          return r.reference.l2_error(c.k);
        });
      });
  m.def("_overshoot", [](FloatArray output, FloatArray input, double neighbourhood,
                         double tolerance, long border) {
    const ImageView out = view_of(output, "overshoot()"), in = view_of(input, "overshoot()");
    OvershootOptions o;
    o.neighbourhood = neighbourhood;
    o.tolerance = tolerance;
    o.border = border;
    const OvershootReport r = translated(true, [&] {
      py::gil_scoped_release free;
      return overshoot(out, in, o);
    });
    py::dict d;
    d["max_overshoot"] = r.max_overshoot;
    d["max_undershoot"] = r.max_undershoot;
    d["pixels"] = r.pixels;
    d["pixels_out_of_range"] = r.pixels_out_of_range;
    d["negative_pixels"] = r.negative_pixels;
    d["negative_energy"] = r.negative_energy;
    d["min"] = r.min;
    d["max"] = r.max;
    return d;
  });
  // uint8 or uint16 (H, W, C), C-contiguous: float32 in linear light, as
  // the same samples in a file read.
  m.def("_to_linear", [](py::array a) {
    const char kind = a.dtype().kind();
    const auto size = a.itemsize();
    if (a.ndim() != 3 || !(a.flags() & py::array::c_style) || kind != 'u' || (size != 1 && size != 2))
      throw std::logic_error("_to_linear(): not a C-contiguous uint8 or uint16 (H, W, C) array");
    const SampleView v(a.data(), long(a.shape(1)), long(a.shape(0)), channel_count(a.shape(2), "array"),
                       size == 1 ? SampleType::UInt8 : SampleType::UInt16);
    Image im;
    {
      py::gil_scoped_release free;
      im = linear_image(v);
    }
    return to_array(std::move(im));
  });
  m.def("_read_image", [](const std::string& path) {
    return translated(false, [&] {
      Image im;
      {
        py::gil_scoped_release free;
        im = read_image(path);
      }
      return to_array(std::move(im));
    });
  });
  // Returns the samples clamped to half's range. `dtype`, `compression`:
  // "" for the format's default; `quality` 0 for none. A type or a
  // compression the format does not take is a ValueError naming the keyword.
  m.def("_write_image", [](const std::string& path, FloatArray a,
                           std::vector<std::string> channel_names, int alpha,
                           const std::string& dtype, const std::string& compression, int quality) {
    Image im = image_of(a, "write_image()");
    return translated(true, [&] {
      check_output(path);
      auto keyword = [](const std::string& name, const std::string& shown, const auto& check) {
        try {
          check();
        } catch (const std::invalid_argument& e) {
          throw std::invalid_argument(name + "=" + shown + ": " + e.what());
        }
      };
      WriteOptions how;
      if (!dtype.empty())
        keyword("dtype", "'" + dtype + "'", [&] { how.format = parse_sample_format(dtype); });
      if (!compression.empty())
        keyword("compression", "'" + compression + "'", [&] { how.compression = parse_compression(compression); });
      if (quality) {
        keyword("quality", std::to_string(quality), [&] {
          if (quality < 1 || quality > 100) throw std::invalid_argument("expected 1 to 100");
          if (how.compression.quality && how.compression.quality != quality)
            throw std::invalid_argument("compression='" + compression + "' gives another; give it once");
          how.compression.quality = quality;
        });
      }
      const SampleFormat format = how.format.value_or(default_sample_format(path));
      auto check = [&](const Compression& c) {
        try {
          check_write_options(path, im.channels, format, c);
        } catch (const std::invalid_argument& e) {
          throw std::invalid_argument(path + ": " + e.what());
        }
      };
      if (how.format) keyword("dtype", "'" + dtype + "'", [&] { check({}); });
      if (!compression.empty())
        keyword("compression", "'" + compression + "'", [&] { check(how.compression); });
      else if (quality)
        keyword("quality", std::to_string(quality), [&] { check(how.compression); });
      py::gil_scoped_release free;
      // As siproject -d half: magnitudes past half's largest value clamped
      // there (a half file would hold infinities), and counted.
      long clamped = 0;
      if (format == SampleFormat::Half) {
        constexpr float kHalfMax = 65504.0f;
        for (float& v : im.data)
          if (std::abs(v) > kHalfMax) v = std::copysign(kHalfMax, v), ++clamped;
      }
      StagedFileSignals cleanup;  // SIGTERM, SIGHUP... remove the staged file
      write_image(path, im, channel_names, {{"Software", "siproject (Python)"}}, alpha, how);
      return clamped;
    });
  });
  m.def("_srgb8", [](FloatArray a) {
    const ImageView im = view_of(a, "srgb8()");
    py::array_t<std::uint8_t> out({py::ssize_t(im.height), py::ssize_t(im.width), py::ssize_t(im.channels)});
    std::uint8_t* o = out.mutable_data();
    const std::size_t n = std::size_t(im.width) * im.height * im.channels;
    {
      py::gil_scoped_release free;
      // as an 8-bit file holds it: encoded, then OpenImageIO's rounding to 8 bits
      for (std::size_t q = 0; q < n; ++q) o[q] = std::uint8_t(linear_to_srgb(im.data[q]) * 255.0f + 0.5f);
    }
    return out;
  });
  m.def("_luminance", [](FloatArray a) {
    const ImageView im = view_of(a, "luminance()");
    const Grid<double> l = translated(true, [&] { return luminance(im); });
    py::array_t<double> out({py::ssize_t(l.height), py::ssize_t(l.width)});
    std::memcpy(out.mutable_data(), l.data.data(), l.data.size() * sizeof(double));
    return out;
  });
}
