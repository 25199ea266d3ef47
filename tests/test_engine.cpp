// The engine driven directly (sis/engine.h), on files and on samples in
// memory: the coefficients and the final image are siproject's, bit for
// bit, on both lattices; the reports are those a direct count gives; the
// caller's samples are never changed.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "sis/coefficients.h"
#include "sis/engine.h"
#include "sis/imageio.h"
#include "sis/projection.h"
#include "sis/range.h"
#include "support.h"

namespace fs = std::filesystem;
using namespace sis;
using namespace sis::test;

#ifndef SIPROJECT
#error "SIPROJECT must name the siproject binary"
#endif

namespace {

class Engine : public TempDirTest {};

void write_float(const std::string& path, const Image& img) {
  OIIO::ImageSpec spec(int(img.width), int(img.height), img.channels, OIIO::TypeDesc::FLOAT);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::FLOAT, img.data.data()) && out->close());
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * 4) == 0;
}

std::vector<float> as_floats(const Grid<double>& g) {
  return std::vector<float>(g.data.begin(), g.data.end());
}

std::vector<float> file_floats(const std::string& path) {
  const Image img = read_image(path);
  return std::vector<float>(img.data.begin(), img.data.end());
}

}  // namespace

TEST_F(Engine, FilesAndMemoryGiveSiprojectsBits) {
  // 603 rows: three bands of the acquisition, read on two workers.
  const Image img = random_image(201, 603, 3, 21);
  const Image before = img;
  write_float(path("in.exr"), img);
  struct Case {
    std::string args;
    Space space;
    Method method;
    Display display;
  };
  const Space cubic = CartesianSpace{}, mitchell = CartesianSpace{Kernel::mitchell()},
              hexq = HexagonalSpace{};
  const Case cases[] = {
      {"--factor 3", cubic, Method::MinError, Display::antialiased_2x2()},
      {"--factor 3 --generator mitchell", mitchell, Method::Conventional, Display::centred()},
      {"--factor 3 --lattice hex", hexq, Method::MinError, Display::antialiased_2x2()},
  };
  for (const Case& c : cases) {
    const Result r = run_tool(SIPROJECT, path("in.exr") + " -o " + path("out.exr") + " --coeffs " +
                                             path("c.exr") + " -d float -q " + c.args);
    ASSERT_EQ(r.status, 0) << r.output;
    const std::vector<float> want_c = file_floats(path("c.exr")), want = file_floats(path("out.exr"));
    for (bool memory : {false, true}) {
      ProjectionRequest rq;
      rq.inputs = {memory ? ProjectionInput::memory(img) : ProjectionInput::file(path("in.exr"))};
      rq.width = 67;
      rq.height = 201;
      rq.space = c.space;
      rq.method = c.method;
      rq.threads = 2;
      const Projection p = project(rq);
      EXPECT_TRUE(same_bits(as_floats(p.coefficients.c), want_c)) << c.args << (memory ? " memory" : " file");
      const FinalImage f =
          final_image(p.coefficients, c.display, 67, 201, Clamp::None, p.local_range.get(), 2);
      EXPECT_TRUE(same_bits(std::vector<float>(f.image.data.begin(), f.image.data.end()), want))
          << c.args << (memory ? " memory" : " file");
    }
  }
  EXPECT_EQ(img.data, before.data);  // the caller's samples, untouched
}

TEST_F(Engine, MemoryBandsAndReports) {
  // Samples in memory as three bands of one grid, with a NaN: the result
  // equals the whole image's, the non-finite report names the band, the
  // position and the count; under the error policy it is an InputError.
  Image img = random_image(40, 300, 1, 3);
  img.at(7, 170, 0) = NAN;
  img.at(9, 260, 0) = INFINITY;
  Image a(40, 100, 1), b(40, 100, 1), c(40, 100, 1);
  std::copy(img.row(0), img.row(100), a.data.begin());
  std::copy(img.row(100), img.row(200), b.data.begin());
  std::copy(img.row(200), img.row(300), c.data.begin());
  ProjectionRequest rq;
  rq.width = 10;
  rq.height = 75;
  rq.zero_nonfinite = true;
  rq.threads = 2;
  rq.inputs = {ProjectionInput::memory(img, "whole")};
  const Projection whole = project(rq);
  ProjectionInput pa = ProjectionInput::memory(a, "a"), pb = ProjectionInput::memory(b, "b"),
                  pc = ProjectionInput::memory(c, "c");
  pb.row = 100;
  pc.row = 200;
  for (ProjectionInput* p : {&pa, &pb, &pc}) p->rows = 300;
  rq.inputs = {pc, pa, pb};  // any order
  const Projection banded = project(rq);
  EXPECT_EQ(banded.coefficients.c.data, whole.coefficients.c.data);
  EXPECT_EQ(banded.nonfinite.count, 2);
  EXPECT_EQ(banded.nonfinite.file, "b");
  EXPECT_EQ(banded.nonfinite.x, 7);
  EXPECT_EQ(banded.nonfinite.y, 70);  // row 70 of band b
  EXPECT_EQ(banded.inputs.label, "a and 2 more bands");
  rq.zero_nonfinite = false;
  EXPECT_THROW(project(rq), InputError);
  rq.inputs = {pa, pc};  // a gap
  EXPECT_THROW(project(rq), InputError);
}

