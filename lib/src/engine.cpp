#include "sis/engine.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <filesystem>
#include <mutex>
#include <sstream>
#include <thread>
#include <type_traits>

#include "sis/memory.h"
#include "sis/parallel.h"
#include "sis/partial.h"
#include "sis/scattered_input.h"
#include "sis/projection.h"
#include "sis/space.h"
#include "space_sinks.h"

namespace sis {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Adds a strip's non-finite samples to n: per strip row r of `rows`, count[r]
// of them, the first at value first[r] of the row (read only when count[r]);
// the strip's rows start at row y0 of `file`.
template <typename Counts>
void add_nonfinite(NonFiniteReport& n, const Counts& count, const Counts& first, long rows, long y0,
                   int channels, const std::string& file) {
  for (long r = 0; r < rows; ++r) {
    if (count[r] && n.count == 0) {
      n.channel = int(first[r] % channels);
      n.x = first[r] / channels;
      n.y = y0 + r;
      n.file = file;
    }
    n.count += count[r];
  }
}


// Above this many inputs each file is closed once its header is read (so
// that any number of bands fits the descriptor limit); fewer stay open until
// the reading is done: a decoder freed before the reading raises glibc's
// dynamic mmap threshold, and the reading's buffers then stay on the heap.
constexpr std::size_t kKeptOpen = 64;


}  // namespace

std::vector<std::string> default_channel_names(int channels) {
  if (channels == 1) return {"Y"};
  if (channels == 3) return {"R", "G", "B"};
  if (channels == 4) return {"R", "G", "B", "A"};
  std::vector<std::string> v;
  for (int c = 0; c < channels; ++c) v.push_back("c" + std::to_string(c));
  return v;
}

long first_nonfinite(const double* v, std::size_t n) {
  for (std::size_t q = 0; q < n; ++q)
    if (!std::isfinite(v[q])) return long(q);
  return -1;
}
long first_nonfinite(const float* v, std::size_t n) {
  for (std::size_t q = 0; q < n; ++q)
    if (!std::isfinite(v[q])) return long(q);
  return -1;
}

std::string value_position(long q, long width, const std::vector<std::string>& names) {
  const int C = int(std::max<std::size_t>(1, names.size()));
  const long c = q % C, p = q / C;
  std::ostringstream m;
  m << "x " << p % width << ", y " << p / width << ", channel "
    << (c < long(names.size()) ? names[c] : std::to_string(c));
  return m.str();
}

double table_bytes(long coefficients_x, long samples_x, long coefficients_y, long samples_y,
                   double R) {
  // an index and a weight per entry; an axis's entries also span the input
  // model's reach (acquisition.cpp: 36 samples either side upsampling, 2
  // downsampling by a factor that is not whole)
  auto axis = [&](long n, long samples) {
    const double ratio = double(samples) / double(std::max(1L, n));
    const double entries = 2 * R * std::max(1.0, ratio) + 2 + (ratio < 1 ? 2 * 36 + 4 : 4);
    return double(n) * (entries + 2 * R + 2) * 16;
  };
  return axis(coefficients_x, samples_x) + axis(coefficients_y, samples_y);
}

std::uint64_t projection_bytes(long W, long H, int C, std::uint64_t coefficients, bool local,
                               bool coefficient_file, int threads, double tables) {
  // While acquiring and resampling: the coefficients (double), the local
  // input range (min and max, float) and the final image (float); while
  // writing: the image, its converted copy and the coefficient file's float
  // grid beside the coefficients; plus the readers' strips and decoders per
  // thread and the program itself. In double: absurd sides pass 2^64.
  const double values = double(W) * double(H) * C, grid = double(coefficients) * C;
  const double acquire = 8 * grid + (local ? 8 * values : 0) + 4 * values;
  const double write = 8 * values + (coefficient_file ? 12 * grid : 0);
  const double bytes =
      std::max(acquire, write) + tables + threads * double(16 << 20) + double(64 << 20);
  return bytes < 1.8e19 ? std::uint64_t(bytes) : UINT64_MAX;
}

void check_memory(std::uint64_t needed, const std::string& what) {
  const std::uint64_t available = available_memory();
  if (needed > available)
    throw RequestError("the request needs about " + format_bytes(needed) + " of memory (" + what +
                       "), more than the " + format_bytes(available) +
                       " available; ask for a smaller output (--size or --factor)");
}

