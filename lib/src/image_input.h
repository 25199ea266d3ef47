#pragma once
// Opening a file for reading through OpenImageIO, one way for the library.
#include <OpenImageIO/imageio.h>

#include <memory>
#include <string>

namespace sis {

// Opens `path` with the reader its name implies when that reader tells its
// format by the file's magic number (OpenEXR, TIFF, PNG, JPEG, BMP, DPX,
// FITS, SGI) and the file has it, and with that reader only: if it then
// fails (a damaged file, memory running out), *error holds its reason.
// OpenImageIO's own open() would go on to offer the file to every other
// reader, and some of them (DICOM's) crash when memory runs out. A file of
// another format than its name says (a PNG named .exr), or of a format
// whose reader cannot tell it without opening it (GIF, HDR, WebP...), is
// offered to every reader, as ImageInput::open() does. Returns null with
// *error set on failure.
std::unique_ptr<OIIO::ImageInput> open_input(const std::string& path, std::string* error);

}  // namespace sis
