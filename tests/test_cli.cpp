// The command lines as users of neighbouring tools type them: sizes and
// names as oiiotool spells them, frame sequences and batches, the first
// real error of a multi-threaded run, out of memory in every tool, and the
// options' documentation.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstring>
#include <map>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "sis/imageio.h"
#include "sis/sequence.h"
#include "support.h"

namespace fs = std::filesystem;
using namespace sis;
using namespace sis::test;

#if !defined(SIPROJECT) || !defined(SIMETRICS) || !defined(SISTABILITY) || !defined(DOCS_DIR)
#error "SIPROJECT, SIMETRICS, SISTABILITY and DOCS_DIR must be defined"
#endif

namespace {

Result run(const std::string& args) { return run_tool(SIPROJECT, args); }
Result shell(const std::string& cmd) { return run_tool("bash -c", "'" + cmd + "'"); }

class Cli : public TempDirTest {};

void write_exr(const std::string& path, const Image& img, OIIO::TypeDesc type = OIIO::TypeDesc::FLOAT) {
  OIIO::ImageSpec spec(int(img.width), int(img.height), img.channels, type);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::FLOAT, img.data.data()) && out->close());
}

std::pair<long, long> size_of(const std::string& path) {
  const Image im = read_image(path);
  return {im.width, im.height};
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_F(Cli, SizesAsOiiotoolSpellsThem) {
  // 101 x 75: every spelling rounds each side to the nearest pixel, halves
  // up, as oiiotool does (50% of 101 is 50.5: 51).
  write_exr(path("in.exr"), random_image(101, 75, 1, 3));
  const std::string in = path("in.exr") + " -q -o " + path("o.exr");
  struct Case {
    std::string opts;
    long w, h;
  };
  const std::vector<Case> cases = {
      {"--size 40x30", 40, 30},
      {"--size 40", 40, 30},        // 40 * 75 / 101 = 29.7
      {"--size 40x0", 40, 30},
      {"--size 0x30", 40, 30},      // 30 * 101 / 75 = 40.4
      {"--size 50%", 51, 38},       // 50.5, 37.5
      {"--size 33%x50%", 33, 38},   // 33.33, 37.5
      {"--size 20%x30", 20, 30},    // 20.2
      {"--resize 50%", 51, 38},
      {"--scale 0.5", 51, 38},
      {"--scale 1.5", 152, 113},    // 151.5, 112.5
      {"--factor 2", 51, 38},
  };
  for (const Case& c : cases) {
    const Result r = run(in + " " + c.opts);
    ASSERT_EQ(r.status, 0) << c.opts << ": " << r.output;
    EXPECT_EQ(size_of(path("o.exr")), std::make_pair(c.w, c.h)) << c.opts;
  }
  // oiiotool's own --resize gives the same sizes where no side falls on a
  // half pixel (there oiiotool 2.4 rounds either way: 50% of 101 is 52,
  // 10% of 75 is 7)
  for (const std::string g : {"0x30", "25%", "33%x50%"}) {
    const Result o = run_tool("oiiotool", path("in.exr") + " --resize " + g +
                                              " --echo \"{TOP.width}x{TOP.height}\"");
    ASSERT_EQ(o.status, 0) << o.output;
    ASSERT_EQ(run(in + " --size " + g).status, 0);
    const auto [w, h] = size_of(path("o.exr"));
    EXPECT_TRUE(contains(o.output, std::to_string(w) + "x" + std::to_string(h))) << g << ": " << o.output;
  }
  // one projection whatever the spelling: 50%, 0.5 and factor 2 on 100 x 76
  write_exr(path("even.exr"), random_image(100, 76, 3, 4));
  ASSERT_EQ(run(path("even.exr") + " -q -o " + path("f.exr") + " --factor 2").status, 0);
  for (const std::string opts : {"--size 50%", "--scale 0.5", "--size 50x38", "--size 50", "--size 0x38"}) {
    ASSERT_EQ(run(path("even.exr") + " -q -o " + path("s.exr") + " " + opts).status, 0) << opts;
    EXPECT_EQ(read_image(path("s.exr")).data, read_image(path("f.exr")).data) << opts;
  }
  // a coefficient file evaluated at a percentage of its frame
  ASSERT_EQ(run(path("even.exr") + " -q -o " + path("f.exr") + " --factor 2 --coeffs " + path("c.exr")).status, 0);
  ASSERT_EQ(run(path("c.exr") + " -q -o " + path("big.exr") + " --size 200%").status, 0);
  EXPECT_EQ(size_of(path("big.exr")), std::make_pair(100L, 76L));
  // refused, naming the option, nothing written
  fs::remove(path("o.exr"));
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--size 0x0", "--size '0x0': expected WxH"},
      {"--size 0", "--size '0': expected WxH"},
      {"--size abc", "--size 'abc': expected WxH"},
      {"--size 40x", "--size '40x': expected WxH"},
      {"--size 40x30x2", "--size '40x30x2': expected WxH"},
      {"--size -40x30", "expected WxH"},
      {"--size 0%", "--size '0%': expected WxH"},
      {"--size 1e3%", "--size '1e3%': expected WxH"},
      {"--size 0.001%", "the output of the 101 x 75 image would be 0 x 0 pixels"},
      {"--scale 0", "--scale 0: expected a finite number above 0"},
      {"--scale nan", "--scale nan: expected a finite number above 0"},
      {"--scale 0.5 --factor 2", "give one of --factor, --size and --scale"},
      {"--size 50% --factor 2", "give one of --factor, --size and --scale"},
      {"--scale 1e12", "more than 2147483647 per side"},
  };
  for (const auto& [opts, says] : bad) {
    const Result r = run(in + " " + opts);
    EXPECT_EQ(r.status, 2) << opts << ": " << r.output;
    EXPECT_TRUE(contains(r.output, says)) << opts << ": " << r.output;
    EXPECT_FALSE(fs::exists(path("o.exr"))) << opts;
  }
}

