// sidecode: the decode-only floor of the benchmark. Reads an image with
// OpenImageIO in row strips, exactly as siproject does, and does nothing else.
#include <CLI/CLI.hpp>

#include <iostream>
#include <vector>

#include "sis/imageio.h"

int main(int argc, char** argv) {
  std::string input;
  CLI::App app{"sidecode: read an image in strips as siproject does, and nothing else", "sidecode"};
  app.add_option("IN", input, "image to decode")->required();
  CLI11_PARSE(app, argc, argv);
  try {
    sis::ImageReader reader(input);
    const long strip = reader.preferred_strip();
    std::vector<float> rows(std::size_t(strip) * reader.width() * reader.channels());
    double checksum = 0;
    for (long y = 0; y < reader.height(); y += strip) {
      reader.read_rows(y, std::min(reader.height(), y + strip), rows.data());
      checksum += rows[0];
    }
    return checksum == -1.0 ? 1 : 0;  // keeps the reads from being optimised away
  } catch (const sis::InputError& e) {
    std::cerr << "sidecode: " << e.what() << "\n";
    return 3;
  }
}
