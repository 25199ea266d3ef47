// siproject --mip: a tiled, MIP-mapped OpenEXR whose levels are maketx's
// for the same size, read through OpenImageIO's TextureSystem, each level
// the image a single run at that level's size gives; the bad requests.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>
#include <OpenImageIO/texture.h>

#include <cstring>
#include <regex>
#include <string>
#include <vector>

#include "sis/imageio.h"
#include "sis/pyramid.h"
#include "sis/settings.h"
#include "support.h"

using namespace sis;
using namespace sis::test;

#ifndef SIPROJECT
#error "SIPROJECT must name the siproject binary"
#endif

namespace {

Result run(const std::string& args) { return run_tool(SIPROJECT, args); }

class Mip : public TempDirTest {
 protected:
  // A half render of (w x h) * factor samples.
  std::string render(long w, long h, int factor, unsigned seed) {
    const std::string p = path("render-" + std::to_string(w) + "x" + std::to_string(h) + ".exr");
    write_image(p, random_image(w * factor, h * factor, 3, seed, 0.0f, 2.0f), {}, {}, -1,
                WriteOptions(SampleFormat::Half));
    return p;
  }
};

// The "MIP-map levels: ..." line of `oiiotool --info -v FILE`.
std::string mip_levels(const std::string& file) {
  const Result r = run_tool("oiiotool", "--info -v " + file);
  EXPECT_EQ(r.status, 0) << r.output;
  std::smatch m;
  const std::regex line("MIP-map levels: ([0-9x ]+)");
  return std::regex_search(r.output, m, line) ? m[1].str() : std::string("none");
}

Image read_float(const std::string& file, int miplevel = 0) {
  auto in = OIIO::ImageInput::open(file);
  EXPECT_TRUE(in) << file;
  if (!in) return {};
  EXPECT_TRUE(in->seek_subimage(0, miplevel));
  const OIIO::ImageSpec& s = in->spec();
  Image img(s.width, s.height, s.nchannels);
  EXPECT_TRUE(in->read_image(0, miplevel, 0, s.nchannels, OIIO::TypeDesc::FLOAT, img.data.data()));
  return img;
}

TEST_F(Mip, LevelsAreMaketxsForOddAndEvenSizes) {
  if (run_tool("sh", "-c 'command -v maketx'").status != 0) GTEST_SKIP() << "no maketx";
  for (const auto& [w, h] : std::vector<std::pair<long, long>>{{37, 21}, {64, 48}, {1, 5}}) {
    const std::string in = render(w, h, 2, 40);
    const std::string ours = path("ours.exr"), frame = path("frame.exr"), theirs = path("tx.exr");
    const Result r = run(in + " -o " + ours + " --factor 2 --mip");
    ASSERT_EQ(r.status, 0) << r.output;
    // maketx from an image of level 0's size
    ASSERT_EQ(run_tool("oiiotool", in + " --resize " + std::to_string(w) + "x" + std::to_string(h) +
                                       " -o " + frame).status, 0);
    ASSERT_EQ(run_tool("maketx", frame + " -o " + theirs).status, 0);
    const std::string levels = mip_levels(ours);
    EXPECT_EQ(levels, mip_levels(theirs)) << w << " x " << h;
    std::string expected;
    for (const auto& [lw, lh] : pyramid_sizes(w, h))
      expected += (expected.empty() ? "" : " ") + std::to_string(lw) + "x" + std::to_string(lh);
    EXPECT_EQ(levels, expected);
  }
}

TEST_F(Mip, TheTextureSystemReadsEveryLevelAsItsOwnRun) {
  // odd sizes (fractional ratios to the samples below level 0)
  const std::string in = render(37, 21, 8, 41);
  OIIO::TextureSystem* ts = OIIO::TextureSystem::create(false);
  struct Case {
    std::string options, generator, method, display, boundary;
  };
  const Case cases[] = {
      {"", "cubic", "min-error", "", "mirror"},
      {"--generator box --display centred", "box", "min-error", "centred", "mirror"},
      {"--generator tent --display pixel --boundary periodic", "tent", "min-error", "pixel", "periodic"},
      {"--generator lanczos3 --method conventional", "lanczos3", "conventional", "", "mirror"},
  };
  for (const Case& c : cases) {
    const std::string tex = path("tex.exr");
    const Result r = run(in + " -o " + tex + " --factor 8 --mip -d float " + c.options);
    ASSERT_EQ(r.status, 0) << r.output;
    ts->invalidate(OIIO::ustring(tex), true);
    const auto sizes = pyramid_sizes(37, 21);
    for (std::size_t j = 0; j < sizes.size(); ++j) {
      const auto [w, h] = sizes[j];
      // the single projection at level j's size (what siproject --size WxH
      // -d float writes, float samples as they are)
      Settings st;
      st.size = std::to_string(w) + "x" + std::to_string(h);
      st.generator = c.generator;
      st.method = c.method;
      st.display = c.display;
      st.boundary = c.boundary;
      st.generator_given = st.method_given = true;
      const Formed own = form(st, {ProjectionInput::file(in)});
      const Image& expected = own.final.image;
      OIIO::TextureOpt opt;
      std::vector<float> texels(std::size_t(w) * h * 3);
      ASSERT_TRUE(ts->get_texels(OIIO::ustring(tex), opt, int(j), 0, int(w), 0, int(h), 0, 1, 0, 3,
                                 OIIO::TypeDesc::FLOAT, texels.data()))
          << ts->geterror();
      ASSERT_EQ(texels.size(), expected.data.size());
      EXPECT_EQ(std::memcmp(texels.data(), expected.data.data(), texels.size() * sizeof(float)), 0)
          << c.options << ", level " << j;
      // and by ImageInput's seek to the level
      const Image level = read_float(tex, int(j));
      EXPECT_EQ(std::memcmp(level.data.data(), expected.data.data(), texels.size() * sizeof(float)), 0);
    }
  }
  OIIO::TextureSystem::destroy(ts);
}

TEST_F(Mip, TextureLookupsFilterAtTheLevelsSize) {
  // a square power-of-two frame: a lookup at a texel's centre, closest
  // texel, one level, with derivatives of 0.9 texel of level j, reads level j
  const std::string in = render(32, 32, 4, 42);
  const std::string tex = path("tex.exr");
  ASSERT_EQ(run(in + " -o " + tex + " --factor 4 --mip -d float").status, 0);
  OIIO::TextureSystem* ts = OIIO::TextureSystem::create(false);
  OIIO::TextureOpt opt;
  opt.mipmode = OIIO::TextureOpt::MipModeOneLevel;
  opt.interpmode = OIIO::TextureOpt::InterpClosest;
  const auto sizes = pyramid_sizes(32, 32);
  for (std::size_t j = 0; j < sizes.size(); ++j) {
    const long n = sizes[j].first;
    const Image level = read_float(tex, int(j));
    for (long y = 0; y < n; y += std::max(1L, n / 5))
      for (long x = 0; x < n; x += std::max(1L, n / 7)) {
        float v[3];
        const float d = 0.9f / float(n);
        ASSERT_TRUE(ts->texture(OIIO::ustring(tex), opt, (x + 0.5f) / n, (y + 0.5f) / n, d, 0, 0, d,
                                3, v))
            << ts->geterror();
        for (int c = 0; c < 3; ++c)
          EXPECT_FLOAT_EQ(v[c], level.at(x, y, c)) << "level " << j << " at " << x << ", " << y;
      }
  }
  OIIO::TextureSystem::destroy(ts);
}

TEST_F(Mip, BadRequestsAreRefusedAndLeaveNothing) {
  const std::string in = render(16, 12, 2, 43);
  const auto refused = [&](const std::string& args, const std::string& named, int status = 2) {
    const Result r = run(in + " " + args);
    EXPECT_EQ(r.status, status) << args << ": " << r.output;
    EXPECT_NE(r.output.find(named), std::string::npos) << args << ": " << r.output;
    EXPECT_EQ(files(), std::vector<std::string>{"render-16x12.exr"}) << args;
  };
  refused("-o " + path("t.png") + " --factor 2 --mip", "--mip: -o " + path("t.png"));
  refused("-o " + path("t.tif") + " --factor 2 --mip", "OpenEXR");
  refused("-o " + path("t.exr") + " --factor 2 --mip --lattice hex", "hexagonal");
  refused("-o " + path("t.exr") + " --factor 2 --mip --coeffs " + path("k.png"), "--coeffs");
  refused("-o " + path("t.exr") + " --factor 2 --mip --compression piz", "--compression");
  refused("-o " + path("t.exr") + " --factor 2 --mip -d uint8", "-d");
  refused("-o " + path("t.exr") + " --scale 0.01 --mip", "--scale");  // a size with no level
  refused("-o " + path("t.exr") + " --factor 2 --mip --partial", "--partial");
  // a coefficient file holds one level
  const std::string k = path("k.exr");
  ASSERT_EQ(run(in + " -o " + path("a.exr") + " --factor 2 --coeffs " + k).status, 0);
  const Result r = run(k + " -o " + path("t.exr") + " --mip");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("coefficient file of one level"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(path("t.exr")));
  // a pyramid's coefficient file: its levels' sizes are recorded
  const std::string kp = path("kp.exr");
  ASSERT_EQ(run(in + " -o " + path("b.exr") + " --factor 2 --mip --coeffs " + kp).status, 0);
  const Result s = run(kp + " -o " + path("t.exr") + " --mip --size 4x3");
  EXPECT_EQ(s.status, 2) << s.output;
  EXPECT_NE(s.output.find("drop --factor, --scale and --size"), std::string::npos) << s.output;
  EXPECT_FALSE(std::filesystem::exists(path("t.exr")));
}

TEST_F(Mip, APyramidsCoefficientFileHoldsEveryLevelsOwnCoefficients) {
  const std::string in = render(37, 21, 4, 44);
  const std::string tex = path("tex.exr"), kp = path("kp.exr");
  ASSERT_EQ(run(in + " -o " + tex + " --factor 4 --mip -d float --coeffs " + kp).status, 0);
  // OpenEXR's levels, of maketx's sizes, the coefficients as float
  EXPECT_EQ(mip_levels(kp), mip_levels(tex));
  const auto sizes = pyramid_sizes(37, 21);
  for (std::size_t j = 0; j < sizes.size(); ++j) {
    const auto [w, h] = sizes[j];
    // level j: the coefficient file of the single run at its size, bit for bit
    const std::string kj = path("k" + std::to_string(j) + ".exr");
    ASSERT_EQ(run(in + " -o " + path("img.exr") + " --size " + std::to_string(w) + "x" +
                  std::to_string(h) + " --coeffs " + kj).status, 0);
    const Image mine = read_float(kp, int(j)), own = read_float(kj);
    ASSERT_EQ(mine.data.size(), own.data.size()) << "level " << j;
    EXPECT_EQ(std::memcmp(mine.data.data(), own.data.data(), own.data.size() * sizeof(float)), 0)
        << "level " << j;
    // read back as coefficients of level j's frame
    ImageReader reader(kp);
    EXPECT_EQ(coefficient_levels(reader), int(sizes.size()));
    reader.select_level(int(j));
    const Coefficients k = read_coefficients(reader);
    EXPECT_EQ(k.image_width, double(w));
    EXPECT_EQ(k.image_height, double(h));
    EXPECT_EQ(k.c.width, w);
  }
  // evaluated again: the texture of the direct run, every level bit for bit
  const std::string again = path("again.exr");
  const Result r = run(kp + " -o " + again + " --mip -d float");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(mip_levels(again), mip_levels(tex));
  for (std::size_t j = 0; j < sizes.size(); ++j) {
    const Image a = read_float(again, int(j)), b = read_float(tex, int(j));
    ASSERT_EQ(a.data.size(), b.data.size());
    EXPECT_EQ(std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)), 0)
        << "level " << j;
  }
  // as one coefficient file: level 0, at its frame
  const std::string level0 = path("level0.exr"), direct = path("direct.exr");
  ASSERT_EQ(run(kp + " -o " + level0 + " -d float").status, 0);
  ASSERT_EQ(run(in + " -o " + direct + " --factor 4 -d float").status, 0);
  const Image a = read_float(level0), b = read_float(direct);
  ASSERT_EQ(a.data.size(), b.data.size());
  EXPECT_EQ(std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)), 0);
}

}  // namespace