InputSet inspect(const std::vector<ProjectionInput>& inputs, bool partial) {
  if (inputs.empty()) throw RequestError("no input");
  InputSet set;
  struct Header {
    const ProjectionInput* input;
    long width, height, full_x, full_y, full_w, full_h, data_x, data_y;
    int channels, alpha;
    std::vector<std::string> names;
    bool half;
    Transfer transfer;
    int integer_bits;
    bool coefficients;
    std::string path;
  };
  std::vector<Header> h;
  // Partial files are merged whole: none is a band of an image.
  if (!inputs.front().image && is_partial_file(ImageReader(inputs.front().path))) {
    for (const ProjectionInput& in : inputs)
      if (in.image || !is_partial_file(ImageReader(in.path)))
        throw RequestError((in.image ? in.name : in.path) + ": not a partial file; partial files (" +
                           inputs.front().path + ") merge only with partial files");
    set.partial_files = true;
    // the inputs as the partials record them (the first's; merge() checks the rest)
    const Partial head = read_partial(inputs.front().path, false);
    set.width = head.input_width;
    set.height = set.rows = head.input_height;
    set.channels = int(head.channel_names.size());
    set.channel_names = head.channel_names;
    set.alpha = head.alpha;
    set.half = head.half;
    set.transfer = head.transfer;
    set.srgb = head.transfer.kind == Transfer::SRGB;
    set.integer_bits = head.integer_bits;
    for (const ProjectionInput& in : inputs) set.bands.push_back(in);
    set.label = fs::path(inputs.front().path).filename().string() +
                (inputs.size() > 1 ? " and " + std::to_string(inputs.size() - 1) + " more partials" : "");
    return set;
  }
  for (const ProjectionInput& in : inputs) {
    if (in.image) {
      const SampleView& im = in.image;
      if (im.width < 1 || im.height < 1 || im.channels < 1)
        throw InputError(in.name + ": empty image");
      const long full = in.rows > 0 ? in.rows : in.row + im.height;
      h.push_back({&in, im.width, im.height, 0, 0, im.width, full, 0, in.row, im.channels, in.alpha,
                   in.channel_names.empty() ? default_channel_names(im.channels) : in.channel_names,
                   im.is_half(), in.transfer ? *in.transfer : default_transfer(im.is_integer(), ""),
                   im.type == SampleType::UInt8 ? 8 : im.type == SampleType::UInt16 ? 16 : 0, false,
                   in.name});
      continue;
    }
    auto reader = std::make_shared<ImageReader>(in.path);
    const ImageReader& r = *reader;
    if (is_partial_file(r))
      throw RequestError(in.path + ": a partial file merges only with partial files, not with " +
                         (inputs.front().image ? inputs.front().name : inputs.front().path));
    if (is_scattered_file(r)) {
      // samples at their own places: one file, projected whole
      if (inputs.size() > 1)
        throw RequestError(in.path + ": a file of scattered samples (position channels " +
                           kPositionChannelX + ", " + kPositionChannelY +
                           ") is projected alone, not as a band or with other inputs");
      if (partial)
        throw RequestError(in.path + ": a file of scattered samples (position channels " +
                           kPositionChannelX + ", " + kPositionChannelY +
                           ") has no row bands; --partial takes a grid's bands");
      const ScatteredLayout l = scattered_layout(r);
      set.scattered_file = true;
      set.width = r.width();
      set.height = set.rows = r.height();
      set.channels = int(l.values.size());
      set.channel_names = l.names;
      set.alpha = l.alpha;
      set.half = r.stores_half();
      set.integer_bits = l.integer_bits;
      set.transfer = r.transfer();
      set.srgb = set.transfer.kind == Transfer::SRGB;
      set.label = fs::path(in.path).filename().string();
      set.bands.push_back(in);
      set.readers.push_back(std::move(reader));
      return set;
    }
    h.push_back({&in, r.width(), r.height(), r.full_x(), r.full_y(), r.full_width(),
                 r.full_height(), r.data_x(), r.data_y(), r.channels(), r.alpha_channel(),
                 r.channel_names(), r.stores_half(), r.transfer(), r.integer_bits(), is_coefficient_file(r),
                 in.path});
    if (inputs.size() > kKeptOpen) reader->release();
    set.readers.push_back(std::move(reader));
  }
  std::stable_sort(h.begin(), h.end(), [](const Header& a, const Header& b) { return a.data_y < b.data_y; });
  const Header& first = h.front();
  set.width = first.width;
  set.height = first.height;
  set.channels = first.channels;
  set.channel_names = first.names;
  set.alpha = first.alpha;
  set.coefficient_file = first.coefficients;
  set.rows = first.height;
  if (h.size() > 1 || partial) {
    long next = first.full_y;
    if (partial) {
      if (first.data_y < first.full_y || first.data_x != first.full_x || first.width != first.full_w)
        throw InputError(first.path + ": not a row band of its display window (its data window "
                         "must span the full width, within the display window)");
      next = first.data_y;
      set.first_row = first.data_y - first.full_y;
    }
    for (const Header& b : h) {
      std::ostringstream m;
      m << b.path << ": not a row band of " << first.path << "'s image: ";
      if (b.coefficients) throw RequestError(b.path + ": a coefficient file cannot be a band");
      if (b.channels != first.channels || b.names != first.names)
        throw InputError(m.str() + "other channels");
      if (b.transfer != first.transfer)
        throw InputError(m.str() + "samples of another transfer (" + b.transfer.name() + ", not " +
                         first.transfer.name() + ")");
      if (b.full_x != first.full_x || b.full_y != first.full_y || b.full_w != first.full_w ||
          b.full_h != first.full_h)
        throw InputError(m.str() + "another display window");
      if (b.data_x != b.full_x || b.width != b.full_w)
        throw InputError(m.str() + "its data window does not span the full width");
      if (b.data_y != next) {
        m << "rows from " << b.data_y << " where row " << next << " was expected (gap or overlap)";
        throw InputError(m.str());
      }
      next = b.data_y + b.height;
    }
    if (partial ? next > first.full_y + first.full_h : next != first.full_y + first.full_h) {
      std::ostringstream m;
      m << "the bands end at row " << next << " of a display window ending at row "
        << first.full_y + first.full_h;
      throw InputError(m.str());
    }
    set.width = first.full_w;
    set.height = first.full_h;
    set.rows = next - first.full_y - set.first_row;
  } else if (first.input->image && first.full_h != first.height) {
    throw InputError(first.path + ": a band of " + std::to_string(first.height) + " rows from row " +
                     std::to_string(first.data_y) + " does not fill a grid of " +
                     std::to_string(first.full_h) + " rows");
  }
  set.half = std::all_of(h.begin(), h.end(), [](const Header& b) { return b.half; });
  // the bands are read as one type: half samples in memory only with half everywhere
  for (const Header& b : h)
    if (b.input->image && b.half && !set.half)
      throw RequestError(b.path + ": half samples in memory with bands that are not half; "
                         "give every band as half or every band as float");
  set.transfer = first.transfer;
  set.srgb = set.transfer.kind == Transfer::SRGB;
  for (const Header& b : h) set.integer_bits = std::max(set.integer_bits, b.integer_bits);
  if (!std::all_of(h.begin(), h.end(), [](const Header& b) { return b.integer_bits > 0; }))
    set.integer_bits = 0;
  set.label = (first.input->image ? first.path : fs::path(first.path).filename().string()) +
              (h.size() > 1 ? " and " + std::to_string(h.size() - 1) + " more bands" : "");
  for (const Header& b : h) set.bands.push_back(*b.input);
  return set;
}

