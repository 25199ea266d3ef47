#include "sis/weights.h"

#include <algorithm>
#include <map>

namespace sis {

double AxisWeights::sum(long t) const {
  double s = 0;
  for (long e = begin(t); e < end(t); ++e) s += weight[e];
  return s;
}

AxisWeights AxisWeights::transposed() const {
  AxisWeights out;
  out.targets = sources;
  out.sources = targets;
  out.offset.assign(sources + 1, 0);
  for (long i : index) ++out.offset[i + 1];
  for (long s = 0; s < sources; ++s) out.offset[s + 1] += out.offset[s];
  out.index.resize(index.size());
  out.weight.resize(weight.size());
  std::vector<long> fill(out.offset.begin(), out.offset.end() - 1);
  for (long t = 0; t < targets; ++t)  // targets in increasing order: stays sorted
    for (long e = begin(t); e < end(t); ++e) {
      const long pos = fill[index[e]]++;
      out.index[pos] = t;
      out.weight[pos] = weight[e];
    }
  return out;
}

AxisWeights make_axis_weights(long targets, long sources, Boundary boundary,
                              const std::function<std::pair<long, long>(long)>& range,
                              const std::function<double(long, long)>& weight) {
  AxisWeights w;
  w.targets = targets;
  w.sources = sources;
  w.offset.reserve(targets + 1);
  w.offset.push_back(0);
  std::map<long, double> merged;
  for (long t = 0; t < targets; ++t) {
    merged.clear();
    const auto [first, last] = range(t);
    for (long k = first; k <= last; ++k) {
      const double v = weight(t, k);
      if (v != 0.0) merged[extend_index(k, sources, boundary)] += v;
    }
    for (const auto& [i, v] : merged) {
      w.index.push_back(i);
      w.weight.push_back(v);
    }
    w.offset.push_back(static_cast<long>(w.index.size()));
  }
  return w;
}

}  // namespace sis
