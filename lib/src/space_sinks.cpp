#include "space_sinks.h"

#include "sis/parallel.h"

namespace sis {

void CartesianSink::Band::add_strip(const Strip& s, LocalRange::Band& range,
                                    SampleStages::Counts& bad, SampleStages::Counts& bad_first) {
  const bool half = format_.half;
  const std::size_t row_size = format_.row_size;
  const SampleStages& stages = *format_.stages;
  const long y = s.global, y1 = y + s.y1 - s.y0;
  band_.add_rows(y, y1, [&](long gy, long k0, long k1, float* scratch) {
    const long r = gy - y;
    float* v = half ? scratch : s.floats + r * row_size + k0;
    stages.scan(half ? s.half + r * row_size : nullptr, r, k0, k1, v, bad, bad_first);
    stages.transform(gy, k0, k1, v, range);
    return static_cast<const float*>(v);
  });
}

namespace {
// A strip through the stages whole: as float (converted into `converted`
// from half), every row scanned, then each column piece of every row
// transformed by transform(y, k0, k1, v), on the band's threads; the
// values, interleaved rows.
template <typename Transform>
const float* staged_strip(const StripFormat& format, const Strip& s, Buffer<float>& converted,
                          SampleStages::Counts& bad, SampleStages::Counts& bad_first,
                          const Transform& transform) {
  const bool half = format.half;
  const std::size_t row_size = format.row_size;
  const int inner = format.threads;
  const long y = s.global, rows = s.y1 - s.y0;
  float* data = s.floats;
  if (half) {
    converted.resize(std::size_t(rows) * row_size);
    data = converted.data();
  }
  parallel_for(rows, inner, [&](long r0, long r1) {
    for (long r = r0; r < r1; ++r)
      SampleStages::scan(half ? s.half + r * row_size : nullptr, r, 0, long(row_size),
                         data + r * row_size, bad, bad_first);
  });
  parallel_for(long(row_size), inner, [&](long k0, long k1) {
    for (long r = 0; r < rows; ++r) transform(y + r, k0, k1, data + r * row_size + k0);
  });
  return data;
}
}  // namespace

void HexagonalSink::Band::add_strip(const Strip& s, LocalRange::Band& range,
                                    SampleStages::Counts& bad, SampleStages::Counts& bad_first) {
  const SampleStages& stages = *format_.stages;
  const float* data = staged_strip(format_, s, converted_, bad, bad_first,
                                   [&](long y, long k0, long k1, float* v) {
                                     stages.transform(y, k0, k1, v, range);
                                   });
  band_.add_rows(s.global, s.global + s.y1 - s.y0, data);
}

ManySinks::Band::Band(ManySinks& many, const StripFormat& format) : format_(format) {
  for (const auto& make : many.makers_) bands_.push_back(make(format));
}

void ManySinks::Band::add_strip(const Strip& s,
                                const std::vector<std::unique_ptr<LocalRange::Band>>& ranges,
                                SampleStages::Counts& bad, SampleStages::Counts& bad_first) {
  const SampleStages& stages = *format_.stages;
  const float* data = staged_strip(format_, s, converted_, bad, bad_first,
                                   [&](long y, long k0, long k1, float* v) {
                                     stages.transform(y, k0, k1, v, ranges);
                                   });
  for (auto& band : bands_) band->add_values(s.global, s.global + s.y1 - s.y0, data);
}

}  // namespace sis
