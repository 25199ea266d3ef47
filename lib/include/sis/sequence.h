#pragma once
// Numbered frame sequences as oiiotool names them: a file name with one
// frame wildcard ('#' four digits, '@' one digit, printf's %0Nd or %d),
// its frames given by a range written before the wildcard ("big.1-3#.tif"),
// by a separate range (oiiotool's --frames), or found on disk.
#include <optional>
#include <string>
#include <vector>

namespace sis {

// More frames than this in one range are refused.
inline constexpr long kMaxFrames = 1000000;

// The frames of a range as oiiotool spells it, in its order: "7", "1-10",
// "10-1" (backwards), "1-10x3" (every third: 1, 4, 7, 10), "1-10y3" (the
// complement of that set: 2, 3, 5, 6, 8, 9), and comma-separated lists of
// these ("3,4,10-20x2"). Frame numbers are whole and not negative. Throws
// std::invalid_argument naming the spelling.
std::vector<long> parse_frame_range(const std::string& spelling);

// A path with one frame wildcard.
struct FramePattern {
  std::string spelling;        // as given
  std::string prefix, suffix;  // around the wildcard (and its range)
  int padding = 0;             // digits of a frame number, zero-padded (0: as many as it has)
  bool printf_style = false;   // %0Nd or %d (a --framepadding does not apply)
  std::string range;           // the range written before the wildcard ("": none)
  // The path of `frame`: prefix, the number padded to `padding` digits, suffix.
  std::string name(long frame) const;
};

// The pattern in `path`: a run of '#' (4 digits each) and '@' (1 digit
// each), or %0Nd (N digits) or %d, in the file name (not its folders),
// optionally preceded by a range (the longest run of range characters that
// parses). `framepadding` > 0 replaces the digits of '#' and '@'. None when
// the name holds no wildcard. Throws std::invalid_argument for a name with
// two wildcards.
std::optional<FramePattern> parse_frame_pattern(const std::string& path, int framepadding = 0);

// The frames present on disk: the files of the pattern's folder named
// prefix + number + suffix, the number with the pattern's padding (more
// digits only without a leading zero), sorted.
std::vector<long> frames_on_disk(const FramePattern& pattern);

}  // namespace sis
