// sidecode: the decode-only floor of the benchmark. Reads an image with
// OpenImageIO in row strips, exactly as siproject does (samples stored as
// half are read as they are stored, without conversion), and does nothing
// else.
#include <CLI/CLI.hpp>

#include <cstdint>
#include <iostream>
#include <vector>

#include "sis/imageio.h"

int main(int argc, char** argv) {
  std::string input;
  bool as_float = false;
  CLI::App app{"sidecode: read an image in strips as siproject does, and nothing else", "sidecode"};
  app.add_option("IN", input, "image to decode")->required();
  app.add_flag("--as-float", as_float,
               "read half samples as float through OpenImageIO's conversion (what a reader "
               "asking for float pays), instead of as they are stored");
  CLI11_PARSE(app, argc, argv);
  try {
    sis::ImageReader reader(input);
    const long strip = reader.preferred_strip();
    const std::size_t n = std::size_t(strip) * reader.width() * reader.channels();
    const bool half = reader.stores_half() && !as_float;
    std::vector<float> rows(half ? 0 : n);
    std::vector<std::uint16_t> half_rows(half ? n : 0);
    double checksum = 0;
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
    return 3;
  }
}
