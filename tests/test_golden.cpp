// Golden outputs: siproject against the outputs committed in tests/golden/
// (cases.txt lists them, make.sh wrote them), every sample's bits, the
// stored sample type, the channel names and every sis: attribute. A change
// of the pipeline keeps results unless it is meant to change them.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "support.h"

namespace fs = std::filesystem;
using namespace sis::test;

#ifndef SIPROJECT
#error "SIPROJECT must name the siproject binary"
#endif
#ifndef GOLDEN_DIR
#error "GOLDEN_DIR must name tests/golden"
#endif

namespace {

struct Case {
  std::string name, inputs, options;
};

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

std::vector<Case> cases() {
  std::ifstream in(std::string(GOLDEN_DIR) + "/cases.txt");
  std::vector<Case> v;
  std::string line;
  while (std::getline(in, line)) {
    if (trim(line).empty() || trim(line)[0] == '#') continue;
    const auto a = line.find('|'), b = line.find('|', a + 1);
    v.push_back({trim(line.substr(0, a)), trim(line.substr(a + 1, b - a - 1)), trim(line.substr(b + 1))});
  }
  return v;
}

struct File {
  OIIO::ImageSpec spec;
  std::vector<float> pixels;
};

File load(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path << ": " << OIIO::geterror();
  if (!in) return {};
  File f{in->spec(), {}};
  f.pixels.resize(std::size_t(f.spec.width) * f.spec.height * f.spec.nchannels);
  EXPECT_TRUE(in->read_image(0, 0, 0, f.spec.nchannels, OIIO::TypeDesc::FLOAT, f.pixels.data()))
      << path;
  return f;
}

void expect_same(const std::string& got_path, const std::string& want_path, const std::string& name) {
  const File got = load(got_path), want = load(want_path);
  ASSERT_EQ(got.spec.width, want.spec.width) << name;
  ASSERT_EQ(got.spec.height, want.spec.height) << name;
  EXPECT_EQ(got.spec.channelnames, want.spec.channelnames) << name;
  EXPECT_EQ(got.spec.format, want.spec.format) << name;
  ASSERT_EQ(got.pixels.size(), want.pixels.size()) << name;
  EXPECT_EQ(0, std::memcmp(got.pixels.data(), want.pixels.data(), got.pixels.size() * 4)) << name;
  for (const auto& p : want.spec.extra_attribs) {
    const std::string key = p.name().string();
    if (key.rfind("sis:", 0) != 0) continue;
    EXPECT_EQ(got.spec.get_string_attribute(key), want.spec.get_string_attribute(key))
        << name << ": " << key;
  }
  for (const auto& p : got.spec.extra_attribs) {
    if (p.name().string().rfind("sis:", 0) == 0) {
      EXPECT_TRUE(want.spec.extra_attribs.contains(p.name().string())) << name << ": " << p.name();
    }
  }
}

class Golden : public TempDirTest {};

}  // namespace

TEST_F(Golden, EveryCaseMatchesItsCommittedOutput) {
  const std::string g = GOLDEN_DIR;
  const std::vector<Case> all = cases();
  ASSERT_GT(all.size(), 40u);
  for (const Case& c : all) {
    std::string ins;
    std::istringstream words(c.inputs);
    for (std::string w; words >> w;)
      ins += " " + (w[0] == '@' ? path(w.substr(1) + ".coeffs.exr") : g + "/" + w);
    std::string opts = c.options;
    for (std::size_t q; (q = opts.find("OUT/")) != std::string::npos;) opts.replace(q, 4, dir_ + "/");
    const std::string ext = c.name.size() > 4 && c.name.substr(c.name.size() - 4) == "-png" ? "png" : "exr";
    const std::string out = path(c.name + "." + ext);
    std::string quoted;  // each word quoted: a display's offsets hold ';'
    std::istringstream ow(opts);
    for (std::string w; ow >> w;) quoted += " '" + w + "'";
    const Result r = run_tool(SIPROJECT, ins + " -o " + out + quoted + " -q");
    ASSERT_EQ(r.status, 0) << c.name << ": " << r.output;
    expect_same(out, g + "/" + c.name + "." + ext, c.name);
    if (opts.find("--coeffs") != std::string::npos)
      expect_same(path(c.name + ".coeffs.exr"), g + "/" + c.name + ".coeffs.exr", c.name + " coefficients");
  }
}
