#pragma once
// Per-axis weight tables: the plan shared by acquisition and resampling.
// For each target index, the source indices (already folded into [0, sources)
// by the boundary rule, sorted, duplicates merged) and their weights.
#include <array>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

#include "sis/boundary.h"
#include "sis/parallel.h"

namespace sis {

struct AxisWeights {
  long targets = 0, sources = 0;
  std::vector<long> offset;  // targets + 1 entries into index/weight
  std::vector<long> index;
  std::vector<double> weight;

  long begin(long t) const { return offset[t]; }
  long end(long t) const { return offset[t + 1]; }
  double sum(long t) const;  // sum of the weights of target t
};

// The table applied to one row of `channels` interleaved channels (sources
// * channels values): out[t] = sum_e weight[e] in[index[e]] per channel, for
// the targets [t0, t1). The sum over a target's entries is four interleaved
// partial sums, p_j over the entries k = j mod 4 in increasing k, combined
// as (p0 + p1) + (p2 + p3) (four chains the processor runs at once); every
// path (vector or scalar, any channel count) keeps this order and gives the
// same bits.
void apply_weights(const AxisWeights& w, const double* in, int channels, long t0, long t1,
                   double* out);

// Rows weighted into sums, elementwise: sums[i][offset + k] += w[i] * x[k]
// for i in [0, count), k in [0, n) (a product, then a sum, so the same bits
// at any vector width); x is read once for up to four sums. With assign, the
// sums' first terms: sums[i][offset + k] = 0.0 + w[i] * x[k], the bits of
// adding them to zeros, without reading the sums.
template <typename T>
void add_scaled_rows(double* const* sums, const double* w, int count, long offset, const T* x,
                     long n, bool assign = false);

// Several rows into the same sums: for each sum i, the terms of rows
// x[0], ..., x[rows - 1] in that order, sums[i][offset + k] +=
// w[r][i] * x[r][k], except that the last `starts` sums begin with row 0's
// term (assigned, as add_scaled_rows with assign): the bits of
// add_scaled_rows row after row. Each sum is loaded and stored once per four
// rows.
template <typename T>
void add_scaled_row_group(double* const* sums, const double* const* w, int count, int starts,
                          long offset, const T* const* x, int rows, long n);

// 4-point cubic Lagrange interpolation at fraction f in [0, 1) between taps
// 0 and 1 of the taps -1, 0, 1, 2: reproduces every cubic. As a function of
// the distance to one sample it is the piecewise cubic cardinal function of
// support 4 samples (the model of the samples where the point sum is not an
// inner product: acquisition.cpp, hex_acquisition.cpp).
inline std::array<double, 4> lagrange4(double f) {
  return {-f * (f - 1) * (f - 2) / 6, (f + 1) * (f - 1) * (f - 2) / 2,
          -(f + 1) * f * (f - 2) / 2, (f + 1) * f * (f - 1) / 6};
}
// The first tap and the fraction of position p (in sample indices).
inline std::pair<long, double> lagrange_base(double p) {
  const double b = std::floor(p);
  return {static_cast<long>(b) - 1, p - b};
}

// Builds a table: for target t, the extended source indices k in
// range(t) = [first, last] get weight(t, k); k is folded by the boundary rule.
AxisWeights make_axis_weights(long targets, long sources, Boundary boundary,
                              const std::function<std::pair<long, long>(long)>& range,
                              const std::function<double(long, long)>& weight);

}  // namespace sis