TEST_F(Cli, AliasesGiveTheCanonicalNamesBits) {
  // Each alias against its canonical name: the same pixels, and the
  // canonical name in the metadata.
  write_exr(path("in.exr"), random_image(60, 48, 3, 5));
  const std::string in = path("in.exr") + " -q --factor 3 -d float ";
  struct Case {
    std::string canonical, alias, key, value;
  };
  const std::vector<Case> cases = {
      {"--generator tent", "--generator triangle", "sis:generator", "tent"},
      {"--generator tent", "--filter triangle", "sis:generator", "tent"},
      {"--generator tent --method conventional", "--filter triangle --method conventional",
       "sis:method", "conventional"},
      {"--generator mitchell", "--filter mitchell", "sis:generator", "mitchell"},
      {"--display centred", "--display center", "sis:display", "centred"},
      {"--display centred", "--display centre", "sis:display", "centred"},
      {"--display centred", "--display centered", "sis:display", "centred"},
      {"--lattice hex", "--lattice hexagonal", "sis:lattice", "hexagonal"},
      {"--lattice hex --generator hex-hat", "--lattice hexagonal --filter hex-hat", "sis:generator",
       "hex-hat"},
  };
  for (const Case& c : cases) {
    ASSERT_EQ(run(in + c.canonical + " -o " + path("a.exr")).status, 0) << c.canonical;
    const Result r = run(in + c.alias + " -o " + path("b.exr"));
    ASSERT_EQ(r.status, 0) << c.alias << ": " << r.output;
    EXPECT_EQ(read_image(path("a.exr")).data, read_image(path("b.exr")).data) << c.alias;
    EXPECT_EQ(ImageReader(path("b.exr")).attribute(c.key), c.value) << c.alias;
    EXPECT_EQ(ImageReader(path("b.exr")).attribute("sis:generator"),
              ImageReader(path("a.exr")).attribute("sis:generator")) << c.alias;
  }
  // the messages name the new spellings
  Result r = run(in + "--lattice hexa -o " + path("c.exr"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "expected cartesian or hex (hexagonal)")) << r.output;
}

TEST(FrameRange, AsOiiotoolSpellsIt) {
  using V = std::vector<long>;
  EXPECT_EQ(parse_frame_range("7"), V({7}));
  EXPECT_EQ(parse_frame_range("1-5"), V({1, 2, 3, 4, 5}));
  EXPECT_EQ(parse_frame_range("5-1"), V({5, 4, 3, 2, 1}));
  EXPECT_EQ(parse_frame_range("1-10x3"), V({1, 4, 7, 10}));
  EXPECT_EQ(parse_frame_range("1-10y3"), V({2, 3, 5, 6, 8, 9}));
  EXPECT_EQ(parse_frame_range("1-5x2"), V({1, 3, 5}));  // oiiotool's examples
  EXPECT_EQ(parse_frame_range("1-5y2"), V({2, 4}));
  EXPECT_EQ(parse_frame_range("3,4,10-20x2"), V({3, 4, 10, 12, 14, 16, 18, 20}));
  EXPECT_EQ(parse_frame_range("0010-0012"), V({10, 11, 12}));
  for (const std::string bad : {"", "a", "1-", "-3", "1,,2", "1,", "1-5x0", "1-5x", "1-5z2", "1.5",
                                "0-2000000"})
    EXPECT_THROW(parse_frame_range(bad), std::invalid_argument) << bad;
}

TEST(FramePattern, WildcardsAsOiiotoolSpellsThem) {
  auto p = parse_frame_pattern("dir/big.1-3#.tif");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->prefix, "dir/big.");
  EXPECT_EQ(p->suffix, ".tif");
  EXPECT_EQ(p->range, "1-3");
  EXPECT_EQ(p->name(2), "dir/big.0002.tif");
  EXPECT_EQ(parse_frame_pattern("f.#@@.exr")->name(12), "f.000012.exr");  // 4 + 1 + 1 digits
  EXPECT_EQ(parse_frame_pattern("f.@@@.exr")->name(7), "f.007.exr");
  EXPECT_EQ(parse_frame_pattern("f.%04d.exr")->name(7), "f.0007.exr");
  EXPECT_EQ(parse_frame_pattern("f.%d.exr")->name(123), "f.123.exr");
  EXPECT_EQ(parse_frame_pattern("f.#.exr", 3)->name(7), "f.007.exr");     // --framepadding
  EXPECT_EQ(parse_frame_pattern("f.%04d.exr", 2)->name(7), "f.0007.exr");  // not for printf
  EXPECT_EQ(parse_frame_pattern("f.1-10x2%03d.exr")->range, "1-10x2");
  EXPECT_EQ(parse_frame_pattern("shot-1-3#.exr")->prefix, "shot-");
  EXPECT_EQ(parse_frame_pattern("take.#.exr")->range, "");
  EXPECT_FALSE(parse_frame_pattern("plain.exr"));
  EXPECT_FALSE(parse_frame_pattern("100%.exr"));
  EXPECT_FALSE(parse_frame_pattern("dir#/plain.exr"));  // folders are not patterns
  EXPECT_THROW(parse_frame_pattern("f.#.#.exr"), std::invalid_argument);
}

