#pragma once
// Threads for the compute stages: a fork-join loop over an index range, run
// on worker threads kept for the life of the process.
#include <functional>

namespace sis {

// Runs fn(begin, end) over [0, n) split into contiguous chunks on up to
// `threads` threads. Each index is handled by exactly one call. Callers make
// each index's result independent of the split, so that every thread count
// gives the same bits.
void parallel_for(long n, int threads, const std::function<void(long, long)>& fn);

}  // namespace sis
