#include "sis/sequence.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace sis {

namespace fs = std::filesystem;

namespace {

bool all_digits(const std::string& s) {
  return !s.empty() && s.size() <= 12 &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::invalid_argument bad_range(const std::string& s, const std::string& why) {
  return std::invalid_argument("frame range '" + s + "': " + why +
                               " (expected e.g. 7, 1-10, 10-1, 1-10x2, 1-10y2 or 3,4,10-20x2)");
}

}  // namespace

std::vector<long> parse_frame_range(const std::string& s) {
  std::vector<long> frames;
  if (s.empty()) throw bad_range(s, "empty");
  std::stringstream list(s);
  std::string part;
  std::size_t parts = 0, commas = std::count(s.begin(), s.end(), ',');
  while (std::getline(list, part, ',')) {
    ++parts;
    if (part.empty()) throw bad_range(s, "an empty item");
    const std::size_t dash = part.find('-');
    if (dash == std::string::npos) {
      if (!all_digits(part)) throw bad_range(s, "'" + part + "' is not a frame number");
      frames.push_back(std::stol(part));
      continue;
    }
    const std::string a = part.substr(0, dash);
    std::string b = part.substr(dash + 1);
    long step = 1;
    bool complement = false;
    const std::size_t xy = b.find_first_of("xy");
    if (xy != std::string::npos) {
      const std::string n = b.substr(xy + 1);
      if (!all_digits(n) || std::stol(n) < 1)
        throw bad_range(s, "'" + part + "': the step must be a whole number above 0");
      step = std::stol(n);
      complement = b[xy] == 'y';
      b = b.substr(0, xy);
    }
    if (!all_digits(a) || !all_digits(b)) throw bad_range(s, "'" + part + "' is not FIRST-LAST");
    const long first = std::stol(a), last = std::stol(b);
    const long dir = last >= first ? 1 : -1;
    const long count = (last - first) * dir + 1;
    if (count > kMaxFrames || long(frames.size()) + count > kMaxFrames)
      throw bad_range(s, "more than " + std::to_string(kMaxFrames) + " frames");
    for (long i = 0; i < count; ++i)
      if ((i % step == 0) != complement) frames.push_back(first + dir * i);
  }
  if (parts != commas + 1) throw bad_range(s, "an empty item");
  if (frames.empty()) throw bad_range(s, "no frames");
  return frames;
}

std::string FramePattern::name(long frame) const {
  char digits[32];
  std::snprintf(digits, sizeof digits, "%0*ld", padding, frame);
  return prefix + digits + suffix;
}

std::optional<FramePattern> parse_frame_pattern(const std::string& path, int framepadding) {
  const std::size_t base = path.find_last_of('/') + 1;  // npos + 1 = 0
  struct Wildcard {
    std::size_t at, length;
    int padding;
    bool printf_style;
  };
  std::vector<Wildcard> found;
  for (std::size_t i = base; i < path.size();) {
    if (path[i] == '#' || path[i] == '@') {
      std::size_t j = i;
      int pad = 0;
      while (j < path.size() && (path[j] == '#' || path[j] == '@')) pad += path[j++] == '#' ? 4 : 1;
      found.push_back({i, j - i, framepadding > 0 ? framepadding : pad, false});
      i = j;
    } else if (path[i] == '%') {
      std::size_t j = i + 1;
      while (j < path.size() && std::isdigit(static_cast<unsigned char>(path[j]))) ++j;
      const std::string width = path.substr(i + 1, j - i - 1);
      if (j < path.size() && path[j] == 'd' && (width.empty() || (width[0] == '0' && width.size() <= 3))) {
        found.push_back({i, j + 1 - i, width.empty() ? 0 : std::stoi(width), true});
        i = j + 1;
      } else {
        ++i;
      }
    } else {
      ++i;
    }
  }
  if (found.empty()) return std::nullopt;
  if (found.size() > 1)
    throw std::invalid_argument(path + ": more than one frame wildcard (#, @, %0Nd) in the name");
  const Wildcard& w = found.front();
  FramePattern p;
  p.spelling = path;
  p.padding = w.padding;
  p.printf_style = w.printf_style;
  p.suffix = path.substr(w.at + w.length);
  // The range: the longest run of range characters before the wildcard
  // that parses, starting with a digit.
  std::size_t r = w.at;
  while (r > base && std::string_view("0123456789-,xy").find(path[r - 1]) != std::string_view::npos) --r;
  for (; r < w.at; ++r) {
    if (!std::isdigit(static_cast<unsigned char>(path[r]))) continue;
    try {
      parse_frame_range(path.substr(r, w.at - r));
      break;
    } catch (const std::invalid_argument&) {
    }
  }
  p.range = path.substr(r, w.at - r);
  p.prefix = path.substr(0, r);
  return p;
}

std::vector<long> frames_on_disk(const FramePattern& p) {
  const fs::path folder = fs::path(p.prefix).parent_path();
  const std::string head = fs::path(p.prefix + "x").filename().string();  // the name's part before the number
  const std::string name_prefix = head.substr(0, head.size() - 1);
  std::set<long> frames;
  std::error_code ec;
  for (fs::directory_iterator it(folder.empty() ? fs::path(".") : folder, ec), end; !ec && it != end;
       it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() <= name_prefix.size() + p.suffix.size() || n.compare(0, name_prefix.size(), name_prefix) ||
        n.compare(n.size() - p.suffix.size(), p.suffix.size(), p.suffix))
      continue;
    const std::string d = n.substr(name_prefix.size(), n.size() - name_prefix.size() - p.suffix.size());
    if (!all_digits(d)) continue;
    const bool padded = long(d.size()) == std::max(p.padding, 1) ||
                        (long(d.size()) > std::max(p.padding, 1) && d[0] != '0');
    if (padded && !it->is_directory(ec)) frames.insert(std::stol(d));
  }
  return {frames.begin(), frames.end()};
}

}  // namespace sis