namespace {


// Rows per strip of in-memory bands: as a file's (about 1 MB of float).
long memory_strip_rows(long width, int channels) {
  const long row_bytes = std::max(1L, width * channels * 4L);
  return std::clamp(16 * ((1L << 20) / row_bytes / 16), 16L, 256L);
}

// How the grid is read in bands: its bands' names and images, how many
// workers (several for OpenEXR files and samples in memory, one for other
// formats) and the strip height (a worker's own decoding: about 1 MB, in
// its cache; OpenEXR's pool with one worker: several of its blocks).
struct Reading {
  bool memory = false, half = false;
  std::vector<std::string> names;
  std::vector<SampleView> images;
  std::vector<FileSignature> signatures;  // the files as inspected
  int workers = 1;
  long strip = 0;
};

Reading plan_reading(const InputSet& in, int threads, const BandPartition& bands) {
  Reading g;
  g.memory = static_cast<bool>(in.bands.front().image);
  g.half = in.half;
  for (const ProjectionInput& b : in.bands) {
    g.names.push_back(g.memory ? b.name : b.path);
    g.images.push_back(b.image);
    g.signatures.emplace_back();
    for (const auto& r : in.readers)
      if (!b.image && r->path() == b.path) g.signatures.back() = r->signature();
  }
  bool exr = true;
  if (!g.memory)
    for (const auto& r : in.readers) exr = exr && r->format_name() == "openexr";
  g.workers = exr ? int(std::min<long>(threads, bands.count())) : 1;
  if (g.memory) {
    g.strip = memory_strip_rows(in.width, in.channels);
  } else {
    const ImageReader* first = in.readers.front().get();
    for (const auto& r : in.readers)
      if (r->path() == in.bands.front().path) first = r.get();
    g.strip = g.workers > 1 ? decode_strip_rows(*first) : first->preferred_strip();
  }
  return g;
}

// Reads the grid as planned, then the first non-finite sample of all bands
// and their count.
NonFiniteReport read_grid(const Reading& g, const BandPartition& bands, long first_band,
                          const BandCallbacks& cb, const std::vector<NonFiniteReport>& bad) {
  std::vector<BandSource> sources;
  for (std::size_t f = 0; f < g.names.size(); ++f)
    sources.push_back({g.names[f], g.images[f], g.signatures[f]});
  read_bands(sources, bands, g.strip, g.workers, g.half, cb, first_band);
  NonFiniteReport all;
  for (const NonFiniteReport& n : bad) {
    if (n.count && all.count == 0) all = n;
    else all.count += n.count;
  }
  return all;
}

using RangeBands = std::vector<std::unique_ptr<LocalRange::Band>>;

// One space's sink as the reading drives it: its band with the one range.
template <typename Sink>
struct OneSink {
  Sink& sink;
  const BandPartition& bands() const { return sink.bands(); }
  class Band {
   public:
    Band(OneSink& one, const StripFormat& format) : band_(one.sink, format) {}
    void begin(long b) { band_.begin(b); }
    void add_strip(const Strip& s, const RangeBands& ranges, SampleStages::Counts& bad,
                   SampleStages::Counts& bad_first) {
      band_.add_strip(s, *ranges.front(), bad, bad_first);
    }
    void end() { band_.end(); }

