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

// Lets a child of fork() use the library again and exit: registers (once)
// the handlers that make the worker pool anew in the child and stop the
// thread pools of the library's dependencies (OpenEXR's, log4cplus's)
// before a fork. Called by the first parallel_for and by the Python module
// at import; a program that forks after using OpenImageIO otherwise calls it.
void keep_fork_safe();

}  // namespace sis
