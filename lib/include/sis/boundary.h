#pragma once
// Boundary rules: how a finite sequence (input samples or coefficients) is
// extended beyond its ends. The same rule extends the input for acquisition
// and the coefficients for the prefilter and resampling, so a result is
// exactly the projection of the extended image.
#include <string>

namespace sis {

enum class Boundary {
  Mirror,    // half-sample symmetric: x[-1] = x[0], x[-2] = x[1]; x[n] = x[n-1]
  Periodic,  // x[-1] = x[n-1]
};

Boundary parse_boundary(const std::string& spelling);  // "mirror" | "periodic"
std::string boundary_name(Boundary b);

// Index into [0, n) of sample i of the extended sequence.
inline long extend_index(long i, long n, Boundary b) {
  if (i >= 0 && i < n) return i;
  const long period = (b == Boundary::Mirror) ? 2 * n : n;
  long m = i % period;
  if (m < 0) m += period;
  if (b == Boundary::Mirror && m >= n) m = 2 * n - 1 - m;
  return m;
}

}  // namespace sis