   private:
    typename Sink::Band band_;
  };
};

// Reads the grid band by band into the sinks (Sinks: OneSink of a space's
// CartesianSink or HexagonalSink, or ManySinks; lib/src/space_sinks.h) and
// the local ranges, a band of each per worker thread: each worker decodes
// its band's strips and uses them while they are in its cache; other
// formats than OpenEXR are read by one worker. The sinks' band converts,
// checks, decodes, folds, compresses and adds each strip, counting the
// non-finite samples of each strip row (bad) and the first's value index
// (bad_first, the least). Stops at the first band with a non-finite sample
// when `stop`.
template <typename Sinks>
NonFiniteReport acquire_in_bands(const InputSet& in, int threads, const SampleStages& stages,
                                 Sinks& sinks, const std::vector<LocalRange*>& locals, bool stop,
                                 const std::function<void(double)>& progress,
                                 const std::function<void()>& interrupt) {
  const BandPartition& bands = sinks.bands();
  const long first_band = bands.of(in.first_row);
  const Reading g = plan_reading(in, threads, bands);
  StripFormat format;
  format.stages = &stages;
  format.half = g.half;
  format.row_size = std::size_t(in.width) * in.channels;
  format.threads = g.workers > 1 ? 1 : threads;  // threads within a band
  struct Worker {
    std::unique_ptr<typename Sinks::Band> acquisition;
    RangeBands ranges;
    std::vector<std::atomic<long>> bad, bad_first;  // per strip row (pieces of a row run at once)
    explicit Worker(long rows) : bad(rows), bad_first(rows) {}
  };
  std::vector<std::unique_ptr<Worker>> w;
  for (int t = 0; t < g.workers; ++t) {
    w.push_back(std::make_unique<Worker>(g.strip));
    w.back()->acquisition = std::make_unique<typename Sinks::Band>(sinks, format);
    for (LocalRange* local : locals) w.back()->ranges.push_back(std::make_unique<LocalRange::Band>(*local));
  }
  std::vector<NonFiniteReport> bad(bands.count());  // per band, each written by the thread taking it
  std::mutex progress_mutex;
  long rows_done = 0;
  BandCallbacks cb;
  cb.begin = [&](int t, long b) {
    w[t]->acquisition->begin(b);
    for (auto& range : w[t]->ranges) range->begin(b);
  };
  cb.strip = [&](int t, const Strip& s) {
    if (interrupt) interrupt();
    Worker& k = *w[t];
    const long y = s.global, rows = s.y1 - s.y0, y1 = y + rows;
    for (long r = 0; r < rows; ++r) k.bad[r] = 0, k.bad_first[r] = LONG_MAX;
    for (auto& range : k.ranges) range->open(y, y1);
    k.acquisition->add_strip(s, k.ranges, k.bad, k.bad_first);
    for (auto& range : k.ranges) range->close(y1);
    NonFiniteReport& n = bad[bands.of(y)];
    add_nonfinite(n, k.bad, k.bad_first, rows, s.y0, in.channels, *s.path);
    return !(stop && n.count);
  };
  cb.end = [&](int t, long b) {
    w[t]->acquisition->end();
    for (auto& range : w[t]->ranges) range->end();
    std::lock_guard<std::mutex> lock(progress_mutex);
    rows_done += bands.end(b) - bands.begin(b);
    if (progress) progress(double(rows_done) / std::max(1L, in.rows));
  };
  return read_grid(g, bands, first_band, cb, bad);
}

}  // namespace

