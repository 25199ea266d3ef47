// Scattered samples from arrays and from files with position channels
// (sis/scattered_input.h).
#include "sis/scattered_input.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <thread>

#include "sis/engine.h"

namespace fs = std::filesystem;

namespace sis {

using OIIO::TypeDesc;

std::string ScatteredInput::sample_name(long i) const {
  if (grid_width <= 0) return "row " + std::to_string(i);
  return "pixel (" + std::to_string(grid_x + i % grid_width) + ", " +
         std::to_string(grid_y + i / grid_width) + ")";
}

ScatteredInput scattered_input(const SampleView& values, const double* positions,
                               const double* weights, const std::optional<Transfer>& transfer) {
  if (values.height != 1 && values.width > 0)
    throw std::logic_error("scattered_input(): the values are not one row of samples");
  const long n = values.width;
  const int C = values.channels;
  ScatteredInput in;
  in.half = values.is_half();
  in.integer_bits = values.type == SampleType::UInt8 ? 8 : values.type == SampleType::UInt16 ? 16 : 0;
  in.transfer = transfer ? *transfer : default_transfer(values.is_integer(), "");
  in.channel_names = default_channel_names(C);
  ScatteredSamples& s = in.samples;
  s.channels = C;
  s.positions.assign(positions, positions + 2 * std::size_t(n));
  if (weights) s.weights.assign(weights, weights + n);
  s.values.resize(std::size_t(n) * C);
  // a chunk at a time: converted to float as a file's samples are, decoded, widened
  constexpr long kChunk = 4096;
  std::vector<float> f(std::size_t(std::min(n, kChunk)) * C);
  const TypeDesc from = values.type == SampleType::UInt8    ? TypeDesc::UINT8
                        : values.type == SampleType::UInt16 ? TypeDesc::UINT16
                        : values.type == SampleType::Half   ? TypeDesc::HALF
                                                            : TypeDesc::FLOAT;
  for (long i0 = 0; i0 < n; i0 += kChunk) {
    const long i1 = std::min(n, i0 + kChunk);
    const std::size_t m = std::size_t(i1 - i0) * C;
    const unsigned char* src = values.row(0) + std::size_t(i0) * C * values.value_bytes();
    if (!OIIO::convert_pixel_values(from, src, TypeDesc::FLOAT, f.data(), int(m)))
      throw std::logic_error("scattered_input(): the values were not converted");
    decode_to_linear(in.transfer, f.data(), m, C, -1);
    std::copy(f.begin(), f.begin() + m, s.values.begin() + std::size_t(i0) * C);
  }
  return in;
}

bool is_scattered_file(const ImageReader& reader) {
  for (const std::string& n : reader.channel_names())
    if (n == kPositionChannelX || n == kPositionChannelY) return true;
  return has_pattern_metadata(reader);
}

ScatteredLayout scattered_layout(const ImageReader& r) {
  ScatteredLayout l;
  const std::vector<std::string> names = r.channel_names();
  for (int c = 0; c < int(names.size()); ++c) {
    if (names[c] == kPositionChannelX) l.x = c;
    else if (names[c] == kPositionChannelY) l.y = c;
    else if (names[c] == kWeightChannel) l.weight = c;
    else {
      if (c == r.alpha_channel()) l.alpha = int(l.values.size());
      l.values.push_back(c);
      l.names.push_back(names[c]);
    }
  }
  const std::string& path = r.path();
  if (has_pattern_metadata(r)) {
    if (l.x >= 0 || l.y >= 0)
      throw InputError(path + ": has both a position channel (" +
                       (l.x >= 0 ? kPositionChannelX : kPositionChannelY) + ") and a sample pattern (" +
                       kPatternKey + "): the positions are one or the other");
    l.pattern = read_pattern_metadata(r);
  } else if (l.x < 0 || l.y < 0)
    throw InputError(path + ": has the position channel " +
                     (l.x < 0 ? kPositionChannelY : kPositionChannelX) + " but not " +
                     (l.x < 0 ? kPositionChannelX : kPositionChannelY) +
                     " (a file of scattered samples has both: each sample's x and y in output "
                     "pixels)");
  for (int c : {l.x, l.y, l.weight}) {
    if (c < 0) continue;
    const std::string t = r.channel_type(c);
    if (t != "half" && t != "float" && t != "double")
      throw InputError(path + ": channel " + names[c] + " is stored as " + t +
                       "; positions and weights are float or half");
  }
  for (int c : l.values) {
    const std::string t = r.channel_type(c);
    const int b = t == "uint8" ? 8 : t == "uint16" ? 16 : t == "uint" || t == "uint32" ? 32 : 0;
    if (!b) {
      l.integer_bits = 0;
      break;
    }
    l.integer_bits = std::max(l.integer_bits, b);
  }
  if (l.values.empty())
    throw InputError(path + ": no value channel beside " + kPositionChannelX + ", " +
                     kPositionChannelY + (l.weight >= 0 ? std::string(" and ") + kWeightChannel : "") +
                     " (scattered samples need a value)");
  return l;
}

ScatteredInput read_scattered(const std::string& path, const std::optional<Transfer>& transfer,
                              const FileSignature& expected) {
  ImageReader r(path, expected);
  const ScatteredLayout l = scattered_layout(r);
  const long w = r.width(), h = r.height();
  const int all = r.channels(), C = int(l.values.size());
  const std::uint64_t n = std::uint64_t(w) * std::uint64_t(h);
  // the samples as doubles (positions, values, weights) and a strip of the file's rows
  check_memory(n * std::uint64_t(8 * (2 + C + (l.weight >= 0))),
               path + "'s " + std::to_string(n) + " scattered samples");
  ScatteredInput in;
  in.label = fs::path(path).filename().string();
  in.channel_names = l.names;
  in.alpha = l.alpha;
  in.positions_name = l.pattern ? path + ": its pattern " + pattern_name(l.pattern->kind)
                               : path + ": " + kPositionChannelX + ", " + kPositionChannelY;
  in.pattern = l.pattern;
  in.values_name = path;
  in.weights_name = path + ": " + kWeightChannel;
  in.grid_width = w;
  in.grid_x = r.data_x();
  in.grid_y = r.data_y();
  in.transfer = transfer ? *transfer : r.transfer();
  in.half = r.stores_half();
  in.integer_bits = l.integer_bits;
  ScatteredSamples& s = in.samples;
  s.channels = C;
  s.positions.resize(2 * n);
  if (l.pattern) sample_positions(*l.pattern, 0, long(n), s.positions.data(),
                                    int(std::max(1u, std::thread::hardware_concurrency())));
  s.values.resize(n * C);
  if (l.weight >= 0) s.weights.resize(n);
  const long strip = std::max(1L, r.preferred_strip());
  std::vector<float> rows(std::size_t(std::min(strip, h)) * w * all), v(std::size_t(w) * C);
  for (long y0 = 0; y0 < h; y0 += strip) {
    const long y1 = std::min(h, y0 + strip);
    r.read_rows(y0, y1, rows.data());
    for (long y = y0; y < y1; ++y) {
      const float* p = rows.data() + std::size_t(y - y0) * w * all;
      const std::size_t i0 = std::size_t(y) * w;
      for (long x = 0; x < w; ++x) {
        const float* q = p + std::size_t(x) * all;
        if (!l.pattern) {
          s.positions[2 * (i0 + x)] = q[l.x];
          s.positions[2 * (i0 + x) + 1] = q[l.y];
        }
        if (l.weight >= 0) s.weights[i0 + x] = q[l.weight];
        for (int c = 0; c < C; ++c) v[std::size_t(x) * C + c] = q[l.values[c]];
      }
      decode_to_linear(in.transfer, v.data(), v.size(), C, in.alpha);
      std::copy(v.begin(), v.end(), s.values.begin() + i0 * C);
    }
  }
  return in;
}

void add_refinement(ScatteredInput& base, const std::string& path, const std::optional<Transfer>& transfer) {
  ImageReader r(path);
  const std::string text = r.attribute(kRefinementKey);
  if (text.empty())
    throw InputError(path + ": no " + kRefinementKey +
                     " attribute: not the second pass of an adaptive render (sirays assemble --refinement)");
  Refinement ref;
  try {
    ref = parse_refinement(text, path + ": " + kRefinementKey);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  if (!base.pattern)
    throw InputError(path + ": refines a sobol render, and " + base.label +
                     " names no sample pattern (a render of make SAMPLES=sobol, sirays assemble)");
  const SamplePattern& p = *base.pattern;
  if (p.kind != ref.base.kind || p.seed != ref.base.seed || p.width != ref.base.width ||
      p.height != ref.base.height || p.factor != ref.base.factor)
    throw InputError(path + ": refines pattern " + pattern_name(ref.base.kind) + " seed " +
                     std::to_string(ref.base.seed) + " frame " + std::to_string(ref.base.width) + "x" +
                     std::to_string(ref.base.height) + " factor " + metadata_number(ref.base.factor) + "; " +
                     base.label + " is " + pattern_name(p.kind) + " seed " + std::to_string(p.seed) +
                     " frame " + std::to_string(p.width) + "x" + std::to_string(p.height) + " factor " +
                     metadata_number(p.factor));
  const long m = ref.extra_count();
  if (m == 0) {  // nothing refined: the base's samples as they are
    base.label += " + " + fs::path(path).filename().string();
    return;
  }
  if (r.channel_names() != base.channel_names)
    throw InputError(path + ": its channels are not " + base.label + "'s");
  const long w = r.width(), h = r.height();
  if (std::uint64_t(w) * std::uint64_t(h) < std::uint64_t(m))
    throw InputError(path + ": " + std::to_string(w * h) + " pixels for the refinement's " +
                     std::to_string(m) + " extra rays");
  const int C = r.channels();
  std::vector<float> rows(std::size_t(w) * h * C);
  r.read_rows(0, h, rows.data());
  rows.resize(std::size_t(m) * C);
  const Transfer t = transfer ? *transfer : r.transfer();
  decode_to_linear(t, rows.data(), rows.size(), C, base.alpha);
  for (std::size_t q = 0; q < rows.size(); ++q)
    if (!std::isfinite(rows[q])) {
      const long i = long(q / std::size_t(C));
      throw InputError(path + ": extra ray " + std::to_string(i) + " (pixel " + std::to_string(i % w) + ", " +
                       std::to_string(i / w) + ") holds a non-finite value");
    }
  const std::vector<double> v(rows.begin(), rows.end());
  try {
    base.samples = adaptive_samples(std::move(base.samples), ref, v);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + e.what());
  }
  base.label += " + " + fs::path(path).filename().string();
}

RefinedPlan refine_render(const std::string& path, double budget, std::optional<long> rays,
                          std::optional<double> share, long tile, Estimator estimator, int threads) {
  if (tile < 1) throw std::invalid_argument("a tile of " + std::to_string(tile) + " pixels: expected >= 1");
  ScatteredInput in = read_scattered(path, std::nullopt);
  if (!in.pattern || in.pattern->kind != PatternKind::Sobol)
    throw InputError(path + ": " +
                     (in.pattern ? std::string("a ") + pattern_name(in.pattern->kind) + " render"
                                 : std::string("names no sample pattern")) +
                     ": refinement adds sobol points to a sobol render's pixels (make SAMPLES=sobol)");
  const SamplePattern& pat = *in.pattern;
  try {
    make_refinement(pat, tile, pat.count() / (pat.width * pat.height) + 1, {});
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + e.what());
  }
  ScatteredTarget t;
  t.width = double(pat.width);
  t.height = double(pat.height);
  ScatteredOptions so;
  so.threads = threads;
  RefinedPlan plan;
  try {
    const Coefficients k = project_scattered(in.samples, t, so);
    plan.estimate = estimate_tile_error(in.samples, k, t, so, estimator, tile);
  } catch (const std::invalid_argument& x) {
    throw InputError(path + ": " + x.what());
  }
  plan.refinement = plan_refinement(pat, plan.estimate, tile, budget, rays, share);
  return plan;
}

}  // namespace sis
