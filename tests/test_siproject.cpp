// siproject end to end, through the built binary, on inputs the tests write.
#include <gtest/gtest.h>

#include <OpenEXR/openexr.h>
#include <OpenImageIO/imageio.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <random>
#include <thread>

#include "sis/imageio.h"
#include "sis/metrics.h"
#include "sis/projection.h"
#include "support.h"

namespace fs = std::filesystem;
using namespace sis;
using namespace sis::test;

#ifndef SIPROJECT
#error "SIPROJECT must name the siproject binary"
#endif

namespace {

Result run(const std::string& args) { return run_tool(SIPROJECT, args); }

class Siproject : public TempDirTest {};

void write_half(const std::string& path, const Image& img) {
  OIIO::ImageSpec spec(int(img.width), int(img.height), img.channels, OIIO::TypeDesc::HALF);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::FLOAT, img.data.data()) && out->close());
}

}  // namespace

TEST_F(Siproject, HalfSamplesConvertAsOpenImageIOConvertsThem) {
  // Every half bit pattern, stored in a half EXR, read natively and converted
  // by half_to_float (F16C where the processor has it), against OpenImageIO's
  // own conversion of the same file.
  std::vector<std::uint16_t> bits(65536);
  for (std::size_t q = 0; q < bits.size(); ++q) bits[q] = std::uint16_t(q);
  OIIO::ImageSpec spec(256, 256, 1, OIIO::TypeDesc::HALF);
  auto out = OIIO::ImageOutput::create(path("all.exr"));
  ASSERT_TRUE(out && out->open(path("all.exr"), spec) &&
              out->write_image(OIIO::TypeDesc::HALF, bits.data()) && out->close());
  ImageReader r(path("all.exr"));
  ASSERT_TRUE(r.stores_half());
  std::vector<float> theirs(65536), ours(65536);
  std::vector<std::uint16_t> stored(65536);
  r.read_rows(0, 256, theirs.data());
  r.read_rows_half(0, 256, stored.data());
  EXPECT_EQ(stored, bits);
  // a length that is not a whole vector; the patterns below 0x7c00 (half's
  // positive finite values) report finite, any range holding 0x7c00 (+Inf)
  // or the patterns above 0xfc00 (-Inf and NaN) does not
  EXPECT_FALSE(half_to_float(stored.data(), ours.data(), 65533));
  EXPECT_FALSE(half_to_float(stored.data() + 65533, ours.data() + 65533, 3));
  std::vector<float> scratch(0x7c00 + 1);
  EXPECT_TRUE(half_to_float(stored.data(), scratch.data(), 0x7c00));
  EXPECT_FALSE(half_to_float(stored.data(), scratch.data(), 0x7c01));
  EXPECT_FALSE(half_to_float(stored.data() + 0x7c00, scratch.data(), 1));
  EXPECT_TRUE(half_to_float(stored.data() + 0x8000, scratch.data(), 0x7c00));  // negative finite
  EXPECT_FALSE(half_to_float(stored.data() + 0x8000, scratch.data(), 0x7c01));
  long nan = 0;
  for (std::size_t q = 0; q < bits.size(); ++q) {
    if (std::isnan(theirs[q])) {
      EXPECT_TRUE(std::isnan(ours[q])) << q;
      ++nan;
      continue;
    }
    std::uint32_t a, b;
    std::memcpy(&a, &theirs[q], 4);
    std::memcpy(&b, &ours[q], 4);
    EXPECT_EQ(a, b) << "half bits " << q;
  }
  EXPECT_EQ(nan, 2 * 1023);  // exponent all ones, mantissa not zero, both signs
  // a float file has no half path
  write_image(path("f.exr"), random_image(4, 4, 1, 1));
  ImageReader f(path("f.exr"));
  EXPECT_FALSE(f.stores_half());
  EXPECT_THROW(f.read_rows_half(0, 4, stored.data()), std::logic_error);
}

