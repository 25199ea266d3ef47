#pragma once
// Internal: the one lock around FFTW's planner, which is not thread-safe.
// Every plan creation and destruction in the library holds it.
#include <mutex>

namespace sis::detail {
std::mutex& fftw_planner_mutex();
}  // namespace sis::detail
