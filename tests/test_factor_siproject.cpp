// siproject at non-integer factors, through the built binary, on a flat
// image written by oiiotool (issue 29's reproduction); the memory estimate
// against the measured peak.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
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

namespace {

// siproject ARGS under /usr/bin/time: its peak resident set (bytes) and,
// with -v, the memory it estimated before allocating (bytes; 0 if none).
struct Peak {
  int status = -1;
  double peak = 0, estimate = 0;
  std::string output;
};
Peak measure(const std::string& args) {
  Peak p;
  const Result r = run_tool("/usr/bin/time", "-f 'peak %M KB' " + std::string(SIPROJECT) + " " + args);
  p.status = r.status;
  p.output = r.output;
  const std::size_t k = r.output.rfind("peak ");
  if (k != std::string::npos) p.peak = std::stod(r.output.substr(k + 5)) * 1024;
  const std::size_t e = r.output.find("memory: about ");
  if (e != std::string::npos) {
    std::size_t used = 0;
    const double v = std::stod(r.output.substr(e + 14), &used);
    const std::string unit = r.output.substr(e + 14 + used + 1, 2);
    p.estimate = v * (unit == "GB" ? 1 << 30 : 1 << 20);
  }
  return p;
}

}  // namespace

TEST_F(FactorCli, MemoryEstimateBoundsThePeak) {
  // The estimate siproject checks against the memory left (docs/siproject.md)
  // bounds what the request adds to the process: its peak resident set less
  // the peak of a request whose allocations are negligible (the program,
  // its libraries, OpenImageIO's plugins). The hexagonal lattice onto a
  // small output (its weight table and interpolated rows grow with the
  // input's samples per output pixel: 800 x 800 onto 3 x 3 added 150 MB
  // against a 96 MB estimate when the rows were interpolated a band at a
  // time and the table left out), and the Cartesian lattice at a
  // non-integer factor, on inputs written by oiiotool.
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/time")) << "the test measures with /usr/bin/time";
  for (const char* make : {"--pattern noise 64x64 3 -d half -o small.exr",
                           "--pattern noise 800x800 3 -d half -o big.exr"}) {
    const Result r = run_tool("cd " + dir_ + " && oiiotool", make);
    ASSERT_EQ(r.status, 0) << r.output;
  }
  const Peak base = measure(path("small.exr") + " -o " + path("s.exr") + " --size 16x16 -v");
  ASSERT_EQ(base.status, 0) << base.output;
  ASSERT_GT(base.peak, 0) << base.output;
  for (const std::string& options :
       {std::string("--size 3x3 --lattice hex"), std::string("--size 3x3 --lattice hex --generator hex-hat"),
        std::string("--size 211x190 --lattice hex"), std::string("--size 311x290")}) {
    const Peak p = measure(path("big.exr") + " -o " + path("o.exr") + " " + options + " -v");
    ASSERT_EQ(p.status, 0) << options << ": " << p.output;
    ASSERT_GT(p.estimate, 0) << options << ": " << p.output;
    EXPECT_LE(p.peak - base.peak, p.estimate)
        << options << ": peak " << p.peak / 1e6 << " MB, a negligible request's " << base.peak / 1e6
        << " MB, estimate " << p.estimate / 1e6 << " MB";
  }
}

TEST_F(FactorCli, HexagonalTableTooLargeForMemoryIsRefused) {
  // 8400 x 8400 samples onto 3 x 3 on the hexagonal lattice: the quartic's
  // weight table alone, (2 n s2 - 1)(2 n s1 + 1) doubles with s1 = 3008 and
  // s2 = 2606 aligned columns and rows per lattice step, is about 1 GB.
  // Under a 1 GB address-space limit it is refused before anything is
  // allocated: status 2, the option named, nothing written.
  const Result made = run_tool("oiiotool", "--pattern constant:color=0.5 8400x8400 1 -d half -o " +
                                               path("big.exr"));
  ASSERT_EQ(made.status, 0) << made.output;
  const Result r = run_tool("ulimit -v 1000000; " + std::string(SIPROJECT),
                            path("big.exr") + " -o " + path("o.exr") + " --size 3x3 --lattice hex");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--lattice hex"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("of memory"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(path("o.exr")));
}

TEST_F(FactorCli, VariationalWorkingSetIsCountedBeforeItIsAllocated) {
  // 4,000,000 samples at random positions (three oiiotool noise channels:
  // a value and pFilm.x, pFilm.y) onto 500 x 500. The fit's working set is
  // six grids and a value per sample (about 44 MB); the variational rule by
  // GCV solves 4 probes beside the value (5 channels) through nine grids and
  // keeps f_app and the values of all five at every sample (about 530 MB).
  // Under a 1 GB address-space limit the fit runs, and the variational rule
  // is refused before it allocates: status 2, the memory named, no output.
  const std::string noise = "--pattern noise:type=uniform:min=0:max=1:seed=";
  const Result made = run_tool("cd " + dir_ + " && oiiotool",
                               noise + "1 2000x2000 1 " + noise + "2 2000x2000 1 " + noise +
                                   "3 2000x2000 1 --chappend --chappend --chnames R,pFilm.x,pFilm.y "
                                   "--mulc 1,500,500 -d float -o s.exr");
  ASSERT_EQ(made.status, 0) << made.output;
  const std::string run = "ulimit -v 1000000; " + std::string(SIPROJECT);
  const std::string in = path("s.exr") + " --size 500x500 -o " + path("o.exr");
  const Result fit = run_tool(run, in + " --rule fit");
  ASSERT_EQ(fit.status, 0) << fit.output;
  std::filesystem::remove(path("o.exr"));
  const Result v = run_tool(run, in + " --rule variational");
  EXPECT_EQ(v.status, 2) << v.output;
  EXPECT_NE(v.output.find("the request needs about"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("4000000 scattered samples"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("give --lambda"), std::string::npos) << v.output;
  EXPECT_FALSE(std::filesystem::exists(path("o.exr")));
}
