// siproject at non-integer factors, through the built binary, on a flat
// image written by oiiotool (issue 29's reproduction).
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <string>
#include <vector>

#include "support.h"

using namespace sis::test;

#ifndef SIPROJECT
#error "SIPROJECT must name the siproject binary"
#endif

namespace {

class FactorCli : public TempDirTest {};

std::vector<float> read_all(const std::string& path, int& channels) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) return {};
  const OIIO::ImageSpec& spec = in->spec();
  channels = spec.nchannels;
  std::vector<float> v(std::size_t(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, v.data())) return {};
  return v;
}

}  // namespace

TEST_F(FactorCli, FlatImageStaysFlatAtNonIntegerFactors) {
  // oiiotool --pattern constant:color=0.25 120x120 1 -d float, then
  // siproject at factors 1.5, 2.5 (box: [0.111, 0.444] and [0.16, 0.36]
  // with the plain point sum) and 3.3 (tent: a 2.5 % ripple, cubic 0.03 %),
  // every output sample 0.25 to half an ulp of the float output (2^-24 of
  // 0.25; the computation in double adds far less), on both lattices.
  const Result made = run_tool("oiiotool", "--pattern constant:color=0.25 120x120 1 -d float -o " +
                                               path("flat.exr"));
  ASSERT_EQ(made.status, 0) << made.output;
  struct Run {
    std::string factor, options;
  };
  const Run runs[] = {{"1.5", "--generator box"},
                      {"2.5", "--generator box"},
                      {"3.3", "--generator tent"},
                      {"3.3", "--generator cubic"},
                      {"1.5", "--generator box --method conventional"},
                      {"2.5", "--generator mitchell"},
                      {"3.3", "--generator lanczos3"},
                      {"1.5", "--lattice hex --generator hex-hat"},
                      {"3.3", "--lattice hex --generator hex-quartic"}};
  for (const Run& r : runs) {
    const std::string out = path("o.exr");
    const Result res = run_tool(SIPROJECT, path("flat.exr") + " -o " + out + " --factor " +
                                               r.factor + " " + r.options + " -d float -q");
    ASSERT_EQ(res.status, 0) << r.options << ": " << res.output;
    int channels = 0;
    const std::vector<float> v = read_all(out, channels);
    ASSERT_EQ(channels, 1);
    const long side = std::lround(120 / std::stod(r.factor));
    ASSERT_EQ(long(v.size()), side * side) << r.options;
    float lo = v[0], hi = v[0];
    for (float x : v) lo = std::min(lo, x), hi = std::max(hi, x);
    EXPECT_NEAR(lo, 0.25, std::ldexp(0.25, -24)) << "--factor " << r.factor << " " << r.options;
    EXPECT_NEAR(hi, 0.25, std::ldexp(0.25, -24)) << "--factor " << r.factor << " " << r.options;
  }
}