TEST_F(Siproject, FloatsConvertToHalfAsOpenImageIOConvertsThem) {
  // Every finite half value, the midpoints between neighbours (ties, which
  // round to the even one) and a float step either side of each, values past
  // half's largest (65504; ties from 65520 go to infinity), below its
  // smallest subnormal, zeros, infinities and NaN: float_to_half against
  // OpenImageIO's conversion when it writes floats to a half file.
  std::vector<float> v;
  for (std::uint32_t h = 0; h < 0x7c00; ++h) {
    const std::uint16_t pair[2] = {std::uint16_t(h), std::uint16_t(h + 1)};
    float ab[2];
    half_to_float(pair, ab, 2);  // exact (the test above)
    const float a = ab[0], b = ab[1];
    const float mid = a + (b - a) / 2;  // exact: one bit more than half's mantissa
    for (float x : {a, mid, std::nextafter(mid, 0.0f), std::nextafter(mid, INFINITY)}) {
      v.push_back(x);
      v.push_back(-x);
    }
  }
  for (float x : {65519.0f, 65520.0f, 1e10f, 1e-9f, 2.9e-8f, 3.0e-8f, 0.0f, INFINITY, NAN})
    v.push_back(x), v.push_back(-x);
  const long w = 1024, h = long(v.size() + w - 1) / w;
  v.resize(w * h, 0.5f);
  OIIO::ImageSpec spec(int(w), int(h), 1, OIIO::TypeDesc::HALF);
  auto out = OIIO::ImageOutput::create(path("h.exr"));
  ASSERT_TRUE(out && out->open(path("h.exr"), spec) &&
              out->write_image(OIIO::TypeDesc::FLOAT, v.data()) && out->close());
  ImageReader r(path("h.exr"));
  std::vector<std::uint16_t> theirs(v.size()), ours(v.size());
  r.read_rows_half(0, h, theirs.data());
  float_to_half(v.data(), ours.data(), v.size() - 3);  // a length that is not a whole vector
  float_to_half(v.data() + v.size() - 3, ours.data() + v.size() - 3, 3);
  long nan = 0;
  for (std::size_t q = 0; q < v.size(); ++q) {
    if (std::isnan(v[q])) {  // any NaN pattern, as OpenImageIO's
      EXPECT_EQ(ours[q] & 0x7c00, 0x7c00) << q;
      EXPECT_NE(ours[q] & 0x03ff, 0) << q;
      ++nan;
      continue;
    }
    EXPECT_EQ(ours[q], theirs[q]) << "float " << v[q];
  }
  EXPECT_EQ(nan, 2);
  EXPECT_EQ(ours[std::find(v.begin(), v.end(), 65520.0f) - v.begin()], 0x7c00);  // +Inf
  EXPECT_EQ(ours[std::find(v.begin(), v.end(), 65519.0f) - v.begin()], 0x7bff);  // 65504
}

TEST_F(Siproject, AgreesWithTheLibrary) {
  const Image in = random_image(64, 48, 3, 1);
  write_image(path("in.exr"), in);
  for (const std::string g : {"cubic", "tent", "box"}) {
    for (const std::string d : {"centred", "2x2", "pixel"}) {
      const Result r = run(path("in.exr") + " -o " + path("out.exr") + " --factor 4 -q --generator " + g +
                           " --display " + d);
      ASSERT_EQ(r.status, 0) << r.output;
      const Image got = read_image(path("out.exr"));
      ProjectionOptions o;
      o.generator = Kernel::parse(g);
      Coefficients k = project(in, 16, 12, o);
      for (double& v : k.c.data) v = static_cast<float>(v);  // as the tool keeps them
      const Image ref = final_image(k, Display::parse(d), 16, 12);
      ASSERT_EQ(got.width, 16);
      ASSERT_EQ(got.height, 12);
      for (std::size_t q = 0; q < ref.data.size(); ++q) EXPECT_EQ(got.data[q], ref.data[q]) << g << " " << d;
    }
  }
  const Result r = run(path("in.exr") + " -o " + path("m.exr") + " --factor 4 -q --generator mitchell");
  ASSERT_EQ(r.status, 0) << r.output;  // a conventional filter alone implies --method conventional
  ProjectionOptions o;
  o.generator = Kernel::mitchell();
  o.method = Method::Conventional;
  const Coefficients k = project(in, 16, 12, o);
  const Image got = read_image(path("m.exr"));
  for (std::size_t q = 0; q < got.data.size(); ++q) EXPECT_EQ(got.data[q], static_cast<float>(k.c.data[q]));
}

