// Several targets from one reading (sis/engine.h): one read of the samples
// feeding the sinks of several spaces and frames gives each target the bits
// of its own run, for samples in memory and in a half file, on one thread
// and several, with every sample stage; targets that would need their own
// reading are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <functional>
#include <cstring>
#include <limits>

#include "sis/engine.h"
#include "support.h"

namespace sis {
namespace {

struct Target {
  Space space;
  Method method;
  Boundary boundary;
  long width, height;
};
// Both lattices, min-error and conventional, both boundary rules, frames of
// their own sizes (a pyramid's levels among them).
const Target kTargets[] = {
    {CartesianSpace{Kernel::bspline(3)}, Method::MinError, Boundary::Mirror, 47, 61},
    {CartesianSpace{Kernel::bspline(3)}, Method::MinError, Boundary::Mirror, 24, 31},
    {CartesianSpace{Kernel::bspline(1)}, Method::Conventional, Boundary::Periodic, 20, 13},
    {CartesianSpace{Kernel::parse("mitchell")}, Method::Conventional, Boundary::Mirror, 33, 40},
    {HexagonalSpace{2, 1.0}, Method::MinError, Boundary::Mirror, 30, 37},
    {HexagonalSpace{1, 1.7}, Method::MinError, Boundary::Periodic, 18, 22},
};

ProjectionRequest request(const Target& t, std::vector<ProjectionInput> inputs, int threads) {
  ProjectionRequest rq;
  rq.inputs = std::move(inputs);
  rq.space = t.space;
  rq.method = t.method;
  rq.boundary = t.boundary;
  rq.width = t.width;
  rq.height = t.height;
  rq.threads = threads;
  return rq;
}

template <typename T>
bool same_bits(const T& a, const T& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
}

// Every target of one reading against its own run; `stages` sets the
// sample stages on every request alike.
template <typename Stages>
void expect_own_runs_bits(const std::vector<ProjectionInput>& inputs, int threads,
                          const Stages& stages, const std::string& what) {
  std::vector<ProjectionRequest> all;
  for (const Target& t : kTargets) {
    all.push_back(request(t, all.empty() ? inputs : std::vector<ProjectionInput>{}, threads));
    stages(all.back());
  }
  const std::vector<Projection> one_read = project(all);
  ASSERT_EQ(one_read.size(), all.size());
  for (std::size_t q = 0; q < all.size(); ++q) {
    ProjectionRequest alone = all[q];
    alone.inputs = inputs;
    const Projection own = project(alone);
    const Projection& p = one_read[q];
    EXPECT_TRUE(same_bits(p.coefficients.c.data, own.coefficients.c.data))
        << what << ", target " << q;
    EXPECT_EQ(p.coefficients.c.width, own.coefficients.c.width) << what << ", target " << q;
    EXPECT_EQ(generator_name(p.coefficients), generator_name(own.coefficients));
    EXPECT_EQ(p.coefficients.boundary, own.coefficients.boundary);
    EXPECT_TRUE(same_bits(p.local_range->min().data, own.local_range->min().data))
        << what << ", target " << q;
    EXPECT_TRUE(same_bits(p.local_range->max().data, own.local_range->max().data))
        << what << ", target " << q;
    EXPECT_EQ(p.nonfinite.count, own.nonfinite.count) << what;
    EXPECT_EQ(p.nonfinite.where, own.nonfinite.where) << what;
    EXPECT_EQ(p.coefficients.input.transfer, own.coefficients.input.transfer) << what;
    EXPECT_EQ(p.coefficients.highlight_compressed, own.coefficients.highlight_compressed) << what;
    EXPECT_EQ(p.coefficients.channel_names, own.coefficients.channel_names) << what;
    EXPECT_EQ(p.coefficients.input.label, own.coefficients.input.label) << what;
  }
}

class Targets : public test::TempDirTest {};

TEST_F(Targets, OneReadingGivesEveryTargetItsOwnRunsBits) {
  // 3 bands of 256 rows and a short one: several workers take bands at once
  const Image image = test::random_image(83, 3 * 256 + 41, 3, 21, 0.0f, 4.0f);
  const auto none = [](ProjectionRequest&) {};
  for (int threads : {1, 3})
    expect_own_runs_bits({ProjectionInput::memory(image)}, threads, none,
                         "memory, " + std::to_string(threads) + " threads");
  // a half file in two bands, read by its own readers in strips
  Image top(83, 300, 3), bottom(83, image.height - 300, 3);
  std::memcpy(top.data.data(), image.data.data(), top.data.size() * sizeof(float));
  std::memcpy(bottom.data.data(), image.row(300), bottom.data.size() * sizeof(float));
  const std::string a = path("top.exr"), b = path("bottom.exr");
  write_image(a, top, {}, {}, -1, WriteOptions(SampleFormat::Half));
  write_image(b, bottom, {}, {}, -1, WriteOptions(SampleFormat::Half));
  // the bottom band's rows placed below the top's by its data window
  const std::string bottom_band = path("bottom_band.exr");
  ASSERT_EQ(std::system(("oiiotool " + b + " --origin +0+300 --fullsize 83x" +
                         std::to_string(image.height) + "+0+0 -d half -o " + bottom_band)
                            .c_str()),
            0);
  const std::string top_band = path("top_band.exr");
  ASSERT_EQ(std::system(("oiiotool " + a + " --fullsize 83x" + std::to_string(image.height) +
                         "+0+0 -d half -o " + top_band)
                            .c_str()),
            0);
  for (int threads : {1, 2})
    expect_own_runs_bits({ProjectionInput::file(top_band), ProjectionInput::file(bottom_band)},
                         threads, none, "half bands, " + std::to_string(threads) + " threads");
}

TEST_F(Targets, EverySampleStageRunsOnceForAll) {
  Image image = test::random_image(64, 2 * 256 + 9, 4, 22, 0.0f, 30.0f);
  image.data[3 * 4 * 64 + 7] = std::numeric_limits<float>::quiet_NaN();
  image.data[300 * 4 * 64 + 2] = std::numeric_limits<float>::infinity();
  std::vector<ProjectionInput> in{ProjectionInput::memory(image)};
  in.front().channel_names = {"R", "G", "B", "A"};
  const auto stages = [](ProjectionRequest& rq) {
    rq.zero_nonfinite = true;
    rq.highlight_compress = true;
    rq.input_transfer = Transfer::power(2.2);
  };
  for (int threads : {1, 3}) expect_own_runs_bits(in, threads, stages, "stages");
  // and a non-finite sample refused: the same error as one run's
  std::vector<ProjectionRequest> all{request(kTargets[0], in, 2), request(kTargets[4], {}, 2)};
  std::string alone;
  try {
    project(request(kTargets[0], in, 2));
  } catch (const InputError& e) {
    alone = e.what();
  }
  ASSERT_FALSE(alone.empty());
  try {
    project(all);
    ADD_FAILURE() << "a NaN sample was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), alone);
  }
}

TEST_F(Targets, TargetsThatNeedTheirOwnReadingAreRefused) {
  const Image image = test::random_image(40, 30, 3, 23);
  const std::vector<ProjectionInput> in{ProjectionInput::memory(image)};
  EXPECT_THROW(project(std::vector<ProjectionRequest>{}), RequestError);
  const auto refused = [&](const std::function<void(ProjectionRequest&)>& change,
                           const std::string& named) {
    std::vector<ProjectionRequest> all{request(kTargets[0], in, 1), request(kTargets[1], {}, 1)};
    change(all[1]);
    try {
      project(all);
      ADD_FAILURE() << named << " accepted";
    } catch (const RequestError& e) {
      EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("target 2"), std::string::npos) << e.what();
    }
  };
  refused([&](ProjectionRequest& r) { r.inputs = in; }, "inputs");
  refused([](ProjectionRequest& r) { r.zero_nonfinite = true; }, "--nonfinite");
  refused([](ProjectionRequest& r) { r.highlight_compress = true; }, "--highlight-compress");
  refused([](ProjectionRequest& r) { r.input_transfer = Transfer::srgb(); }, "--input-transfer");
  // a target the space cannot make: that space's own refusal
  std::vector<ProjectionRequest> all{request(kTargets[0], in, 1), request(kTargets[1], {}, 1)};
  all[1].width = 0;
  EXPECT_THROW(project(all), RequestError);
}

}  // namespace
}  // namespace sis
