// siproject: forms a final image from any image OpenImageIO reads, treated as
// point samples of a continuous image, by orthogonal projection onto a
// shift-invariant space (min-error) or a conventional filter.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <exception>
#include <functional>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <iostream>
#include <optional>
#include <sstream>
#include <thread>

#include "cli.h"
#include "sis/hex_projection.h"
#include "sis/imageio.h"
#include "sis/memory.h"
#include "sis/prefetch.h"
#include "sis/projection.h"
#include "sis/range.h"

namespace fs = std::filesystem;
using namespace sis;

namespace {

double srgb_decode(double v) { return srgb_to_linear(float(v)); }

using sis::cli::kExitUsage;
using sis::cli::kExitInput;
using sis::cli::kExitOutput;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// More worker threads than this are refused (each has a stack and buffers;
// the output is the same for every count).
constexpr int kMaxThreads = 1024;

// The largest output side (OpenImageIO's image sides are int).
constexpr long kMaxSide = 2147483647;

// The index of the first value that is NaN or infinite, or -1.
template <typename T>
long first_nonfinite(const T* v, std::size_t n) {
  for (std::size_t q = 0; q < n; ++q)
    if (!std::isfinite(v[q])) return long(q);
  return -1;
}

// "x 3, y 7, channel G" of value q of interleaved rows of `width` pixels.
std::string value_position(long q, long width, const std::vector<std::string>& names) {
  const int C = int(std::max<std::size_t>(1, names.size()));
  const long c = q % C, p = q / C;
  std::ostringstream m;
  m << "x " << p % width << ", y " << p / width << ", channel "
    << (c < long(names.size()) ? names[c] : std::to_string(c));
  return m.str();
}

// Refuses a request whose estimated peak memory is more than the process
// can have (sis/memory.h), before anything large is allocated.
void check_memory(std::uint64_t needed, const std::string& what, bool verbose) {
  const std::uint64_t available = available_memory();
  if (verbose)
    std::fprintf(stderr, "siproject: memory: about %s needed (%s), %s available\n",
                 format_bytes(needed).c_str(), what.c_str(),
                 available == UINT64_MAX ? "no limit" : format_bytes(available).c_str());
  if (needed > available)
    throw UsageError("the request needs about " + format_bytes(needed) + " of memory (" + what +
                     "), more than the " + format_bytes(available) +
                     " available; ask for a smaller output (--size or --factor)");
}

// Peak bytes of a projection to a W x H x C output over a coefficient grid
// of `coefficients` values per channel: while acquiring and resampling, the
// coefficients (double), the local input range (min and max, float) and
// the final image (float); while writing, the image, its converted copy
// and the coefficient file's float grid beside the coefficients; plus the
// readers' strips and decoders per thread and the program itself.
// Bytes of the per-axis weight tables (an index and a weight per entry) of
// an acquisition from `samples` to `coefficients` along each axis, a kernel
// of radius R, and of the resampling to the output: an upsampled axis's
// entries also span the input model's reach (acquisition.cpp).
double table_bytes(long coefficients_x, long samples_x, long coefficients_y, long samples_y,
                   double R) {
  auto axis = [&](long n, long samples) {
    const double ratio = double(samples) / double(std::max(1L, n));
    const double entries = 2 * R * std::max(1.0, ratio) + 2 + (ratio < 1 ? 2 * 36 + 4 : 0);
    return double(n) * (entries + 2 * R + 2) * 16;
  };
  return axis(coefficients_x, samples_x) + axis(coefficients_y, samples_y);
}

std::uint64_t projection_bytes(long W, long H, int C, std::uint64_t coefficients, bool local,
                               bool coeffs_file, int threads, double tables = 0) {
  // in double: the product of absurd sides passes 2^64
  const double values = double(W) * double(H) * C, grid = double(coefficients) * C;
  const double acquire = 8 * grid + (local ? 8 * values : 0) + 4 * values;
  const double write = 8 * values + (coeffs_file ? 12 * grid : 0);
  const double bytes =
      std::max(acquire, write) + tables + threads * double(16 << 20) + double(64 << 20);
  return bytes < 1.8e19 ? std::uint64_t(bytes) : UINT64_MAX;
}

struct Options {
  std::vector<std::string> inputs;
  std::string output, coeffs;
  double factor = 0;
  std::string size;
  std::string generator = "cubic", method = "min-error", display, boundary = "mirror";
  std::string nonfinite = "error", prefilter = "fft", clamp = "none";
  std::string data_format;  // "": the input's
  bool highlight_compress = false;
  std::string lattice = "cartesian", quadrature = "point";
  double density = 1.0;
  bool factor_given = false;
  std::string factor_spelling, density_spelling = "1";
  bool lattice_given = false, density_given = false, quadrature_given = false;
  int threads = 0;
  bool verbose = false, quiet = false;
  bool generator_given = false, method_given = false, boundary_given = false;
};

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// "WxH" with positive integers.
std::pair<long, long> parse_size(const std::string& s) {
  long w = 0, h = 0;
  char x = 0, extra = 0;
  std::istringstream in(s);
  if (!(in >> w >> x >> h) || (x != 'x' && x != 'X') || (in >> extra) || w < 1 || h < 1)
    throw UsageError("--size '" + s + "': expected WxH with positive whole numbers, e.g. 1000x750");
  if (w > kMaxSide || h > kMaxSide)
    throw UsageError("--size '" + s + "': more than " + std::to_string(kMaxSide) + " pixels per side");
  return {w, h};
}

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

// True when no sample is NaN or infinite. A branch-free scan of the bits
// (exponent all ones plus one carries into the sign bit) that compilers
// vectorise: the common case costs little.
bool all_finite(const float* v, std::size_t n) {
  std::uint32_t carry = 0;
  for (std::size_t q = 0; q < n; ++q) {
    std::uint32_t u;
    std::memcpy(&u, v + q, sizeof u);
    carry |= (u & 0x7f800000u) + 0x00800000u;
  }
  return !(carry & 0x80000000u);
}

class Progress {
 public:
  Progress(bool enabled, const char* what) : enabled_(enabled), what_(what), start_(Clock::now()) {}
  void update(double fraction) {
    if (!enabled_ || seconds_since(start_) < 1.0) return;
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
  int last_ = -1;
  bool shown_ = false;
};

// Reads chunks 0, 1, ... in order on a thread of its own, chunk i into slot
// i mod `slots`, once chunk i - slots (the slot's last) is released.
class ReadAhead {
 public:
  ReadAhead(std::size_t count, int slots, std::function<void(std::size_t, int)> read)
      : count_(count), slots_(slots), read_(std::move(read)), thread_([this] { loop(); }) {}
  ~ReadAhead() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  // The slot of chunk i, once read; rethrows the error of a failed read.
  int wait(std::size_t i) {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return read_count_ > i || error_; });
    if (read_count_ <= i) std::rethrow_exception(error_);
    return int(i % slots_);
  }
  // Chunk i is used: its slot may be read into again.
  void release(std::size_t i) {
    {
      std::lock_guard<std::mutex> lock(m_);
      released_ = i + 1;
    }
    cv_.notify_all();
  }

