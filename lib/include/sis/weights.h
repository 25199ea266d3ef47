#pragma once
// Per-axis weight tables: the plan shared by acquisition and resampling.
// For each target index, the source indices (already folded into [0, sources)
// by the boundary rule, sorted, duplicates merged) and their weights.
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
  // The transpose: for each source, the targets it contributes to.
  AxisWeights transposed() const;
};

// Builds a table: for target t, the extended source indices k in
// range(t) = [first, last] get weight(t, k); k is folded by the boundary rule.
AxisWeights make_axis_weights(long targets, long sources, Boundary boundary,
                              const std::function<std::pair<long, long>(long)>& range,
                              const std::function<double(long, long)>& weight);

}  // namespace sis
