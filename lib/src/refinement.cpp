// Adaptive rays (sis/refinement.h, docs/design.md section 17).
#include "sis/refinement.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "sis/imageio.h"

namespace sis {

namespace {

long pixel_of(double v, long side) {
  const long p = long(std::floor(v));
  return std::clamp(p, 0L, side - 1);
}

long tile_of(const TileGrid& g, double x, double y) {
  return (pixel_of(y, g.height) / g.tile) * g.columns() + pixel_of(x, g.width) / g.tile;
}

void check_frame(const ScatteredTarget& target, const Coefficients& k, long tile) {
  if (tile < 1) throw std::invalid_argument("a tile of " + std::to_string(tile) + " pixels: expected >= 1");
  if (!(target.width >= 1) || !(target.height >= 1) || target.width != std::floor(target.width) ||
      target.height != std::floor(target.height))
    throw std::invalid_argument("the frame must be whole pixels, at least 1 x 1");
  if (k.image_width != target.width || k.image_height != target.height)
    throw std::invalid_argument("the coefficients' frame is not the target's");
  if (!std::holds_alternative<CartesianSpace>(target.space))
    throw std::invalid_argument("the estimators take the Cartesian space");
}

// The samples of one parity of their index, each weighing twice its own.
ScatteredSamples half(const ScatteredSamples& s, int parity, double area) {
  ScatteredSamples h;
  h.channels = s.channels;
  const long n = s.count();
  const long m = (n - parity + 1) / 2;
  h.positions.reserve(std::size_t(2 * m));
  h.values.reserve(std::size_t(m) * s.channels);
  h.weights.reserve(std::size_t(m));
  for (long i = parity; i < n; i += 2) {
    h.positions.push_back(s.positions[2 * i]);
    h.positions.push_back(s.positions[2 * i + 1]);
    for (int c = 0; c < s.channels; ++c) h.values.push_back(s.values[std::size_t(i) * s.channels + c]);
    h.weights.push_back(s.weights.empty() ? 2 * area / double(n) : 2 * s.weights[std::size_t(i)]);
  }
  return h;
}

}  // namespace

const char* estimator_name(Estimator e) {
  switch (e) {
    case Estimator::Halves: return "halves";
    case Estimator::Contrast: return "contrast";
    case Estimator::Residual: return "residual";
    case Estimator::HighPass: return "highpass";
  }
  return "?";
}

Estimator parse_estimator(const std::string& s) {
  for (Estimator e : {Estimator::Halves, Estimator::Contrast, Estimator::Residual, Estimator::HighPass})
    if (s == estimator_name(e)) return e;
  throw std::invalid_argument("unknown estimator '" + s + "'; known: halves, contrast, residual, highpass");
}

long TileGrid::pixels(long t) const {
  const long tx = t % columns(), ty = t / columns();
  return (std::min(width, (tx + 1) * tile) - tx * tile) * (std::min(height, (ty + 1) * tile) - ty * tile);
}

std::vector<double> estimate_tile_error(const ScatteredSamples& samples, const Coefficients& k,
                                        const ScatteredTarget& target, const ScatteredOptions& options,
                                        Estimator estimator, long tile) {
  check_frame(target, k, tile);
  const TileGrid g{long(target.width), long(target.height), tile};
  std::vector<double> est(std::size_t(g.count()), 0.0);
  const int C = samples.channels;
  const long n = samples.count();
  if (n < 1) throw std::invalid_argument("no sample");
  switch (estimator) {
    case Estimator::Contrast: {
      const long P = g.width * g.height;
      std::vector<double> lo(std::size_t(P) * C, HUGE_VAL), hi(std::size_t(P) * C, -HUGE_VAL);
      for (long i = 0; i < n; ++i) {
        const long p = pixel_of(samples.positions[2 * i + 1], g.height) * g.width +
                       pixel_of(samples.positions[2 * i], g.width);
        for (int c = 0; c < C; ++c) {
          const double v = samples.values[std::size_t(i) * C + c];
          lo[std::size_t(p) * C + c] = std::min(lo[std::size_t(p) * C + c], v);
          hi[std::size_t(p) * C + c] = std::max(hi[std::size_t(p) * C + c], v);
        }
      }
      for (long p = 0; p < P; ++p) {
        const long t = ((p / g.width) / tile) * g.columns() + (p % g.width) / tile;
        for (int c = 0; c < C; ++c) {
          const double d = hi[std::size_t(p) * C + c] - lo[std::size_t(p) * C + c];
          if (d > 0) est[std::size_t(t)] += d * d;
        }
      }
      break;
    }
    case Estimator::Residual: {
      const std::vector<double> f = evaluate_at_samples(k, samples, options.threads);
      const double w0 = target.width * target.height / double(n);
      for (long i = 0; i < n; ++i) {
        const double w = samples.weights.empty() ? w0 : samples.weights[std::size_t(i)];
        double e = 0;
        for (int c = 0; c < C; ++c) {
          const double d = samples.values[std::size_t(i) * C + c] - f[std::size_t(i) * C + c];
          e += d * d;
        }
        est[std::size_t(tile_of(g, samples.positions[2 * i], samples.positions[2 * i + 1]))] += w * e;
      }
      break;
    }
    case Estimator::HighPass: {
      const Grid<double>& c = k.c;
      auto at = [&](long x, long y, int ch) {
        x = std::clamp(x, 0L, c.width - 1);
        y = std::clamp(y, 0L, c.height - 1);
        return c.data[(std::size_t(y) * c.width + x) * c.channels + ch];
      };
      const double b[3] = {0.25, 0.5, 0.25};
      for (long y = 0; y < c.height; ++y)
        for (long x = 0; x < c.width; ++x) {
          // the coefficient's centre (x + 1/2) h in the frame
          const double px = (double(x) + 0.5) * target.width / double(c.width);
          const double py = (double(y) + 0.5) * target.height / double(c.height);
          double e = 0;
          for (int ch = 0; ch < c.channels; ++ch) {
            double s = 0;
            for (int j = -1; j <= 1; ++j)
              for (int i = -1; i <= 1; ++i) s += b[j + 1] * b[i + 1] * at(x + i, y + j, ch);
            const double d = at(x, y, ch) - s;
            e += d * d;
          }
          est[std::size_t(tile_of(g, px, py))] += e;
        }
      break;
    }
    case Estimator::Halves: {
      const double area = target.width * target.height;
      const Coefficients ka = project_scattered(half(samples, 0, area), target, options);
      const Coefficients kb = project_scattered(half(samples, 1, area), target, options);
      // the difference on 4 x 4 points a pixel, each standing for 1/16 pixel^2
      constexpr int s = 4;
      ScatteredSamples pts;
      pts.channels = C;
      pts.positions.resize(std::size_t(2 * g.width * g.height * s * s));
      std::size_t q = 0;
      for (long y = 0; y < g.height * s; ++y)
        for (long x = 0; x < g.width * s; ++x) {
          pts.positions[q++] = (double(x) + 0.5) / s;
          pts.positions[q++] = (double(y) + 0.5) / s;
        }
      pts.values.assign(std::size_t(pts.count()) * C, 0.0);
      const std::vector<double> fa = evaluate_at_samples(ka, pts, options.threads);
      const std::vector<double> fb = evaluate_at_samples(kb, pts, options.threads);
      for (long i = 0; i < pts.count(); ++i) {
        double e = 0;
        for (int c = 0; c < C; ++c) {
          const double d = fa[std::size_t(i) * C + c] - fb[std::size_t(i) * C + c];
          e += d * d;
        }
        est[std::size_t(tile_of(g, pts.positions[2 * i], pts.positions[2 * i + 1]))] += e / (s * s);
      }
      break;
    }
  }
  return est;
}

long Refinement::base_rays() const { return base.count() / (base.width * base.height); }

long Refinement::extra_count() const {
  const TileGrid g = grid();
  long n = 0;
  for (long t : tiles) n += g.pixels(t);
  return n * (rays - base_rays());
}

double Refinement::rays_per_pixel() const {
  return double(base.count() + extra_count()) / double(base.width * base.height);
}

Refinement make_refinement(const SamplePattern& base, long tile, long rays, std::vector<long> tiles) {
  if (base.kind != PatternKind::Sobol)
    throw std::invalid_argument(std::string("the base pattern is ") + pattern_name(base.kind) +
                                "; refinement adds sobol points to a sobol render's pixels");
  const long P = base.width * base.height;
  if (P < 1 || base.count() % P != 0)
    throw std::invalid_argument("the base's " + std::to_string(base.count()) + " rays over " +
                                std::to_string(base.width) + " x " + std::to_string(base.height) +
                                " pixels: refinement needs the same whole number of rays in every "
                                "pixel (a whole factor)");
  if (tile < 1) throw std::invalid_argument("a tile of " + std::to_string(tile) + " pixels: expected >= 1");
  Refinement r;
  r.base = base;
  r.tile = tile;
  r.rays = rays;
  const long b = r.base_rays();
  if (rays <= b || rays > (1L << 20))
    throw std::invalid_argument("refined tiles of " + std::to_string(rays) +
                                " rays per pixel: expected more than the base's " + std::to_string(b) +
                                " and at most 2^20");
  const TileGrid g = r.grid();
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    if (tiles[i] < 0 || tiles[i] >= g.count())
      throw std::invalid_argument("tile " + std::to_string(tiles[i]) + " lies outside the frame: " +
                                  std::to_string(g.width) + " x " + std::to_string(g.height) +
                                  " pixels make " + std::to_string(g.columns()) + " x " +
                                  std::to_string(g.rows()) + " tiles of " + std::to_string(tile) +
                                  " (indices 0 to " + std::to_string(g.count() - 1) + ")");
    if (i && tiles[i] <= tiles[i - 1])
      throw std::invalid_argument("tile " + std::to_string(tiles[i]) + " after tile " +
                                  std::to_string(tiles[i - 1]) + ": the tiles must increase, each once");
  }
  r.tiles = std::move(tiles);
  return r;
}

