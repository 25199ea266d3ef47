#pragma once
// Bands: the input rows in runs of a fixed count, the unit in which streamed
// sums are ordered. Each band's sums are complete in themselves, so bands
// can be taken at once on different threads (each thread decoding and
// summing its own rows while they are in its cache) and give the bits of
// one band after another, whatever the thread count.
//
// An output row whose inputs lie in one band is written by that band. One
// whose inputs lie in several is written by its first band, and each later
// band writes its part into a slot of its own; once the row's last band has
// ended, the slots are combined into the row in band order.
//
// A set of ended bands can be taken out as a partial (BandPartial) and
// absorbed by another accumulation of the same plan: each row whose every
// band is in the set as its value, each row it shares with bands outside
// the set as the parts of the set's bands, unmerged. Absorbing the partials
// of any split of the bands, in any order, merges every shared row in band
// order: the bits of one run.
#include <algorithm>
#include <atomic>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "sis/image.h"

namespace sis {

// Input rows per band of siproject's acquisition and local range (and of an
// AcquisitionPlan given no other count): at 8000 samples of half RGB a row,
// 12 MB of samples, 32 bands; each a few of OpenEXR's zip blocks of 16 rows.
constexpr long kBandRows = 256;

class BandPartition {
 public:
  BandPartition() = default;
  // Rows [0, rows) in bands of band_rows (the last may be shorter); band_rows
  // < 1 or >= rows: one band.
  BandPartition(long rows, long band_rows)
      : rows_(rows), band_rows_(band_rows < 1 || band_rows > rows ? std::max(1L, rows) : band_rows) {}
  long rows() const { return rows_; }
  long band_rows() const { return band_rows_; }
  long count() const { return (rows_ + band_rows_ - 1) / band_rows_; }
  long begin(long b) const { return b * band_rows_; }
  long end(long b) const { return std::min(rows_, (b + 1) * band_rows_); }
  long of(long y) const { return y / band_rows_; }

 private:
  long rows_ = 0, band_rows_ = 1;
};

// The sums of some bands of an accumulation: rows `rows` complete (every
// band of theirs taken), and the parts (row, band) of rows shared with
// bands not taken; values: the rows' then the parts', `size` each.
template <typename T>
struct BandPartial {
  std::vector<long> rows;
  std::vector<std::pair<long, long>> parts;  // (row, band)
  std::vector<T> values;
  std::size_t size = 0;
  const T* row_values(std::size_t k) const { return values.data() + k * size; }
  const T* part_values(std::size_t k) const { return values.data() + (rows.size() + k) * size; }
};

// The slots of the output rows that several bands write, `size` values each.
template <typename T>
class BandSlots {
 public:
  BandSlots() = default;
  // row_bands[r]: the bands output row r's inputs lie in, ascending.
  BandSlots(const std::vector<std::vector<long>>& row_bands, long bands, std::size_t size)
      : row_bands_(row_bands), first_(row_bands.size(), -1), count_(row_bands.size(), 0),
        by_band_(bands), size_(size) {
    long slots = 0;
    for (std::size_t r = 0; r < row_bands.size(); ++r) {
      const auto& b = row_bands[r];
      if (b.size() < 2) continue;
      first_[r] = slots;
      count_[r] = long(b.size()) - 1;
      for (std::size_t k = 0; k < b.size(); ++k) {
        by_band_[b[k]].push_back(long(r));
        if (k > 0) band_of_slot_.push_back(b[k]), ++slots;
      }
    }
    remaining_ = std::make_unique<std::atomic<long>[]>(row_bands.size());
    for (std::size_t r = 0; r < row_bands.size(); ++r) remaining_[r] = long(row_bands[r].size());
    data_.resize(std::size_t(slots) * size_);  // unset: each is written before it is read
  }
  // Where band b writes output row r: nullptr for the row itself (its only
  // or first band), else b's slot.
  T* slot(long r, long b) {
    for (long s = first_[r]; s >= 0 && s < first_[r] + count_[r]; ++s)
      if (band_of_slot_[s] == b) return data_.data() + std::size_t(s) * size_;
    return nullptr;
  }
  // Band b has written its rows and slots: for each row of b's that no other
  // band still writes, merge(r, slot) for its slots in band order (on the
  // calling thread). Bands may end on any thread, in any order.
  template <typename Merge>
  void ended(long b, const Merge& merge) {
    for (long r : by_band_[b])
      if (remaining_[r].fetch_sub(1, std::memory_order_acq_rel) == 1)
        for (long s = first_[r]; s < first_[r] + count_[r]; ++s)
          merge(r, static_cast<const T*>(data_.data() + std::size_t(s) * size_));
  }

