#pragma once
// Software prefetch for the row-streaming stages. They walk the rows of a
// strip a block of columns at a time: each row's block is a short run of
// cache lines far from the last (a row apart), which the hardware
// prefetchers do not foresee, so each block would start with misses to the
// outer caches. The stages ask for a later row's block while they work on
// this one.
#include <algorithm>
#include <cstddef>

namespace sis {

// How far ahead, in rows, for blocks of `bytes` bytes: about 2 KB of lines
// in flight. (BM_Acquisition degree 3, one thread, float rows in 2 KB
// blocks: one row ahead 44.9 ms against 56.3 ms without, medians of 12
// alternated invocations; two rows ahead 60-62 ms in single runs. In
// siproject, half rows in 1 KB blocks: two rows ahead beat one in perf's
// samples. Measured before the vertical sums took rows in groups of four;
// after, distances of 2 to 16 KB measured alike within the noise.)
inline long prefetch_rows(std::size_t bytes) {
  return std::max(1L, long(2048 / std::max<std::size_t>(bytes, 1)));
}

// Asks for the cache lines of [p, p + bytes) to be brought into the
// first-level cache. Only a hint: no effect on results, and no fault on any
// address.
inline void prefetch(const void* p, std::size_t bytes) {
  const char* c = static_cast<const char*>(p);
  for (std::size_t q = 0; q < bytes; q += 64) __builtin_prefetch(c + q, 0, 3);
}

// For a stage at values [k0, k1) of row r of `rows` (rows [0, end), each
// row_size values apart): prefetches the same values prefetch_rows() rows on,
// if that row exists.
template <typename T>
inline void prefetch_ahead(const T* rows, long r, long end, std::size_t row_size, long k0, long k1) {
  const std::size_t bytes = std::size_t(k1 - k0) * sizeof(T);
  const long ahead = r + prefetch_rows(bytes);
  if (ahead < end) prefetch(rows + std::size_t(ahead) * row_size + k0, bytes);
}

}  // namespace sis