TEST_F(Siproject, CoefficientRoundTripEqualsDirectResult) {
  write_image(path("in.exr"), random_image(90, 60, 3, 2));
  for (const std::string extra : {"", "--display pixel", "--display centred"}) {
    ASSERT_EQ(run(path("in.exr") + " -o " + path("direct.exr") + " --factor 3 -q --coeffs " +
                  path("c.exr") + " " + extra).status, 0);
    const Result r = run(path("c.exr") + " -o " + path("rt.exr") + " -q " + extra);
    ASSERT_EQ(r.status, 0) << r.output;
    const Image a = read_image(path("direct.exr")), b = read_image(path("rt.exr"));
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.data, b.data) << extra;
  }
  // A half input: the direct output is half, and so is the evaluation of its
  // coefficient file (which records the input's sample type), bit for bit.
  write_half(path("inh.exr"), random_image(90, 60, 3, 3));
  ASSERT_EQ(run(path("inh.exr") + " -o " + path("directh.exr") + " --factor 3 -q --coeffs " +
                path("ch.exr")).status, 0);
  ASSERT_EQ(run(path("ch.exr") + " -o " + path("rth.exr") + " -q").status, 0);
  EXPECT_EQ(ImageReader(path("ch.exr")).attribute("sis:input_format"), "half");
  EXPECT_TRUE(ImageReader(path("directh.exr")).stores_half());
  EXPECT_TRUE(ImageReader(path("rth.exr")).stores_half());
  EXPECT_EQ(read_image(path("directh.exr")).data, read_image(path("rth.exr")).data);
  // At another size: the stored approximation sampled there.
  ProjectionOptions o;
  Coefficients k = project(read_image(path("in.exr")), 30, 20, o);
  for (double& v : k.c.data) v = static_cast<float>(v);
  for (const std::string d : {"2x2", "pixel"}) {
    ASSERT_EQ(run(path("c.exr") + " -o " + path("rt.exr") + " -q --size 41x17 --display " + d).status, 0);
    EXPECT_EQ(read_image(path("rt.exr")).data, resample(k, Display::parse(d), 41, 17).data) << d;
  }
  ImageReader c(path("c.exr"));
  EXPECT_EQ(c.attribute("sis:generator"), "cubic");
  EXPECT_EQ(c.attribute("sis:boundary"), "mirror");
  EXPECT_EQ(c.attribute("sis:method"), "min-error");
  EXPECT_EQ(c.attribute("sis:lattice"), "cartesian");
  EXPECT_EQ(c.width(), 30);
  // the recorded options cannot be overridden
  EXPECT_EQ(run(path("c.exr") + " -o " + path("x.exr") + " --generator tent").status, 2);
}

TEST_F(Siproject, EveryChannelCountAndHalfInput) {
  // 3 and 4 channels take the vectorised paths, the others the scalar ones
  for (int channels : {1, 2, 3, 4, 5}) {
    const Image in = random_image(40, 40, channels, channels);
    write_half(path("in.exr"), in);
    const Result r = run(path("in.exr") + " -o " + path("out.exr") + " --factor 2 -q");
    ASSERT_EQ(r.status, 0) << r.output;
    ImageReader out(path("out.exr"));
    EXPECT_EQ(out.channels(), channels);
    EXPECT_EQ(out.width(), 20);
    EXPECT_EQ(out.attribute("sis:method"), "min-error");
    EXPECT_EQ(out.attribute("sis:display"), "2x2");
    // half input: equals projecting the half samples read as float ...
    const Image half = read_image(path("in.exr"));
    ProjectionOptions o;
    Coefficients k = project(half, 20, 20, o);
    for (double& v : k.c.data) v = static_cast<float>(v);
    const Image ref = final_image(k, Display::antialiased_2x2(), 20, 20);
    // ... stored as half by default, as the input (oiiotool's habit) ...
    EXPECT_TRUE(out.stores_half());
    write_image(path("ref.exr"), ref, {}, {}, -1, SampleFormat::Half);
    EXPECT_EQ(read_image(path("out.exr")).data, read_image(path("ref.exr")).data) << channels;
    // ... and bit for bit as float with -d float
    ASSERT_EQ(run(path("in.exr") + " -o " + path("outf.exr") + " --factor 2 -q -d float").status, 0);
    EXPECT_FALSE(ImageReader(path("outf.exr")).stores_half());
    EXPECT_EQ(read_image(path("outf.exr")).data, ref.data) << channels;
  }
  // a float input gives a float output; -d half makes it half
  write_image(path("inf.exr"), random_image(40, 40, 3, 7));
  ASSERT_EQ(run(path("inf.exr") + " -o " + path("o1.exr") + " --factor 2 -q").status, 0);
  EXPECT_FALSE(ImageReader(path("o1.exr")).stores_half());
  ASSERT_EQ(run(path("inf.exr") + " -o " + path("o2.exr") + " --factor 2 -q -d half").status, 0);
  EXPECT_TRUE(ImageReader(path("o2.exr")).stores_half());
}

