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
#include <algorithm>
#include <atomic>
#include <memory>
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

// The slots of the output rows that several bands write, `size` values each.
template <typename T>
class BandSlots {
 public:
  BandSlots() = default;
  // row_bands[r]: the bands output row r's inputs lie in, ascending.
  BandSlots(const std::vector<std::vector<long>>& row_bands, long bands, std::size_t size)
      : first_(row_bands.size(), -1), count_(row_bands.size(), 0), by_band_(bands), size_(size) {
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

 private:
  std::vector<long> first_, count_;         // per output row: its first slot (-1: none), how many
  std::vector<long> band_of_slot_;          // per slot: its band
  std::vector<std::vector<long>> by_band_;  // per band: its rows that have slots
  std::unique_ptr<std::atomic<long>[]> remaining_;  // per output row: bands not yet ended
  Buffer<T> data_;
  std::size_t size_ = 0;
};

}  // namespace sis