 private:
  void loop() {
    for (std::size_t i = 0; i < count_; ++i) {
      {
        std::unique_lock<std::mutex> lock(m_);
        cv_.wait(lock, [&] { return stop_ || i < released_ + slots_; });
        if (stop_) return;
      }
      try {
        read_(i, int(i % slots_));
      } catch (...) {
        std::lock_guard<std::mutex> lock(m_);
        error_ = std::current_exception();
        cv_.notify_all();
        return;
      }
      {
        std::lock_guard<std::mutex> lock(m_);
        read_count_ = i + 1;
      }
      cv_.notify_all();
    }
  }
  const std::size_t count_;
  const std::size_t slots_;
  std::function<void(std::size_t, int)> read_;
  std::mutex m_;
  std::condition_variable cv_;
  std::size_t read_count_ = 0, released_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
  std::thread thread_;  // last: starts once the members above are ready
};

// The first non-finite sample read (in row order) and how many there were.
struct NonFinite {
  long count = 0, x = -1, y = -1;
  int c = -1;
  std::string file;
};

// Values [k0, k1) of a row as float in v (converted from `half_row` when
// given, else already there): false when one is not finite.
bool row_values(const std::uint16_t* half_row, long k0, long k1, float* v) {
  const std::size_t n = std::size_t(k1 - k0);
  return half_row ? half_to_float(half_row + k0, v, n) : all_finite(v, n);
}

// Zeroes the non-finite values of v[0, n) (values k0... of their row); returns
// how many, the first's index in *first.
long zero_nonfinite(float* v, std::size_t n, long k0, long* first) {
  long count = 0;
  for (std::size_t q = 0; q < n; ++q)
    if (!std::isfinite(v[q])) {
      if (count++ == 0) *first = k0 + long(q);
      v[q] = 0.0f;
    }
  return count;
}

// Adds a strip's non-finite samples to n: per strip row r of `rows`, count[r]
// of them, the first at value first[r] of the row (read only when count[r]);
// the strip's rows start at row y0 of `file`.
template <typename Counts>
void add_nonfinite(NonFinite& n, const Counts& count, const Counts& first, long rows, long y0,
                   int channels, const std::string& file) {
  for (long r = 0; r < rows; ++r) {
    if (count[r] && n.count == 0) {
      n.c = int(first[r] % channels);
      n.x = first[r] / channels;
      n.y = y0 + r;
      n.file = file;
    }
    n.count += count[r];
  }
}