TEST_F(Cli, FrameSequencesToAFolderAndToAPattern) {
  // Three frames (distinct images) projected as a sequence give the three
  // single runs' files, bit for bit, whatever the spelling.
  fs::create_directory(path("in"));
  for (int f = 1; f <= 3; ++f)
    write_exr(path("in/f." + std::string("000") + std::to_string(f) + ".exr"),
              random_image(48, 36, 3, 10 + f));
  const std::string opts = " -q --factor 3 -d float";
  fs::create_directory(path("single"));
  for (int f = 1; f <= 3; ++f) {
    const std::string n = "f.000" + std::to_string(f) + ".exr";
    ASSERT_EQ(run(path("in/" + n) + " -o " + path("single/" + n) + opts).status, 0);
  }
  auto same_as_singles = [&](const std::string& pattern) {
    for (int f = 1; f <= 3; ++f) {
      char name[64];
      std::snprintf(name, sizeof name, pattern.c_str(), f);
      ASSERT_TRUE(fs::exists(name)) << name;
      EXPECT_EQ(read_image(name).data,
                read_image(path("single/f.000" + std::to_string(f) + ".exr")).data) << name;
    }
  };
  struct Case {
    std::string inputs, output, written;  // written: printf of each frame's output
  };
  const std::vector<Case> cases = {
      {path("in/f.#.exr"), path("a/"), path("a/f.%04d.exr")},
      {path("in/f.1-3#.exr"), path("b"), path("b/f.%04d.exr")},
      {path("in/f.@@@@.exr"), path("c/out.%03d.exr"), path("c/out.%03d.exr")},
      {"--frames 1-3 " + path("in/f.%04d.exr"), path("d/o.#.exr"), path("d/o.%04d.exr")},
      {path("in/f.1-3#.exr"), path("e/o.1-3@.exr"), path("e/o.%d.exr")},
      {path("in/f.0001.exr") + " " + path("in/f.0002.exr") + " " + path("in/f.0003.exr"), path("g/"),
       path("g/f.%04d.exr")},
  };
  for (const Case& c : cases) {
    fs::create_directories(fs::path(c.written).parent_path());
    const Result r = run(c.inputs + " -o " + c.output + opts);
    ASSERT_EQ(r.status, 0) << c.inputs << " -o " << c.output << ": " << r.output;
    same_as_singles(c.written);
    EXPECT_EQ(std::distance(fs::directory_iterator(fs::path(c.written).parent_path()),
                            fs::directory_iterator()), 3) << c.output;
  }
  // backwards and with a step: the frames named, nothing else
  fs::create_directory(path("h"));
  ASSERT_EQ(run(path("in/f.3-1x2#.exr") + " -o " + path("h/") + opts).status, 0);
  EXPECT_TRUE(fs::exists(path("h/f.0001.exr")) && fs::exists(path("h/f.0003.exr")));
  EXPECT_FALSE(fs::exists(path("h/f.0002.exr")));
  // the coefficient files of a sequence, to a pattern
  fs::create_directory(path("k"));
  ASSERT_EQ(run(path("in/f.#.exr") + " -o " + path("k/") + " --coeffs " + path("k/c.#.exr") + opts).status, 0);
  for (int f = 1; f <= 3; ++f)
    EXPECT_EQ(ImageReader(path("k/c.000" + std::to_string(f) + ".exr")).attribute("sis:input"),
              "f.000" + std::to_string(f) + ".exr");
}

TEST_F(Cli, FrameSequencesRefuseWhatTheyCannotDo) {
  fs::create_directory(path("in"));
  for (int f = 1; f <= 3; ++f)
    write_exr(path("in/f.000" + std::to_string(f) + ".exr"), random_image(48, 36, 3, 20 + f));
  fs::create_directory(path("out"));
  const std::string opts = " --factor 3";
  struct Case {
    std::string args;
    int status;
    std::string says;
  };
  const std::vector<Case> cases = {
      // a missing frame of a range: nothing runs
      {path("in/f.1-4#.exr") + " -o " + path("out/"), 3,
       path("in/f.0004.exr") + ": no such file (frame 4 of " + path("in/f.1-4#.exr") + ")"},
      {"--frames 2-5 " + path("in/f.#.exr") + " -o " + path("out/"), 3, "f.0004.exr: no such file (frame 4"},
      {path("in/g.#.exr") + " -o " + path("out/"), 3, "g.#.exr: no file matches the frame pattern"},
      {path("in/f.0001.exr") + " " + path("in/f.0009.exr") + " -o " + path("out/"), 3,
       path("in/f.0009.exr") + ": no such file"},
      // several frames, one output file
      {path("in/f.#.exr") + " -o " + path("out/one.exr"), 2,
       "3 input frames and one output file " + path("out/one.exr") + ": give -o a folder"},
      {path("in/f.0001.exr") + " " + path("in/f.0002.exr") + " -o " + path("out/one.exr"), 2,
       "row bands of one image: --bands"},
      // a pattern output needs numbered inputs
      {path("in/f.0001.exr") + " " + path("in/f.0002.exr") + " -o " + path("out/o.#.exr"), 2,
       "a pattern numbers frames from numbered inputs"},
      {path("in/f.1-3#.exr") + " -o " + path("out/o.1-2#.exr"), 2, "its frame range is not the inputs' frames"},
      {path("in/f.1-3#.exr") + " --frames 1-3 -o " + path("out/"), 2, "give one"},
      {path("in/f.0001.exr") + " --frames 1-3 -o " + path("out/"), 2, "no input has a frame wildcard"},
      {path("in/f.#.exr") + " -o " + path("in/"), 2, "would be written over an input frame"},
      {path("in/f.#.exr") + " -o " + path("nowhere/"), 4, "-o " + path("nowhere/") + ": no such folder"},
      {path("in/f.#.#.exr") + " -o " + path("out/"), 2, "more than one frame wildcard"},
      {path("in/f.#.exr") + " -o " + path("out/") + " --coeffs " + path("out/c.exr"), 2,
       "give --coeffs a folder or a pattern"},
      {"--bands " + path("in/f.#.exr") + " -o " + path("out/"), 2, "--bands makes one image"},
      {path("in/f.#.exr") + " --frames 1-2,x -o " + path("out/"), 2, "--frames: frame range '1-2,x'"},
  };
  for (const Case& c : cases) {
    const Result r = run(c.args + opts);
    EXPECT_EQ(r.status, c.status) << c.args << ": " << r.output;
    EXPECT_TRUE(contains(r.output, c.says)) << c.args << ": " << r.output;
    EXPECT_TRUE(fs::is_empty(path("out"))) << c.args;
  }
  // One frame that fails stops the sequence, as oiiotool stops: the frames
  // before it written whole, it and those after not, no temporary file,
  // the input's status.
  Image bad = random_image(48, 36, 3, 22);
  bad.at(5, 5, 0) = NAN;
  write_exr(path("in/f.0002.exr"), bad);
  const Result r = run(path("in/f.#.exr") + " -o " + path("out/") + opts);
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_TRUE(contains(r.output, "f.0002.exr: non-finite sample")) << r.output;
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(path("out"))) names.push_back(e.path().filename());
  EXPECT_EQ(names, std::vector<std::string>{"f.0001.exr"});
}