namespace {

SpaceRequest space_request(long input_width, long input_height, int channels, long W, long H,
                           Method method, PrefilterMethod prefilter, Boundary boundary,
                           int threads) {
  SpaceRequest srq;
  srq.input_width = input_width;
  srq.input_height = input_height;
  srq.channels = channels;
  srq.width = W;
  srq.height = H;
  srq.method = method;
  srq.prefilter = prefilter;
  srq.boundary = boundary;
  srq.threads = threads;
  return srq;
}

// The frame's sides, the space's checks and the memory the projection
// needs (RequestError before anything is read).
std::uint64_t check_request(const Space& space, const SpaceRequest& srq, bool coefficient_file,
                            bool check_fit = true) {
  const long W = srq.width, H = srq.height;
  if (W < 1 || H < 1 || W > kMaxOutputSide || H > kMaxOutputSide) {
    std::ostringstream m;
    m << "an output of " << W << " x " << H << " pixels: each side from 1 to " << kMaxOutputSide;
    throw RequestError(m.str());
  }
  const SpaceBudget budget = visit_space(space, [&](const auto& s) {
    s.check(srq);
    return s.budget(srq);
  });
  const std::uint64_t bytes = projection_bytes(W, H, srq.channels, budget.coefficients, true,
                                               coefficient_file, srq.threads, budget.tables);
  if (check_fit)
    check_memory(bytes, "a " + std::to_string(W) + " x " + std::to_string(H) + " x " +
                          std::to_string(srq.channels) + " output");
  return bytes;
}

// The non-finite report's message, and the error it is unless replaced.
void report_nonfinite(NonFiniteReport& bad, const std::vector<std::string>& names, bool stop) {
  if (!bad.count) return;
  std::ostringstream m;
  m << bad.file << ": non-finite sample (NaN or Inf) at x " << bad.x << ", y " << bad.y
    << ", channel "
    << (bad.channel < int(names.size()) ? names[bad.channel] : std::to_string(bad.channel));
  bad.where = m.str();
  if (stop) throw InputError(bad.where + "; use --nonfinite zero to replace them with 0");
}

// The acquired sums to coefficients: described (the inputs' channels, the
// transfer decoded, the highlight compression), prefiltered, kept in float
// where asked, checked for overflow (project and merge).
Coefficients finish_coefficients(Coefficients k, const InputSet& in, const Transfer& transfer,
                                 bool highlight_compressed, PrefilterMethod method, int threads,
                                 bool float_coefficients, double* seconds) {
  k.channel_names = in.channel_names;
  k.alpha = in.alpha;
  k.highlight_compressed = highlight_compressed;
  k.input.label = in.label;
  k.input.half = in.half;
  k.input.transfer = transfer;
  const std::string& label = in.label;
  const std::vector<std::string>& names = in.channel_names;
  const auto t2 = Clock::now();
  prefilter(k, threads, method);
  *seconds = seconds_since(t2);
  // Coefficients are kept in float, as a coefficient file stores them, so
  // that evaluating a written coefficient file reproduces this run exactly.
  if (float_coefficients)
    parallel_for(long(k.c.data.size()), threads, [&](long q0, long q1) {
      for (long q = q0; q < q1; ++q) k.c.data[q] = static_cast<float>(k.c.data[q]);
    });
  // Finite samples near float's largest value can still overflow there.
  const long overflow = first_nonfinite(k.c.data.data(), k.c.data.size());
  if (overflow >= 0)
    throw InputError(label + ": the samples are too large: the coefficients pass float's "
                     "largest value (3.4e38) at coefficient " +
                     value_position(overflow, k.c.width, names) + "; nothing written");
  return k;
}

// The sample stages the request asks for on these inputs, and the transfer
// they decode.
SampleStages sample_stages(const ProjectionRequest& rq, const InputSet& in, Transfer* decoded) {
  const int C = in.channels;
  const int alpha = in.alpha;
  // Display-encoded samples (by default integer ones: PNG, JPEG, TIFF...,
  // default_transfer) are decoded to linear light first: the method filters
  // radiance, and an 8-bit output encodes again (a flat 128 stays 128).
  SampleStages stages;
  *decoded = rq.input_transfer ? *rq.input_transfer : in.transfer;
  if (decoded->kind != Transfer::Linear)
    stages.decode = [C, alpha, t = *decoded](float* v, std::size_t n, std::size_t k0) {
      decode_to_linear(t, v, n, C, alpha, k0);
    };
  if (rq.highlight_compress)
    stages.compress = [C, alpha](float* v, std::size_t n, std::size_t k0) {
      for (std::size_t q = 0; q < n; ++q)
        if (int((k0 + q) % C) != alpha) v[q] = static_cast<float>(highlight_compress(v[q]));
    };
  return stages;
}

// Reads the inputs (all the grid's bands, or the whole bands a partial's
// inputs hold) into the space's sink and a local range; then done(sink)
// while the sink lives.
template <typename Done>
void acquire_inputs(const ProjectionRequest& rq, const InputSet& in, const SpaceRequest& srq,
                    Projection& p, Transfer* decoded, const Done& done) {
  const SampleStages stages = sample_stages(rq, in, decoded);
  const bool stop = !rq.zero_nonfinite;
  const auto t = Clock::now();
  visit_space(rq.space, [&](const auto& space) {
    // The plan (the weights of every input row and column, some
    // milliseconds) is made while the first strips decode.
    const auto sink = space.sink(srq);
    p.local_range = std::make_unique<LocalRange>(in.width, in.height, in.channels, srq.width,
                                                 srq.height, sink->bands().band_rows());
    OneSink<typename std::decay_t<decltype(*sink)>> one{*sink};
    NonFiniteReport bad = acquire_in_bands(in, srq.threads, stages, one, {p.local_range.get()},
                                           stop, rq.progress, rq.interrupt);
    p.acquire_seconds = seconds_since(t);
    for (auto& r : p.inputs.readers) r->release();  // the decoders' buffers, before the later stages
    report_nonfinite(bad, in.channel_names, stop);
    p.nonfinite = bad;
    done(*sink);
  });
}

}  // namespace