// Reads and acquires the image on the Cartesian lattice band by band
// (read_bands): with OpenEXR inputs each worker thread decodes its band's
// strips and sums them while they are in its cache, into a band of the
// acquisition and of the local range of its own; other formats are read by
// one thread, the sums split among the threads by columns. Stops at the first band with a non-finite sample when `stop`.
// `readers`: the inputs in row order (their paths and formats).
NonFinite acquire_bands(const std::vector<std::unique_ptr<ImageReader>>& readers, bool half,
                        int threads, bool stop,
                        const std::function<void(float*, std::size_t, std::size_t)>& decode,
                        const std::function<void(float*, std::size_t, std::size_t)>& compress,
                        Acquisition& acquisition, LocalRange& local, const BandPartition& bands,
                        const std::function<void(double)>& progress) {
  const ImageReader& first = *readers.front();
  std::vector<std::string> paths;
  bool exr = true;
  for (const auto& r : readers) {
    paths.push_back(r->path());
    exr = exr && r->format_name() == "openexr";
  }
  const int workers = exr ? int(std::min<long>(threads, bands.count())) : 1;
  // A worker's own decoding: strips of about 1 MB, in its cache; OpenEXR's
  // pool (one worker): strips of several of its blocks, one per pool thread.
  const long strip = workers > 1 ? decode_strip_rows(first) : first.preferred_strip();
  const std::size_t row_size = std::size_t(first.width()) * first.channels();
  struct Worker {
    std::unique_ptr<Acquisition::Band> acquisition;
    std::unique_ptr<LocalRange::Band> range;
    std::vector<std::atomic<long>> bad, bad_first;  // per strip row (pieces of a row run at once)
    explicit Worker(long rows) : bad(rows), bad_first(rows) {}
  };
  std::vector<std::unique_ptr<Worker>> w;
  for (int t = 0; t < workers; ++t) {
    w.push_back(std::make_unique<Worker>(strip));
    w.back()->acquisition = std::make_unique<Acquisition::Band>(acquisition, workers > 1 ? 1 : threads);
    w.back()->range = std::make_unique<LocalRange::Band>(local);
  }
  std::vector<NonFinite> bad(bands.count());  // per band, each written by the thread taking it
  std::mutex progress_mutex;
  long rows_done = 0;
  BandCallbacks cb;
  cb.begin = [&](int t, long b) {
    w[t]->acquisition->begin(b);
    w[t]->range->begin(b);
  };
  cb.strip = [&](int t, const Strip& s) {
    Worker& k = *w[t];
    const long y = s.global, rows = s.y1 - s.y0, y1 = y + rows;
    for (long r = 0; r < rows; ++r) k.bad[r] = 0, k.bad_first[r] = LONG_MAX;
    k.range->open(y, y1);
    k.acquisition->add_rows(y, y1, [&](long gy, long k0, long k1, float* scratch) {
      const long r = gy - y;
      // the block a later call will ask for
      if (half)
        prefetch_ahead(s.half, r, rows, row_size, k0, k1);
      else
        prefetch_ahead(s.floats, r, rows, row_size, k0, k1);
      float* v = half ? scratch : s.floats + r * row_size + k0;
      if (!row_values(half ? s.half + r * row_size : nullptr, k0, k1, v)) {
        long first_bad = -1;
        k.bad[r] += zero_nonfinite(v, std::size_t(k1 - k0), k0, &first_bad);
        long seen = k.bad_first[r].load();
        while (first_bad < seen && !k.bad_first[r].compare_exchange_weak(seen, first_bad)) {
        }
      }
      if (decode) decode(v, std::size_t(k1 - k0), std::size_t(k0));
      k.range->fold(gy, k0, k1, v);
      if (compress) compress(v, std::size_t(k1 - k0), std::size_t(k0));
      return static_cast<const float*>(v);
    });
    k.range->close(y1);
    NonFinite& n = bad[bands.of(y)];
    add_nonfinite(n, k.bad, k.bad_first, rows, s.y0, first.channels(), *s.path);
    return !(stop && n.count);
  };
  cb.end = [&](int t, long b) {
    w[t]->acquisition->end();
    w[t]->range->end();
    std::lock_guard<std::mutex> lock(progress_mutex);
    rows_done += bands.end(b) - bands.begin(b);
    progress(double(rows_done) / bands.rows());
  };
  read_bands(paths, bands, strip, workers, half, cb);
  NonFinite all;
  for (const NonFinite& n : bad) {
    if (n.count && all.count == 0) all = n;
    else all.count += n.count;
  }
  return all;
}