Refinement plan_refinement(const SamplePattern& base, const std::vector<double>& estimate, long tile,
                           double budget, std::optional<long> rays, std::optional<double> share) {
  Refinement r = make_refinement(base, tile, base.count() / (base.width * base.height) + 1, {});
  const long b = r.base_rays();
  if (!std::isfinite(budget) || budget < double(b))
    throw std::invalid_argument("a budget of " + metadata_number(budget) +
                                " rays per pixel is below the base pattern's " + std::to_string(b) +
                                " (the first pass alone spends that)");
  if (rays && share) throw std::invalid_argument("give the refined tiles' rays or their share, not both");
  if (share && !(*share > 0 && *share <= 1))
    throw std::invalid_argument("a share of " + metadata_number(*share) + ": expected (0, 1]");
  const TileGrid g = r.grid();
  if (long(estimate.size()) != g.count())
    throw std::invalid_argument(std::to_string(estimate.size()) + " tile estimates for " +
                                std::to_string(g.count()) + " tiles");
  for (double e : estimate)
    if (!std::isfinite(e)) throw std::invalid_argument("a tile estimate is not finite");
  std::vector<long> order(estimate.size());
  std::iota(order.begin(), order.end(), 0L);
  std::stable_sort(order.begin(), order.end(),
                   [&](long a, long c) { return estimate[std::size_t(a)] > estimate[std::size_t(c)]; });
  // both passes' rays within budget x pixels (whole rays)
  const double P = double(base.width * base.height);
  const long allowed = long(std::floor(budget * P + 1e-6)) - base.count();
  // the tiles by decreasing estimate while they fit; the estimate they leave
  // under the model that a tile's error falls as 1 / its rays
  auto choose = [&](long fine, double* left) {
    long used = 0;
    double removed = 0;
    std::vector<long> chosen;
    for (long t : order) {
      const long add = g.pixels(t) * (fine - b);
      if (used + add > allowed) break;
      used += add;
      removed += estimate[std::size_t(t)] * (1 - double(b) / double(fine));
      chosen.push_back(t);
    }
    if (left) *left = -removed;
    std::sort(chosen.begin(), chosen.end());
    return chosen;
  };
  long fine;
  if (rays) {
    fine = *rays;
  } else if (share) {
    fine = b + long(std::floor((budget - double(b)) / *share + 1e-9));
  } else {
    // the refined rays that leave the least estimated error, from b + 1 to
    // max(64, budget) (ties: the fewer rays)
    const long top = std::max(64L, long(std::floor(budget)));
    fine = b + 1;
    double best = HUGE_VAL;
    for (long f = b + 1; f <= top; ++f) {
      double left = 0;
      choose(f, &left);
      if (left < best) best = left, fine = f;
    }
  }
  if (fine <= b) fine = b + 1;
  r = make_refinement(base, tile, fine, {});
  r.tiles = choose(fine, nullptr);
  return r;
}