Projection project(const ProjectionRequest& rq, InputSet inputs) {
  Projection p;
  p.inputs = std::move(inputs);
  const InputSet& in = p.inputs;
  if (in.coefficient_file)
    throw RequestError(in.bands.front().path +
                       " is a coefficient file: it is evaluated (load_coefficients), not projected");
  if (in.scattered_file)
    throw RequestError(in.bands.front().path +
                       " is a file of scattered samples: form() projects it (read_scattered, "
                       "project_scattered), not the grid's engine");
  const int threads = std::max(1, rq.threads);
  const SpaceRequest srq = space_request(in.width, in.height, in.channels, rq.width, rq.height,
                                         rq.method, rq.prefilter, rq.boundary, threads);
  p.estimated_bytes = check_request(rq.space, srq, rq.coefficient_file);
  Coefficients k;
  Transfer decoded;
  acquire_inputs(rq, in, srq, p, &decoded, [&](auto& sink) { k = sink.finish(); });
  p.coefficients = finish_coefficients(std::move(k), in, decoded, rq.highlight_compress, rq.prefilter,
                                       threads, rq.float_coefficients, &p.prefilter_seconds);
  return p;
}

Projection project(const ProjectionRequest& rq) { return project(rq, inspect(rq.inputs)); }

std::vector<Projection> project(const std::vector<ProjectionRequest>& requests) {
  if (requests.empty()) throw RequestError("project(): no target");
  const ProjectionRequest& rq = requests.front();
  for (std::size_t q = 1; q < requests.size(); ++q) {
    const ProjectionRequest& other = requests[q];
    const char* differs = !other.inputs.empty()                          ? "inputs"
                          : other.zero_nonfinite != rq.zero_nonfinite       ? "--nonfinite"
                          : other.highlight_compress != rq.highlight_compress ? "--highlight-compress"
                          : other.input_transfer != rq.input_transfer       ? "--input-transfer"
                                                                            : nullptr;
    if (differs)
      throw RequestError("target " + std::to_string(q + 1) + " of one reading gives its own " +
                         differs + ": the targets after the first share the first's inputs "
                         "and sample stages (leave their inputs empty)");
  }
  InputSet in = inspect(rq.inputs);
  if (in.coefficient_file)
    throw RequestError(in.bands.front().path +
                       " is a coefficient file: it is evaluated (load_coefficients), not projected");
  const int threads = std::max(1, rq.threads);
  const std::size_t N = requests.size();
  std::vector<SpaceRequest> srq;
  std::vector<Projection> p(N);
  std::uint64_t bytes = 0;
  for (std::size_t q = 0; q < N; ++q) {
    const ProjectionRequest& r = requests[q];
    srq.push_back(space_request(in.width, in.height, in.channels, r.width, r.height, r.method,
                                r.prefilter, r.boundary, threads));
    p[q].estimated_bytes = check_request(r.space, srq[q], r.coefficient_file, false);
    bytes += p[q].estimated_bytes;
  }
  check_memory(bytes, std::to_string(N) + " outputs of one reading");
  Transfer decoded;
  const SampleStages stages = sample_stages(rq, in, &decoded);
  // every target's sink, held while the reading feeds them all
  ManySinks many;
  std::vector<std::shared_ptr<void>> held(N);
  std::vector<std::function<Coefficients()>> finish(N);
  std::vector<LocalRange*> locals;
  for (std::size_t q = 0; q < N; ++q)
    visit_space(requests[q].space, [&](const auto& space) {
      std::shared_ptr<typename std::decay_t<decltype(space)>::Sink> sink = space.sink(srq[q]);
      many.add(*sink);
      finish[q] = [raw = sink.get()] { return raw->finish(); };
      held[q] = sink;
      p[q].local_range = std::make_unique<LocalRange>(in.width, in.height, in.channels,
                                                      srq[q].width, srq[q].height,
                                                      sink->bands().band_rows());
      locals.push_back(p[q].local_range.get());
    });
  const bool stop = !rq.zero_nonfinite;
  const auto t = Clock::now();
  NonFiniteReport bad =
      acquire_in_bands(in, threads, stages, many, locals, stop, rq.progress, rq.interrupt);
  const double acquire_seconds = seconds_since(t);
  for (auto& r : in.readers) r->release();
  report_nonfinite(bad, in.channel_names, stop);
  for (std::size_t q = 0; q < N; ++q) {
    const ProjectionRequest& r = requests[q];
    p[q].inputs = in;
    p[q].nonfinite = bad;
    p[q].acquire_seconds = acquire_seconds;
    Coefficients k = finish[q]();
    held[q].reset();
    p[q].coefficients = finish_coefficients(std::move(k), in, decoded, rq.highlight_compress,
                                            r.prefilter, threads, r.float_coefficients,
                                            &p[q].prefilter_seconds);
  }
  return p;
}

std::vector<long> band_cuts(long rows, long parts, long band_rows) {
  const BandPartition bands(rows, band_rows);
  if (rows < 1 || parts < 1 || parts > bands.count()) {
    std::ostringstream m;
    m << rows << " rows in " << parts << " parts of whole bands of " << bands.band_rows()
      << " rows: from 1 to " << bands.count() << " parts";
    throw RequestError(m.str());
  }
  std::vector<long> cuts;
  for (long t = 0; t < parts; ++t) cuts.push_back(bands.begin(t * bands.count() / parts));
  cuts.push_back(rows);
  return cuts;
}

