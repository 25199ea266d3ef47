#include "sis/partial.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "image_input.h"
#include "sis/memory.h"
#include "sis/projection.h"
#include "sis/staged_file.h"

namespace sis {

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {

std::string size_of(long w, long h) { return std::to_string(w) + "x" + std::to_string(h); }
std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t k = 0; k < v.size(); ++k) s += (k ? "," : "") + v[k];
  return s;
}

// Row lists as runs ("0-99 105"), parts as row@band.
std::string runs(const std::vector<long>& v) {
  std::ostringstream s;
  for (std::size_t k = 0; k < v.size();) {
    std::size_t e = k;
    while (e + 1 < v.size() && v[e + 1] == v[e] + 1) ++e;
    s << (k ? " " : "") << v[k];
    if (e > k) s << "-" << v[e];
    k = e + 1;
  }
  return s.str();
}
std::string parts_of(const std::vector<std::pair<long, long>>& v) {
  std::ostringstream s;
  for (std::size_t k = 0; k < v.size(); ++k) s << (k ? " " : "") << v[k].first << "@" << v[k].second;
  return s.str();
}

// Channel names in OpenEXR's order (sorted by name): s0000, s0001...
std::vector<std::string> word_names(const std::string& prefix, int count) {
  std::vector<std::string> v;
  for (int k = 0; k < count; ++k) {
    char n[16];
    std::snprintf(n, sizeof n, "%s%04d", prefix.c_str(), k);
    v.push_back(n);
  }
  return v;
}

struct Bad : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

long whole(const std::string& key, const std::string& text, long lo = 0, long hi = LONG_MAX) {
  std::size_t used = 0;
  long v = 0;
  try {
    v = std::stol(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || v < lo || v > hi)
    throw Bad(key + " '" + text + "': expected a whole number from " + std::to_string(lo));
  return v;
}
std::vector<long> parse_runs(const std::string& key, const std::string& text, long limit,
                             std::size_t most = SIZE_MAX) {
  std::vector<long> v;
  std::istringstream s(text);
  std::string run;
  while (s >> run) {
    const auto dash = run.find('-', 1);
    const long a = whole(key, run.substr(0, dash), 0, limit - 1);
    const long b = dash == std::string::npos ? a : whole(key, run.substr(dash + 1), a, limit - 1);
    if (!v.empty() && a <= v.back()) throw Bad(key + ": not ascending");
    if (std::size_t(b - a) >= most - v.size()) throw Bad(key + ": more rows than its part holds");
    for (long r = a; r <= b; ++r) v.push_back(r);
  }
  return v;
}
std::vector<std::pair<long, long>> parse_parts(const std::string& key, const std::string& text,
                                               long rows, long bands) {
  std::vector<std::pair<long, long>> v;
  std::istringstream s(text);
  std::string part;
  while (s >> part) {
    const auto at = part.find('@');
    if (at == std::string::npos) throw Bad(key + " '" + part + "': expected ROW@BAND");
    v.push_back({whole(key, part.substr(0, at), 0, rows - 1),
                 whole(key, part.substr(at + 1), 0, bands - 1)});
  }
  return v;
}

}  // namespace

Metadata partial_request(const Partial& p) {
  Metadata md = {{"sis:lattice", space_name(p.space)}};
  const Metadata own = visit_space(p.space, [](const auto& s) { return s.parameters(); });
  md.insert(md.end(), own.begin(), own.end());
  md.insert(md.end(), {
      {"sis:input_size", size_of(p.input_width, p.input_height)},
      {"sis:size", size_of(p.width, p.height)},
      {"sis:channels", joined(p.channel_names)},
      {"sis:alpha", std::to_string(p.alpha)},
      {"sis:method", method_name(p.method)},
      {"sis:boundary", boundary_name(p.boundary)},
      {"sis:prefilter", p.prefilter == PrefilterMethod::FFT ? "fft" : "recursive"},
      {"sis:input_transfer", p.transfer.name()},
      {"sis:highlight_compress", p.highlight_compressed ? "1" : "0"},
      {"sis:nonfinite", p.zero_nonfinite ? "zero" : "error"},
      {"sis:band_rows", std::to_string(p.band_rows)},
      {"sis:band_count", std::to_string(p.band_count)},
  });
  return md;
}

bool is_partial_file(const ImageReader& reader) { return reader.attribute("sis:partial") == "1"; }