std::string refinement_text(const Refinement& r) {
  std::ostringstream o;
  o << "sis-refinement 1\npattern " << pattern_name(r.base.kind) << "\nseed " << r.base.seed << "\nframe "
    << r.base.width << "x" << r.base.height << "\nfactor " << metadata_number(r.base.factor) << "\ntile "
    << r.tile << "\nrays " << r.rays << "\ntiles " << r.tiles.size() << "\n";
  for (std::size_t i = 0; i < r.tiles.size(); ++i)
    o << r.tiles[i] << ((i % 16 == 15 || i + 1 == r.tiles.size()) ? "\n" : " ");
  return o.str();
}

Refinement parse_refinement(const std::string& text, const std::string& label) {
  std::istringstream in(text);
  std::string line;
  int number = 0;
  auto next = [&](const std::string& key) {
    while (std::getline(in, line)) {
      ++number;
      if (!line.empty()) break;
    }
    std::istringstream l(line);
    std::string k, v, rest;
    if (!(l >> k >> v) || k != key || (l >> rest))
      throw std::invalid_argument(label + ": line " + std::to_string(number) + ": expected '" + key +
                                  " VALUE', found '" + line + "'");
    return v;
  };
  auto whole = [&](const std::string& key, const std::string& v) {
    std::size_t used = 0;
    long x = -1;
    try {
      x = std::stol(v, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != v.size() || x < 0)
      throw std::invalid_argument(label + ": line " + std::to_string(number) + ": " + key + " '" + v +
                                  "': expected a whole number >= 0");
    return x;
  };
  if (next("sis-refinement") != "1")
    throw std::invalid_argument(label + ": line 1: expected 'sis-refinement 1' (version 1)");
  PatternKind kind;
  try {
    kind = parse_pattern(next("pattern"));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(label + ": line " + std::to_string(number) + ": " + e.what());
  }
  const long seed = whole("seed", next("seed"));
  const std::string frame = next("frame");
  const auto xpos = frame.find('x');
  if (xpos == std::string::npos)
    throw std::invalid_argument(label + ": line " + std::to_string(number) + ": frame '" + frame +
                                "': expected WxH");
  const long w = whole("frame", frame.substr(0, xpos)), h = whole("frame", frame.substr(xpos + 1));
  const std::string fs = next("factor");
  double factor = 0;
  try {
    std::size_t used = 0;
    factor = std::stod(fs, &used);
    if (used != fs.size()) factor = 0;
  } catch (const std::exception&) {
    factor = 0;
  }
  const long fline = number;
  const long tile = whole("tile", next("tile"));
  const long rays = whole("rays", next("rays"));
  const long count = whole("tiles", next("tiles"));
  std::vector<long> tiles;
  std::string tok;
  while (in >> tok) tiles.push_back(whole("tile index", tok));
  if (long(tiles.size()) != count)
    throw std::invalid_argument(label + ": " + std::to_string(tiles.size()) + " tile indices; its 'tiles' line says " +
                                std::to_string(count));
  SamplePattern base;
  try {
    base = make_pattern(kind, std::uint64_t(seed), w, h, factor);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(label + ": line " + std::to_string(fline) + ": " + e.what());
  }
  try {
    return make_refinement(base, tile, rays, std::move(tiles));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(label + ": " + e.what());
  }
}

void extra_positions(const Refinement& r, long k0, long k1, double* xy) {
  const long total = r.extra_count();
  if (k0 < 0 || k1 < k0 || k1 > total)
    throw std::invalid_argument("extra_positions(): rays [" + std::to_string(k0) + ", " + std::to_string(k1) +
                                ") outside [0, " + std::to_string(total) + ")");
  const TileGrid g = r.grid();
  const long b = r.base_rays(), per = r.rays - b;
  long k = 0;
  for (long t : r.tiles) {
    const long n = g.pixels(t) * per;
    if (k + n <= k0) {
      k += n;
      continue;
    }
    if (k >= k1) break;
    const long tx = t % g.columns(), ty = t / g.columns();
    const long x0 = tx * g.tile, x1 = std::min(g.width, x0 + g.tile);
    const long y0 = ty * g.tile, y1 = std::min(g.height, y0 + g.tile);
    for (long y = y0; y < y1; ++y)
      for (long x = x0; x < x1; ++x)
        for (long j = b; j < r.rays; ++j, ++k) {
          if (k < k0 || k >= k1) continue;
          const Vec2 p = sobol_pixel_point(r.base.seed, g.width, y * g.width + x, j);
          xy[2 * (k - k0)] = p.x;
          xy[2 * (k - k0) + 1] = p.y;
        }
  }
}

ScatteredSamples adaptive_samples(ScatteredSamples base, const Refinement& r,
                                  const std::vector<double>& extra_values) {
  const long n = base.count(), m = r.extra_count();
  const int C = base.channels;
  if (n != r.base.count())
    throw std::invalid_argument(std::to_string(n) + " base samples; the refinement's base pattern has " +
                                std::to_string(r.base.count()));
  if (long(extra_values.size()) != m * C)
    throw std::invalid_argument(std::to_string(extra_values.size() / std::size_t(std::max(1, C))) +
                                " extra rays' values; the refinement places " + std::to_string(m));
  if (r.tiles.empty()) return base;
  const TileGrid g = r.grid();
  std::vector<char> refined(std::size_t(g.width * g.height), 0);
  for (long t : r.tiles) {
    const long tx = t % g.columns(), ty = t / g.columns();
    for (long y = ty * g.tile; y < std::min(g.height, (ty + 1) * g.tile); ++y)
      for (long x = tx * g.tile; x < std::min(g.width, (tx + 1) * g.tile); ++x)
        refined[std::size_t(y * g.width + x)] = 1;
  }
  const double wb = 1.0 / double(r.base_rays()), wr = 1.0 / double(r.rays);
  base.weights.resize(std::size_t(n + m));
  for (long i = 0; i < n; ++i) {
    const long p = pixel_of(base.positions[2 * i + 1], g.height) * g.width + pixel_of(base.positions[2 * i], g.width);
    base.weights[std::size_t(i)] = refined[std::size_t(p)] ? wr : wb;
  }
  for (long i = n; i < n + m; ++i) base.weights[std::size_t(i)] = wr;
  base.positions.resize(std::size_t(2 * (n + m)));
  extra_positions(r, 0, m, base.positions.data() + 2 * n);
  base.values.insert(base.values.end(), extra_values.begin(), extra_values.end());
  base.times.clear();
  return base;
}

}  // namespace sis
