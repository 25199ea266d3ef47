#pragma once
// Image I/O through OpenImageIO: strip reading for streaming acquisition,
// atomic writing (temporary name in the same folder, then rename), and
// coefficient files (float EXR whose metadata records the approximation).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sis/bands.h"
#include "sis/image.h"
#include "sis/staged_file.h"

namespace sis {

// A file that cannot be read as wanted. The message names the file.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// A file that cannot be written. The message names the file.
struct OutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

using Metadata = std::vector<std::pair<std::string, std::string>>;
// A number as a metadata value: 17 significant digits, which read back exactly.
std::string metadata_number(double v);

// Sample types of image files: integers (written sRGB-encoded, clamped to
// [0, 1]) and floats (linear), as oiiotool's -d spells them.
enum class SampleFormat { UInt8, UInt16, Half, Float };
SampleFormat parse_sample_format(const std::string& spelling);  // uint8 | uint16 | half | float
std::string sample_format_name(SampleFormat f);
inline bool is_integer(SampleFormat f) { return f == SampleFormat::UInt8 || f == SampleFormat::UInt16; }

// How stored samples encode linear light: linear, the sRGB curve
// (IEC 61966-2-1) or a pure power (linear = stored ^ gamma). What the
// engine decodes before it projects.
struct Transfer {
  enum Kind { Linear, SRGB, Power };
  Kind kind = Linear;
  double gamma = 1.0;  // Power only
  static Transfer linear() { return {}; }
  static Transfer srgb() { return {SRGB, 1.0}; }
  static Transfer power(double g) { return {Power, g}; }
  std::string name() const;  // "linear", "srgb", "gamma2.2" (sis:input_transfer)
  bool operator==(const Transfer& o) const { return kind == o.kind && gamma == o.gamma; }
  bool operator!=(const Transfer& o) const { return !(*this == o); }
};
// The one rule for samples whose transfer is not stated by the user, files
// and arrays alike: float and half samples are linear; integer samples are
// display-encoded, sRGB, unless their colour space (OpenImageIO's
// oiio:ColorSpace, "" for none) says linear ("Linear", "lin_srgb",
// "scene_linear"...) or a power ("Gamma2.2", or "GammaCorrected" with
// `gamma`, OpenImageIO's oiio:Gamma; a PNG's gAMA chunk), as viewers and
// oiiotool's colour management take them.
Transfer default_transfer(bool integer_samples, const std::string& colorspace, double gamma = 0);
// "linear", "srgb" or "gammaG" (G > 0; any case: "sRGB", "Linear"), as
// Transfer::name() spells them; else std::invalid_argument.
Transfer parse_transfer(const std::string& spelling);

// IEEE half-precision bits to float, exactly (every half is a float); with
// the processor's F16C conversion where it has one. Returns whether every
// value was finite (a check on the half bits, in the same pass).
bool half_to_float(const std::uint16_t* in, float* out, std::size_t n);
// Float to IEEE half bits, rounded to nearest even as OpenImageIO's (Imath's)
// conversion rounds (beyond half's range: infinity); with F16C where the
// processor has it. Half outputs are converted here, not in the writer.
void float_to_half(const float* in, std::uint16_t* out, std::size_t n);

// What a file was when a reader opened it: its identity on disk (device,
// inode, size, modification time) and the header its reading relies on
// (data and display windows, channels, their names and sample types, the
// tiling, the format). A file opened again by name (read_bands' workers,
// the engine after inspect, a coefficient file after its header was read)
// must be the same file, or it was replaced or changed in between.
struct FileSignature {
  bool known = false;  // false: nothing to compare with
  std::uint64_t device = 0, inode = 0, size = 0;
  std::int64_t mtime_ns = 0;
  std::string header;  // "300 x 530 at (0, 0) of 300 x 530 at (0, 0), 3 channels R G B half, ..."
};

// Refuses a path that holds a NUL character (C strings end there: another
// file would be opened). Throws InputError, or OutputError with `output`.
void check_path(const std::string& path, bool output = false);

// Reads an image in row strips as float, whatever its stored type.
class ImageReader {
 public:
  explicit ImageReader(const std::string& path);  // throws InputError
  // Opens `path` again: an InputError naming it unless it is still the
  // file `expected` describes (when known).
  ImageReader(const std::string& path, const FileSignature& expected);
  // The file as it was opened (kept after release()).
  const FileSignature& signature() const;
  ~ImageReader();
  ImageReader(const ImageReader&) = delete;
  ImageReader& operator=(const ImageReader&) = delete;
  // Closes the file (its descriptor and decoder); the header stays readable,
  // reading then is a logic_error.
  void release();
  // Multi-resolution and multi-part files: level 0 of part 0 is what is
  // read; these say how many there are.
  int levels() const;
  int parts() const;
  // Reads MIP level `level` of part 0 from now on (its size, its rows):
  // InputError naming the file for a level it does not have.
  void select_level(int level);
  int level() const;
  // A luminance-chroma OpenEXR file (subsampled RY, BY channels), read as
  // half RGB(A) through OpenEXR's RGBA interface.
  bool luminance_chroma() const;
  static bool is_luminance_chroma(const std::string& path);

