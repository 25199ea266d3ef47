#pragma once
// The acquisition sinks of the spaces (internal to the library): what the
// engine's band reading drives, one per space, with the same per-band
// interface. Each sink owns its acquisition and its band partition (every
// space's is bands of kBandRows input rows, so that one reading can feed
// several sinks: ManySinks, below); a
// Band takes bands in any order on any worker thread (begin(b), strips,
// end()), and every strip passes the sample stages on the worker that
// decoded it before the space sums it. Both sinks keep per-band partial
// sums merged in band order (sis/bands.h), so the result is the same bits
// for any thread count and any order in which the bands are taken.
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>
#include <vector>

#include "sis/acquisition.h"
#include "sis/hex_acquisition.h"
#include "sis/imageio.h"
#include "sis/range.h"

namespace sis {

using ValueHook = std::function<void(float*, std::size_t, std::size_t)>;

namespace stages {
// True when no sample is NaN or infinite. A branch-free scan of the bits
// (exponent all ones plus one carries into the sign bit) that compilers
// vectorise: the common case costs little.
inline bool all_finite(const float* v, std::size_t n) {
  std::uint32_t carry = 0;
  for (std::size_t q = 0; q < n; ++q) {
    std::uint32_t u;
    std::memcpy(&u, v + q, sizeof u);
    carry |= (u & 0x7f800000u) + 0x00800000u;
  }
  return !(carry & 0x80000000u);
}

// Values [k0, k1) of a row as float in v (converted from `half_row` when
// given, else already there): false when one is not finite.
inline bool row_values(const std::uint16_t* half_row, long k0, long k1, float* v) {
  const std::size_t n = std::size_t(k1 - k0);
  return half_row ? half_to_float(half_row + k0, v, n) : all_finite(v, n);
}

// Zeroes the non-finite values of v[0, n) (values k0... of their row); returns
// how many, the first's index in *first.
inline long zero_nonfinite(float* v, std::size_t n, long k0, long* first) {
  long count = 0;
  for (std::size_t q = 0; q < n; ++q)
    if (!std::isfinite(v[q])) {
      if (count++ == 0) *first = k0 + long(q);
      v[q] = 0.0f;
    }
  return count;
}

// The least of `seen` and `value`, kept in `seen` (pieces of a row run at once).
inline void keep_least(std::atomic<long>& seen, long value) {
  long s = seen.load();
  while (value < s && !seen.compare_exchange_weak(s, value)) {
  }
}
}  // namespace stages

// What every piece of a strip's samples passes on the worker that decoded
// it, before the acquisition sums it, in every space: the non-finite scan
// (each such sample counted and zeroed), then the sRGB decoding, the local
// range (the samples folded in) and the highlight compression. A piece is
// values [k0, k1) of one strip row, interleaved.
struct SampleStages {
  using Counts = std::vector<std::atomic<long>>;
  ValueHook decode, compress;  // empty: not asked for

  // The piece as float in v (converted from the strip's half row where
  // given), its non-finite samples counted into bad[r] (the least first
  // value index into bad_first[r]) and zeroed.
  static void scan(const std::uint16_t* half_row, long r, long k0, long k1, float* v, Counts& bad,
                   Counts& bad_first) {
    if (stages::row_values(half_row, k0, k1, v)) return;
    long first_bad = -1;
    bad[r] += stages::zero_nonfinite(v, std::size_t(k1 - k0), k0, &first_bad);
    stages::keep_least(bad_first[r], first_bad);
  }
  // The scanned piece at image row y: decoded, folded into the range, compressed.
  void transform(long y, long k0, long k1, float* v, LocalRange::Band& range) const {
    const std::size_t n = std::size_t(k1 - k0);
    if (decode) decode(v, n, std::size_t(k0));
    range.fold(y, k0, k1, v);
    if (compress) compress(v, n, std::size_t(k0));
  }
  // The same, folded into each of several ranges (one reading, several targets).
  void transform(long y, long k0, long k1, float* v,
                 const std::vector<std::unique_ptr<LocalRange::Band>>& ranges) const {
    const std::size_t n = std::size_t(k1 - k0);
    if (decode) decode(v, n, std::size_t(k0));
    for (const auto& range : ranges) range->fold(y, k0, k1, v);
    if (compress) compress(v, n, std::size_t(k0));
  }
};

// What a sink's band needs of the reading: the stages, whether strips come
// as half, the values per input row, threads within the band.
struct StripFormat {
  const SampleStages* stages = nullptr;
  bool half = false;
  std::size_t row_size = 0;
  int threads = 1;
};

// The Cartesian space's sink: each strip handed to the acquisition in
// pieces of columns, each piece through the stages on the worker threads
// while the sums use it (the fused path).
class CartesianSink {
 public:
  CartesianSink(long input_width, long input_height, int channels, long W, long H,
                const Kernel& generator, Boundary boundary, Method method, int threads)
      : plan_(input_width, input_height, channels, double(W), double(H), Lattice::cartesian(),
              generator, boundary, method),
        whole_(plan_, threads) {}
  const BandPartition& bands() const { return plan_.bands(); }
  class Band {
   public:
    Band(CartesianSink& sink, const StripFormat& format) : format_(format), band_(sink.whole_, format.threads) {}
    void begin(long b) { band_.begin(b); }
    void add_strip(const Strip& s, LocalRange::Band& range, SampleStages::Counts& bad,
                   SampleStages::Counts& bad_first);
    // Rows [y0, y1) of samples that have passed the stages, interleaved.
    void add_values(long y0, long y1, const float* rows) { band_.add_rows(y0, y1, rows); }
    void end() { band_.end(); }