TEST_F(Cli, HexagonalBandsReportTheFirstRealError) {
  // 4000 rows: 16 bands of the acquisition, taken on 3 to 8 threads. A NaN
  // in a late band, or a file cut short, is reported as such (status 3),
  // never as the bands that gave up waiting on it, at every thread count
  // and run after run.
  Image img = random_image(200, 4000, 3, 41);
  write_exr(path("whole.exr"), img, OIIO::TypeDesc::HALF);
  img.at(17, 3300, 2) = NAN;
  write_exr(path("nan.exr"), img, OIIO::TypeDesc::HALF);
  {
    const auto size = fs::file_size(path("whole.exr"));
    std::ifstream in(path("whole.exr"), std::ios::binary);
    std::string bytes(size * 6 / 10, '\0');
    in.read(bytes.data(), std::streamsize(bytes.size()));
    std::ofstream(path("cut.exr"), std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  }
  for (int t : {3, 4, 8})
    for (int rep = 0; rep < 4; ++rep) {
      const std::string opts = " --factor 4 --lattice hex --threads " + std::to_string(t) + " -o " + path("o.exr");
      Result r = run(path("nan.exr") + opts);
      EXPECT_EQ(r.status, 3) << t << " threads: " << r.output;
      EXPECT_TRUE(contains(r.output, "nan.exr: non-finite sample (NaN or Inf) at x 17, y 3300, channel B"))
          << t << " threads: " << r.output;
      r = run(path("cut.exr") + opts);
      EXPECT_EQ(r.status, 3) << t << " threads: " << r.output;
      // refused by the header check before any band is read
      EXPECT_TRUE(contains(r.output, "cut.exr: truncated file: the chunk of rows from"))
          << t << " threads: " << r.output;
      EXPECT_FALSE(contains(r.output, "abandoned")) << t << " threads: " << r.output;
      EXPECT_FALSE(fs::exists(path("o.exr")));
    }
}

TEST_F(Cli, EveryToolReportsRunningOutOfMemory) {
  // Under a 1 GB address-space limit: a message and status 1, not an
  // uncaught std::bad_alloc (which aborts, status 134 through the shell).
  Result r = shell("ulimit -v 1000000; " + std::string(SISTABILITY) + " --size 4096 --factor 16");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "sistability: out of memory (--size 4096 --factor 16")) << r.output;
  // simetrics: an image whose pixels pass the limit (its header is small)
  const std::string big = path("big.exr");
  {
    OIIO::ImageSpec spec(20000, 20000, 4, OIIO::TypeDesc::HALF);
    spec.tile_width = spec.tile_height = 64;
    auto out = OIIO::ImageOutput::create(big);
    ASSERT_TRUE(out && out->open(big, spec));
    std::vector<std::uint16_t> tile(64 * 64 * 4, 0x3c00);
    for (int y = 0; y < 20000; y += 64)
      for (int x = 0; x < 20000; x += 64)
        ASSERT_TRUE(out->write_tile(x, y, 0, OIIO::TypeDesc::HALF, tile.data()));
    ASSERT_TRUE(out->close());
  }
  r = shell("ulimit -v 1000000; " + std::string(SIMETRICS) + " " + big);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "simetrics: out of memory")) << r.output;
}

TEST_F(Cli, SiprojectReportsRunningOutOfMemoryAtEveryLimit) {
  // siproject's memory check refuses a request the limit cannot hold (status
  // 2, naming what it needs); below that, from the start-up floor of its
  // libraries, each allocation that fails is out of memory (status 1), or the
  // input's reader saying it could not allocate (status 3), never an abort, a
  // crash, or another error's message ("no writer for this name's format").
  ASSERT_EQ(run_tool("oiiotool", "--pattern constant:color=0.5,0.5,0.5 2000x2000 3 -d half -o " +
                                     path("in.exr")).status, 0);
  const auto limited = [&](long kb, const std::string& args) {
    return shell("ulimit -v " + std::to_string(kb) + "; exec " + std::string(SIPROJECT) + " " + args);
  };
  // the floor: the least limit (in MB steps) at which siproject reaches main
  // (below, the loader cannot map its libraries, or OpenImageIO's static
  // initialisers fail); from there --version prints or runs out of memory
  const auto started = [&](long kb) {
    const Result r = limited(kb, "--version");
    return r.status == 0 || (r.status == 1 && contains(r.output, "siproject: out of memory"));
  };
  long lo = 1 << 10, hi = 4 << 20;  // KB
  ASSERT_TRUE(started(hi));
  while (hi - lo > 1 << 10) {
    const long mid = (lo + hi) / 2;
    (started(mid) ? hi : lo) = mid;
  }
  const std::string args = path("in.exr") + " -o " + path("o.exr") + " --factor 4 --threads 2";
  std::set<int> seen;
  for (long kb = hi; kb < hi + (64 << 10); kb += 1 << 10) {
    const Result r = limited(kb, args);
    seen.insert(r.status);
    const std::string at = std::to_string(kb) + " KB: ";
    EXPECT_TRUE(r.status == 1 || r.status == 2 || r.status == 3) << at << r.status << " " << r.output;
    if (r.status == 1) {
      EXPECT_TRUE(contains(r.output, "siproject: out of memory")) << at << r.output;
    }
    if (r.status == 3) {
      EXPECT_TRUE(contains(r.output, "bad_alloc") || contains(r.output, "allocate memory")) << at << r.output;
    }
    if (r.status == 2) {
      EXPECT_TRUE(contains(r.output, "the request needs about")) << at << r.output;
      break;  // the memory check is reached: every larger limit reaches it
    }
    EXPECT_FALSE(fs::exists(path("o.exr"))) << at;
  }
  EXPECT_TRUE(seen.count(1)) << "no limit ran out of memory past the floor";
  EXPECT_TRUE(seen.count(2)) << "no limit reached the memory check";
}