  // The partial of the ended bands `taken` (ascending); get(r, out) copies
  // output row r's values (as written so far) into out.
  BandPartial<T> partial(const std::vector<long>& taken,
                         const std::function<void(long, T*)>& get) const {
    BandPartial<T> p;
    p.size = size_;
    std::vector<char> in(by_band_.size(), 0);
    for (long b : taken) in[b] = 1;
    std::vector<T> row(size_);
    std::vector<std::pair<long, const T*>> parts;  // the parts' values, where they are
    for (std::size_t r = 0; r < row_bands_.size(); ++r) {
      const auto& b = row_bands_[r];
      const long n = long(std::count_if(b.begin(), b.end(), [&](long q) { return in[q]; }));
      if (n == 0) continue;
      if (n == long(b.size())) {
        p.rows.push_back(long(r));
        get(long(r), row.data());
        p.values.insert(p.values.end(), row.begin(), row.end());
      }
    }
    for (std::size_t r = 0; r < row_bands_.size(); ++r) {
      const auto& b = row_bands_[r];
      const long n = long(std::count_if(b.begin(), b.end(), [&](long q) { return in[q]; }));
      if (n == 0 || n == long(b.size())) continue;
      for (std::size_t k = 0; k < b.size(); ++k) {
        if (!in[b[k]]) continue;
        p.parts.push_back({long(r), b[k]});
        if (k == 0) {
          get(long(r), row.data());
          p.values.insert(p.values.end(), row.begin(), row.end());
        } else {
          const T* slot = data_.data() + std::size_t(first_[r] + long(k) - 1) * size_;
          p.values.insert(p.values.end(), slot, slot + size_);
        }
      }
    }
    return p;
  }
  // Takes in a partial of bands `taken` (none of them ended here) as if they
  // had ended: put(r, values) writes output row r; its shared rows whose
  // last band this is are merged (merge, as in ended()). Throws
  // std::invalid_argument when the partial does not hold what `taken` asks.
  template <typename Merge>
  void absorb(const BandPartial<T>& p, const std::vector<long>& taken,
              const std::function<void(long, const T*)>& put, const Merge& merge) {
    if (p.size != size_ || p.values.size() != (p.rows.size() + p.parts.size()) * size_)
      throw std::invalid_argument("rows of another size");
    std::vector<char> in(by_band_.size(), 0);
    for (long b : taken) in[b] = 1;
    std::size_t expected_rows = 0, expected_parts = 0;
    for (const auto& b : row_bands_) {
      const long n = long(std::count_if(b.begin(), b.end(), [&](long q) { return in[q]; }));
      if (n == long(b.size()) && n > 0) ++expected_rows;
      else expected_parts += std::size_t(n);
    }
    if (p.rows.size() != expected_rows || p.parts.size() != expected_parts)
      throw std::invalid_argument("not the rows of its bands");
    for (std::size_t k = 0; k < p.rows.size(); ++k) {
      const long r = p.rows[k];
      if (r < 0 || r >= long(row_bands_.size())) throw std::invalid_argument("a row out of range");
      const auto& b = row_bands_[r];
      if (b.empty() || !std::all_of(b.begin(), b.end(), [&](long q) { return in[q]; }))
        throw std::invalid_argument("a row not of its bands");
      put(r, p.row_values(k));
      remaining_[r] = 0;  // complete: its bands' ends below merge nothing into it
    }
    for (std::size_t k = 0; k < p.parts.size(); ++k) {
      const auto [r, band] = p.parts[k];
      if (r < 0 || r >= long(row_bands_.size())) throw std::invalid_argument("a row out of range");
      const auto& b = row_bands_[r];
      const auto at = std::find(b.begin(), b.end(), band);
      if (at == b.end() || !in[band]) throw std::invalid_argument("a part not of its bands");
      if (at == b.begin()) {
        put(r, p.part_values(k));
      } else {
        T* slot = data_.data() + std::size_t(first_[r] + long(at - b.begin()) - 1) * size_;
        std::memcpy(slot, p.part_values(k), size_ * sizeof(T));
      }
    }
    for (long b : taken) ended(b, merge);
  }

 private:
  std::vector<std::vector<long>> row_bands_;  // per output row: its bands, ascending
  std::vector<long> first_, count_;         // per output row: its first slot (-1: none), how many
  std::vector<long> band_of_slot_;          // per slot: its band
  std::vector<std::vector<long>> by_band_;  // per band: its rows that have slots
  std::unique_ptr<std::atomic<long>[]> remaining_;  // per output row: bands not yet ended
  Buffer<T> data_;
  std::size_t size_ = 0;
};

}  // namespace sis