TEST_F(Siproject, HalfOutputNeverHoldsInfinities) {
  // A step from half's largest value to 0: min-error cubic overshoots past
  // 65504, which half cannot hold.
  Image in(64, 64, 1);
  for (long y = 0; y < 64; ++y)
    for (long x = 0; x < 64; ++x) in.at(x, y, 0) = x < 32 ? 65504.0f : 0.0f;
  write_half(path("step.exr"), in);
  // by default: written as float, with a warning
  Result r = run(path("step.exr") + " -o " + path("d.exr") + " --factor 2");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("beyond half's largest value"), std::string::npos) << r.output;
  EXPECT_FALSE(ImageReader(path("d.exr")).stores_half());
  const Image d = read_image(path("d.exr"));
  const float top = *std::max_element(d.data.begin(), d.data.end());
  EXPECT_GT(top, 65504.0f);
  EXPECT_TRUE(std::isfinite(top));
  // -d half: clamped to +-65504, counted, never infinite
  r = run(path("step.exr") + " -o " + path("h.exr") + " --factor 2 -d half");
  ASSERT_EQ(r.status, 0) << r.output;
  ImageReader h(path("h.exr"));
  EXPECT_TRUE(h.stores_half());
  long beyond = 0;
  for (float v : d.data) beyond += std::abs(v) > 65504.0f;
  EXPECT_GT(beyond, 0);
  EXPECT_EQ(h.attribute("sis:half_clamped"), std::to_string(beyond));
  for (float v : read_image(path("h.exr")).data) EXPECT_LE(std::abs(v), 65504.0f);
}

TEST_F(Siproject, BitIdenticalForAnyThreadCount) {
  // 603 rows: three bands of the acquisition (kBandRows), taken at once
  write_image(path("in.exr"), random_image(301, 603, 3, 3));
  Buffer<float> first;
  for (int t : {1, 2, 3}) {
    ASSERT_EQ(run(path("in.exr") + " -o " + path("out.exr") + " --size 97x201 -q --threads " +
                  std::to_string(t)).status, 0);
    const Image img = read_image(path("out.exr"));
    if (first.empty()) first = img.data;
    EXPECT_EQ(img.data, first) << t << " threads";
  }
}

TEST_F(Siproject, EightBitOutputIsSrgbClamped) {
  Image in(8, 8, 3);
  for (long y = 0; y < 8; ++y)
    for (long x = 0; x < 8; ++x) {
      in.at(x, y, 0) = 0.5f;   // sRGB 0.7354 -> 188
      in.at(x, y, 1) = 3.0f;   // clamped -> 255
      in.at(x, y, 2) = -1.0f;  // clamped -> 0
    }
  write_image(path("in.exr"), in);
  ASSERT_EQ(run(path("in.exr") + " -o " + path("out.png") + " --factor 2 -q --generator box").status, 0);
  auto png = OIIO::ImageInput::open(path("out.png"));
  ASSERT_TRUE(png);
  std::vector<unsigned char> px(4 * 4 * 3);
  ASSERT_TRUE(png->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, px.data()));
  EXPECT_EQ(px[0], 188);
  EXPECT_EQ(px[1], 255);
  EXPECT_EQ(px[2], 0);
}

TEST_F(Siproject, NonFiniteSamplesAreAnErrorUnlessReplaced) {
  Image in = random_image(16, 16, 3, 4);
  in.at(5, 7, 1) = std::numeric_limits<float>::infinity();
  in.at(9, 9, 0) = std::nanf("");
  write_image(path("in.exr"), in);
  Result r = run(path("in.exr") + " -o " + path("out.exr") + " --factor 2");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("non-finite"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("x 5, y 7"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("out.exr")));
  r = run(path("in.exr") + " -o " + path("out.exr") + " --factor 2 --nonfinite zero");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("replaced 2 non-finite"), std::string::npos) << r.output;
  for (float v : read_image(path("out.exr")).data) EXPECT_TRUE(std::isfinite(v));
}