int run(const Options& o) {
  const auto t_start = Clock::now();
  const int threads = o.threads > 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency());
  if (o.verbose && o.quiet) throw UsageError("-v and -q exclude each other");
  if (o.threads < 0) throw UsageError("--threads " + std::to_string(o.threads) + ": expected 0 (all cores) or more");
  if (o.threads > kMaxThreads)
    throw UsageError("--threads " + std::to_string(o.threads) + ": at most " +
                     std::to_string(kMaxThreads));
  if (o.factor_given && !(std::isfinite(o.factor) && o.factor > 0))
    throw UsageError("--factor " + o.factor_spelling + ": expected a finite number above 0");
  if (!(std::isfinite(o.density) && o.density > 0))
    throw UsageError("--density " + o.density_spelling + ": expected a finite number above 0");
  if (o.factor_given && !o.size.empty()) throw UsageError("give --factor or --size, not both");
  std::pair<long, long> size{0, 0};
  if (!o.size.empty()) size = parse_size(o.size);
  const bool hex = o.lattice == "hex";
  if (!hex && o.lattice != "cartesian")
    throw UsageError("--lattice '" + o.lattice + "': expected cartesian or hex");
  if (!hex && o.density_given) throw UsageError("--density applies to --lattice hex only");
  if (!hex && o.quadrature_given)
    throw UsageError("--quadrature applies to --lattice hex only");
  HexQuadrature quadrature;
  try {
    quadrature = parse_hex_quadrature(o.quadrature);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--quadrature: ") + e.what());
  }
  if (!hex && o.generator.rfind("hex-", 0) == 0)
    throw UsageError("--generator " + o.generator + " needs --lattice hex");
  const int hex_order = [&] {
    if (!hex) return 0;
    try {
      return BoxSpline::parse(o.generator_given ? o.generator : "hex-quartic").order();
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--lattice hex: ") + e.what());
    }
  }();
  const Kernel generator = [&] {
    if (hex) return hex_generator_kernel(hex_order);
    try {
      return Kernel::parse(o.generator);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--generator: ") + e.what());
    }
  }();
  Method method;
  Boundary boundary;
  std::optional<Display> display;
  try {
    method = parse_method(o.method);
    boundary = parse_boundary(o.boundary);
    if (!o.display.empty()) display = Display::parse(o.display);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  if (method == Method::MinError && !generator.is_bspline())
    throw UsageError("--method min-error needs a B-spline generator (box, tent, quadratic, cubic, "
                     "bspline:N), not " + generator.name() + "; use --method conventional");
  Clamp clamp;
  try {
    clamp = parse_clamp(o.clamp);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--clamp: ") + e.what());
  }
  if (o.nonfinite != "error" && o.nonfinite != "zero")
    throw UsageError("--nonfinite '" + o.nonfinite + "': expected error or zero");
  if (o.prefilter != "fft" && o.prefilter != "recursive")
    throw UsageError("--prefilter '" + o.prefilter + "': expected fft or recursive");
  if (hex && method != Method::MinError)
    throw UsageError("--lattice hex has the min-error method only");
  if (hex && o.prefilter != "fft") throw UsageError("--lattice hex has the fft prefilter only");
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
  }
  if (!o.coeffs.empty() && same_file(o.output, o.coeffs))
    throw UsageError("--coeffs " + o.coeffs + " is the output file");
  for (const std::string& path : {o.output, o.coeffs}) {
    if (path.empty()) continue;
    check_output(path);
    if (!o.coeffs.empty() && path == o.coeffs && is_8bit_format(path))
      throw UsageError("--coeffs " + path + ": coefficient files are float EXR");
  }

  // Several inputs are row bands of one image: each band's data window
  // spans the full width and the bands tile the display window's rows.
  // Their headers. Many bands: each file is closed once its header is read
  // (opened again to be read), so that any number fits the descriptor
  // limit. A few stay open until the reading is done: a decoder freed
  // before the reading raises glibc's dynamic mmap threshold, and the
  // reading's buffers then stay on the heap (a higher peak).
  constexpr std::size_t kKeptOpen = 64;
  std::vector<std::unique_ptr<ImageReader>> readers;
  for (const std::string& in : o.inputs) {
    readers.push_back(std::make_unique<ImageReader>(in));
    if (o.inputs.size() > kKeptOpen) readers.back()->release();
  }
  std::sort(readers.begin(), readers.end(),
            [](const auto& a, const auto& b) { return a->data_y() < b->data_y(); });
  ImageReader& reader = *readers.front();
  long win = reader.width(), hin = reader.height();
  const int C = reader.channels();
  const std::vector<std::string> names = reader.channel_names();
  if (readers.size() > 1) {
    long next = reader.full_y();
    for (const auto& r : readers) {
      std::ostringstream m;
      m << r->path() << ": not a row band of " << reader.path() << "'s image: ";
      if (is_coefficient_file(*r)) throw UsageError(r->path() + ": a coefficient file cannot be a band");
      if (r->channels() != C || r->channel_names() != names)
        throw InputError(m.str() + "other channels");
      if (r->full_x() != reader.full_x() || r->full_y() != reader.full_y() ||
          r->full_width() != reader.full_width() || r->full_height() != reader.full_height())
        throw InputError(m.str() + "another display window");
      if (r->data_x() != r->full_x() || r->width() != r->full_width())
        throw InputError(m.str() + "its data window does not span the full width");
      if (r->data_y() != next) {
        m << "rows from " << r->data_y() << " where row " << next << " was expected (gap or overlap)";
        throw InputError(m.str());
      }
      next = r->data_y() + r->height();
    }
    if (next != reader.full_y() + reader.full_height()) {
      std::ostringstream m;
      m << "the bands end at row " << next << " of a display window ending at row "
        << reader.full_y() + reader.full_height();
      throw InputError(m.str());
    }
    win = reader.full_width();
    hin = reader.full_height();
  }
  auto out_size = [&](long w, long h) -> std::pair<long, long> {
    if (size.first) return size;
    if (!o.factor_given) return {w, h};
    const double dw = std::round(w / o.factor), dh = std::round(h / o.factor);
    if (!(dw <= kMaxSide && dh <= kMaxSide)) {
      std::ostringstream m;
      m << "--factor " << o.factor_spelling << ": the output would be " << dw << " x " << dh
        << " pixels, more than " << kMaxSide << " per side";
      throw UsageError(m.str());
    }
    const long ow = long(dw), oh = long(dh);
    if (ow < 1 || oh < 1) {
      std::ostringstream m;
      m << "--factor " << o.factor << " is larger than the image (" << w << " x " << h << ")";
      throw UsageError(m.str());
    }
    return {ow, oh};
  };

  // Output samples as the input's (oiiotool's habit): half when every input
  // stores half, float otherwise; a coefficient file records its input's.
  const bool half = std::all_of(readers.begin(), readers.end(),
                                [](const auto& r) { return r->stores_half(); });
  const bool input_half =
      is_coefficient_file(reader) ? reader.attribute("sis:input_format") == "half" : half;
  SampleFormat out_format = input_half ? SampleFormat::Half : SampleFormat::Float;
  if (data_format) out_format = *data_format;
  const std::string input_label =
      fs::path(reader.path()).filename().string() +
      (readers.size() > 1 ? " and " + std::to_string(readers.size() - 1) + " more bands" : "");
  Coefficients k;
  double t_acquire = 0, t_prefilter = 0;
  long W, H;
  bool compressed = o.highlight_compress;
  std::unique_ptr<LocalRange> local;
  const int alpha = reader.alpha_channel();
  // f on the colour values of data, values [k0, k0 + n) of interleaved rows
  // Integer samples tagged sRGB (PNG, JPEG, 8- and 16-bit TIFF) are decoded
  // to linear light first: the method filters radiance, and an 8-bit output
  // encodes again (a flat 128 stays 128).
  const bool srgb = std::all_of(readers.begin(), readers.end(),
                                [](const auto& r) { return r->srgb_encoded(); });
  auto for_colour = [&](float* data, std::size_t n, double (*f)(double), std::size_t k0 = 0) {
    for (std::size_t q = 0; q < n; ++q)
      if (int((k0 + q) % C) != alpha) data[q] = static_cast<float>(f(data[q]));
  };
  if (is_coefficient_file(reader)) {
    if (readers.size() > 1) throw UsageError("a coefficient file is evaluated alone, not with other inputs");
    if (o.generator_given || o.method_given || o.boundary_given || o.highlight_compress)
      throw UsageError(reader.path() + " is a coefficient file: its generator, method, boundary and "
                       "highlight compression are recorded in it; drop --generator, --method, "
                       "--boundary and --highlight-compress");
    if (clamp == Clamp::Local)
      throw UsageError("--clamp local needs the input samples; " + reader.path() + " is a coefficient file");
    if (o.lattice_given || o.density_given || o.quadrature_given)
      throw UsageError(reader.path() + " is a coefficient file: its lattice is recorded in it; "
                       "drop --lattice, --density and --quadrature");
    compressed = reader.attribute("sis:highlight_compress") == "1";
    const std::uint64_t stored = std::uint64_t(reader.width()) * std::uint64_t(reader.height());
    check_memory(projection_bytes(0, 0, C, stored + stored / 2, false, false, 1),
                 "a coefficient grid of " + std::to_string(reader.width()) + " x " +
                     std::to_string(reader.height()) + " x " + std::to_string(C),
                 false);
    const auto t = Clock::now();
    ImageReader file(reader.path());
    k = read_coefficients(file);
    t_acquire = seconds_since(t);
    const long bad_c = first_nonfinite(k.c.data.data(), k.c.data.size());
    if (bad_c >= 0) {
      const std::string where = reader.path() + ": non-finite coefficient (NaN or Inf) at " +
                                value_position(bad_c, k.c.width, names);
      if (o.nonfinite == "error")
        throw InputError(where + "; use --nonfinite zero to replace them with 0");
      long count = 0;
      for (double& v : k.c.data)
        if (!std::isfinite(v)) v = 0, ++count;
      if (!o.quiet)
        std::cerr << "siproject: warning: replaced " << count
                  << " non-finite coefficients with 0; first: " << where << "\n";
    }
    // its own size is its frame's (a hexagonal grid also covers a margin)
    if (k.lattice.is_hexagonal())
      std::tie(W, H) = out_size(std::lround(k.image_width), std::lround(k.image_height));
    else
      std::tie(W, H) = out_size(k.c.width, k.c.height);
    check_memory(projection_bytes(W, H, C, std::uint64_t(k.c.width) * std::uint64_t(k.c.height),
                                  false, false, threads,
                                  table_bytes(W, k.c.width, H, k.c.height, k.generator.radius())),
                 "a " + std::to_string(W) + " x " + std::to_string(H) + " x " +
                     std::to_string(C) + " output",
                 o.verbose);
  } else {
    if (!o.factor_given && !size.first)
      throw UsageError("give the output size: --factor S (output = input / S) or --size WxH");
    std::tie(W, H) = out_size(win, hin);
    std::uint64_t coefficients = std::uint64_t(W) * std::uint64_t(H);
    if (hex) {
      // The hexagonal acquisition sums samples under each lattice point: it
      // needs at least one sample per lattice step (it has no interpolation
      // model of the input, as the Cartesian one has where it upsamples),
      // and a lattice step no larger than the frame.
      const double h = Lattice::hexagonal(o.density).matrix()[0];
      const double spacing = std::max(double(W) / double(win), double(H) / double(hin));
      std::ostringstream m;
      m.precision(4);
      if (h < spacing) {
        m << "--lattice hex: the lattice's step (" << h << " output pixels at --density "
          << o.density << ") is finer than the input's sample spacing (" << spacing
          << " output pixels); the hexagonal acquisition needs a sample per lattice step: use "
             "--density at most "
          << 2 / (std::sqrt(3.0) * spacing * spacing) << ", or a smaller output";
        throw UsageError(m.str());
      }
      if (h > double(std::min(W, H))) {
        m << "--density " << o.density << ": the hexagonal lattice's step (" << h
          << " output pixels) is larger than the " << W << " x " << H << " frame";
        throw UsageError(m.str());
      }
      const HexLayout layout =
          hex_layout(o.density, double(W), double(H), hex_default_margin(hex_order));
      coefficients = std::uint64_t(layout.columns) * std::uint64_t(layout.rows);
    }
    check_memory(projection_bytes(W, H, C, coefficients, true, !o.coeffs.empty(), threads,
                                  table_bytes(W, win, H, hin, generator.radius())),
                 "a " + std::to_string(W) + " x " + std::to_string(H) + " x " +
                     std::to_string(C) + " output",
                 o.verbose);
    std::unique_ptr<AcquisitionPlan> plan;
    std::unique_ptr<Acquisition> cartesian;
    std::unique_ptr<HexAcquisitionPlan> hex_plan;
    std::unique_ptr<HexAcquisition> hexagonal;
    NonFinite bad;
    if (!hex) {
      const auto t = Clock::now();
      plan = std::make_unique<AcquisitionPlan>(win, hin, C, double(W), double(H),
                                               Lattice::cartesian(), generator, boundary, method);
      cartesian = std::make_unique<Acquisition>(*plan, threads);
      local = std::make_unique<LocalRange>(win, hin, C, W, H, plan->bands().band_rows());
      std::function<void(float*, std::size_t, std::size_t)> compress;
      if (compressed)
        compress = [&](float* v, std::size_t n, std::size_t k0) {
          for_colour(v, n, highlight_compress, k0);
        };
      std::function<void(float*, std::size_t, std::size_t)> decode;
      if (srgb)
        decode = [&](float* v, std::size_t n, std::size_t k0) {
          for_colour(v, n, srgb_decode, k0);
        };
      Progress progress(!o.quiet, "reading and acquiring");
      bad = acquire_bands(readers, half, threads, o.nonfinite == "error", decode, compress, *cartesian,
                          *local, plan->bands(), [&](double f) { progress.update(f); });
      t_acquire = seconds_since(t);
    } else {
      // The rows as chunks of the bands (one band for one input), in order.
      struct Chunk {
        ImageReader* reader;
        long y0, y1, global;
      };
      std::vector<Chunk> chunks;
      long strip = 0;
      long g = 0;
      for (const auto& r : readers) {
        strip = std::max(strip, r->preferred_strip());
        for (long y = 0; y < r->height(); y += r->preferred_strip()) {
          const long y1 = std::min(r->height(), y + r->preferred_strip());
          chunks.push_back({r.get(), y, y1, g + y});
        }
        g += r->height();
      }
      // Samples stored as half are read as they are and converted here, on
      // the worker threads (OpenImageIO's conversion is serial and slower than
      // decoding). Strips are read on a thread of their own into two slots:
      // the next strip decodes while this one is acquired.
      const std::size_t row_size = std::size_t(win) * C;
      const int slots = 2;
      std::vector<Buffer<std::uint16_t>> half_rows(slots);  // unset: each strip is read into them
      std::vector<Buffer<float>> float_rows(slots);
      for (int b = 0; b < slots; ++b) {
        if (half) half_rows[b].resize(strip * row_size);
        float_rows[b].resize(strip * row_size);
      }
      // Per strip row: its non-finite samples (rows are checked at once on
      // different threads).
      std::vector<long> strip_bad(strip), strip_bad_first(strip);
      {
        Progress progress(!o.quiet, "reading and acquiring");
        const auto t = Clock::now();
        // one file open at a time, in row order, on the reading thread
        std::unique_ptr<ImageReader> file;
        auto read = [&](std::size_t i, int b) {
          const Chunk& ch = chunks[i];
          if (!file || file->path() != ch.reader->path())
            file.reset(), file = std::make_unique<ImageReader>(ch.reader->path());
          if (half)
            file->read_rows_half(ch.y0, ch.y1, half_rows[b].data());
          else
            file->read_rows(ch.y0, ch.y1, float_rows[b].data());
        };
        ReadAhead ahead(chunks.size(), slots, read);
        // The plan (the weights of every input row and column, some
        // milliseconds) is made while the first strips decode.
        const HexLayout layout =
            hex_layout(o.density, double(W), double(H), hex_default_margin(hex_order));
        hex_plan = std::make_unique<HexAcquisitionPlan>(win, hin, C, double(W), double(H), layout,
                                                        hex_order, boundary, quadrature);
        hexagonal = std::make_unique<HexAcquisition>(*hex_plan, threads);
        local = std::make_unique<LocalRange>(win, hin, C, W, H);
        for (std::size_t i = 0; i < chunks.size(); ++i) {
          const Chunk& ch = chunks[i];
          const long y = ch.global, y1 = ch.global + ch.y1 - ch.y0;
          const int b = ahead.wait(i);  // rethrows a read error
          const long rows = y1 - y;
          float* data = float_rows[b].data();
          const long values = long(row_size);
          // Non-finite samples zeroed (and counted), ...
          parallel_for(rows, threads, [&](long r0, long r1) {
            for (long r = r0; r < r1; ++r) {
              float* v = data + r * row_size;
              strip_bad[r] = 0;
              if (!row_values(half ? half_rows[b].data() + r * row_size : nullptr, 0, values, v))
                strip_bad[r] = zero_nonfinite(v, row_size, 0, &strip_bad_first[r]);
            }
          });
          // ... then their local range taken and highlights compressed.
          local->open(y, y1);
          parallel_for(values, threads, [&](long k0, long k1) {
            for (long r = 0; r < rows; ++r) {
              float* v = data + r * row_size + k0;
              if (srgb) for_colour(v, std::size_t(k1 - k0), srgb_decode, std::size_t(k0));
              local->fold(y + r, k0, k1, v);
              if (compressed) for_colour(v, std::size_t(k1 - k0), highlight_compress, std::size_t(k0));
            }
          });
          local->close(y1);
          hexagonal->add_rows(y, y1, data);
          add_nonfinite(bad, strip_bad, strip_bad_first, rows, ch.y0, C, ch.reader->path());
          ahead.release(i);
          if (bad.count && o.nonfinite == "error") break;
          progress.update(double(y1) / hin);
        }
        t_acquire = seconds_since(t);
      }
    }
    readers.clear();  // frees the decoders' buffers before the later stages
    if (bad.count) {
      std::ostringstream m;
      m << bad.file << ": non-finite sample (NaN or Inf) at x " << bad.x << ", y " << bad.y
        << ", channel " << (bad.c < int(names.size()) ? names[bad.c] : std::to_string(bad.c));
      if (o.nonfinite == "error") {
        m << "; use --nonfinite zero to replace them with 0";
        throw InputError(m.str());
      }
      if (!o.quiet) std::cerr << "siproject: warning: replaced " << bad.count << " non-finite samples with 0; first: " << m.str() << "\n";
    }
    k = hex ? hexagonal->finish() : cartesian->finish();
    const auto t = Clock::now();
    prefilter(k, threads, o.prefilter == "fft" ? PrefilterMethod::FFT : PrefilterMethod::Recursive);
    t_prefilter = seconds_since(t);
    // Coefficients are kept in float, as a coefficient file stores them, so
    // that evaluating a written coefficient file reproduces this run exactly.
    parallel_for(long(k.c.data.size()), threads, [&](long q0, long q1) {
      for (long q = q0; q < q1; ++q) k.c.data[q] = static_cast<float>(k.c.data[q]);
    });
    // Finite samples near float's largest value can still overflow there.
    const long overflow = first_nonfinite(k.c.data.data(), k.c.data.size());
    if (overflow >= 0)
      throw InputError(input_label + ": the samples are too large: the coefficients pass float's "
                       "largest value (3.4e38) at coefficient " +
                       value_position(overflow, k.c.width, names) + "; nothing written");
  }

  const Display shown = display ? *display : (k.min_error ? Display::antialiased_2x2() : Display::centred());
  auto t = Clock::now();
  Image image = final_image(k, shown, W, H, threads);
  if (compressed) for_colour(image.data.data(), image.data.size(), highlight_expand);
  const bool own_range = local && local->min().width == W && local->min().height == H;
  const RangeReport before = report_range(image, own_range ? local.get() : nullptr, threads);
  apply_clamp(image, clamp, local.get());
  RangeReport after = clamp == Clamp::None ? before : report_range(image, nullptr, threads);
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
  const double t_resample = seconds_since(t);
  // Never a non-finite pixel from finite coefficients without saying so:
  // resampling or the highlight expansion can pass float's range.
  const long bad_pixel = first_nonfinite(image.data.data(), image.data.size());
  if (bad_pixel >= 0)
    throw InputError(input_label + ": the final image passes float's range at " +
                     value_position(bad_pixel, W, names) + "; nothing written");
  const bool from_samples = local != nullptr;
  local.reset();  // what is no longer needed goes before the output is written

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
      {"sis:lattice", k.lattice.is_hexagonal() ? "hexagonal" : "cartesian"},
      {"sis:half_clamped", std::to_string(half_clamped)},
      {"Software", "siproject"},
  };
  t = Clock::now();
  // Both outputs are written whole before either replaces a file.
  std::optional<StagedFile> coeffs_file;
  if (!o.coeffs.empty())
    coeffs_file.emplace(stage_coefficients(o.coeffs, k, names,
                                           {{"sis:input", md[4].second},
                                            {"sis:input_format", input_half ? "half" : "float"},
                                            {"sis:highlight_compress", compressed ? "1" : "0"}}));
  Buffer<double>().swap(k.c.data);
  StagedFile output_file = stage_image(o.output, image, names, md, alpha, out_format);
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
                 threads, t_acquire, t_prefilter, t_resample, t_write, seconds_since(t_start));
    if (k.lattice.is_hexagonal())
      std::fprintf(stderr,
                   "siproject: hexagonal lattice, %.6g points per output pixel (step %.6g), "
                   "%ld x %ld offset-row coefficients over the frame and its margin%s\n",
                   1.0 / std::abs(k.lattice.determinant()), k.lattice.matrix()[0], k.c.width,
                   k.c.height,
                   from_samples ? (", " + hex_quadrature_name(quadrature) + " quadrature").c_str() : "");
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
      "is (EXR alpha is premultiplied, so it is filtered with the colour). EXR output\n"
      "keeps the input's sample type (half or float; -d), with the method in its\n"
      "metadata; PNG, JPEG and TIFF are written 8-bit, sRGB-encoded and clamped to\n"
      "[0, 1]. If IN is a coefficient file (--coeffs), the stored approximation is\n"
      "evaluated instead: at its own size, --size or --factor, with any --display.\n"
      "Exit status: 0 success, 2 usage, 3 input, 4 output.",
      "siproject"};
  app.add_option("IN", o.inputs,
                 "input image, or a coefficient file written by --coeffs; several inputs are row "
                 "bands of one image (by their data windows, e.g. partial renders cropped with "
                 "oiiotool --crop), projected as one")->required();
  app.add_option("-o,--output", o.output, "output image (.exr half or float, see -d; .png/.jpg/.tif 8-bit sRGB)")->required();
  auto* fac = app.add_option("--factor", o.factor,
                             "supersampling factor per axis: output = input / S (any real S > 0; "
                             "S < 1 upsamples: the input's cubic interpolant is projected)");
  app.add_option("--size", o.size, "output size WxH (any ratio to the input)");
  auto* g = app.add_option("--generator", o.generator,
                           "box, tent, quadratic, cubic, bspline:N (N = 0..7), mitchell, gaussian, "
                           "catmull-rom, lanczos3; with --lattice hex: hex-hat or hex-quartic "
                           "(the default there)")->capture_default_str();
  auto* lat = app.add_option("--lattice", o.lattice,
                             "cartesian (coefficients on the output pixels) or hex (a hexagonal "
                             "lattice, min-error, resampled to the output pixels)")
                  ->capture_default_str();
  auto* quad = app.add_option("--quadrature", o.quadrature,
                              "--lattice hex: the inner products from the samples: point (each "
                              "sample a point, as on the Cartesian lattice) or cell (each sample "
                              "the value over its cell: flat areas exact at any sampling, a "
                              "slight blur; better with hex-hat)")
                   ->capture_default_str();
  auto* dens = app.add_option("--density", o.density,
                              "--lattice hex: lattice points per output pixel (at most one "
                              "per input sample)")
                   ->capture_default_str();
  auto* m = app.add_option("--method", o.method,
                           "min-error (orthogonal projection, B-spline generators) or conventional "
                           "(normalised weighted average, any generator)")->capture_default_str();
  app.add_option("--display", o.display,
                 "how the continuous approximation is sampled: centred, 2x2 (off-centre "
                 "antialiasing at +-1/4), pixel (exact pixel average) or offsets:DX,DY;DX,DY;... "
                 "[default: 2x2 for min-error, centred (the filtered pixels) for conventional]");
  auto* b = app.add_option("--boundary", o.boundary,
                           "mirror (half-sample symmetric) or periodic")->capture_default_str();
  app.add_option("--coeffs", o.coeffs, "also write the coefficients as a float EXR with their metadata");
  app.add_option("-d,--data-format", o.data_format,
                 "sample type of an EXR (or other float) output: half or float [default: the "
                 "input's, as oiiotool does: half when the input stores half, float where the "
                 "output passes half's largest value 65504; -d half clamps there instead]");
  app.add_option("--nonfinite", o.nonfinite,
                 "NaN/Inf samples: error, or zero to replace them with 0")->capture_default_str();
  app.add_flag("--highlight-compress", o.highlight_compress,
               "compress the samples' range with OpenImageIO's log curve (identity below 0.18) "
               "before projecting, expand after: far less HDR ringing, at a cost in energy");
  app.add_option("--clamp", o.clamp,
                 "clamp displayed samples: none, zero (at 0), local (to the min/max of the input "
                 "samples under each output pixel)")->capture_default_str();
  app.add_option("--prefilter", o.prefilter, "fft or recursive (same result to rounding)")->capture_default_str();
  app.add_option("--threads", o.threads, "worker threads (0: all cores); output is bit-identical for any N")
      ->capture_default_str();
  app.add_flag("-v,--verbose", o.verbose, "print sizes and the time of each stage");
  app.add_flag("-q,--quiet", o.quiet, "print nothing but errors");
  if (const auto code = sis::cli::parse(app, argc, argv)) return *code;
  remove_staged_files_on_signals();
  o.generator_given = g->count() > 0;
  o.method_given = m->count() > 0;
  o.boundary_given = b->count() > 0;
  o.lattice_given = lat->count() > 0;
  o.density_given = dens->count() > 0;
  o.factor_given = fac->count() > 0;
  if (o.factor_given) o.factor_spelling = fac->as<std::string>();
  if (o.density_given) o.density_spelling = dens->as<std::string>();
  o.quadrature_given = quad->count() > 0;
  // A conventional filter named alone means the conventional method.
  if (o.generator_given && !o.method_given) {
    try {
      if (!Kernel::parse(o.generator).is_bspline()) o.method = "conventional";
    } catch (const std::invalid_argument&) {  // reported by run()
    }
  }
  try {
    return run(o);
  } catch (const UsageError& e) {
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