   private:
    StripFormat format_;
    Acquisition::Band band_;
  };
  Coefficients finish() { return whole_.finish(); }
  BandPartial<double> partial(std::vector<long>* taken) const { return whole_.partial(taken); }
  void absorb(const BandPartial<double>& p, const std::vector<long>& taken) { whole_.absorb(p, taken); }

 private:
  AcquisitionPlan plan_;
  Acquisition whole_;
};

// The hexagonal space's sink: each strip through the stages (scanned row
// by row, then the rest column piece by column piece, on the band's
// threads), then added whole.
class HexagonalSink {
 public:
  HexagonalSink(long input_width, long input_height, int channels, long W, long H,
                const HexLayout& layout, int order, Boundary boundary, int threads)
      : plan_(input_width, input_height, channels, double(W), double(H), layout, order, boundary),
        whole_(plan_, threads) {}
  const BandPartition& bands() const { return whole_.bands(); }
  class Band {
   public:
    Band(HexagonalSink& sink, const StripFormat& format) : format_(format), band_(sink.whole_, format.threads) {}
    void begin(long b) { band_.begin(b); }
    void add_strip(const Strip& s, LocalRange::Band& range, SampleStages::Counts& bad,
                   SampleStages::Counts& bad_first);
    void add_values(long y0, long y1, const float* rows) { band_.add_rows(y0, y1, rows); }
    void end() { band_.end(); }

   private:
    StripFormat format_;
    HexAcquisition::Band band_;
    Buffer<float> converted_;  // a half strip as float
  };
  Coefficients finish() { return whole_.finish(); }
  BandPartial<double> partial(std::vector<long>* taken) const { return whole_.partial(taken); }
  void absorb(const BandPartial<double>& p, const std::vector<long>& taken) { whole_.absorb(p, taken); }

 private:
  HexAcquisitionPlan plan_;
  HexAcquisition whole_;
};

// Several sinks fed by one reading (several targets from one read): every
// strip passes the stages once, as in the hexagonal sink (scanned row by
// row, then decoded, folded into each target's range and compressed column
// piece by column piece on the band's threads), and its values go to each
// sink's band in the order the sinks were added. Each sink sums the same
// values in its own order, so each result is the bits of its own reading.
class ManySinks {
  struct AnyBand {
    virtual ~AnyBand() = default;
    virtual void begin(long band) = 0;
    virtual void add_values(long y0, long y1, const float* rows) = 0;
    virtual void end() = 0;
  };
  template <typename Sink>
  struct BandOf final : AnyBand {
    BandOf(Sink& sink, const StripFormat& format) : band(sink, format) {}
    void begin(long b) override { band.begin(b); }
    void add_values(long y0, long y1, const float* rows) override { band.add_values(y0, y1, rows); }
    void end() override { band.end(); }
    typename Sink::Band band;
  };

 public:
  // A sink whose bands are the others' (std::logic_error if not); it must
  // outlive the reading.
  template <typename Sink>
  void add(Sink& sink) {
    const BandPartition& b = sink.bands();
    if (!makers_.empty() && (b.rows() != bands_.rows() || b.band_rows() != bands_.band_rows()))
      throw std::logic_error("ManySinks::add(): the sinks' bands differ");
    bands_ = b;
    makers_.push_back([&sink](const StripFormat& format) -> std::unique_ptr<AnyBand> {
      return std::make_unique<BandOf<Sink>>(sink, format);
    });
  }
  const BandPartition& bands() const { return bands_; }
  std::size_t size() const { return makers_.size(); }

  class Band {
   public:
    Band(ManySinks& many, const StripFormat& format);
    void begin(long b) {
      for (auto& band : bands_) band->begin(b);
    }
    void add_strip(const Strip& s, const std::vector<std::unique_ptr<LocalRange::Band>>& ranges,
                   SampleStages::Counts& bad, SampleStages::Counts& bad_first);
    void end() {
      for (auto& band : bands_) band->end();
    }

   private:
    StripFormat format_;
    std::vector<std::unique_ptr<AnyBand>> bands_;
    Buffer<float> converted_;  // a half strip as float
  };

 private:
  std::vector<std::function<std::unique_ptr<AnyBand>(const StripFormat&)>> makers_;
  BandPartition bands_;
};

}  // namespace sis