void write_partial(const std::string& path, const Partial& p) {
  check_output(path);
  const int C = int(p.channel_names.size());
  const std::size_t records = p.acquisition.rows.size() + p.acquisition.parts.size();
  const std::size_t range_records = p.range.rows.size() + p.range.parts.size();
  if (C < 1 || records == 0 || range_records == 0 || p.acquisition.size % C || p.range.size % C)
    throw std::logic_error("write_partial(): an empty or malformed partial");
  if (!holds_coefficients(path)) throw OutputError(path + ": partial files are OpenEXR (.exr)");
  ImageSpec sums(int(p.acquisition.size / C), int(records), 2 * C, TypeDesc::UINT);
  sums.channelnames = word_names("s", 2 * C);
  sums.attribute("compression", "zip");
  sums.attribute("name", "sums");
  sums.attribute("sis:partial", "1");
  for (const auto& [key, value] : partial_request(p)) sums.attribute(key, value);
  sums.attribute("sis:bands", runs(p.bands));
  sums.attribute("sis:label", p.label);
  sums.attribute("sis:integer_bits", std::to_string(p.integer_bits));
  sums.attribute("sis:half", p.half ? "1" : "0");
  sums.attribute("sis:nonfinite_count", std::to_string(p.nonfinite.count));
  if (p.nonfinite.count) {
    sums.attribute("sis:nonfinite_at", std::to_string(p.nonfinite.x) + " " +
                                           std::to_string(p.nonfinite.y) + " " +
                                           std::to_string(p.nonfinite.channel));
    sums.attribute("sis:nonfinite_file", p.nonfinite.file);
    sums.attribute("sis:nonfinite_where", p.nonfinite.where);
  }
  sums.attribute("sis:sums_rows", runs(p.acquisition.rows));
  sums.attribute("sis:sums_parts", parts_of(p.acquisition.parts));
  sums.attribute("sis:range_rows", runs(p.range.rows));
  sums.attribute("sis:range_parts", parts_of(p.range.parts));
  ImageSpec range(int(p.range.size / C), int(range_records), C, TypeDesc::FLOAT);
  range.channelnames = word_names("r", C);
  range.attribute("compression", "zip");
  range.attribute("name", "range");
  // one display window for both parts, as OpenEXR's multi-part files require
  for (ImageSpec* s : {&sums, &range}) {
    s->full_width = std::max(sums.width, range.width);
    s->full_height = std::max(sums.height, range.height);
  }
  const ImageSpec specs[2] = {sums, range};

  StagedFile file(path);
  auto out = ImageOutput::create("openexr");
  if (!out) throw OutputError(path + ": cannot write OpenEXR: " + OIIO::geterror());
  // the doubles' bits as two 32-bit words each (the sums are kept exactly)
  std::vector<std::uint32_t> words(2 * p.acquisition.values.size());
  std::memcpy(words.data(), p.acquisition.values.data(), words.size() * sizeof(std::uint32_t));
  const bool ok = out->open(file.temporary(), 2, specs) &&
                  out->write_image(TypeDesc::UINT, words.data()) &&
                  out->open(file.temporary(), range, ImageOutput::AppendSubimage) &&
                  out->write_image(TypeDesc::FLOAT, p.range.values.data()) && out->close();
  const std::string why = out->geterror();
  out.reset();
  if (!ok) throw OutputError(path + ": " + (why.empty() ? "write failed" : why));
  file.commit();
}