Partial project_partial(const ProjectionRequest& rq) {
  return project_partial(rq, inspect(rq.inputs, true));
}

Partial project_partial(const ProjectionRequest& rq, InputSet inputs) {
  Projection p;
  p.inputs = std::move(inputs);
  const InputSet& in = p.inputs;
  if (in.coefficient_file)
    throw RequestError(in.bands.front().path + " is a coefficient file: it has no partial");
  const int threads = std::max(1, rq.threads);
  const SpaceRequest srq = space_request(in.width, in.height, in.channels, rq.width, rq.height,
                                         rq.method, rq.prefilter, rq.boundary, threads);
  p.estimated_bytes = check_request(rq.space, srq, false);
  // whole bands of the sinks' partition (kBandRows), checked before reading
  const long y0 = in.first_row, y1 = in.first_row + in.rows;
  if (y0 % kBandRows != 0 || (y1 != in.height && y1 % kBandRows != 0)) {
    std::ostringstream m;
    m << in.label << ": rows " << y0 << " to " << y1 - 1 << " of " << in.height
      << " are not whole bands of " << kBandRows << " rows; a partial's rows start at a multiple of "
      << kBandRows << " and end at one or at the grid's end (siproject --band-cuts)";
    throw RequestError(m.str());
  }
  Partial out;
  out.space = rq.space;
  acquire_inputs(rq, in, srq, p, &out.transfer, [&](auto& sink) {
    const BandPartition& bands = sink.bands();
    if (bands.band_rows() != std::min(kBandRows, std::max(1L, in.height)))
      throw std::logic_error("project_partial(): a sink's bands are not of kBandRows");
    out.band_rows = bands.band_rows();
    out.band_count = bands.count();
    out.acquisition = sink.partial(&out.bands);
  });
  std::vector<long> range_bands;
  out.range = p.local_range->partial(&range_bands);
  if (range_bands != out.bands) throw std::logic_error("project_partial(): the range's bands differ");
  out.input_width = in.width;
  out.input_height = in.height;
  out.width = rq.width;
  out.height = rq.height;
  out.channel_names = in.channel_names;
  out.alpha = in.alpha;
  out.method = rq.method;
  out.boundary = rq.boundary;
  out.prefilter = rq.prefilter;
  out.highlight_compressed = rq.highlight_compress;
  out.zero_nonfinite = rq.zero_nonfinite;
  out.integer_bits = in.integer_bits;
  out.half = in.half;
  out.label = in.label;
  out.nonfinite = p.nonfinite;
  return out;
}

namespace {
std::string band_span(const std::vector<long>& bands) {
  if (bands.empty()) return "no bands";
  return bands.size() == 1 ? "band " + std::to_string(bands.front())
                           : "bands " + std::to_string(bands.front()) + " to " +
                                 std::to_string(bands.back());
}
}  // namespace