TEST_F(Siproject, BadInputGetsAClearErrorAndLosesNothing) {
  write_image(path("in.exr"), random_image(32, 32, 3, 5));
  { std::ofstream(path("text.exr")) << "this is not an image\n"; }
  { std::ofstream(path("empty.exr")); }
  {  // a truncated EXR: the header survives, the pixels do not
    write_image(path("big.exr"), random_image(256, 256, 3, 6));
    fs::resize_file(path("big.exr"), fs::file_size(path("big.exr")) / 2);
  }
  const auto before = files();
  struct Case {
    std::string args;
    int status;
    std::string says;
  };
  const std::string in = path("in.exr"), out = " -o " + path("out.exr");
  const Case cases[] = {
      {path("missing.exr") + out + " --factor 2", 3, "missing.exr: no such file"},
      {path("big.exr") + out + " --factor 2", 3, "big.exr"},
      {path("text.exr") + out + " --factor 2", 3, "text.exr"},
      {path("empty.exr") + out + " --factor 2", 3, "empty.exr"},
      {in + out + " --factor 100", 2, "--factor 100 is larger than the image"},
      {in + out + " --factor 2 --generator sinc", 2, "unknown generator 'sinc'"},
      {in + out + " --factor 2 --generator mitchell --method min-error", 2, "needs a B-spline generator"},
      {in + out + " --size 10by10", 2, "--size '10by10'"},
      {in + out + " --size 0x0", 2, "--size '0x0'"},
      {in + out + " --factor 2 --display 3x3", 2, "unknown display '3x3'"},
      {in + out + " --factor 2 --display offsets:0.1", 2, "offset '0.1'"},
      {in + " -o " + path("nowhere/out.exr") + " --factor 2", 4, "does not exist"},
      {in + " -o " + in + " --factor 2", 2, "is the input file"},
      {in + out, 2, "give the output size"},
      {in + out + " --factor 2 --boundary clamp", 2, "unknown boundary rule 'clamp'"},
      {in + out + " --factor -2", 2, "--factor"},
      {in + out + " --factor 2 -d double", 2, "-d/--data-format: sample format 'double'"},
      {in + " -o " + path("out.png") + " --factor 2 -d half", 2, "out.png's format holds uint8 or uint16 samples, not half"},
  };
  for (const Case& c : cases) {
    const Result r = run(c.args);
    EXPECT_EQ(r.status, c.status) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(files(), before) << "left a file behind: " << c.args;
  }
}

TEST_F(Siproject, HdrRemediesAreHonestAboutWhatTheyChange) {
  // A small square of value 100 on a dim background (0.05).
  Image in(128, 128, 1);
  for (long y = 0; y < 128; ++y)
    for (long x = 0; x < 128; ++x) in.at(x, y, 0) = (x >= 60 && x < 68 && y >= 60 && y < 68) ? 100.0f : 0.05f;
  write_image(path("hdr.exr"), in);
  auto negative_energy = [](const Image& img, long* count) {
    double e = 0;
    *count = 0;
    for (float v : img.data)
      if (v < 0) e += double(v) * v, ++*count;
    return e;
  };
  const std::string base = path("hdr.exr") + " --factor 4 -q --generator cubic -o ";
  ASSERT_EQ(run(base + path("plain.exr")).status, 0);
  ASSERT_EQ(run(base + path("zero.exr") + " --clamp zero").status, 0);
  ASSERT_EQ(run(base + path("hc.exr") + " --highlight-compress").status, 0);
  ASSERT_EQ(run(base + path("local.exr") + " --clamp local").status, 0);
  long n_plain, n_zero, n_hc, n_local;
  const double e_plain = negative_energy(read_image(path("plain.exr")), &n_plain);
  EXPECT_EQ(negative_energy(read_image(path("zero.exr")), &n_zero), 0.0);
  const double e_hc = negative_energy(read_image(path("hc.exr")), &n_hc);
  const Image local = read_image(path("local.exr"));
  negative_energy(local, &n_local);
  EXPECT_GT(n_plain, 0) << "min-error cubic rings below zero around the highlight";
  EXPECT_EQ(n_zero, 0);
  EXPECT_EQ(n_local, 0);
  EXPECT_LT(e_hc * 100, e_plain) << e_hc << " vs " << e_plain;
  for (float v : local.data) EXPECT_LE(v, 100.0f);  // within the input range under each pixel
  // recorded in the metadata
  ImageReader plain(path("plain.exr")), hc(path("hc.exr")), zero(path("zero.exr"));
  EXPECT_EQ(hc.attribute("sis:highlight_compress"), "1");
  EXPECT_EQ(zero.attribute("sis:clamp"), "zero");
  EXPECT_EQ(plain.attribute("sis:negative_before_clamp"), std::to_string(n_plain));
  EXPECT_EQ(zero.attribute("sis:negative_before_clamp"), std::to_string(n_plain));
  EXPECT_EQ(std::stod(zero.attribute("sis:output_min")), 0.0);
  EXPECT_NE(plain.attribute("sis:out_of_range_before_clamp"), "0");
  EXPECT_EQ(run(base + path("x.exr") + " --clamp soft").status, 2);
}