Partial read_partial(const std::string& path, bool values) {
  ImageReader reader(path);
  if (!is_partial_file(reader)) throw InputError(path + ": not a partial file (no sis:partial)");
  std::string why;
  auto in = open_input(path, &why);
  if (!in) throw InputError(path + ": " + why);
  Partial p;
  try {
    const ImageSpec sums = in->spec(0, 0);
    const ImageSpec range = in->spec(1, 0);
    auto get = [&](const char* key) { return sums.get_string_attribute(key); };
    // the request
    const std::string lattice = get("sis:lattice");
    p.space = parse_space(lattice, get("sis:generator"), true,
                          lattice == CartesianSpace::lattice_name ? 1.0 : std::stod(get("sis:density")),
                          lattice != CartesianSpace::lattice_name);
    auto sides = [&](const char* key, long* w, long* h) {
      const std::string v = get(key);
      const auto x = v.find('x');
      if (x == std::string::npos) throw Bad(std::string(key) + " '" + v + "': expected WxH");
      *w = whole(key, v.substr(0, x), 1);
      *h = whole(key, v.substr(x + 1), 1);
    };
    sides("sis:input_size", &p.input_width, &p.input_height);
    sides("sis:size", &p.width, &p.height);
    std::istringstream names(get("sis:channels"));
    for (std::string n; std::getline(names, n, ',');) p.channel_names.push_back(n);
    const int C = int(p.channel_names.size());
    p.alpha = int(whole("sis:alpha", get("sis:alpha"), -1, C - 1));
    p.method = parse_method(get("sis:method"));
    p.boundary = parse_boundary(get("sis:boundary"));
    const std::string pre = get("sis:prefilter");
    if (pre != "fft" && pre != "recursive") throw Bad("sis:prefilter '" + pre + "'");
    p.prefilter = pre == "fft" ? PrefilterMethod::FFT : PrefilterMethod::Recursive;
    p.transfer = parse_transfer(get("sis:input_transfer"));
    p.highlight_compressed = whole("sis:highlight_compress", get("sis:highlight_compress"), 0, 1);
    const std::string nf = get("sis:nonfinite");
    if (nf != "zero" && nf != "error") throw Bad("sis:nonfinite '" + nf + "'");
    p.zero_nonfinite = nf == "zero";
    p.band_rows = whole("sis:band_rows", get("sis:band_rows"), 1);
    p.band_count = whole("sis:band_count", get("sis:band_count"), 1);
    if (p.band_count != BandPartition(p.input_height, p.band_rows).count())
      throw Bad("sis:band_count does not match the grid's bands");
    // what it holds
    p.bands = parse_runs("sis:bands", get("sis:bands"), p.band_count);
    if (p.bands.empty()) throw Bad("sis:bands: none");
    p.label = path;  // messages name the file the user gave (sis:label: its inputs)
    p.integer_bits = int(whole("sis:integer_bits", get("sis:integer_bits"), 0, 32));
    p.half = whole("sis:half", get("sis:half"), 0, 1);
    p.nonfinite.count = whole("sis:nonfinite_count", get("sis:nonfinite_count"));
    if (p.nonfinite.count) {
      std::istringstream at(get("sis:nonfinite_at"));
      at >> p.nonfinite.x >> p.nonfinite.y >> p.nonfinite.channel;
      p.nonfinite.file = get("sis:nonfinite_file");
      p.nonfinite.where = get("sis:nonfinite_where");
    }
    // the records: their tables, then their values
    if (C < 1 || C > 4999 || sums.channelnames != word_names("s", 2 * C) ||
        sums.format != TypeDesc::UINT || range.channelnames != word_names("r", C) ||
        range.format != TypeDesc::FLOAT)
      throw Bad("its parts are not the sums (2 uint channels a channel) and the range (float)");
    p.acquisition.rows = parse_runs("sis:sums_rows", get("sis:sums_rows"), kMaxOutputSide,
                                     std::size_t(sums.height));
    p.acquisition.parts =
        parse_parts("sis:sums_parts", get("sis:sums_parts"), kMaxOutputSide, p.band_count);
    p.range.rows = parse_runs("sis:range_rows", get("sis:range_rows"), p.height,
                                std::size_t(range.height));
    p.range.parts = parse_parts("sis:range_parts", get("sis:range_parts"), p.height, p.band_count);
    if (long(p.acquisition.rows.size() + p.acquisition.parts.size()) != sums.height ||
        long(p.range.rows.size() + p.range.parts.size()) != range.height)
      throw Bad("its tables of rows do not match its parts' heights");
    p.acquisition.size = std::size_t(sums.width) * C;
    p.range.size = std::size_t(range.width) * C;
    if (!values) return p;
    const double bytes = 8.0 * double(sums.width) * sums.height * C +
                         4.0 * double(range.width) * range.height * C;
    check_memory(std::uint64_t(2 * bytes) + (64u << 20), "the partial " + path);
    p.acquisition.values.resize(std::size_t(sums.width) * sums.height * C);
    p.range.values.resize(std::size_t(range.width) * range.height * C);
    std::vector<std::uint32_t> words(2 * p.acquisition.values.size());
    if (!in->read_image(0, 0, 0, 2 * C, TypeDesc::UINT, words.data()) ||
        !in->read_image(1, 0, 0, C, TypeDesc::FLOAT, p.range.values.data()))
      throw InputError(path + ": cannot read: " + in->geterror());
    std::memcpy(p.acquisition.values.data(), words.data(), words.size() * sizeof(std::uint32_t));
  } catch (const InputError&) {
    throw;
  } catch (const RequestError& e) {
    throw InputError(path + ": partial file metadata: " + e.what());
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": partial file metadata: " + e.what());
  } catch (const std::out_of_range& e) {
    throw InputError(path + ": partial file metadata out of range");
  }
  return p;
}

}  // namespace sis