TEST(Docs, EveryOptionOfSiprojectIsDocumented) {
  // Every long option siproject --help prints appears in docs/siproject.md,
  // written as `--option` (the table's or the text's code spans).
  const Result help = run("--help");
  ASSERT_EQ(help.status, 0);
  std::ifstream in(std::string(DOCS_DIR) + "/siproject.md");
  std::stringstream doc;
  doc << in.rdbuf();
  const std::string md = doc.str();
  // the option lines: "  -o,--output TEXT ...", "  --size,--resize TEXT ..."
  std::set<std::string> options;
  const std::regex line("^ +(-[a-zA-Z],)?(--[a-z][a-z0-9-]*)(,(--[a-z][a-z0-9-]*))?");
  std::istringstream lines(help.output);
  for (std::string l; std::getline(lines, l);) {
    std::smatch m;
    if (!std::regex_search(l, m, line)) continue;
    options.insert(m[2]);
    if (m[4].matched) options.insert(m[4]);
  }
  ASSERT_GE(options.size(), 25u) << help.output;  // the options section was read
  for (const std::string& o : options) {
    if (o == "--help") continue;
    EXPECT_TRUE(std::regex_search(md, std::regex("`" + o + "[` ,=]"))) << o << " is not in docs/siproject.md";
  }
}

// ---- output formats as oiiotool users expect ---------------------------------