namespace {
// Rows [y0, y1) of `img` as a band: data window y0..y1, display window whole.
void write_band(const std::string& path, const Image& img, long y0, long y1) {
  OIIO::ImageSpec spec(int(img.width), int(y1 - y0), img.channels, OIIO::TypeDesc::HALF);
  spec.y = int(y0);
  spec.full_x = 0;
  spec.full_y = 0;
  spec.full_width = int(img.width);
  spec.full_height = int(img.height);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::FLOAT, img.row(y0)) && out->close());
}
}  // namespace

TEST_F(Siproject, RowBandsProjectAsOneImage) {
  const Image in = random_image(96, 80, 3, 7);
  write_half(path("whole.exr"), in);
  write_band(path("b0.exr"), in, 0, 13);
  write_band(path("b1.exr"), in, 13, 50);
  write_band(path("b2.exr"), in, 50, 80);
  for (const std::string opts : {"--factor 4", "--size 30x17 --generator tent --display pixel"}) {
    ASSERT_EQ(run(path("whole.exr") + " -o " + path("a.exr") + " -q " + opts).status, 0);
    // any order on the command line
    const Result r = run("--bands " + path("b2.exr") + " " + path("b0.exr") + " " + path("b1.exr") +
                         " -o " + path("b.exr") + " -q " + opts);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(read_image(path("a.exr")).data, read_image(path("b.exr")).data) << opts;
  }
  // a gap, an overlap, a missing last band: errors naming the file, no output
  write_band(path("over.exr"), in, 40, 80);
  const auto before = files();
  Result r = run("--bands " + path("b0.exr") + " " + path("b2.exr") + " -o " + path("c.exr") + " --factor 4");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("b2.exr: not a row band"), std::string::npos) << r.output;
  r = run("--bands " + path("b0.exr") + " " + path("b1.exr") + " " + path("over.exr") + " -o " + path("c.exr") + " --factor 4");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("gap or overlap"), std::string::npos) << r.output;
  r = run("--bands " + path("b0.exr") + " " + path("b1.exr") + " -o " + path("c.exr") + " --factor 4");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("the bands end at row 50"), std::string::npos) << r.output;
  EXPECT_EQ(files(), before);
}

TEST_F(Siproject, SimetricsContinuousErrorOfAZonePlate) {
  // The zone plate of scenes/zoneplate.pov, sampled at factor 4, has its
  // truth in closed form: min-error cubic must approximate it far better
  // than the conventional tent, and simetrics must report what the library
  // computes.
  const double K = 0.7 * std::acos(-1.0) * 48;
  auto zp = [K](double x, double y, int) {
    const double u = x / 48 - 0.5, v = y / 48 - 0.5;
    return 0.5 + 0.5 * std::cos(K * (u * u + v * v));
  };
  Image in(192, 192, 1);
  for (long j = 0; j < 192; ++j)
    for (long i = 0; i < 192; ++i) in.at(i, j, 0) = float(zp((i + 0.5) / 4, (j + 0.5) / 4, 0));
  write_image(path("zp.exr"), in);
  auto l2 = [&](const std::string& opts) {
    EXPECT_EQ(run(path("zp.exr") + " -o " + path("o.exr") + " --factor 4 -q --coeffs " +
                  path("c.exr") + " " + opts).status, 0);
    const Result r = run_tool(SIMETRICS, path("o.exr") + " --coeffs " + path("c.exr") +
                                             " --zoneplate " + std::to_string(K) + " --border 2 --json");
    EXPECT_EQ(r.status, 0) << r.output;
    const auto at = r.output.find("\"l2_error\": ");
    EXPECT_NE(at, std::string::npos) << r.output;
    return std::stod(r.output.substr(at + 12));
  };
  const double cubic = l2("--generator cubic"), tent = l2("--generator tent --method conventional");
  ImageReader reader(path("c.exr"));
  const Coefficients k = read_coefficients(reader);
  EXPECT_NEAR(tent, l2_error(k, zp, 8, 2.0), 1e-9);
  EXPECT_LT(cubic * 3, tent) << cubic << " " << tent;
  EXPECT_EQ(run_tool(SIMETRICS, path("o.exr") + " --coeffs " + path("c.exr")).status, 2);
  EXPECT_EQ(run_tool(SIMETRICS, path("missing.exr")).status, 3);
}

