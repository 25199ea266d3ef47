// sirays: rays at a pattern's positions (sis/pattern.h) through POV-Ray's
// mesh camera, and the renders assembled into an input siproject reads.
//
//   sirays mesh SCENE.pov -o BAND.pov --pattern jitter --seed 1 --size 1000x1000 --factor 4 --rows 0:500
//     writes a scene that includes SCENE.pov and replaces its camera by a
//     mesh_camera (distribution 0, one ray per pixel) whose face y * W + x is
//     the ray of sample (y0 + y) * W + x of the pattern's grid (W its width):
//     the ray from the face's centroid along its normal,
//     normalize((P3 - P1) x (P2 - P1)), computed from the scene's camera as
//     POV-Ray computes it (docs/design.md section 13).
//   sirays assemble BAND.exr... -o RENDER.exr --pattern ... [--row-bug]
//     the bands' renders in order, as one image of the pattern's grid with
//     the pattern in its metadata (siproject computes the positions again).
//
// POV-Ray 3.7.0 (FS#254, fixed in 3.7.1) traces face row 0 for output rows
// 0 and 1 and never the last face row: render each band one row higher and
// assemble with --row-bug, which reads pixel (i, j + 1) as ray j * W + i.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <optional>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include "cli.h"
#include "sis/imageio.h"
#include "sis/parallel.h"
#include "sis/pattern.h"
#include "sis/refinement.h"
#include "sis/scattered_input.h"
#include "sis/staged_file.h"

namespace fs = std::filesystem;
using namespace sis;