namespace {

// The sRGB encoding (IEC 61966-2-1) in double, written here: the expected
// integer samples are not computed by the encoder under test.
double srgb_encode(double v) {
  v = std::clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

struct Read {
  OIIO::ImageSpec spec;
  std::string format;
  std::vector<float> floats;           // every sample, as OpenImageIO converts it
  std::vector<std::uint16_t> uint16s;  // the same, as uint16
};

Read read_back(const std::string& path) {
  Read r;
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path << ": " << OIIO::geterror();
  if (!in) return r;
  r.spec = in->spec();
  r.format = in->format_name();
  const std::size_t n = std::size_t(r.spec.width) * r.spec.height * r.spec.nchannels;
  r.floats.resize(n);
  r.uint16s.resize(n);
  EXPECT_TRUE(in->read_image(0, 0, 0, r.spec.nchannels, OIIO::TypeDesc::FLOAT, r.floats.data()));
  EXPECT_TRUE(in->read_image(0, 0, 0, r.spec.nchannels, OIIO::TypeDesc::UINT16, r.uint16s.data()));
  return r;
}

// A smooth 3-channel float input whose output spans [0, 1] and beyond.
void write_ramp(const std::string& path, long w, long h, int channels = 3) {
  Image in(w, h, channels);
  for (long y = 0; y < h; ++y)
    for (long x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c)
        in.at(x, y, c) = float(1.1 * (x + 0.5) / w * (c + 1) / channels + 0.002 * y);
  write_exr(path, in);
}

const char* const kTypes[] = {"uint8", "uint16", "half", "float"};
const OIIO::TypeDesc kOiioTypes[] = {OIIO::TypeDesc::UINT8, OIIO::TypeDesc::UINT16,
                                     OIIO::TypeDesc::HALF, OIIO::TypeDesc::FLOAT};

}  // namespace

TEST_F(Cli, WriterTableIsWhatOpenImageIOsWritersDo) {
  // Each format written by OpenImageIO itself (not our writer) with each
  // sample type, a namespaced key and a long multi-line description, read
  // back: the types it holds and how it carries metadata are the table's.
  std::string description;
  for (int k = 0; k < 16; ++k) description += "sis:key" + std::to_string(k) + "=" + std::string(30, 'v') + "\n";
  const std::pair<const char*, int> formats[] = {
      {"exr", 3}, {"tif", 3}, {"png", 3}, {"jpg", 3}, {"tga", 3}, {"dpx", 3}, {"sgi", 3},
      {"fits", 3}, {"bmp", 3}, {"ppm", 3}, {"hdr", 3}, {"webp", 3}, {"iff", 3}, {"gif", 3},
      {"rla", 3}, {"heic", 3}, {"zfile", 1}};
  for (const auto& [ext, channels] : formats) {
    const std::string name = path(std::string("probe.") + ext);
    std::string held;
    for (int t = 0; t < 4; ++t) {
      OIIO::ImageSpec spec(8, 8, channels, kOiioTypes[t]);
      if (t == 2 && std::string(ext) == "tif") spec.attribute("tiff:half", 1);  // as stage_image asks
      // 16-bit values no multiple of 257, read back exactly: 8-bit values
      // widened (PNM) do not pass
      std::vector<std::uint16_t> want(8 * 8 * channels);
      std::vector<float> px(want.size(), 0.5f);
      for (std::size_t q = 0; q < px.size() && t == 1; ++q)
        px[q] = float(want[q] = std::uint16_t((1 + 997 * q) % 65536)) / 65535;
      auto out = OIIO::ImageOutput::create(name);
      ASSERT_TRUE(out) << name;
      const bool wrote = out->open(name, spec) && out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close();
      out.reset();
      auto in = wrote ? OIIO::ImageInput::open(name) : nullptr;
      bool holds = in && in->spec().format == kOiioTypes[t];
      if (holds && t == 1) {
        std::vector<std::uint16_t> back(px.size());
        holds = in->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT16, back.data()) && back == want;
      }
      in.reset();
      EXPECT_EQ(holds_format(name, SampleFormat(t)), holds) << name << " " << kTypes[t];
      fs::remove(name);
    }
    OIIO::ImageSpec spec(8, 8, channels, std::string(ext) == "hdr" || std::string(ext) == "zfile"
                                             ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
    spec.attribute("sis:probe", "kept");
    spec.attribute("ImageDescription", description);
    std::vector<float> px(8 * 8 * channels, 0.5f);
    auto out = OIIO::ImageOutput::create(name);
    ASSERT_TRUE(out->open(name, spec) && out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close()) << name;
    out.reset();
    auto in = OIIO::ImageInput::open(name);
    ASSERT_TRUE(in) << name;
    const MetadataCarrier measured =
        in->spec().get_string_attribute("sis:probe") == "kept" ? MetadataCarrier::Named
        : in->spec().get_string_attribute("ImageDescription") == description ? MetadataCarrier::Description
                                                                             : MetadataCarrier::None;
    EXPECT_EQ(int(metadata_carrier(name)), int(measured)) << name;
  }
}

TEST_F(Cli, RangeReportIsInEveryFormatThatCarriesIt) {
  write_ramp(path("in.exr"), 32, 24);
  // the keys' values, from the EXR output (named string attributes)
  ASSERT_EQ(run(path("in.exr") + " -o " + path("o.exr") + " --factor 2 -q").status, 0);
  auto exr = OIIO::ImageInput::open(path("o.exr"));
  ASSERT_TRUE(exr);
  std::map<std::string, std::string> expected;
  for (const auto& p : exr->spec().extra_attribs)
    if (p.name().string().rfind("sis:", 0) == 0) expected[p.name().string()] = p.get_string();
  exr.reset();
  ASSERT_GE(expected.size(), 14u);
  EXPECT_EQ(expected["sis:method"], "min-error");
  EXPECT_EQ(expected["sis:generator"], "cubic");
  EXPECT_EQ(expected["sis:input"], "in.exr");
  EXPECT_EQ(expected["sis:highlight_compress"], "0");
  EXPECT_EQ(expected["sis:lattice"], "cartesian");
  EXPECT_EQ(expected["sis:half_clamped"], "0");
  // PNG by name; TIFF, JPEG and HEIF as key=value lines of the description,
  // read by OpenImageIO and parsed here, and through ImageReader::attribute
  for (const char* ext : {"png", "tif", "jpg", "heic"}) {
    const std::string out = path(std::string("o.") + ext);
    ASSERT_EQ(run(path("in.exr") + " -o " + out + " --factor 2 -q").status, 0) << out;
    auto in = OIIO::ImageInput::open(out);
    ASSERT_TRUE(in) << out;
    std::map<std::string, std::string> got;
    for (const auto& p : in->spec().extra_attribs)
      if (p.name().string().rfind("sis:", 0) == 0) got[p.name().string()] = p.get_string();
    std::istringstream lines(in->spec().get_string_attribute("ImageDescription"));
    for (std::string l; std::getline(lines, l);)
      if (l.rfind("sis:", 0) == 0 && l.find('=') != std::string::npos)
        got[l.substr(0, l.find('='))] = l.substr(l.find('=') + 1);
    EXPECT_EQ(got, expected) << out;
    const ImageReader reader(out);
    for (const auto& [k, v] : expected) EXPECT_EQ(reader.attribute(k), v) << out << " " << k;
  }
  // oiiotool shows them as the user sees them
  const Result info = run_tool("oiiotool", "--info -v " + path("o.tif"));
  EXPECT_TRUE(contains(info.output, "sis:highlight_compress=0")) << info.output;
  // a name holding a newline and a backslash comes back as it was
  const std::string odd = path("in\\ \n.exr");
  fs::copy_file(path("in.exr"), odd);
  ASSERT_EQ(run("'" + odd + "' -o " + path("odd.tif") + " --factor 2 -q").status, 0);
  EXPECT_EQ(ImageReader(path("odd.tif")).attribute("sis:input"), "in\\ \n.exr");
}

TEST_F(Cli, SixteenBitAndFloatOutputsAsAsked) {
  write_ramp(path("in.exr"), 40, 30);
  ASSERT_EQ(run(path("in.exr") + " -o " + path("f.exr") + " --factor 2 -q -d float").status, 0);
  const Read linear = read_back(path("f.exr"));
  ASSERT_EQ(linear.spec.format, OIIO::TypeDesc::FLOAT);
  for (const char* ext : {"png", "tif"}) {
    const std::string out = path(std::string("o16.") + ext);
    ASSERT_EQ(run(path("in.exr") + " -o " + out + " --factor 2 -q -d uint16").status, 0) << out;
    const Read r = read_back(out);
    EXPECT_EQ(r.spec.format, OIIO::TypeDesc::UINT16) << out;
    EXPECT_EQ(r.spec.get_string_attribute("oiio:ColorSpace"), "sRGB") << out;
    ASSERT_EQ(r.uint16s.size(), linear.floats.size());
    // The encoder works in float: its encoded value is within a few float
    // ulps (about 1e-7 relative, 0.01 of a 16-bit step) of the double
    // encoding, so a sample whose exact value lies that close to a rounding
    // midpoint may round the other way: at most one step, and rarely.
    long exact = 0, clipped = 0;
    for (std::size_t q = 0; q < r.uint16s.size(); ++q) {
      const double want = std::round(65535.0 * srgb_encode(linear.floats[q]));
      EXPECT_LE(std::abs(r.uint16s[q] - want), 1.0) << out << " sample " << q;
      exact += r.uint16s[q] == want;
      clipped += linear.floats[q] > 1;
    }
    EXPECT_GE(exact, long(0.97 * r.uint16s.size())) << out;
    EXPECT_GT(clipped, 0) << "the ramp reaches past 1: clamping is tested";
  }
  // float and half TIFF: the EXR output's samples, bit for bit
  for (const char* type : {"float", "half"}) {
    const std::string tif = path(std::string(type) + ".tif"), exr = path(std::string(type) + ".exr");
    ASSERT_EQ(run(path("in.exr") + " -o " + tif + " --factor 2 -q -d " + type).status, 0);
    ASSERT_EQ(run(path("in.exr") + " -o " + exr + " --factor 2 -q -d " + type).status, 0);
    const Read t = read_back(tif), e = read_back(exr);
    EXPECT_EQ(t.spec.format, std::string(type) == "half" ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    EXPECT_EQ(t.spec.get_string_attribute("oiio:ColorSpace"), "") << "linear, not tagged sRGB";
    ASSERT_EQ(t.floats.size(), e.floats.size());
    EXPECT_EQ(std::memcmp(t.floats.data(), e.floats.data(), t.floats.size() * sizeof(float)), 0) << type;
  }
  // without -d a float input stays 8-bit in integer formats
  ASSERT_EQ(run(path("in.exr") + " -o " + path("o8.tif") + " --factor 2 -q").status, 0);
  EXPECT_EQ(read_back(path("o8.tif")).spec.format, OIIO::TypeDesc::UINT8);
}

TEST_F(Cli, SixteenBitInputsStaySixteenBit) {
  for (const char* ext : {"tif", "png"}) {
    const std::string in = path(std::string("in16.") + ext);
    ASSERT_EQ(run_tool("oiiotool", "--pattern fill:left=0.1,0.2,0.3:right=0.9,0.8,0.7 64x48 3 -d uint16 -o " + in).status, 0);
    for (const char* out_ext : {"tif", "png"}) {
      const std::string out = path(std::string("o-") + ext + "." + out_ext);
      const Result r = run(in + " -o " + out + " --factor 2");
      ASSERT_EQ(r.status, 0) << r.output;
      EXPECT_EQ(r.output, "") << "no bits lost, nothing to say";
      EXPECT_EQ(read_back(out).spec.format, OIIO::TypeDesc::UINT16) << out;
    }
    // JPEG holds 8 bits: written 8-bit, and said
    const Result r = run(in + " -o " + path("o.jpg") + " --factor 2");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "warning: the input's 16-bit samples are written 8-bit")) << r.output;
    EXPECT_EQ(read_back(path("o.jpg")).spec.format, OIIO::TypeDesc::UINT8);
    // -d uint8 asks for 8 bits: no warning
    const Result asked = run(in + " -o " + path("o8.png") + " --factor 2 -d uint8");
    ASSERT_EQ(asked.status, 0) << asked.output;
    EXPECT_EQ(asked.output, "");
    EXPECT_EQ(read_back(path("o8.png")).spec.format, OIIO::TypeDesc::UINT8);
  }
}