TEST_F(Siproject, ReadBandsTakesEveryBandOnceWholeAndInOrder) {
  // Two files (37 and 50 rows) in bands of 16 rows of the 87, strips of 5:
  // each band begun, its strips in row order (cut at the file's and the
  // band's ends, whole strips of the file's rows otherwise), ended, all on
  // one worker; the rows a single reader reads. PNG: one worker.
  const Image a = random_image(23, 37, 3, 21), b = random_image(23, 50, 3, 22);
  write_half(path("a.exr"), a);
  write_half(path("b.exr"), b);
  write_image(path("fa.exr"), a);
  write_image(path("fb.exr"), b);
  write_image(path("a.png"), a);
  write_image(path("b.png"), b);
  const BandPartition bands(87, 16);
  for (const std::string kind : {"half", "float", "png"}) {
    const std::vector<std::string> paths =
        kind == "half"    ? std::vector<std::string>{path("a.exr"), path("b.exr")}
        : kind == "float" ? std::vector<std::string>{path("fa.exr"), path("fb.exr")}
                          : std::vector<std::string>{path("a.png"), path("b.png")};
    std::vector<float> want;
    for (const std::string& p : paths) {
      ImageReader r(p);
      std::vector<float> rows(std::size_t(r.width()) * r.height() * 3);
      r.read_rows(0, r.height(), rows.data());
      want.insert(want.end(), rows.begin(), rows.end());
    }
    const bool half = kind == "half";
    for (int workers : kind == "png" ? std::vector<int>{1} : std::vector<int>{1, 2, 3}) {
      SCOPED_TRACE(kind + ", " + std::to_string(workers) + " workers");
      std::mutex m;
      std::vector<std::vector<std::string>> log(bands.count());  // per band: what its worker saw
      std::vector<long> next(bands.count(), -1);                 // per band: its next row
      std::vector<float> got(want.size(), -7.0f);
      BandCallbacks cb;
      cb.begin = [&](int t, long n) {
        std::lock_guard<std::mutex> lock(m);
        log[n].push_back("begin " + std::to_string(t));
        next[n] = bands.begin(n);
      };
      cb.strip = [&](int t, const Strip& s) {
        const long n = bands.of(s.global);
        EXPECT_EQ(s.global, s.y0 + (s.file == 1 ? 37 : 0));
        EXPECT_EQ(*s.path, paths[s.file]);
        EXPECT_LE(s.global + s.y1 - s.y0, bands.end(n));
        // cut only at the file's strips of 5 rows, the band's ends and the file's end
        EXPECT_TRUE(s.y0 % 5 == 0 || s.global == bands.begin(n)) << "strip from " << s.y0;
        EXPECT_TRUE(s.y1 % 5 == 0 || s.global + s.y1 - s.y0 == bands.end(n) ||
                    s.y1 == (s.file == 0 ? 37 : 50))
            << "strip to " << s.y1;
        EXPECT_EQ(s.y0 / 5, (s.y1 - 1) / 5) << "within one strip of the file";
        const std::size_t n0 = std::size_t(s.global) * 23 * 3, count = std::size_t(s.y1 - s.y0) * 23 * 3;
        if (half)
          half_to_float(s.half, got.data() + n0, count);
        else
          std::copy(s.floats, s.floats + count, got.begin() + n0);
        std::lock_guard<std::mutex> lock(m);
        EXPECT_EQ(s.global, next[n]) << "strips in row order";
        next[n] = s.global + s.y1 - s.y0;
        log[n].push_back("strip " + std::to_string(t));
        return true;
      };
      cb.end = [&](int t, long n) {
        std::lock_guard<std::mutex> lock(m);
        EXPECT_EQ(next[n], bands.end(n)) << "band " << n << " whole";
        log[n].push_back("end " + std::to_string(t));
      };
      EXPECT_EQ(read_bands(paths, bands, 5, workers, half, cb), -1);
      EXPECT_EQ(got, want);
      for (long n = 0; n < bands.count(); ++n) {
        ASSERT_GE(log[n].size(), 3u) << "band " << n;
        const std::string t = log[n].front().substr(6);
        EXPECT_EQ(log[n].front(), "begin " + t);
        EXPECT_EQ(log[n].back(), "end " + t);
        for (std::size_t i = 1; i + 1 < log[n].size(); ++i) EXPECT_EQ(log[n][i], "strip " + t);
      }
    }
  }
}