namespace {

using sis::cli::kExitInput;
using sis::cli::kExitOutput;
using sis::cli::kExitUsage;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

using V3 = std::array<double, 3>;
V3 operator+(V3 a, V3 b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
V3 operator-(V3 a, V3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 operator*(double s, V3 a) { return {s * a[0], s * a[1], s * a[2]}; }
double dot(V3 a, V3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 cross(V3 a, V3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double length(V3 a) { return std::sqrt(dot(a, a)); }
V3 normalized(V3 a) { return (1 / length(a)) * a; }

// ---- the scene's camera -----------------------------------------------------

// The camera statement's subset the project's scenes use: perspective or
// orthographic; location, direction, right, up, sky, look_at, angle;
// rotate, translate, scale; vectors and numbers in expressions of + - * /,
// parentheses, <a, b, c>, x, y, z, pi, image_width, image_height.
struct Token {
  std::string text;
  int line = 0;
};

std::vector<Token> tokenize(const std::string& s, int first_line = 1) {
  std::vector<Token> t;
  int line = first_line;
  for (std::size_t i = 0; i < s.size();) {
    const char c = s[i];
    if (c == '\n') ++line, ++i;
    else if (std::isspace(static_cast<unsigned char>(c))) ++i;
    else if (c == '/' && i + 1 < s.size() && s[i + 1] == '/') {
      while (i < s.size() && s[i] != '\n') ++i;
    } else if (c == '/' && i + 1 < s.size() && s[i + 1] == '*') {
      i += 2;
      while (i + 1 < s.size() && !(s[i] == '*' && s[i + 1] == '/')) line += s[i++] == '\n';
      i += 2;
    } else if (c == '"') {
      std::size_t j = i + 1;
      while (j < s.size() && s[j] != '"' && s[j] != '\n') ++j;
      t.push_back({s.substr(i, j + 1 - i), line});
      i = j + 1;
    } else if (std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == '#') {
      std::size_t j = i + 1;
      while (j < s.size() && (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == '_')) ++j;
      t.push_back({s.substr(i, j - i), line});
      i = j;
    } else if (std::isdigit(static_cast<unsigned char>(c)) || (c == '.' && i + 1 < s.size() &&
                                                               std::isdigit(static_cast<unsigned char>(s[i + 1])))) {
      std::size_t j = i;
      while (j < s.size() && (std::isdigit(static_cast<unsigned char>(s[j])) || s[j] == '.')) ++j;
      if (j < s.size() && (s[j] == 'e' || s[j] == 'E')) {
        std::size_t k = j + 1;
        if (k < s.size() && (s[k] == '+' || s[k] == '-')) ++k;
        if (k < s.size() && std::isdigit(static_cast<unsigned char>(s[k]))) {
          j = k;
          while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) ++j;
        }
      }
      t.push_back({s.substr(i, j - i), line});
      i = j;
    } else {
      t.push_back({std::string(1, c), line});
      ++i;
    }
  }
  return t;
}

struct Value {
  bool vector = false;
  V3 v{0, 0, 0};  // a number is v[0]
};

class CameraParser {
 public:
  CameraParser(std::vector<Token> tokens, std::string path, double image_width, double image_height)
      : t_(std::move(tokens)), path_(std::move(path)), iw_(image_width), ih_(image_height) {}

  [[noreturn]] void fail(const std::string& what) const {
    const int line = pos_ < t_.size() ? t_[pos_].line : (t_.empty() ? 0 : t_.back().line);
    throw InputError(path_ + ":" + std::to_string(line) + ": camera: " + what);
  }
  bool at(const char* s) const { return pos_ < t_.size() && t_[pos_].text == s; }
  void back() { --pos_; }  // the token just taken, for a message naming its line
  bool done() const { return pos_ >= t_.size(); }
  const std::string& peek() const { return t_[pos_].text; }
  std::string next() {
    if (done()) fail("ends early");
    return t_[pos_++].text;
  }
  void expect(const char* s) {
    if (!at(s)) fail(std::string("expected '") + s + "'" + (done() ? "" : ", found '" + peek() + "'"));
    ++pos_;
  }

  Value expression() {
    Value a = term();
    while (at("+") || at("-")) {
      const bool plus = next() == "+";
      const Value b = term();
      a = combine(a, b, plus ? '+' : '-');
    }
    return a;
  }
  V3 vector() {
    const Value v = expression();
    return v.vector ? v.v : V3{v.v[0], v.v[0], v.v[0]};
  }
  double number() {
    const Value v = expression();
    if (v.vector) fail("expected a number, found a vector");
    return v.v[0];
  }

 private:
  Value combine(Value a, Value b, char op) {
    // vectors combine component by component, as POV-Ray's do; a number is
    // promoted to <n, n, n>
    Value r;
    r.vector = a.vector || b.vector;
    for (int c = 0; c < 3; ++c) {
      const double x = a.vector ? a.v[c] : a.v[0], y = b.vector ? b.v[c] : b.v[0];
      r.v[c] = op == '+' ? x + y : op == '-' ? x - y : op == '*' ? x * y : x / y;
    }
    return r;
  }
  Value term() {
    Value a = unary();
    while (at("*") || at("/")) {
      const char op = next()[0];
      const Value b = unary();
      a = combine(a, b, op);
    }
    return a;
  }
  Value unary() {
    if (at("-")) {
      ++pos_;
      Value v = unary();
      for (double& c : v.v) c = -c;
      return v;
    }
    if (at("+")) {
      ++pos_;
      return unary();
    }
    return primary();
  }
  Value primary() {
    const std::string s = next();
    Value v;
    if (s == "(") {
      v = expression();
      expect(")");
    } else if (s == "<") {
      const double a = number();
      expect(",");
      const double b = number();
      expect(",");
      const double c = number();
      expect(">");
      v.vector = true;
      v.v = {a, b, c};
    } else if (s == "x" || s == "y" || s == "z") {
      v.vector = true;
      v.v[s[0] - 'x'] = 1;
    } else if (s == "pi") {
      v.v[0] = M_PI;
    } else if (s == "image_width") {
      v.v[0] = iw_;
    } else if (s == "image_height") {
      v.v[0] = ih_;
    } else if (std::isdigit(static_cast<unsigned char>(s[0])) || s[0] == '.') {
      v.v[0] = std::stod(s);
    } else {
      --pos_;
      fail("'" + s + "' is not supported in camera expressions (numbers, vectors, x, y, z, pi, "
           "image_width, image_height and + - * /)");
    }
    return v;
  }

  std::vector<Token> t_;
  std::size_t pos_ = 0;
  std::string path_;
  double iw_, ih_;
};

// A 4 x 3 affine map in POV-Ray's convention (row vectors: p' = p M + t).
struct Affine {
  double m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  V3 t{0, 0, 0};
  V3 point(V3 p) const { return direction(p) + t; }
  V3 direction(V3 p) const {
    V3 r{};
    for (int j = 0; j < 3; ++j) r[j] = p[0] * m[0][j] + p[1] * m[1][j] + p[2] * m[2][j];
    return r;
  }
  // this, then `b`
  Affine then(const Affine& b) const {
    Affine r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.m[i][j] = m[i][0] * b.m[0][j] + m[i][1] * b.m[1][j] + m[i][2] * b.m[2][j];
    r.t = b.point(t);
    return r;
  }
};

// POV-Ray's rotate <a, b, c>: about x by a degrees, then y by b, then z by c.
Affine rotation(V3 deg) {
  Affine r;
  for (int axis = 0; axis < 3; ++axis) {
    const double a = deg[axis] * M_PI / 180, c = std::cos(a), s = std::sin(a);
    Affine q;
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;  // x: (y, z); y: (z, x); z: (x, y)
    q.m[i][i] = c;
    q.m[j][j] = c;
    q.m[i][j] = s;
    q.m[j][i] = -s;
    r = r.then(q);
  }
  return r;
}

struct Camera {
  bool orthographic = false;
  V3 location{0, 0, 0}, direction{0, 0, 1}, right{1.33, 0, 0}, up{0, 1, 0};
};

// The tokens of the scene's camera statement (the last one at the top
// level, the one POV-Ray renders with).
std::vector<Token> camera_tokens(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot read the scene (" + std::strerror(errno) + ")");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::vector<Token> all = tokenize(ss.str());
  std::vector<Token> cam;
  int depth = 0;
  bool found = false;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const std::string& s = all[i].text;
    if (s == "{") ++depth;
    else if (s == "}") --depth;
    else if (depth == 0 && s == "camera" && i + 1 < all.size() && all[i + 1].text == "{") {
      std::size_t j = i + 2;
      int d = 1;
      std::vector<Token> body;
      for (; j < all.size(); ++j) {
        if (all[j].text == "{") ++d;
        if (all[j].text == "}" && --d == 0) break;
        body.push_back(all[j]);
      }
      if (j == all.size()) throw InputError(path + ":" + std::to_string(all[i].line) + ": camera: no closing brace");
      cam = std::move(body);
      found = true;
      i = j;
    }
  }
  if (!found)
    throw InputError(path + ": no camera { ... } statement at the top level (sirays reads the scene's "
                     "camera to aim the rays)");
  return cam;
}

// The camera as POV-Ray 3.7 computes it from the statement (the language
// version 3.5 and later order): right, direction, angle (direction's length
// from right's), up, sky, location, look_at (direction, right and up
// re-aimed, their lengths and handedness kept), the orthographic resize,
// then the transformations in their order.
Camera parse_camera(const std::string& path, long image_width, long image_height) {
  CameraParser p(camera_tokens(path), path, double(image_width), double(image_height));
  Camera cam;
  V3 sky{0, 1, 0}, look_at{0, 0, 1};
  bool had_look_at = false, had_up = false, had_right = false, had_angle = false;
  double angle = 0;
  Affine trans;
  while (!p.done()) {
    const std::string item = p.next();
    if (item == "perspective") cam.orthographic = false;
    else if (item == "orthographic") cam.orthographic = true;
    else if (item == "location") cam.location = p.vector();
    else if (item == "direction") cam.direction = p.vector();
    else if (item == "right") cam.right = p.vector(), had_right = true;
    else if (item == "up") cam.up = p.vector(), had_up = true;
    else if (item == "sky") sky = p.vector();
    else if (item == "look_at") look_at = p.vector(), had_look_at = true;
    else if (item == "angle") {
      angle = p.number();
      had_angle = true;
      if (angle < 0 || angle >= 180) p.fail("angle " + std::to_string(angle) + " outside [0, 180)");
    } else if (item == "rotate") trans = trans.then(rotation(p.vector()));
    else if (item == "translate") {
      Affine q;
      q.t = p.vector();
      trans = trans.then(q);
    } else if (item == "scale") {
      const V3 s = p.vector();
      Affine q;
      for (int c = 0; c < 3; ++c) q.m[c][c] = s[c];
      trans = trans.then(q);
    } else {
      p.back();
      p.fail("'" + item +
             "' is not supported by sirays (perspective or orthographic; location, "
             "direction, right, up, sky, look_at, angle; rotate, translate, scale)");
    }
  }
  if (had_angle && angle > 0) {
    cam.direction = (length(cam.right) / std::tan(angle * M_PI / 360) / 2) * normalized(cam.direction);
  }
  if (had_look_at) {
    const double dl = length(cam.direction), ul = length(cam.up), rl = length(cam.right);
    const double handed = dot(cross(cam.up, cam.direction), cam.right);
    V3 d = look_at - cam.location;
    if (dot(d, d) < 1e-10) throw InputError(path + ": camera: location and look_at are the same point");
    d = normalized(d);
    V3 r = cross(sky, d);
    if (std::fabs(r[0]) < 1e-10 && std::fabs(r[1]) < 1e-10 && std::fabs(r[2]) < 1e-10) r = cam.right;
    r = normalized(r);
    cam.up = ul * cross(d, r);
    cam.direction = dl * d;
    cam.right = (handed > 0 ? rl : -rl) * r;
  }
  if (cam.orthographic && ((!had_up && !had_right) || had_angle)) {
    const double k1 = length(look_at - cam.location), k2 = length(cam.direction);
    if (k1 > 1e-10 && k2 > 1e-10) {
      cam.right = (k1 / k2) * cam.right;
      cam.up = (k1 / k2) * cam.up;
    }
  }
  cam.location = trans.point(cam.location);
  cam.direction = trans.direction(cam.direction);
  cam.right = trans.direction(cam.right);
  cam.up = trans.direction(cam.up);
  return cam;
}

// The ray through frame position (x, y) of a W x H frame, as POV-Ray's
// CreateCameraRay makes it for the pixel whose centre that is:
// x0 = x / W - 1/2, y0 = 1/2 - y / H; origin relative to the location.
void camera_ray(const Camera& c, double x0, double y0, V3& origin, V3& direction) {
  if (c.orthographic) {
    origin = x0 * c.right + y0 * c.up;
    direction = normalized(c.direction);
  } else {
    origin = {0, 0, 0};
    direction = normalized(c.direction + x0 * c.right + y0 * c.up);
  }
}

// ---- the mesh -------------------------------------------------------------

void put_float(std::string& out, double v) {
  char b[32];
  auto [e, ec] = std::to_chars(b, b + sizeof b, static_cast<float>(v));
  (void)ec;
  out.append(b, e);
}

// Ray k's triangle: centroid at the origin, in the plane normal to the
// direction n, P1 = o + e1, P2 = o - e1/2 - (sqrt 3 / 2) e2,
// P3 = o - e1/2 + (sqrt 3 / 2) e2 with e1 x e2 = n, so that
// (P3 - P1) x (P2 - P1) points along n.
void put_triangle(std::string& out, V3 o, V3 n) {
  const V3 helper = std::fabs(n[0]) < 0.6 ? V3{1, 0, 0} : V3{0, 1, 0};
  const V3 e1 = normalized(cross(n, helper));
  const V3 e2 = cross(n, e1);
  const double h = std::sqrt(3.0) / 2;
  const V3 p[3] = {o + e1, o - 0.5 * e1 - h * e2, o - 0.5 * e1 + h * e2};
  for (const V3& q : p) {
    out += '<';
    put_float(out, q[0]);
    out += ',';
    put_float(out, q[1]);
    out += ',';
    put_float(out, q[2]);
    out += ">,\n";
  }
}

void write_all(int fd, const std::string& s, const std::string& target) {
  const char* p = s.data();
  std::size_t left = s.size();
  while (left) {
    const ssize_t w = ::write(fd, p, left);
    if (w < 0) {
      if (errno == EINTR) continue;
      throw OutputError(target + ": cannot write (" + std::strerror(errno) + ")");
    }
    p += w;
    left -= std::size_t(w);
  }
}

std::pair<long, long> parse_size(const std::string& s) {
  long w = 0, h = 0;
  const char* e = s.data() + s.size();
  auto [q, ec] = std::from_chars(s.data(), e, w);
  if (ec == std::errc() && q != e && *q == 'x') {
    auto [q2, ec2] = std::from_chars(q + 1, e, h);
    if (ec2 == std::errc() && q2 == e && w > 0 && h > 0) return {w, h};
  }
  throw UsageError("--size " + s + ": expected WxH, the frame in output pixels (positive whole numbers)");
}

struct PatternOptions {
  std::string pattern = "regular", size;
  std::uint64_t seed = 0;
  double factor = 0;
};

void add_pattern_options(CLI::App* app, PatternOptions& o) {
  app->add_option("--pattern", o.pattern, "sample pattern: regular, jitter, sobol")->capture_default_str();
  app->add_option("--seed", o.seed, "the pattern's seed")->capture_default_str();
  app->add_option("--size", o.size, "the frame WxH, output pixels (required without --refinement)");
  app->add_option("--factor", o.factor, "samples per output pixel along each axis (any positive number; "
                                        "required without --refinement)");
}

SamplePattern pattern_of(const PatternOptions& o) {
  PatternKind kind;
  try {
    kind = parse_pattern(o.pattern);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--pattern: ") + e.what());
  }
  const auto [w, h] = parse_size(o.size);
  try {
    return make_pattern(kind, o.seed, w, h, o.factor);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--size ") + o.size + " --factor: " + e.what());
  }
}

std::string pov_string(const std::string& path) {
  if (path.find('"') != std::string::npos) throw UsageError(path + ": a path with a double quote");
  return "\"" + path + "\"";
}

// The band's scene: the scene, the rays' mesh2 declared (a mesh_camera
// takes a mesh { }, which keeps a declared mesh2's triangle order), then the
// mesh camera (the last camera statement is the one POV-Ray uses).
// The rays of a mesh: a grid gw x gh (the render's pixels), ray k at
// positions(k0, k1, xy) (frame coordinates of the frame W x H), `what`
// describes them for the scene's first line.
struct RayGrid {
  long gw = 0, gh = 0;
  long camera_w = 0, camera_h = 0;  // image_width, image_height of the camera's frame (the pattern's grid)
  double W = 0, H = 0;
  std::string what;
  std::function<void(long, long, double*)> positions;
};

RayGrid pattern_rays(const SamplePattern& pat) {
  RayGrid g;
  g.gw = g.camera_w = pat.grid_width();
  g.gh = g.camera_h = pat.grid_height();
  g.W = double(pat.width);
  g.H = double(pat.height);
  g.what = std::string("pattern ") + pattern_name(pat.kind) + ", seed " + std::to_string(pat.seed) +
           ", frame " + std::to_string(pat.width) + "x" + std::to_string(pat.height) + ", factor " +
           metadata_number(pat.factor);
  g.positions = [pat](long k0, long k1, double* xy) { sample_positions(pat, k0, k1, xy); };
  return g;
}

// A refinement's extra rays (sis/refinement.h) in rows as wide as its base's
// grid; the last row's pixels past the last ray repeat it (assemble drops them).
RayGrid refinement_rays(const Refinement& r) {
  RayGrid g;
  const long m = r.extra_count();
  if (m < 1) throw UsageError("the refinement refines no tile: there are no extra rays to trace");
  g.gw = std::min(m, r.base.grid_width());
  g.gh = (m + g.gw - 1) / g.gw;
  // the camera's aspect is the frame's: image_width and image_height as the base render's
  g.camera_w = r.base.grid_width();
  g.camera_h = r.base.grid_height();
  g.W = double(r.base.width);
  g.H = double(r.base.height);
  g.what = "the " + std::to_string(m) + " extra rays of a refinement of " + std::to_string(r.tiles.size()) +
           " tiles of " + std::to_string(r.tile) + " pixels to " + std::to_string(r.rays) +
           " rays per pixel, base pattern " + pattern_name(r.base.kind) + " seed " + std::to_string(r.base.seed);
  g.positions = [r, m](long k0, long k1, double* xy) {
    const long e1 = std::min(k1, m);
    if (e1 > k0) extra_positions(r, k0, e1, xy);
    for (long k = std::max(k0, e1); k < k1; ++k) extra_positions(r, m - 1, m, xy + 2 * (k - k0));
  };
  return g;
}

void write_mesh(const std::string& scene, const std::string& output, const RayGrid& rg,
                long y0, long y1, int threads) {
  const long gw = rg.gw;
  const Camera cam = parse_camera(scene, rg.camera_w, rg.camera_h);
  const long n = (y1 - y0) * gw;
  StagedFile staged(output);
  std::string head;
  head += "// sirays mesh: the rays of samples " + std::to_string(y0 * gw) + " to " +
          std::to_string(y1 * gw - 1) + " of " + rg.what + "\n";
  head += "// render " + std::to_string(gw) + " x " + std::to_string(y1 - y0) +
          " (one row more under POV-Ray 3.7.0's FS#254) with -A\n";
  head += "#version 3.7;\n#include " + pov_string(fs::absolute(scene).lexically_normal().string()) + "\n";
  head += "#declare SIS_Rays = mesh2 {\nvertex_vectors { " + std::to_string(3 * n) + ",\n";
  write_all(staged.fd(), head, output);
  constexpr long kChunk = 1 << 16;
  const long chunks = (n + kChunk - 1) / kChunk;
  const double W = rg.W, H = rg.H;
  // at most 16 chunks (1 M rays, about 100 MB of text) in memory at once,
  // whatever the band's size
  for (long c0 = 0; c0 < chunks; c0 += 16) {
    const long c1 = std::min(chunks, c0 + 16);
    std::vector<std::string> text(std::size_t(c1 - c0));
    parallel_for(c1 - c0, threads, [&](long a, long b) {
      std::vector<double> xy(2 * kChunk);
      for (long c = a; c < b; ++c) {
        const long f0 = (c0 + c) * kChunk, f1 = std::min(n, f0 + kChunk);
        rg.positions(y0 * gw + f0, y0 * gw + f1, xy.data());
        std::string& s = text[std::size_t(c)];
        s.reserve(std::size_t(f1 - f0) * 136);  // a ray is at most about 130 characters
        for (long f = f0; f < f1; ++f) {
          V3 o, d;
          camera_ray(cam, xy[2 * (f - f0)] / W - 0.5, 0.5 - xy[2 * (f - f0) + 1] / H, o, d);
          put_triangle(s, o, d);
        }
      }
    });
    for (const std::string& s : text) write_all(staged.fd(), s, output);
  }
  std::string faces = "}\nface_indices { " + std::to_string(n) + ",\n";
  for (long f = 0; f < n; ++f) {
    faces += '<';
    faces += std::to_string(3 * f);
    faces += ',';
    faces += std::to_string(3 * f + 1);
    faces += ',';
    faces += std::to_string(3 * f + 2);
    faces += ">,\n";
    if (faces.size() > (1 << 22)) {
      write_all(staged.fd(), faces, output);
      faces.clear();
    }
  }
  char loc[128];
  std::snprintf(loc, sizeof loc, "<%.17g,%.17g,%.17g>", cam.location[0], cam.location[1], cam.location[2]);
  faces += "}\n}\ncamera { mesh_camera { 1 0 mesh { SIS_Rays translate " + std::string(loc) + " } } }\n";
  write_all(staged.fd(), faces, output);
  staged.commit();
}

// ---- assembly ---------------------------------------------------------------

void assemble(const std::vector<std::string>& bands, const std::string& output, long gw, long gh,
              const Metadata& md, bool row_bug) {
  const int skip = row_bug ? 1 : 0;
  std::vector<std::string> names;
  Image image;
  long y = 0;
  for (const std::string& path : bands) {
    ImageReader r(path);
    if (names.empty()) {
      names = r.channel_names();
      image = Image(gw, gh, r.channels(), kUnset);
    } else if (r.channel_names() != names) {
      throw InputError(path + ": its channels are not the first band's");
    }
    if (r.width() != gw)
      throw InputError(path + ": " + std::to_string(r.width()) + " pixels wide; the pattern's grid is " +
                       std::to_string(gw) + " (a mesh band renders one pixel per ray of its rows)");
    const long rows = r.height() - skip;
    if (rows < 1)
      throw InputError(path + ": " + std::to_string(r.height()) + " rows: no ray's row" +
                       (row_bug ? " after the row POV-Ray 3.7.0 repeats (FS#254)" : ""));
    if (y + rows > gh)
      throw InputError(path + ": its " + std::to_string(rows) + " rows pass the grid's " +
                       std::to_string(gh) + " (rows " + std::to_string(y) + " on)");
    std::vector<float> all(std::size_t(r.height()) * gw * r.channels());
    r.read_rows(0, r.height(), all.data());
    std::copy(all.begin() + std::size_t(skip) * gw * r.channels(), all.end(), image.row(y));
    y += rows;
  }
  if (y != gh)
    throw InputError("the bands hold " + std::to_string(y) + " rows of rays; the pattern's grid has " +
                     std::to_string(gh) + " (a band POV-Ray did not render whole, or one missing)");
  write_image(output, image, names, md, -1, WriteOptions(SampleFormat::Half));
}

// ---- refinement ------------------------------------------------------------

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw InputError(path + ": cannot read the refinement (" + std::strerror(errno) + ")");
  std::stringstream b;
  b << f.rdbuf();
  return b.str();
}

Refinement read_refinement(const std::string& path) {
  try {
    return parse_refinement(read_text(path), path);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
}

struct RefineOptions {
  std::string base, output, estimates, estimator = "residual";
  double rays = 0;
  long refine_rays = 0, tile = 8;
  double share = 0;
  bool refine_rays_given = false, share_given = false;
  int threads = 0;
};

// The first pass's samples projected (min-error cubic, the fit, mirror),
// every tile's estimate, the tiles the budget buys: the refinement's text
// to -o, and with --estimates an EXR of the tile grid (channels estimate and
// refined, the refinement in its metadata); both written before either
// replaces a file.
void refine(const RefineOptions& o, int threads) {
  Estimator est;
  try {
    est = parse_estimator(o.estimator);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--estimator: ") + e.what());
  }
  if (o.tile < 1) throw UsageError("--tile " + std::to_string(o.tile) + ": expected a whole number >= 1");
  if (!(o.rays > 0) || !std::isfinite(o.rays))
    throw UsageError("--rays " + metadata_number(o.rays) + ": expected a number of rays per pixel > 0");
  RefinedPlan plan;
  try {
    plan = refine_render(o.base, o.rays,
                         o.refine_rays_given ? std::optional<long>(o.refine_rays) : std::nullopt,
                         o.share_given ? std::optional<double>(o.share) : std::nullopt, o.tile, est, threads);
  } catch (const std::invalid_argument& x) {
    throw UsageError("--rays " + metadata_number(o.rays) +
                     (o.refine_rays_given ? " --refine-rays " + std::to_string(o.refine_rays) : std::string()) +
                     (o.share_given ? " --share " + metadata_number(o.share) : std::string()) + ": " + x.what());
  }
  const Refinement& r = plan.refinement;
  const std::vector<double>& e = plan.estimate;
  const std::string text = refinement_text(r);
  StagedFile staged(o.output);
  write_all(staged.fd(), text, o.output);
  std::optional<StagedFile> map;
  if (!o.estimates.empty()) {
    const TileGrid g = r.grid();
    Image im(g.columns(), g.rows(), 2, kUnset);
    for (long q = 0; q < g.count(); ++q) {
      im.data[std::size_t(2 * q)] = float(e[std::size_t(q)]);
      im.data[std::size_t(2 * q + 1)] = std::binary_search(r.tiles.begin(), r.tiles.end(), q) ? 1.0f : 0.0f;
    }
    Metadata md{{kRefinementKey, text}, {"sis:estimator", estimator_name(est)}};
    map.emplace(stage_image(o.estimates, im, {"estimate", "refined"}, md, -1, WriteOptions(SampleFormat::Float)));
  }
  staged.commit();
  if (map) map->commit();
  std::fprintf(stderr, "sirays refine: %zu of %ld tiles of %ld pixels refined to %ld rays per pixel (estimator %s): "
               "%ld extra rays, %.4g rays per pixel in all\n",
               r.tiles.size(), r.grid().count(), r.tile, r.rays, estimator_name(est), r.extra_count(),
               r.rays_per_pixel());
}

}  // namespace

int main(int argc, char** argv) {
  remove_staged_files_on_signals();
  CLI::App app{"sirays: a sample pattern's rays through POV-Ray's mesh camera, and their renders "
               "assembled into one input for siproject"};
  app.require_subcommand(1);
  PatternOptions po;
  std::string scene, output, rows;
  int threads = 0;
  CLI::App* mesh = app.add_subcommand("mesh", "write the scene of a band of rays (a mesh_camera)");
  mesh->add_option("scene", scene, "the POV-Ray scene whose camera aims the rays")->required();
  mesh->add_option("-o,--output", output, "the band's scene (.pov)")->required();
  mesh->add_option("--rows", rows, "the grid's rows Y0:Y1 of the band (default: all)");
  mesh->add_option("--threads", threads, "threads (0: every core)")->capture_default_str();
  std::string refinement;
  mesh->add_option("--refinement", refinement,
                   "trace a refinement's extra rays (sirays refine -o) instead of a pattern's; "
                   "the grid's rows as wide as the base's, the last padded");
  add_pattern_options(mesh, po);
  std::vector<std::string> bands;
  bool row_bug = false;
  CLI::App* asmb = app.add_subcommand("assemble", "the bands' renders as one input with the pattern's metadata");
  asmb->add_option("bands", bands, "the bands' renders (EXR), in row order (none for a refinement of no tile)");
  asmb->add_option("-o,--output", output, "the assembled render (.exr)")->required();
  asmb->add_flag("--row-bug", row_bug,
                 "each band was rendered one row higher for POV-Ray 3.7.0's FS#254: drop its first row");
  asmb->add_option("--refinement", refinement,
                   "the bands are a refinement's extra rays: write them with the refinement in "
                   "sis:refinement (siproject BASE --refined)");
  add_pattern_options(asmb, po);
  CLI::App* grid = app.add_subcommand("grid", "print the width and height of a refinement's ray grid "
                                              "(the second pass's render; 0 0 for no extra ray)");
  grid->add_option("--refinement", refinement, "the refinement (sirays refine -o)")->required();
  RefineOptions ro;
  CLI::App* ref = app.add_subcommand(
      "refine", "estimate where a sobol render's projection errs, per tile, and choose the tiles "
                "a budget of rays refines (the second pass of an adaptive render)");
  ref->add_option("base", ro.base, "the first pass: a sobol render (sirays assemble)")->required();
  ref->add_option("-o,--output", ro.output, "the refinement (text; sirays mesh/assemble --refinement)")->required();
  ref->add_option("--rays", ro.rays, "rays per output pixel over the whole frame, both passes")->required();
  auto* rr = ref->add_option("--refine-rays", ro.refine_rays,
                             "rays per pixel in a refined tile [default: the count up to max(64, --rays) whose tiles leave the least estimated error, a tile's error taken to fall as 1 / its rays]");
  auto* sh = ref->add_option("--share", ro.share,
                             "the fraction of the frame's pixels refined, (0, 1] (sets --refine-rays)");
  ref->add_option("--tile", ro.tile, "tile side in output pixels")->capture_default_str();
  ref->add_option("--estimator", ro.estimator, "residual, halves, contrast or highpass (docs/design.md section 17)")->capture_default_str();
  ref->add_option("--estimates", ro.estimates,
                  "also write every tile's estimate and whether it is refined (EXR, one pixel a tile)");
  ref->add_option("--threads", threads, "threads (0: every core)")->capture_default_str();
  if (auto rc = sis::cli::parse(app, argc, argv)) return *rc;
  try {
    const int nthreads = threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency()));
    if (ref->parsed()) {
      ro.refine_rays_given = rr->count() > 0;
      ro.share_given = sh->count() > 0;
      refine(ro, nthreads);
      return 0;
    }
    std::optional<Refinement> rf;
    if (!refinement.empty()) {
      if (!po.size.empty() || po.factor != 0)
        throw UsageError("--refinement " + refinement + ": the rays are the refinement's; drop --size and --factor");
      rf = read_refinement(refinement);
    } else if (po.size.empty() || po.factor == 0) {
      throw UsageError("--size and --factor: the pattern's frame and factor are required (or --refinement)");
    }
    if (grid->parsed()) {
      const long m = rf->extra_count();
      const long gw = std::min(m, rf->base.grid_width());
      std::cout << gw << " " << (m ? (m + gw - 1) / gw : 0) << "\n";
      return 0;
    }
    if (asmb->parsed() && rf && rf->extra_count() == 0) {
      // no tile refined: a file of no ray (one pixel, which no ray reads)
      if (!bands.empty()) throw UsageError("--refinement " + refinement + " refines no tile: it takes no band");
      Image none(1, 1, 1, kUnset);
      none.data[0] = 0;
      write_image(output, none, {"none"}, {{kRefinementKey, refinement_text(*rf)}}, -1,
                  WriteOptions(SampleFormat::Half));
      return 0;
    }
    if (asmb->parsed() && bands.empty()) throw UsageError("assemble: no band given");
    const RayGrid rg = rf ? refinement_rays(*rf) : pattern_rays(pattern_of(po));
    if (mesh->parsed()) {
      long y0 = 0, y1 = rg.gh;
      if (!rows.empty()) {
        const auto colon = rows.find(':');
        char* e = nullptr;
        bool ok = colon != std::string::npos;
        if (ok) {
          y0 = std::strtol(rows.c_str(), &e, 10);
          ok = e == rows.c_str() + colon;
          y1 = std::strtol(rows.c_str() + colon + 1, &e, 10);
          ok = ok && *e == 0 && colon + 1 < rows.size();
        }
        if (!ok || y0 < 0 || y1 <= y0 || y1 > rg.gh)
          throw UsageError("--rows " + rows + ": expected Y0:Y1 with 0 <= Y0 < Y1 <= " +
                           std::to_string(rg.gh) + " (the grid's rows)");
      }
      if (fs::path(output).extension() != ".pov") throw UsageError("-o " + output + ": a band's scene ends in .pov");
      write_mesh(scene, output, rg, y0, y1, nthreads);
    } else {
      Metadata md;
      if (rf) {
        md.emplace_back(kRefinementKey, refinement_text(*rf));
      } else {
        for (const PatternAttribute& a : pattern_metadata(pattern_of(po))) md.emplace_back(a.name, a.value);
      }
      assemble(bands, output, rg.gw, rg.gh, md, row_bug);
    }
  } catch (const UsageError& e) {
    std::cerr << "sirays: " << e.what() << "\n";
    return kExitUsage;
  } catch (const InputError& e) {
    std::cerr << "sirays: " << e.what() << "\n";
    return kExitInput;
  } catch (const OutputError& e) {
    std::cerr << "sirays: " << e.what() << "\n";
    return kExitOutput;
  } catch (const std::exception& e) {
    std::cerr << "sirays: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