Projection merge(const std::vector<Partial>& parts, int threads, bool float_coefficients) {
  if (parts.empty()) throw RequestError("merge: no partial");
  threads = std::max(1, threads);
  const Partial& first = parts.front();
  const Metadata key = partial_request(first);
  std::vector<long> owner(std::size_t(std::max(0L, first.band_count)), -1);
  for (std::size_t q = 0; q < parts.size(); ++q) {
    const Partial& part = parts[q];
    const Metadata other = partial_request(part);
    for (std::size_t k = 0; k < key.size(); ++k)
      if (k >= other.size() || other[k] != key[k])
        throw RequestError(part.label + ": a partial of another request than " + first.label +
                           "'s (" + key[k].first + " " +
                           (k < other.size() ? other[k].second : "missing") + ", not " +
                           key[k].second + "); partials merge only with the same input size, "
                           "output size and options");
    for (long b : part.bands) {
      if (b < 0 || b >= first.band_count)
        throw RequestError(part.label + ": band " + std::to_string(b) + " out of range");
      if (owner[b] >= 0)
        throw RequestError(part.label + " and " + parts[owner[b]].label + " both hold band " +
                           std::to_string(b) + " (rows from " + std::to_string(b * first.band_rows) +
                           "): partials that overlap");
      owner[b] = long(q);
    }
  }
  for (long b = 0; b < first.band_count; ++b)
    if (owner[b] < 0) {
      std::ostringstream m;
      m << "merge: no partial holds band " << b << " (rows " << b * first.band_rows << " to "
        << std::min(first.input_height, (b + 1) * first.band_rows) - 1 << " of "
        << first.input_height << "): a gap; a merge takes the partials of every band";
      throw RequestError(m.str());
    }
  const SpaceRequest srq =
      space_request(first.input_width, first.input_height, int(first.channel_names.size()),
                    first.width, first.height, first.method, first.prefilter, first.boundary,
                    threads);
  Projection p;
  p.estimated_bytes = check_request(first.space, srq, false);
  InputSet& in = p.inputs;
  in.width = first.input_width;
  in.height = first.input_height;
  in.rows = first.input_height;
  in.channels = srq.channels;
  in.channel_names = first.channel_names;
  in.alpha = first.alpha;
  in.half = std::all_of(parts.begin(), parts.end(), [](const Partial& q) { return q.half; });
  in.transfer = first.transfer;
  in.srgb = first.transfer.kind == Transfer::SRGB;
  in.integer_bits = first.integer_bits;
  for (const Partial& q : parts) in.integer_bits = q.integer_bits ? std::max(in.integer_bits, q.integer_bits) : 0;
  in.label = first.label + (parts.size() > 1 ? " and " + std::to_string(parts.size() - 1) + " more partials" : "");
  // the non-finite report: the first in band order, the count of all
  long nonfinite = 0;
  for (long b = 0; b < first.band_count; ++b) {
    const Partial& q = parts[owner[b]];
    if (q.bands.front() != b) continue;  // each partial once, at its first band
    if (q.nonfinite.count && nonfinite == 0) p.nonfinite = q.nonfinite;
    nonfinite += q.nonfinite.count;
  }
  p.nonfinite.count = nonfinite;
  const auto t = Clock::now();
  Coefficients k;
  visit_space(first.space, [&](const auto& space) {
    const auto sink = space.sink(srq);
    if (sink->bands().band_rows() != first.band_rows || sink->bands().count() != first.band_count)
      throw RequestError(first.label + ": partial of bands of " + std::to_string(first.band_rows) +
                         " rows, not this build's " + std::to_string(sink->bands().band_rows()));
    p.local_range = std::make_unique<LocalRange>(in.width, in.height, in.channels, srq.width,
                                                 srq.height, first.band_rows);
    for (const Partial& q : parts) {
      try {
        sink->absorb(q.acquisition, q.bands);
        p.local_range->absorb(q.range, q.bands);
      } catch (const std::invalid_argument& e) {
        throw InputError(q.label + ": not a whole partial of " + band_span(q.bands) + " (" +
                         e.what() + ")");
      }
    }
    k = sink->finish();
  });
  p.acquire_seconds = seconds_since(t);
  p.coefficients = finish_coefficients(std::move(k), in, first.transfer, first.highlight_compressed,
                                       first.prefilter, threads, float_coefficients,
                                       &p.prefilter_seconds);
  return p;
}

Coefficients load_coefficients(const std::string& path, bool zero_nonfinite,
                               NonFiniteReport* replaced, const FileSignature& expected,
                               int level) {
  ImageReader file(path, expected);
  file.select_level(level);
  const std::uint64_t stored = std::uint64_t(file.width()) * std::uint64_t(file.height());
  check_memory(projection_bytes(0, 0, file.channels(), stored + stored / 2, false, false, 1),
               "a coefficient grid of " + std::to_string(file.width()) + " x " +
                   std::to_string(file.height()) + " x " + std::to_string(file.channels()));
  Coefficients k = read_coefficients(file);
  k.input.label = path;  // messages name the file the user gave
  const long bad = first_nonfinite(k.c.data.data(), k.c.data.size());
  if (bad >= 0) {
    NonFiniteReport n;
    const std::vector<std::string> names = file.channel_names();
    n.where = path + ": non-finite coefficient (NaN or Inf) at " + value_position(bad, k.c.width, names);
    if (!zero_nonfinite) throw InputError(n.where + "; use --nonfinite zero to replace them with 0");
    for (double& v : k.c.data)
      if (!std::isfinite(v)) v = 0, ++n.count;
    n.file = path;
    if (replaced) *replaced = n;
  }
  return k;
}

FinalImage final_image(const Coefficients& k, const Display& display, long W, long H, Clamp clamp,
                       const LocalRange* local, int threads) {
  const std::vector<std::string> names =
      k.channel_names.empty() ? default_channel_names(k.c.channels) : k.channel_names;
  const int alpha = k.alpha;
  const std::string label = k.input.label.empty() ? "the coefficients" : k.input.label;
  FinalImage f;
  f.image = sis::final_image(k, display, W, H, threads);
  Image& image = f.image;
  const int C = image.channels;
  if (k.highlight_compressed)
    for (std::size_t q = 0; q < image.data.size(); ++q)
      if (int(q % C) != alpha) image.data[q] = static_cast<float>(highlight_expand(image.data[q]));
  f.own_range = local && local->min().width == W && local->min().height == H;
  f.before = report_range(image, f.own_range ? local : nullptr, threads);
  apply_clamp(image, clamp, local);
  f.after = clamp == Clamp::None ? f.before : report_range(image, nullptr, threads);
  // Never a non-finite pixel from finite coefficients without saying so:
  // resampling or the highlight expansion can pass float's range.
  const long bad = first_nonfinite(image.data.data(), image.data.size());
  if (bad >= 0)
    throw InputError(label + ": the final image passes float's range at " +
                     value_position(bad, W, names) +
                     "; nothing written");
  return f;
}

}  // namespace sis
