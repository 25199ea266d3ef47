// sidecode: the decode-only floor of the benchmark. Reads an image with
// OpenImageIO in row strips of 64 rows through OpenEXR's thread pool (samples
// stored as half are read as they are stored, without conversion), and does
// nothing else. With --readers N, decodes instead as siproject does: band by
// band on N threads, each through a reader of its own with OpenEXR's thread
// pool off (read_bands), with nothing done to the samples.
#include <CLI/CLI.hpp>

#include <cstdint>
#include <iostream>
#include <vector>

#include "cli.h"
#include "sis/bands.h"
#include "sis/imageio.h"

namespace {
using sis::cli::kExitUsage;
using sis::cli::kExitInput;
}

int main(int argc, char** argv) {
  std::string input;
  bool as_float = false;
  int readers = 0;
  CLI::App app{"sidecode: read an image in strips, and nothing else (the benchmark's decode floor)",
               "sidecode"};
  app.add_option("IN", input, "image to decode")->required();
  app.add_flag("--as-float", as_float,
               "read half samples as float through OpenImageIO's conversion (what a reader "
               "asking for float pays), instead of as they are stored");
  app.add_option("--readers", readers,
                 "decode an OpenEXR file as siproject reads it: bands of 256 rows on N "
                 "threads, each with a reader of its own and OpenEXR's thread pool off, in "
                 "strips of about 1 MB")
      ->check(CLI::Range(1, 256));
  if (const auto code = sis::cli::parse(app, argc, argv)) return *code;
  try {
    sis::ImageReader reader(input);
    const bool half = reader.stores_half() && !as_float;
    double checksum = 0;
    if (readers > 0) {
      if (reader.format_name() != "openexr") {
        std::cerr << "sidecode: --readers " << readers << ": " << input << " is "
                  << reader.format_name()
                  << ", not OpenEXR; only OpenEXR files can be read from any strip on\n";
        return kExitUsage;
      }
      std::vector<double> sums(readers, 0.0);  // per worker
      sis::BandCallbacks cb;
      cb.begin = [](int, long) {};
      cb.strip = [&](int t, const sis::Strip& s) {
        sums[t] += half ? s.half[0] : s.floats[0];
        return true;
      };
      cb.end = [](int, long) {};
      sis::read_bands({input}, sis::BandPartition(reader.height(), sis::kBandRows),
                      sis::decode_strip_rows(reader), readers, half, cb);
      for (double v : sums) checksum += v;
      return checksum == -1.0 ? 1 : 0;  // keeps the reads from being optimised away
    }
    const long strip = reader.preferred_strip();
    const std::size_t n = std::size_t(strip) * reader.width() * reader.channels();
    std::vector<float> rows(half ? 0 : n);
    std::vector<std::uint16_t> half_rows(half ? n : 0);
    for (long y = 0; y < reader.height(); y += strip) {
      const long y1 = std::min(reader.height(), y + strip);
      if (half) {
        reader.read_rows_half(y, y1, half_rows.data());
        checksum += half_rows[0];
      } else {
        reader.read_rows(y, y1, rows.data());
        checksum += rows[0];
      }
    }
    return checksum == -1.0 ? 1 : 0;  // keeps the reads from being optimised away
  } catch (const sis::InputError& e) {
    std::cerr << "sidecode: " << e.what() << "\n";
    return kExitInput;
  }
}
