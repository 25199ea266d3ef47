// Partials that merge: the acquisition of any split of the grid's bands,
// merged in any order, is the single run's bits (coefficients and local
// range), on both lattices; partials from other requests, that overlap or
// leave a gap, are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>

#include "sis/partial.h"
#include "support.h"

namespace sis {
namespace {

// 8 bands of 256 rows (the last of 100).
constexpr long kWidth = 96, kRows = 7 * 256 + 100, kW = 24, kH = 473;

struct Case {
  const char* name;
  Space space;
  Method method;
};
const Case kCases[] = {
    {"cubic", CartesianSpace{Kernel::bspline(3)}, Method::MinError},
    {"tent-conventional", CartesianSpace{Kernel::bspline(1)}, Method::Conventional},
    {"mitchell", CartesianSpace{Kernel::parse("mitchell")}, Method::Conventional},
    {"hex-quartic", HexagonalSpace{2, 1.0}, Method::MinError},
    {"hex-hat-dense", HexagonalSpace{1, 1.7}, Method::MinError},
};

ProjectionRequest request(const Case& c, const Image& image, long y0, long y1) {
  ProjectionRequest rq;
  ProjectionInput in = ProjectionInput::memory(
      SampleView(image.row(y0), image.width, y1 - y0, image.channels, false), "rows " + std::to_string(y0));
  in.row = y0;
  in.rows = image.height;
  rq.inputs = {in};
  rq.width = kW;
  rq.height = kH;
  rq.space = c.space;
  rq.method = c.method;
  rq.threads = 2;
  return rq;
}

bool same_bits(const Buffer<double>& a, const Buffer<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}
bool same_bits(const Image& a, const Image& b) {
  return a.data.size() == b.data.size() &&
         std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)) == 0;
}

class PartialMerge : public ::testing::TestWithParam<Case> {};

TEST_P(PartialMerge, EverySplitInAnyOrderGivesTheSingleRunsBits) {
  const Case& c = GetParam();
  const Image image = test::random_image(kWidth, kRows, 3, 11);
  const Projection whole = project(request(c, image, 0, kRows));
  std::mt19937 rng(5);
  for (long parts : {1L, 2L, 3L, 7L}) {
    const std::vector<long> cuts = band_cuts(kRows, parts);
    ASSERT_EQ(long(cuts.size()), parts + 1);
    std::vector<Partial> ps;
    for (long t = 0; t < parts; ++t) ps.push_back(project_partial(request(c, image, cuts[t], cuts[t + 1])));
    std::shuffle(ps.begin(), ps.end(), rng);
    const Projection merged = merge(ps, 2);
    EXPECT_TRUE(same_bits(merged.coefficients.c.data, whole.coefficients.c.data))
        << c.name << ", " << parts << " parts";
    EXPECT_TRUE(same_bits(merged.local_range->min(), whole.local_range->min())) << parts << " parts";
    EXPECT_TRUE(same_bits(merged.local_range->max(), whole.local_range->max())) << parts << " parts";
    EXPECT_EQ(generator_name(merged.coefficients), generator_name(whole.coefficients));
  }
}

INSTANTIATE_TEST_SUITE_P(Spaces, PartialMerge, ::testing::ValuesIn(kCases),
                         [](const auto& info) {
                           std::string n = info.param.name;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

class PartialFiles : public test::TempDirTest {};

TEST_F(PartialFiles, WrittenAndReadBackTheyMergeToTheSingleRunsBits) {
  for (const Case& c : {kCases[0], kCases[3]}) {
    const Image image = test::random_image(kWidth, kRows, 3, 12);
    const Projection whole = project(request(c, image, 0, kRows));
    const std::vector<long> cuts = band_cuts(kRows, 3);
    std::vector<Partial> ps;
    for (long t = 2; t >= 0; --t) {
      const std::string name = path("part" + std::to_string(t) + ".exr");
      write_partial(name, project_partial(request(c, image, cuts[t], cuts[t + 1])));
      ps.push_back(read_partial(name));
    }
    const Projection merged = merge(ps, 1);
    EXPECT_TRUE(same_bits(merged.coefficients.c.data, whole.coefficients.c.data)) << c.name;
    EXPECT_TRUE(same_bits(merged.local_range->min(), whole.local_range->min())) << c.name;
  }
}

TEST_F(PartialFiles, AFileThatIsNotAPartialIsAnInputError) {
  const std::string p = path("plain.exr");
  write_image(p, test::random_image(8, 8, 3, 1));
  EXPECT_THROW(read_partial(p), InputError);
}

TEST(PartialErrors, OverlapGapAndOtherOptionsAreRefused) {
  const Case& c = kCases[0];
  const Image image = test::random_image(kWidth, kRows, 3, 13);
  const std::vector<long> cuts = band_cuts(kRows, 3);
  const Partial a = project_partial(request(c, image, cuts[0], cuts[1]));
  const Partial b = project_partial(request(c, image, cuts[1], cuts[2]));
  const Partial z = project_partial(request(c, image, cuts[2], cuts[3]));
  auto message = [](const std::vector<Partial>& ps) {
    try {
      merge(ps);
    } catch (const RequestError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({a, b}).find("a gap"), std::string::npos) << message({a, b});
  EXPECT_NE(message({a, b, z, b}).find("overlap"), std::string::npos);
  ProjectionRequest other = request(kCases[1], image, cuts[2], cuts[3]);
  const std::string m = message({a, b, project_partial(other)});
  EXPECT_NE(m.find("another request"), std::string::npos) << m;
  EXPECT_NE(m.find("sis:generator"), std::string::npos) << m;
  ProjectionRequest smaller = request(c, image, cuts[2], cuts[3]);
  smaller.width = kW - 1;
  EXPECT_NE(message({a, b, project_partial(smaller)}).find("sis:size"), std::string::npos);
}

TEST(PartialErrors, RowsThatAreNotWholeBandsAreRefusedBeforeReading) {
  const Image image = test::random_image(kWidth, kRows, 3, 14);
  EXPECT_THROW(project_partial(request(kCases[0], image, 100, 512)), RequestError);
  EXPECT_THROW(project_partial(request(kCases[0], image, 256, 600)), RequestError);
  EXPECT_NO_THROW(project_partial(request(kCases[0], image, 256, 512)));
  EXPECT_NO_THROW(project_partial(request(kCases[0], image, 7 * 256, kRows)));
}

TEST(BandCuts, WholeBandsAsEvenAsTheyAllow) {
  EXPECT_EQ(band_cuts(2000, 1), (std::vector<long>{0, 2000}));
  EXPECT_EQ(band_cuts(2000, 2), (std::vector<long>{0, 1024, 2000}));  // 8 bands: 4 + 4
  EXPECT_EQ(band_cuts(2000, 3), (std::vector<long>{0, 512, 1280, 2000}));  // 2 + 3 + 3
  EXPECT_EQ(band_cuts(100, 1), (std::vector<long>{0, 100}));
  EXPECT_THROW(band_cuts(2000, 9), RequestError);
  EXPECT_THROW(band_cuts(2000, 0), RequestError);
}

}  // namespace
}  // namespace sis