TEST_F(Cli, CompressionAsAskedOrRefused) {
  write_ramp(path("in.exr"), 64, 64);
  // lossless compressions: the name the file reports, the same pixels
  const std::pair<const char*, const char*> lossless[] = {
      {"exr", "zip"}, {"exr", "piz"}, {"exr", "zips:9"}, {"tif", "lzw"}, {"tif", "zip"}, {"tif", "none"}};
  for (const auto& [ext, comp] : lossless) {
    const std::string plain = path(std::string("plain.") + ext);
    const std::string out = path(std::string(comp).substr(0, std::string(comp).find(':')) + "." + ext);
    ASSERT_EQ(run(path("in.exr") + " -o " + plain + " --factor 2 -q -d float").status, 0);
    const Result r = run(path("in.exr") + " -o " + out + " --factor 2 -q -d float --compression " + comp);
    ASSERT_EQ(r.status, 0) << r.output;
    const Read a = read_back(plain), b = read_back(out);
    EXPECT_EQ(b.spec.get_string_attribute("compression"), std::string(comp).substr(0, std::string(comp).find(':')))
        << out;
    EXPECT_EQ(a.floats, b.floats) << out;
  }
  // a lossy one as asked: dwaa:45 in EXR
  ASSERT_EQ(run(path("in.exr") + " -o " + path("dwa.exr") + " --factor 2 -q --compression dwaa:45").status, 0);
  EXPECT_EQ(read_back(path("dwa.exr")).spec.get_string_attribute("compression"), "dwaa");
  // JPEG quality: 50 makes a smaller file than 95; --quality and jpeg:Q agree
  write_ramp(path("big.exr"), 256, 256);
  ASSERT_EQ(run(path("big.exr") + " -o " + path("q50.jpg") + " --factor 2 -q --quality 50").status, 0);
  ASSERT_EQ(run(path("big.exr") + " -o " + path("q95.jpg") + " --factor 2 -q --quality 95").status, 0);
  ASSERT_EQ(run(path("big.exr") + " -o " + path("c50.jpg") + " --factor 2 -q --compression jpeg:50").status, 0);
  EXPECT_LT(fs::file_size(path("q50.jpg")), fs::file_size(path("q95.jpg")));
  // --quality alone reaches WebP's and HEIF's writers too (HEIF's only
  // through its name heic, which siproject gives it)
  for (const char* ext : {"webp", "heic"}) {
    const std::string lo = path(std::string("q30.") + ext), hi = path(std::string("q90.") + ext);
    ASSERT_EQ(run(path("big.exr") + " -o " + lo + " --factor 2 -q --quality 30").status, 0) << lo;
    ASSERT_EQ(run(path("big.exr") + " -o " + hi + " --factor 2 -q --quality 90").status, 0) << hi;
    EXPECT_LT(fs::file_size(lo), fs::file_size(hi)) << ext;
  }
  EXPECT_EQ(read_back(path("q50.jpg")).uint16s, read_back(path("c50.jpg")).uint16s);
  // refused at once (exit 2, no file): names a writer would not take or
  // would replace, qualities outside a name's range, types a format does not hold
  const std::pair<std::string, std::string> refused[] = {
      {"o.exr --compression foo", "--compression foo: " + path("o.exr") + ": OpenEXR output takes compression zip (zip:1 to zip:9), none, rle, zips (zips:1 to zips:9), piz, pxr24, b44, b44a, dwaa (dwaa:1 to dwaa:100) or dwab (dwab:1 to dwab:100), not 'foo'"},
      {"o.exr --compression zip:50", "OpenEXR compression zip takes a quality 1 to 9, not 50"},
      {"o.exr --compression piz:50", "OpenEXR compression piz takes no quality"},
      {"o.exr --compression zip:0", "the quality after ':' is a whole number 1 to 100"},
      {"o.tif --compression piz", "TIFF output takes compression zip (zip:1 to zip:9), none, lzw, packbits or jpeg (jpeg:1 to jpeg:100), not 'piz'"},
      {"o.tif --compression jpeg -d uint16", "TIFF compression jpeg holds 3-channel uint8 images only"},
      {"o.tif --quality 50", "TIFF compression zip takes a quality 1 to 9, not 50"},
      {"o.png --compression zip", "PNG output takes compression default, filtered, huffman, rle or fixed, not 'zip'"},
      {"o.png --quality 90", "PNG output takes no quality"},
      {"o.bmp --compression rle", "BMP output takes no compression or quality"},
      {"o.jpg --compression jpeg:90 --quality 80", "give the quality once"},
      {"o.jpg --quality 0", "--quality"},
      {"o.jpg --quality 101", "--quality"},
      {"o.jpg -d uint16", "-d/--data-format uint16: " + path("o.jpg") + "'s format holds uint8 samples, not uint16"},
      {"o.exr -d uint8", "-d/--data-format uint8: " + path("o.exr") + "'s format holds half or float samples, not uint8"},
      {"o.png -d float", "holds uint8 or uint16 samples, not float"},
      {"o.tif -d int8", "-d/--data-format: sample format 'int8': expected uint8, uint16, half or float"},
  };
  for (const auto& [args, message] : refused) {
    const Result r = run(path("in.exr") + " -o " + path(args) + " --factor 2");
    EXPECT_EQ(r.status, 2) << args << ": " << r.output;
    EXPECT_TRUE(contains(r.output, message)) << args << ": " << r.output;
  }
  // one-channel EXR: the writer would use zip for DWA
  Image grey(16, 16, 1);
  write_exr(path("grey.exr"), grey);
  const Result r = run(path("grey.exr") + " -o " + path("g.exr") + " --factor 2 --compression dwaa");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "needs 2 or more channels")) << r.output;
  for (const char* name : {"o.exr", "o.tif", "o.png", "o.bmp", "o.jpg", "g.exr"})
    EXPECT_FALSE(fs::exists(path(name))) << name;
}

