// Sample patterns (sis/pattern.h).
#include "sis/pattern.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "sis/imageio.h"
#include "sis/parallel.h"

namespace sis {

namespace {

// A 64-bit finaliser (the MurmurHash3 / SplitMix family's constants, as
// pbrt-v4's MixBits): every input bit moves every output bit.
std::uint64_t mix_bits(std::uint64_t v) {
  v ^= v >> 31;
  v *= 0x7fb5d329728ea185ULL;
  v ^= v >> 27;
  v *= 0x81dadef4bc2dd44dULL;
  v ^= v >> 33;
  return v;
}

// A stream of the seed: dimension `dim`'s own 64-bit key.
std::uint64_t stream_key(std::uint64_t seed, std::uint64_t dim) {
  return mix_bits(seed ^ mix_bits(dim + 0x9e3779b97f4a7c15ULL));
}

// A double uniform in [0, 1) from the key and the index (53 bits).
double uniform(std::uint64_t key, std::uint64_t k) {
  return double(mix_bits(key ^ mix_bits(k)) >> 11) * 0x1p-53;
}

// Owen scrambling by hashing, as pbrt-v4's samplers do by default
// (FastOwenScrambler, after Laine and Karras 2011, Burley 2020): in the
// bit-reversed value, xor with even multiples, addition and odd
// multiplication carry only towards higher bits, so each bit of the result
// depends on the bits above it in the value: a nested scramble, a bijection
// of every elementary interval onto one of the same size, so the net
// property holds.
std::uint32_t reverse_bits(std::uint32_t k) {
  k = (k << 16) | (k >> 16);
  k = ((k & 0x00ff00ffu) << 8) | ((k & 0xff00ff00u) >> 8);
  k = ((k & 0x0f0f0f0fu) << 4) | ((k & 0xf0f0f0f0u) >> 4);
  k = ((k & 0x33333333u) << 2) | ((k & 0xccccccccu) >> 2);
  k = ((k & 0x55555555u) << 1) | ((k & 0xaaaaaaaau) >> 1);
  return k;
}
std::uint32_t owen_scramble(std::uint32_t v, std::uint32_t seed) {
  v = reverse_bits(v);
  v ^= v * 0x3d20adeau;
  v += seed;
  v *= (seed >> 16) | 1u;
  v ^= v * 0x05526c56u;
  v ^= v * 0x53a22864u;
  return reverse_bits(v);
}

// Sobol' dimension 0: the van der Corput radical inverse in base 2, as 32 bits.
std::uint32_t sobol0(std::uint32_t k) { return reverse_bits(k); }

// Sobol' dimension 1 (primitive polynomial x + 1): direction numbers
// v_1 = 2^31, v_j = v_{j-1} xor (v_{j-1} >> 1), the Pascal matrix mod 2.
std::uint32_t sobol1(std::uint32_t k) {
  std::uint32_t y = 0, v = 1u << 31;
  for (; k; k >>= 1, v ^= v >> 1)
    if (k & 1) y ^= v;
  return y;
}

// 32 bits to (0, 1): the middle of its interval of 2^-32, so that the
// point never lies on the frame's edge and stays in its elementary interval.
double unit(std::uint32_t v) { return (double(v) + 0.5) * 0x1p-32; }

std::string number_text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

}  // namespace

const char* pattern_name(PatternKind kind) {
  switch (kind) {
    case PatternKind::Regular: return "regular";
    case PatternKind::Jitter: return "jitter";
    case PatternKind::Sobol: return "sobol";
  }
  return "?";
}

PatternKind parse_pattern(const std::string& s) {
  for (PatternKind k : {PatternKind::Regular, PatternKind::Jitter, PatternKind::Sobol})
    if (s == pattern_name(k)) return k;
  throw std::invalid_argument("unknown sample pattern '" + s + "'; known: regular, jitter, sobol");
}

long SamplePattern::grid_width() const { return long(std::floor(double(width) * factor + 0.5)); }
long SamplePattern::grid_height() const { return long(std::floor(double(height) * factor + 0.5)); }

SamplePattern make_pattern(PatternKind kind, std::uint64_t seed, long width, long height,
                           double factor) {
  if (width < 1 || height < 1)
    throw std::invalid_argument("make_pattern(): frame " + std::to_string(width) + " x " +
                                std::to_string(height) + " has a side below 1");
  if (!std::isfinite(factor) || !(factor > 0) || factor > 1e6)
    throw std::invalid_argument("make_pattern(): factor " + number_text(factor) +
                                " not a positive number of samples per pixel along an axis");
  SamplePattern p{kind, seed, width, height, factor};
  if (p.grid_width() < 1 || p.grid_height() < 1)
    throw std::invalid_argument("make_pattern(): factor " + number_text(factor) + " gives a " +
                                std::to_string(p.grid_width()) + " x " + std::to_string(p.grid_height()) +
                                " grid for the " + std::to_string(width) + " x " + std::to_string(height) +
                                " frame: no sample");
  if (double(p.grid_width()) * double(p.grid_height()) > 4294967296.0)
    throw std::invalid_argument("make_pattern(): " + std::to_string(p.grid_width()) + " x " +
                                std::to_string(p.grid_height()) + " samples, more than 2^32");
  return p;
}

Vec2 sample_position(const SamplePattern& p, long k) {
  const long gw = p.grid_width(), gh = p.grid_height();
  const double W = double(p.width), H = double(p.height);
  const long i = k % gw, l = k / gw;
  switch (p.kind) {
    case PatternKind::Regular:
      return {(double(i) + 0.5) * W / double(gw), (double(l) + 0.5) * H / double(gh)};
    case PatternKind::Jitter: {
      const double u = uniform(stream_key(p.seed, 0), std::uint64_t(k));
      const double v = uniform(stream_key(p.seed, 1), std::uint64_t(k));
      return {(double(i) + u) * W / double(gw), (double(l) + v) * H / double(gh)};
    }
    case PatternKind::Sobol: {
      // pixel q holds samples [c(q), c(q + 1)), c(q) = floor(q N / P) (P
      // pixels, N samples): the counts differ by at most one; sample k is
      // point k - c(q) of pixel q's own scrambled sequence.
      __extension__ typedef unsigned __int128 u128;
      const std::uint64_t P = std::uint64_t(p.width) * std::uint64_t(p.height);
      const std::uint64_t N = std::uint64_t(gw) * std::uint64_t(gh);
      const std::uint64_t q = std::uint64_t((u128(k + 1) * P - 1) / N);
      const std::uint64_t i = std::uint64_t(k) - std::uint64_t(u128(q) * N / P);
      return sobol_pixel_point(p.seed, p.width, long(q), long(i));
    }
  }
  return {};
}

Vec2 sobol_pixel_point(std::uint64_t seed, long width, long q, long j) {
  const std::uint64_t pixel = mix_bits(seed ^ mix_bits(std::uint64_t(q) ^ 0x5851f42d4c957f2dULL));
  const double u = unit(owen_scramble(sobol0(std::uint32_t(j)), std::uint32_t(stream_key(pixel, 0))));
  const double v = unit(owen_scramble(sobol1(std::uint32_t(j)), std::uint32_t(stream_key(pixel, 1))));
  return {double(std::uint64_t(q) % std::uint64_t(width)) + u, double(std::uint64_t(q) / std::uint64_t(width)) + v};
}

void sample_positions(const SamplePattern& p, long k0, long k1, double* xy, int threads) {
  if (k0 < 0 || k1 < k0 || k1 > p.count())
    throw std::invalid_argument("sample_positions(): samples [" + std::to_string(k0) + ", " +
                                std::to_string(k1) + ") outside [0, " + std::to_string(p.count()) + ")");
  parallel_for(k1 - k0, threads, [&](long a, long b) {
    for (long q = a; q < b; ++q) {
      const Vec2 s = sample_position(p, k0 + q);
      xy[2 * q] = s.x;
      xy[2 * q + 1] = s.y;
    }
  });
}

std::vector<PatternAttribute> pattern_metadata(const SamplePattern& p) {
  return {{kPatternKey, pattern_name(p.kind)},
          {kPatternSeedKey, std::to_string(p.seed)},
          {kPatternFrameKey, std::to_string(p.width) + "x" + std::to_string(p.height)},
          {kPatternFactorKey, number_text(p.factor)}};
}

bool has_pattern_metadata(const ImageReader& r) {
  for (const char* key : {kPatternKey, kPatternSeedKey, kPatternFrameKey, kPatternFactorKey})
    if (!r.attribute(key).empty()) return true;
  return false;
}

SamplePattern read_pattern_metadata(const ImageReader& r) {
  const std::string& path = r.path();
  auto get = [&](const char* key) {
    const std::string v = r.attribute(key);
    if (v.empty())
      throw InputError(path + ": names a sample pattern but has no " + key +
                       " (a render of a pattern carries " + kPatternKey + ", " + kPatternSeedKey +
                       ", " + kPatternFrameKey + " and " + kPatternFactorKey + ")");
    return v;
  };
  const std::string name = get(kPatternKey), seed_text = get(kPatternSeedKey),
                    frame_text = get(kPatternFrameKey), factor_text = get(kPatternFactorKey);
  PatternKind kind;
  try {
    kind = parse_pattern(name);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + kPatternKey + ": " + e.what());
  }
  std::uint64_t seed = 0;
  {
    const char* e = seed_text.data() + seed_text.size();
    auto [q, ec] = std::from_chars(seed_text.data(), e, seed);
    if (ec != std::errc() || q != e)
      throw InputError(path + ": " + kPatternSeedKey + " '" + seed_text +
                       "' is not a whole number from 0 to 2^64 - 1");
  }
  long w = 0, h = 0;
  {
    const char* b = frame_text.data();
    const char* e = b + frame_text.size();
    auto [q, ec] = std::from_chars(b, e, w);
    bool ok = ec == std::errc() && q != e && *q == 'x';
    if (ok) {
      auto [q2, ec2] = std::from_chars(q + 1, e, h);
      ok = ec2 == std::errc() && q2 == e && w > 0 && h > 0;
    }
    if (!ok)
      throw InputError(path + ": " + kPatternFrameKey + " '" + frame_text +
                       "' is not WxH (the frame in output pixels, positive whole numbers)");
  }
  double factor = 0;
  {
    std::size_t used = 0;
    try {
      factor = std::stod(factor_text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != factor_text.size() || !std::isfinite(factor) || !(factor > 0))
      throw InputError(path + ": " + kPatternFactorKey + " '" + factor_text +
                       "' is not a positive number (samples per output pixel along an axis)");
  }
  SamplePattern p;
  try {
    p = make_pattern(kind, seed, w, h, factor);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": its pattern metadata: " + e.what());
  }
  if (r.width() != p.grid_width() || r.height() != p.grid_height())
    throw InputError(path + ": is " + std::to_string(r.width()) + " x " + std::to_string(r.height()) +
                     " samples, but its pattern (" + name + ", frame " + frame_text + ", factor " +
                     factor_text + ") has " + std::to_string(p.grid_width()) + " x " +
                     std::to_string(p.grid_height()));
  return p;
}

}  // namespace sis