  const std::string& path() const { return path_; }
  long width() const;
  long height() const;
  int channels() const;
  long data_x() const;  // first column of the data window
  long data_y() const;  // first row of the data window
  // The display (full) window, of which the data window may be a band.
  long full_x() const;
  long full_y() const;
  long full_width() const;
  long full_height() const;
  std::vector<std::string> channel_names() const;
  // How channel c is stored, as OpenImageIO names the type: "half",
  // "float", "uint8", "uint"...
  std::string channel_type(int c) const;
  int alpha_channel() const;  // -1 if none
  // The samples' transfer by default_transfer(): integer samples sRGB
  // unless tagged otherwise (PNG, JPEG, TIFF, PNM... of 8 or 16 bits).
  Transfer transfer() const;
  bool srgb_encoded() const { return transfer().kind == Transfer::SRGB; }
  // Bits of integer samples (8, 16, 32: the widest channel's), 0 when a
  // channel is float or half.
  int integer_bits() const;
  std::string format_name() const;
  // A string attribute of the file's metadata ("" when absent); in the
  // formats whose writers keep no named keys (MetadataCarrier::Description:
  // TIFF, JPEG, HEIF) also a key=value line of the ImageDescription.
  std::string attribute(const std::string& name) const;
  // Rows aligned to the file's storage (tile height or 64 scanlines).
  long preferred_strip() const;
  // Rows per tile (0 for scanline files).
  long tile_height() const;
  // Reads rows [y0, y1) (0-based within the data window) into `rows`,
  // interleaved floats: any rows, of scanline or tiled files (tile rows
  // that [y0, y1) cuts are decoded whole, the last one kept for the next
  // call). Throws InputError on a truncated or corrupt file.
  void read_rows(long y0, long y1, float* rows);
  // True when every channel is stored as half: then rows can be read as
  // they are stored, without OpenImageIO's conversion (read_rows_half).
  bool stores_half() const;
  // As read_rows, into the half bits of the samples (needs stores_half()).
  void read_rows_half(long y0, long y1, std::uint16_t* rows);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string path_;
  void read(long y0, long y1, SampleFormat type, void* rows);
  void open_luminance_chroma();
  void read_luminance_chroma(long y0, long y1, SampleFormat format, void* rows);
};

// A strip that read_bands hands over: rows [y0, y1) of input file `file`
// (0-based in its data window; `path` is its name), rows [global, global +
// y1 - y0) of the image the files tile, with its samples as stored: half
// bits in `half`, or floats in `floats` (writable), width * channels per row.
struct Strip {
  std::size_t file;
  const std::string* path;
  long y0, y1, global;
  const std::uint16_t* half;
  float* floats;
};

// Rows per strip for read_bands: about 1 MB of stored samples, whole
// 16-row zip blocks (OpenEXR's largest common block is 32 rows; 16 keeps a
// strip in the second-level cache of the core that decodes it).
long decode_strip_rows(const ImageReader& reader);


// Reads row bands of one image (`paths`, in row order) band by band, the
// bands of `bands` over the image's rows: `workers` threads take the bands
// in increasing order, each band wholly by one thread, in strips of up to
// `strip` rows (whole strips of each file's rows, cut at the band's and the
// file's ends). Per band, on the thread that takes it: begin(worker, band),
// strip(worker, s) for its strips in order, end(worker, band). With several
// workers every file must be OpenEXR: each worker reads through readers of
// its own with OpenEXR's thread pool off, so that a strip's samples are used
// from the cache of the core that decoded them and no worker waits on
// another's strips; with one, OpenEXR's pool decodes. With `half`, samples
// stored as half are handed over as stored (every file must store half).
// An error (a read's or a callback's) in band b, or strip() returning false
// there, stops band b and the later bands not yet ended (their end() is not
// called; another worker may have ended one already); the bands before b
// run to their end. The error of the first band that had one is rethrown
// (when no earlier band stopped); else returns the first band that
// stopped, or -1. (siproject's reading.)
struct BandCallbacks {
  std::function<void(int worker, long band)> begin;
  std::function<bool(int worker, const Strip& s)> strip;
  std::function<void(int worker, long band)> end;
};
long read_bands(const std::vector<std::string>& paths, const BandPartition& bands, long strip,
                int workers, bool half, const BandCallbacks& callbacks);
// The same over sources that are files or samples in memory (float rows,
// or half rows where `half`; handed over strip by strip as copies: the
// callbacks may write them, the caller's samples stay as they are); `name`
// names a strip's source.
struct BandSource {
  std::string name;   // a file's path, or how messages name the samples
  SampleView image;   // samples in memory
  // A file: what it was when inspected (when known): a file that is no
  // longer that file when read_bands opens it is an InputError. Files that
  // a worker opens again are checked against read_bands' own first opening
  // in any case.
  FileSignature expected = {};
};
// The sources hold rows from bands.begin(first_band) to the end of a band
// (those bands are read; by default all of them).
long read_bands(const std::vector<BandSource>& sources, const BandPartition& bands, long strip,
                int workers, bool half, const BandCallbacks& callbacks, long first_band = 0);

// Decodes n interleaved samples of `channels` channels to linear light by
// `t` (the first at channel k0 % channels), the alpha channel (-1: none)
// left as stored.
void decode_to_linear(const Transfer& t, float* v, std::size_t n, int channels, int alpha,
                      std::size_t k0 = 0);

// Samples in memory as float in linear light, by the rule files follow:
// integer samples scaled to [0, 1] as OpenImageIO converts a file's and
// decoded as sRGB (default_transfer, no colour space: every channel), float
// and half as they are.
Image linear_image(const SampleView& samples);

// Reads a whole image as float, in linear light: display-encoded samples
// decoded by the file's transfer (ImageReader::transfer(), the one rule of
// default_transfer) as siproject decodes its inputs.
Image read_image(const std::string& path);

// A writer's compression as oiiotool's --compression spells it: a name and
// a quality (0: none given), "zip", "dwaa:45", "jpeg:90".
struct Compression {
  std::string name;  // "": the writer's default
  int quality = 0;   // 1..100; 0: the writer's default
};
// NAME or NAME:Q (Q a whole number 1..100); else std::invalid_argument.
Compression parse_compression(const std::string& spelling);

// How an output is written: its sample type (none: the format's default,
// default_sample_format(path)) and compression.
struct WriteOptions {
  std::optional<SampleFormat> format;
  Compression compression;
  WriteOptions() = default;
  WriteOptions(SampleFormat f) : format(f) {}  // NOLINT: a type alone says how
};

// Writes an image: integer samples (uint8, uint16) sRGB-encoded and clamped
// to [0, 1], alpha (premultiplied) divided out first and kept linear, the
// file tagged oiio:ColorSpace sRGB; float and half samples linear, as they
// are. The metadata as the format carries it (metadata_carrier): string
// attributes, or key=value lines of its ImageDescription, or not at all.
// Written to a staged file beside `path` (staged_file.h), then renamed:
// never a partial file, and any failed write (a full disk, the last block
// and the close included) is an error; a type the format does not hold, or
// a compression its writer does not take, is refused first
// (check_write_options). Throws OutputError naming the file.
void write_image(const std::string& path, const Image& image,
                 const std::vector<std::string>& channel_names = {},
                 const Metadata& metadata = {}, int alpha_channel = -1,
                 const WriteOptions& options = {});
// As write_image, short of the rename: the caller commits, so that several
// outputs are all written before any of them replaces a file.
StagedFile stage_image(const std::string& path, const Image& image,
                       const std::vector<std::string>& channel_names = {},
                       const Metadata& metadata = {}, int alpha_channel = -1,
                       const WriteOptions& options = {});

// A tiled, MIP-mapped OpenEXR (as maketx writes textures: tiles of
// tile_size, OpenEXR's MIPMAP_LEVELS with sizes rounded down,
// "textureformat" "Plain Texture"), levels[j] its level j, in half or float
// (linear): written to a staged file beside `path` and read back (every
// level, of its size) before the caller commits. The levels' sizes must be
// OpenEXR's for level 0's (sis/pyramid.h's pyramid_sizes). Throws
// OutputError naming the file.
StagedFile stage_mip_image(const std::string& path, const std::vector<Image>& levels,
                           const std::vector<std::string>& channel_names, const Metadata& metadata,
                           int alpha_channel, SampleFormat format, int tile_size = 64);

// The sample type an output gets unless one is asked: float formats (EXR,
// Radiance HDR, FITS, Zfile, PFM) float, or half where every input stores
// half and the format holds it; the others integer, 16-bit where the input's
// integer samples have 16 bits or more (`integer_bits`) and the format holds
// them, else 8-bit.
SampleFormat default_sample_format(const std::string& path, bool input_half = false,
                                   int integer_bits = 0);
// True for the formats written as 8-bit sRGB by default (default_sample_format
// is an integer type): all but the float formats.
bool is_8bit_format(const std::string& path);
// True when the output's format holds samples of type `f` (written and read
// back as that type by OpenImageIO 2.4's writer, measured); `held` gets
// what it holds ("uint8 or uint16").
bool holds_format(const std::string& path, SampleFormat f, std::string* held = nullptr);

// How an output's format carries write_image's metadata (OpenImageIO 2.4's
// writers, measured): as named string attributes (OpenEXR, PNG), as
// key=value lines of the ImageDescription for the keys with a ':' in their
// name, which the writer drops (TIFF, JPEG, HEIF: the one text field they
// keep whole), or not at all (the others: they keep no text, or cut the
// description short).
enum class MetadataCarrier { Named, Description, None };
MetadataCarrier metadata_carrier(const std::string& path);

// Refuses a write the output's writer would not make as asked: a sample
// type its format does not hold, a compression name its writer does not
// take (or would replace by another for these channels or this type: JPEG
// in TIFF outside 3-channel 8-bit, DWA in one-channel EXR, RLE in Targa of
// fewer than 3 channels), a quality the name does not take or outside its
// range. Throws std::invalid_argument saying what the format holds or
// takes (without the file's name: the caller names it and the option).
void check_write_options(const std::string& path, int channels, SampleFormat format,
                         const Compression& compression);

// Refuses, before any work, an output write_image could not make: no
// writer for its name (or ICO and JPEG 2000, whose writers in OpenImageIO
// 2.4 make files it cannot read back, or the term and null writers, which
// make no file), a NUL in its name, its folder missing, the name an existing folder or
// a file that is not a regular file or a link (a FIFO, a device: a finished
// file renamed onto it would replace it). Throws OutputError naming it.
void check_output(const std::string& path);

// Refuses an image the output's format cannot hold as write_image writes
// it (OpenImageIO 2.4's writers, measured): a channel count (DPX 1, 3 or 4;
// PNG, Targa and FITS 1 to 4; JPEG and PNM 1 or 3; BMP 1, 3 or 4; GIF,
// WebP, IFF and HEIF 3 or 4; Radiance HDR 3; Zfile 1), a side past the
// format's largest (JPEG 65500, WebP 16383, IFF 8192, Zfile 32767, RLA
// 32768, SGI 65534, GIF and Targa 65535, PNG 1000000, FITS 999999; 0: not
// known yet), one row
// (FITS), half samples (FITS). Past these a writer aborts the process,
// hangs, writes another image or fails. Throws OutputError naming the
// file, the format, what it holds and what was asked. write_image checks
// it first; a front end calls it as soon as it knows the channels.
void check_output_image(const std::string& path, int channels, long width = 0, long height = 0,
                        bool half = false);
// True when the output's format holds half samples (OpenEXR, TIFF).
bool holds_half(const std::string& path);

// The sRGB transfer functions (IEC 61966-2-1), on [0, 1] (outside, the
// encoder clamps; the decoder extends the curve's ends as they are).
float srgb_to_linear(float v);
float linear_to_srgb(float v);

// Coefficient files: a float EXR of the coefficient grid whose metadata
// records everything Coefficients holds: lattice, generator, degree,
// boundary, method, frame size, the input's label, format and transfer and
// the highlight compression; its channels are k.channel_names (unless
// `channel_names` is given). `extra` adds keys or replaces these.
void write_coefficients(const std::string& path, const Coefficients& k,
                        const std::vector<std::string>& channel_names = {},
                        const Metadata& extra = {});
StagedFile stage_coefficients(const std::string& path, const Coefficients& k,
                              const std::vector<std::string>& channel_names = {},
                              const Metadata& extra = {});
// True for names whose writer is OpenImageIO's OpenEXR writer (.exr, .sxr,
// .mxr): the one format that keeps a coefficient file's string metadata and
// its signed float samples (Radiance HDR, FITS, TIFF, PNG... drop the keys
// or clamp negatives). stage_coefficients refuses the others (OutputError).
bool holds_coefficients(const std::string& path);
bool is_coefficient_file(const ImageReader& reader);
Coefficients read_coefficients(ImageReader& reader);

// A pyramid's coefficient file (siproject --mip --coeffs): the levels'
// coefficients (sis/pyramid.h) as one tiled, MIP-mapped float OpenEXR
// (64 x 64 tiles, zip, OpenEXR's levels rounded down), its metadata level
// 0's coefficient file's with sis:mip_levels (the count) and
// sis:mip_sizes (each level's frame, "WxH WxH ..."), which OpenEXR keeps
// once for every level. Level j must be level 0's space at level j's frame
// (the keys differ in the frame alone): OutputError otherwise.
StagedFile stage_mip_coefficients(const std::string& path, const std::vector<const Coefficients*>& levels);
// The coefficient levels such a file holds (1 for any other coefficient
// file); read_coefficients reads the reader's selected level (select_level)
// at that level's frame.
int coefficient_levels(const ImageReader& reader);

}  // namespace sis