namespace {

// A scattered-samples file: n x 1 pixels of channels R, pFilm.x, pFilm.y at
// pseudo-random positions in a W x H frame.
void write_scattered(const std::string& path, int n, double W, double H) {
  OIIO::ImageSpec spec(n, 1, 3, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"R", "pFilm.x", "pFilm.y"};
  std::vector<float> data(std::size_t(n) * 3);
  for (int i = 0; i < n; ++i) {
    data[3 * i] = float(0.2 + 0.5 * std::fmod(i * 0.618034, 1.0));
    data[3 * i + 1] = float(W * std::fmod(i * 0.7548777 + 0.1, 1.0));
    data[3 * i + 2] = float(H * std::fmod(i * 0.5698403 + 0.3, 1.0));
  }
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::FLOAT, data.data()) && out->close());
}

}  // namespace

TEST_F(Cli, VariationalRuleRunsAndRefusesBadOptions) {
  write_scattered(path("s.exr"), 200, 16, 12);
  const std::string in = path("s.exr") + " --size 16x12 -o " + path("v.exr");
  const Result ok = run(in + " --rule variational --lambda 0.1");
  ASSERT_EQ(ok.status, 0) << ok.output;
  EXPECT_EQ(size_of(path("v.exr")), std::make_pair(16L, 12L));
  const Result gcv = run(in + " --rule variational --smoothness 1");
  ASSERT_EQ(gcv.status, 0) << gcv.output;
  fs::remove(path("v.exr"));
  // The hexagonal lattice: the thin plate with hex-quartic, order 1 with either.
  for (const std::string hex : {" --lattice hex --generator hex-quartic --lambda 0.1",
                                " --lattice hex --generator hex-hat --smoothness 1"}) {
    const Result h = run(in + " --rule variational" + hex);
    ASSERT_EQ(h.status, 0) << hex << ": " << h.output;
    EXPECT_EQ(size_of(path("v.exr")), std::make_pair(16L, 12L));
    fs::remove(path("v.exr"));
  }
  struct Case {
    std::string opts, needle;
  };
  for (const Case& c : {Case{"--rule variational --lambda -1", "--lambda '-1'"},
                        Case{"--rule variational --lambda nan", "--lambda 'nan'"},
                        Case{"--rule variational --lambda big", "--lambda 'big'"},
                        Case{"--rule variational --smoothness 3", "--smoothness 3"},
                        Case{"--rule variational --lattice hex --generator hex-hat",
                             "--smoothness 2 (the thin plate, the default) needs"},
                        Case{"--rule variational --lattice hex --generator hex-hat --smoothness 2",
                             "--generator hex-hat"},
                        Case{"--rule fit --lambda 0.1", "--lambda applies to --rule variational"}}) {
    const Result r = run(in + " " + c.opts);
    EXPECT_NE(r.status, 0) << c.opts;
    EXPECT_TRUE(contains(r.output, c.needle)) << c.opts << ": " << r.output;
    EXPECT_FALSE(fs::exists(path("v.exr"))) << c.opts;
  }
  write_scattered(path("two.exr"), 2, 16, 12);
  const Result few = run(path("two.exr") + " --size 16x12 -o " + path("v.exr") +
                         " --rule variational --lambda 0.1");
  EXPECT_NE(few.status, 0);
  EXPECT_TRUE(contains(few.output, "at least 3 samples, got 2")) << few.output;
  EXPECT_FALSE(fs::exists(path("v.exr")));
}
