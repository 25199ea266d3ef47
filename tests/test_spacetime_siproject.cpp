// siproject --fps: the space-time projection of sub-frames (sis/spacetime.h).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "sis/imageio.h"
#include "support.h"

namespace {

using namespace sis;
using namespace sis::test;
namespace fs = std::filesystem;

const std::string kTool = SIPROJECT;

class SpaceTime : public TempDirTest {
 protected:
  // K sub-frames sub.NNNN.exr, image k = images[k], sis:time = times[k].
  void write_subframes(const std::vector<Image>& images, const std::vector<double>& times) {
    for (std::size_t k = 0; k < images.size(); ++k) {
      char name[32];
      std::snprintf(name, sizeof name, "sub.%04zu.exr", k);
      write_image(path(name), images[k], {}, {{"sis:time", metadata_number(times[k])}});
    }
  }
  std::string subs(std::size_t K) const {
    return path("sub.0-" + std::to_string(K - 1) + "#.exr");
  }
  std::size_t files_in(const std::string& folder) const {
    std::size_t n = 0;
    for (auto& e : fs::directory_iterator(folder)) n += e.is_regular_file();
    return n;
  }
};

// Each frame's sub-frame times: the centres of K equal parts of the frame
// interval [(f - 1/2)/fps, (f + 1/2)/fps), frames 0..n-1.
std::vector<double> centred_times(double fps, int n, int K) {
  std::vector<double> t;
  for (int f = 0; f < n; ++f)
    for (int k = 0; k < K; ++k) t.push_back((f - 0.5 + (k + 0.5) / K) / fps);
  return t;
}

// A static scene (one image K times): every frame is the spatial result.
// The temporal weights sum to 1 to 1e-12 (tests/test_time.cpp), so the frames
// agree with the still image to float rounding of the output (2e-6 relative
// of values in [0, 1] after a cubic projection, whose ringing stays < 2).
TEST_F(SpaceTime, StaticSceneIsTheSpatialResultAtEveryTime) {
  const Image still = random_image(12, 10, 3, 7);
  // uneven times over ten temporal steps (the mirror at the span's ends is
  // exact while the span is longer than a cubic B-spline's support, 4 steps)
  std::vector<double> t;
  for (int k = 0; k < 12; ++k) t.push_back((k + (k % 3 == 1 ? 0.3 : 0.0)) * 0.035);
  write_subframes(std::vector<Image>(t.size(), still), t);
  write_image(path("still.exr"), still);
  ASSERT_EQ(run_tool(kTool, path("still.exr") + " --factor 2 -q -o " + path("still_out.exr")).status, 0);
  fs::create_directory(path("out"));
  for (int D = 0; D <= 3; ++D) {
    const Result r = run_tool(kTool, subs(t.size()) + " --fps 24 --time-degree " + std::to_string(D) +
                                         " --factor 2 -q -o " + path("out/f.#.exr"));
    ASSERT_EQ(r.status, 0) << r.output;
    const Image ref = read_image(path("still_out.exr"));
    int frames = 0;
    for (auto& e : fs::directory_iterator(path("out"))) {
      const Image im = read_image(e.path().string());
      ASSERT_EQ(im.data.size(), ref.data.size());
      for (std::size_t i = 0; i < im.data.size(); ++i)
        ASSERT_NEAR(im.data[i], ref.data[i], 4e-6) << e.path() << " D " << D << " sample " << i;
      ++frames;
    }
    // the span [-0.0175, 0.39725]: frames 0 to 9 at 180 degrees
    EXPECT_EQ(frames, 10) << "D " << D;
    fs::remove_all(path("out"));
    fs::create_directory(path("out"));
  }
}

// Degree 0 with the hold model and a step of the frame interval, a
// 360-degree box centred on the frame (phase -180) and K
// sub-frames at the centres of K equal parts of each frame interval: frame f
// is the projection of the plain average of its K sub-frames (the weights
// are 1/K to 1e-13; both outputs float; 4e-6 as above).
TEST_F(SpaceTime, DegreeZeroFullShutterIsTheSubFrameAverage) {
  const int K = 4, n = 3;
  const double fps = 24;
  const std::vector<double> t = centred_times(fps, n, K);
  std::vector<Image> images;
  for (int k = 0; k < n * K; ++k) images.push_back(random_image(8, 8, 2, 100 + k));
  write_subframes(images, t);
  fs::create_directory(path("out"));
  const Result r = run_tool(kTool, subs(n * K) + " --fps 24 --time-degree 0 --time-model hold --time-step 0.041666666666666667 "
                                   "--shutter 360:-180 "
                                   "--factor 2 -q -o " + path("out/f.#.exr"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(files_in(path("out")), std::size_t(n));
  for (int f = 0; f < n; ++f) {
    Image avg = images[f * K];
    for (std::size_t i = 0; i < avg.data.size(); ++i) {
      double s = 0;
      for (int k = 0; k < K; ++k) s += images[f * K + k].data[i];
      avg.data[i] = float(s / K);
    }
    write_image(path("avg.exr"), avg);
    ASSERT_EQ(run_tool(kTool, path("avg.exr") + " --factor 2 -q -o " + path("avg_out.exr")).status, 0);
    const Image want = read_image(path("avg_out.exr"));
    char name[32];
    std::snprintf(name, sizeof name, "out/f.%04d.exr", f);
    const Image got = read_image(path(name));
    ASSERT_EQ(got.data.size(), want.data.size());
    for (std::size_t i = 0; i < got.data.size(); ++i)
      ASSERT_NEAR(got.data[i], want.data[i], 4e-6) << "frame " << f << " sample " << i;
  }
}

// The frames are bit for bit the same for 1, 2 and 3 threads, both methods.
TEST_F(SpaceTime, BitIdenticalForThreadCounts) {
  const std::vector<double> t = centred_times(24, 3, 3);
  std::vector<Image> images;
  for (std::size_t k = 0; k < t.size(); ++k) images.push_back(random_image(20, 14, 3, 300 + k));
  write_subframes(images, t);
  for (const std::string method : {"min-error", "conventional"}) {
    std::vector<std::vector<Image>> runs;
    for (int threads = 1; threads <= 3; ++threads) {
      const std::string dir = path("t" + std::to_string(threads) + method);
      fs::create_directory(dir);
      const Result r = run_tool(kTool, subs(t.size()) + " --fps 24 --time-degree 3 --method " + method +
                                           " --factor 2 -q --threads " + std::to_string(threads) +
                                           " -o " + dir + "/f.#.exr");
      ASSERT_EQ(r.status, 0) << r.output;
      std::vector<Image> frames;
      for (int f = 0; f <= 2; ++f) {
        char name[32];
        std::snprintf(name, sizeof name, "/f.%04d.exr", f);
        if (fs::exists(dir + name)) frames.push_back(read_image(dir + name));
      }
      ASSERT_FALSE(frames.empty());
      runs.push_back(std::move(frames));
    }
    for (int i = 1; i < 3; ++i) {
      ASSERT_EQ(runs[i].size(), runs[0].size());
      for (std::size_t f = 0; f < runs[0].size(); ++f)
        EXPECT_TRUE(runs[i][f].data == runs[0][f].data) << method << " threads " << i + 1 << " frame " << f;
    }
  }
}

// Sub-frames tagged by oiiotool (`--attrib:type=float sis:time T`, a typed
// float attribute, not the text this project writes) and the same
// sub-frames timed by --times give the same frames bit for bit. The times
// are multiples of 1/128 s, exact in float, so the float attribute holds
// each time exactly.
TEST_F(SpaceTime, TimesTaggedByOiiotoolAreRead) {
  // frames 16 to 18 (times after 1 s: no negative number on oiiotool's
  // command line)
  std::vector<double> t = centred_times(16, 3, 4);
  for (double& x : t) x += 1;
  std::string times;
  for (std::size_t k = 0; k < t.size(); ++k) {
    ASSERT_EQ(double(float(t[k])), t[k]);
    const std::string raw = path("raw" + std::to_string(k) + ".exr");
    write_image(raw, random_image(12, 10, 3, 500 + k));
    char name[32];
    std::snprintf(name, sizeof name, "sub.%04zu.exr", k);
    const Result r = run_tool("oiiotool", raw + " --attrib:type=float sis:time " + metadata_number(t[k]) +
                                              " -o " + path(name));
    ASSERT_EQ(r.status, 0) << r.output;
    times += (k ? "," : "") + metadata_number(t[k]);
  }
  const Result info = run_tool("oiiotool", "--info -v " + path("sub.0004.exr"));
  // a typed float (oiiotool prints its 6 significant digits, no quotes)
  ASSERT_NE(info.output.find("sis:time: 1.03906\n"), std::string::npos) << info.output;
  fs::create_directory(path("a"));
  fs::create_directory(path("b"));
  const std::string common = " --fps 16 --time-degree 1 --factor 2 -q -o ";
  Result r = run_tool(kTool, subs(t.size()) + common + path("a/f.#.exr"));
  ASSERT_EQ(r.status, 0) << r.output;
  std::string raws;
  for (std::size_t k = 0; k < t.size(); ++k) raws += " " + path("raw" + std::to_string(k) + ".exr");
  r = run_tool(kTool, raws + " --times " + times + common + path("b/f.#.exr"));
  ASSERT_EQ(r.status, 0) << r.output;
  ASSERT_EQ(files_in(path("a")), files_in(path("b")));
  ASSERT_GT(files_in(path("a")), 0u);
  for (auto& e : fs::directory_iterator(path("a"))) {
    const Image a = read_image(e.path().string());
    const Image b = read_image(path("b/" + e.path().filename().string()));
    EXPECT_TRUE(a.data == b.data) << e.path();
  }
}

// The frames' output options are the still image's: -d half clamps values
// past half's largest (65504) and says so, with the count and the range in
// the metadata; --compression is the writer's; a -d the format cannot hold
// is refused before any sub-frame is read, leaving nothing.
TEST_F(SpaceTime, OutputOptionsAreTheStillImagesOptions) {
  const std::vector<double> t = centred_times(24, 2, 4);
  std::vector<Image> images;
  for (std::size_t k = 0; k < t.size(); ++k) {
    Image im = random_image(8, 8, 3, 700 + k);
    for (std::size_t i = 0; i < im.data.size(); i += 3) im.data[i] = 1e5f;  // red past half's range
    images.push_back(std::move(im));
  }
  write_subframes(images, t);
  fs::create_directory(path("h"));
  Result r = run_tool(kTool, subs(t.size()) + " --fps 24 --factor 2 -d half -o " + path("h/f.#.exr"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("-d half: 16 samples beyond +-65504 clamped there"), std::string::npos) << r.output;
  ASSERT_EQ(files_in(path("h")), 2u);  // frames 0 and 1 (4 x 4: 16 red samples each)
  for (const std::string& frame : {path("h/f.0000.exr"), path("h/f.0001.exr")}) {
    const Image h = read_image(frame);
    for (std::size_t i = 0; i < h.data.size(); i += 3) ASSERT_EQ(h.data[i], 65504.0f) << frame << " " << i;
    EXPECT_EQ(ImageReader(frame).attribute("sis:half_clamped"), "16") << frame;
    EXPECT_EQ(ImageReader(frame).attribute("sis:output_max"), std::to_string(65504.0)) << frame;
  }

  fs::create_directory(path("c"));
  r = run_tool(kTool, subs(t.size()) + " --fps 24 --factor 2 -q --compression piz -o " + path("c/f.#.exr"));
  ASSERT_EQ(r.status, 0) << r.output;
  const Result info = run_tool("oiiotool", "--info -v " + path("c/f.0000.exr"));
  EXPECT_NE(info.output.find("compression: \"piz\""), std::string::npos) << info.output;

  fs::create_directory(path("p"));
  r = run_tool(kTool, subs(t.size()) + " --fps 24 --factor 2 -d half -o " + path("p/f.#.png"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("-d/--data-format half"), std::string::npos) << r.output;
  EXPECT_EQ(files_in(path("p")), 0u);
}

// Each bad sequence: a non-zero status, a message naming the file or the
// option, and no output.
TEST_F(SpaceTime, BadSequencesAreRefusedLeavingNothing) {
  const std::vector<double> t = {0.0, 0.02, 0.04, 0.06, 0.08};
  std::vector<Image> images;
  for (std::size_t k = 0; k < t.size(); ++k) images.push_back(random_image(8, 8, 3, 500 + k));
  write_subframes(images, t);
  write_image(path("small.exr"), random_image(6, 8, 3, 1), {}, {{"sis:time", "0.1"}});
  write_image(path("gray.exr"), random_image(8, 8, 1, 1), {}, {{"sis:time", "0.1"}});
  write_image(path("notime.exr"), random_image(8, 8, 3, 1));
  write_image(path("badtime.exr"), random_image(8, 8, 3, 1), {}, {{"sis:time", "soon"}});
  write_image(path("early.exr"), random_image(8, 8, 3, 1), {}, {{"sis:time", "0.01"}});
  write_image(path("same.exr"), random_image(8, 8, 3, 1), {}, {{"sis:time", "0.08"}});
  fs::create_directory(path("out"));
  const std::string all = subs(t.size());
  const std::string o = " -o " + path("out/f.#.exr") + " --factor 2";
  struct Case {
    std::string args, named;
  } cases[] = {
      {all + " " + path("missing.exr") + " --fps 24", "missing.exr"},
      {all + " " + path("small.exr") + " --fps 24", "small.exr"},
      {all + " " + path("gray.exr") + " --fps 24", "gray.exr"},
      {all + " " + path("notime.exr") + " --fps 24", "notime.exr"},
      {all + " " + path("badtime.exr") + " --fps 24", "badtime.exr"},
      {all + " " + path("early.exr") + " --fps 24", "early.exr"},
      {all + " " + path("same.exr") + " --fps 24", "same.exr"},
      {all + " --fps 24 --times 0,0.02,nan,0.06,0.08", "--times"},
      {all + " --fps 24 --times 0,0.02,0.04", "--times"},
      {path("sub.0000.exr") + " --fps 24", "--fps"},
      {all + " --fps 24 --shutter 0", "--shutter"},
      {all + " --fps 24 --shutter 400", "--shutter"},
      {all + " --fps 24 --shutter-curve " + path("nocurve.txt"), "nocurve.txt"},
      {all + " --fps 24 --frames 0-5", "--frames"},
      {all + " --fps 0", "--fps"},
      {all + " --fps 24 --time-degree 4", "--time-degree"},
      {all + " --fps 24 --time-model spline", "--time-model"},
      {all + " --fps 24 --time-step 0", "--time-step"},
      {all + " --shutter 90", "--fps"},
      {all + " --time-model cubic", "--fps"},
  };
  for (const Case& c : cases) {
    const Result r = run_tool(kTool, c.args + o);
    EXPECT_NE(r.status, 0) << c.args;
    EXPECT_NE(r.output.find(c.named), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(files_in(path("out")), 0u) << c.args;
  }
}

}  // namespace