TEST_F(Engine, CoefficientsDescribeThemselves) {
  // An 8-bit RGBA PNG written by OpenImageIO (sRGB by default), projected
  // with highlight compression onto both spaces: the coefficients carry
  // the channels, alpha, remedy and input; a coefficient file keeps them
  // (read back, the input is named by the file's path); the final image
  // needs nothing else: the colour channels expanded, alpha not.
  const std::string png = path("rgba.png");
  {
    std::vector<unsigned char> px(48 * 36 * 4);
    for (std::size_t q = 0; q < px.size(); ++q) px[q] = static_cast<unsigned char>((q * 37) % 251);
    OIIO::ImageSpec spec(48, 36, 4, OIIO::TypeDesc::UINT8);
    auto out = OIIO::ImageOutput::create(png);
    ASSERT_TRUE(out && out->open(png, spec) && out->write_image(OIIO::TypeDesc::UINT8, px.data()) &&
                out->close());
  }
  for (const Space& space : {Space{CartesianSpace{Kernel::bspline(3)}}, Space{HexagonalSpace{1, 1.0}}}) {
    const std::string what = space_name(space);
    ProjectionRequest rq;
    rq.inputs = {ProjectionInput::file(png)};
    rq.width = 24;
    rq.height = 18;
    rq.space = space;
    rq.highlight_compress = true;
    const Projection p = project(rq);
    const Coefficients& k = p.coefficients;
    EXPECT_EQ(k.channel_names, (std::vector<std::string>{"R", "G", "B", "A"})) << what;
    EXPECT_EQ(k.alpha, 3) << what;
    EXPECT_TRUE(k.highlight_compressed) << what;
    EXPECT_EQ(k.input.label, "rgba.png") << what;  // as the inputs' label names it
    EXPECT_FALSE(k.input.half) << what;
    EXPECT_EQ(k.input.transfer, Transfer::srgb()) << what;
    EXPECT_EQ(space_name(k.space), what);

    const Display shown = Display::centred();
    const FinalImage f = final_image(k, shown, 24, 18, Clamp::None, nullptr, 1);
    const Image plain = final_image(k, shown, 24, 18, 1);  // f_app alone
    ASSERT_EQ(f.image.data.size(), plain.data.size());
    for (std::size_t q = 0; q < plain.data.size(); ++q) {
      const float want = q % 4 == 3 ? plain.data[q] : static_cast<float>(highlight_expand(plain.data[q]));
      ASSERT_EQ(f.image.data[q], want) << what << ", value " << q;
    }

    const std::string file = path("c.exr");
    write_coefficients(file, k);
    const Coefficients back = load_coefficients(file, false);
    EXPECT_EQ(back.channel_names, k.channel_names) << what;
    EXPECT_EQ(back.alpha, 3) << what;
    EXPECT_TRUE(back.highlight_compressed) << what;
    EXPECT_EQ(back.input.label, file) << what;
    EXPECT_EQ(back.input.transfer, Transfer::srgb()) << what;
    EXPECT_EQ(space_name(back.space), what);
    EXPECT_EQ(generator_name(back), generator_name(k)) << what;
    const FinalImage g = final_image(back, shown, 24, 18, Clamp::None, nullptr, 1);
    EXPECT_TRUE(same_bits(std::vector<float>(g.image.data.begin(), g.image.data.end()),
                          std::vector<float>(f.image.data.begin(), f.image.data.end())))
        << what;

    // an alpha channel under a name no reader takes for alpha keeps its role
    Coefficients layer = k;
    layer.channel_names = {"diffuse.R", "diffuse.G", "diffuse.B", "diffuse.mask"};
    write_coefficients(file, layer);
    const Coefficients again = load_coefficients(file, false);
    EXPECT_EQ(again.channel_names, layer.channel_names) << what;
    EXPECT_EQ(again.alpha, 3) << what;
    const FinalImage h = final_image(again, shown, 24, 18, Clamp::None, nullptr, 1);
    EXPECT_TRUE(same_bits(std::vector<float>(h.image.data.begin(), h.image.data.end()),
                          std::vector<float>(f.image.data.begin(), f.image.data.end())))
        << what;
    // and no alpha stays none, whatever the names
    layer.alpha = -1;
    write_coefficients(file, layer);
    EXPECT_EQ(load_coefficients(file, false).alpha, -1) << what;
  }
}

TEST_F(Engine, RequestsItCannotDoAreRequestErrors) {
  const Image img = random_image(32, 32, 3, 1);
  ProjectionRequest rq;
  rq.inputs = {ProjectionInput::memory(img)};
  rq.width = 16;
  rq.height = 16;
  rq.space = HexagonalSpace{2, 1e30};
  EXPECT_THROW(project(rq), RequestError);
  rq.space = Space{};
  rq.width = 3000000000;
  EXPECT_THROW(project(rq), RequestError);
  rq.width = 16;
  rq.space = CartesianSpace{Kernel::mitchell()};
  EXPECT_THROW(project(rq), RequestError);  // min-error needs a B-spline
}