TEST_F(Siproject, ReadBandsStopsAfterTheFirstBandThatFails) {
  write_half(path("in.exr"), random_image(16, 100, 3, 23));
  // Chunks from row 128 on damaged in place (their leaders and the offset
  // table whole, so the header check passes): their zip data does not
  // decode. (A cut file is refused when it is opened.)
  write_half(path("cut.exr"), random_image(256, 256, 3, 24));
  {
    exr_context_t c = nullptr;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    ASSERT_EQ(exr_start_read(&c, path("cut.exr").c_str(), &init), EXR_ERR_SUCCESS);
    std::vector<std::pair<std::uint64_t, std::uint64_t>> payloads;
    for (int y = 128; y < 256; y += 16) {
      exr_chunk_info_t ci;
      ASSERT_EQ(exr_read_scanline_chunk_info(c, 0, y, &ci), EXR_ERR_SUCCESS);
      payloads.emplace_back(ci.data_offset, ci.packed_size);
    }
    exr_finish(&c);
    std::fstream f(path("cut.exr"), std::ios::in | std::ios::out | std::ios::binary);
    for (const auto& [offset, size] : payloads) {
      f.seekp(std::streamoff(offset));
      const std::string junk(size, char(0xab));
      f.write(junk.data(), std::streamsize(junk.size()));
    }
  }
  long unreadable = 0;  // the first strip of 16 rows a reader fails on
  {
    ImageReader r(path("cut.exr"));
    std::vector<std::uint16_t> rows(16 * 256 * 3);
    try {
      for (; unreadable < 256; unreadable += 16) r.read_rows_half(unreadable, unreadable + 16, rows.data());
    } catch (const InputError&) {
    }
    ASSERT_GT(unreadable, 32);
    ASSERT_LT(unreadable, 256);
  }
  const BandPartition bands(100, 10);
  for (int workers : {1, 2, 3}) {
    SCOPED_TRACE(std::to_string(workers) + " workers");
    std::mutex m;
    std::set<long> ended;
    BandCallbacks cb;
    cb.begin = [](int, long) {};
    cb.end = [&](int, long n) {
      std::lock_guard<std::mutex> lock(m);
      ended.insert(n);
    };
    // Bands that fail, and every band before them ended; a later band ends
    // only if another worker finished it before the failure.
    auto ended_before = [&](long fails) {
      for (long n = 0; n < fails; ++n) EXPECT_EQ(ended.count(n), 1u) << "band " << n;
      EXPECT_EQ(ended.count(fails), 0u) << "band " << fails;
      ended.clear();
    };
    // an error in band 4: rethrown
    cb.strip = [&](int, const Strip& s) {
      if (s.global == 45) throw std::runtime_error("band 4");
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      return true;
    };
    EXPECT_THROW(read_bands({path("in.exr")}, bands, 5, workers, true, cb), std::runtime_error);
    ended_before(4);
    // band 6 says stop: no error, the band returned
    cb.strip = [&](int, const Strip& s) { return s.global != 60; };
    EXPECT_EQ(read_bands({path("in.exr")}, bands, 5, workers, true, cb), 6);
    ended_before(6);
    // errors in bands 3 and 7 (band 7's thrown first): band 3's rethrown
    cb.strip = [&](int, const Strip& s) {
      if (s.global == 70) throw std::runtime_error("band 7");
      if (s.global == 35) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        throw std::logic_error("band 3");
      }
      return true;
    };
    EXPECT_THROW(read_bands({path("in.exr")}, bands, 5, workers, true, cb), std::logic_error);
    ended_before(3);
    // a band that cannot be read: InputError naming the file, every band
    // before it ended
    cb.strip = [](int, const Strip&) { return true; };
    try {
      read_bands({path("cut.exr")}, BandPartition(256, 32), 16, workers, true, cb);
      ADD_FAILURE() << "no error from a truncated file";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("cut.exr"), std::string::npos) << e.what();
    }
    ended_before(unreadable / 32);
  }
}

