// siproject --lattice hex end to end, through the built binary: agreement with
// the library, the coefficient round trip, usage errors.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <stdlib.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <random>

#include "sis/hex_projection.h"
#include "sis/imageio.h"
#include "support.h"

namespace fs = std::filesystem;
using namespace sis;
using namespace sis::test;

#ifndef SIPROJECT
#error "SIPROJECT must name the siproject binary"
#endif

namespace {

Result run(const std::string& args) { return run_tool(SIPROJECT, args); }

class HexSiproject : public TempDirTest {};

// What siproject computes: the library's projection with the coefficients
// rounded to float, as the tool keeps them.
Coefficients library(const Image& in, double W, double H, int order, double density) {
  HexProjectionOptions o;
  o.order = order;
  o.density = density;
  Coefficients k = project_hexagonal(in, W, H, o);
  for (double& v : k.c.data) v = static_cast<float>(v);
  return k;
}

}  // namespace

TEST_F(HexSiproject, AgreesWithTheLibrary) {
  const Image in = random_image(64, 48, 3, 1);
  write_image(path("in.exr"), in);
  for (const auto& [g, density] :
       {std::pair<std::string, double>{"hex-hat", 1.0}, {"hex-quartic", 2.0}}) {
    const Coefficients k = library(in, 16, 12, g == "hex-hat" ? 1 : 2, density);
    for (const std::string d : {"centred", "2x2", "pixel"}) {
      const Result r = run(path("in.exr") + " -o " + path("out.exr") +
                           " --factor 4 -q --lattice hex --generator " + g + " --density " +
                           std::to_string(density) + " --display " + d);
      ASSERT_EQ(r.status, 0) << r.output;
      const Image got = read_image(path("out.exr"));
      ASSERT_EQ(got.width, 16);
      ASSERT_EQ(got.height, 12);
      EXPECT_EQ(got.data, resample(k, Display::parse(d), 16, 12).data) << g << " " << d;
    }
    ImageReader out(path("out.exr"));
    EXPECT_EQ(out.attribute("sis:generator"), g);
    EXPECT_EQ(out.attribute("sis:lattice"), "hexagonal");
  }
  // hex-quartic is the default generator on the hexagonal lattice
  ASSERT_EQ(run(path("in.exr") + " -o " + path("q.exr") + " --factor 4 -q --lattice hex").status,
            0);
  EXPECT_EQ(read_image(path("q.exr")).data,
            resample(library(in, 16, 12, 2, 1.0), Display::antialiased_2x2(), 16, 12).data);
}

TEST_F(HexSiproject, CoefficientRoundTripEqualsDirectResult) {
  write_image(path("in.exr"), random_image(90, 60, 3, 2));
  for (const std::string extra : {"", "--display pixel", "--display centred"}) {
    ASSERT_EQ(run(path("in.exr") + " -o " + path("direct.exr") +
                  " --factor 3 -q --lattice hex --generator hex-hat --density 1.5 --coeffs " +
                  path("c.exr") + " " + extra).status, 0);
    const Result r = run(path("c.exr") + " -o " + path("rt.exr") + " -q " + extra);
    ASSERT_EQ(r.status, 0) << r.output;
    const Image a = read_image(path("direct.exr")), b = read_image(path("rt.exr"));
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.data, b.data) << extra;
  }
  ImageReader c(path("c.exr"));
  EXPECT_EQ(c.attribute("sis:lattice"), "hexagonal");
  EXPECT_EQ(c.attribute("sis:storage"), "offset-rows");
  EXPECT_EQ(c.attribute("sis:generator"), "hex-hat");
  EXPECT_EQ(c.height() % 2, 0);
  const Coefficients k = read_coefficients(c);
  EXPECT_TRUE(k.lattice.is_hexagonal());
  EXPECT_NEAR(std::abs(k.lattice.determinant()), 1 / 1.5, 1e-14);
  // At another size: the stored approximation sampled there.
  for (const std::string d : {"2x2", "pixel"}) {
    const Result r = run(path("c.exr") + " -o " + path("rt.exr") + " -q --size 41x17 --display " + d);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(read_image(path("rt.exr")).data, resample(k, Display::parse(d), 41, 17).data) << d;
  }
  // the recorded lattice cannot be overridden
  EXPECT_EQ(run(path("c.exr") + " -o " + path("x.exr") + " --lattice hex").status, 2);
  EXPECT_EQ(run(path("c.exr") + " -o " + path("x.exr") + " --density 2").status, 2);
}

TEST_F(HexSiproject, UsageErrors) {
  write_image(path("in.exr"), random_image(32, 32, 3, 5));
  const std::string base = path("in.exr") + " -o " + path("out.exr") + " --factor 2 ";
  struct Case {
    std::string args, says;
  };
  const Case cases[] = {
      {"--lattice hex --generator cubic", "hex-hat or hex-quartic"},
      {"--generator hex-hat", "needs --lattice hex"},
      {"--lattice hex --method conventional", "min-error"},
      {"--lattice hex --prefilter recursive", "fft"},
      {"--lattice square", "--lattice 'square'"},
      {"--density 2", "--density applies to --lattice hex"},
      {"--lattice hex --density 0", "--density"},
  };
  for (const Case& c : cases) {
    const Result r = run(base + c.args);
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_FALSE(fs::exists(path("out.exr"))) << c.args;
  }
}

TEST_F(HexSiproject, BandsHalfNonFiniteRemediesAndThreads) {
  // An input of three acquisition bands (603 rows), half, with a NaN, in
  // three row-band files: the hexagonal path gives the single file's bits at
  // 1, 2 and 3 threads, with --nonfinite zero, --clamp local and highlight
  // compression, and names the NaN under the error policy.
  Image img = random_image(301, 603, 3, 31, 0, 4);
  img.at(40, 300, 1) = NAN;
  auto write = [&](const std::string& name, long y0, long y1) {
    OIIO::ImageSpec spec(int(img.width), int(y1 - y0), 3, OIIO::TypeDesc::HALF);
    spec.y = int(y0);
    spec.full_y = 0;
    spec.full_height = int(img.height);
    auto out = OIIO::ImageOutput::create(path(name));
    ASSERT_TRUE(out && out->open(path(name), spec) &&
                out->write_image(OIIO::TypeDesc::FLOAT, img.row(y0)) && out->close());
  };
  write("whole.exr", 0, 603);
  write("a.exr", 0, 250);
  write("b.exr", 250, 400);
  write("c.exr", 400, 603);
  const std::string opts =
      " --factor 3 --lattice hex --nonfinite zero --clamp local --highlight-compress -d float -q";
  ASSERT_EQ(run(path("whole.exr") + " -o " + path("ref.exr") + opts + " --threads 1").status, 0);
  const Image ref = read_image(path("ref.exr"));
  for (int t : {1, 2, 3}) {
    for (const std::string& in :
         std::vector<std::string>{path("whole.exr"), "--bands " + path("c.exr") + " " + path("a.exr") + " " + path("b.exr")}) {
      ASSERT_EQ(run(in + " -o " + path("out.exr") + opts + " --threads " + std::to_string(t)).status, 0);
      EXPECT_EQ(read_image(path("out.exr")).data, ref.data) << t << " threads: " << in;
    }
  }
  for (float v : ref.data) ASSERT_TRUE(std::isfinite(v));
  const Result r = run("--bands " + path("a.exr") + " " + path("b.exr") + " " + path("c.exr") + " -o " +
                       path("e.exr") + " --factor 3 --lattice hex");
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("b.exr: non-finite sample (NaN or Inf) at x 40, y 50, channel G"),
            std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("e.exr")));
}
