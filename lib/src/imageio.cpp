#include "sis/imageio.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfTestFile.h>
#include <OpenEXR/openexr.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>

#include <algorithm>
#include <charconv>
#include <array>
#include <atomic>
#include <cctype>
#include <climits>
#include <cstring>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <tuple>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "image_input.h"
#include "sis/coefficients.h"
#include "sis/parallel.h"
#include "sis/space.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace sis {

std::string metadata_number(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

namespace fs = std::filesystem;
using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {
// The readers of OpenImageIO 2.4 whose valid_file() reads the file's magic
// number; the others' open the file, offering it to every reader in turn.
bool checks_magic(const std::string& format) {
  static const char* const names[] = {"openexr", "tiff", "png", "jpeg", "bmp", "dpx", "fits", "sgi"};
  for (const char* n : names)
    if (format == n) return true;
  return false;
}
}  // namespace

std::unique_ptr<ImageInput> open_input(const std::string& path, std::string* error) {
  std::unique_ptr<ImageInput> in = ImageInput::create(path, /*do_open=*/false);
  if (in && checks_magic(in->format_name()) && in->valid_file(path)) {
    ImageSpec spec;
    if (in->open(path, spec)) return in;
    *error = in->geterror();
    if (error->empty()) *error = OIIO::geterror();
    return nullptr;
  }
  OIIO::geterror();  // the probe's message, if any, is not the open's
  in = ImageInput::open(path);
  if (!in) *error = OIIO::geterror();
  return in;
}

struct ImageReader::Impl {
  std::unique_ptr<ImageInput> in;  // null once released
  // Luminance-chroma OpenEXR files (subsampled RY, BY), which OpenImageIO
  // refuses: read as RGB(A) through OpenEXR's RGBA interface.
  std::unique_ptr<Imf::RgbaInputFile> yc;
  bool yc_alpha = false;
  std::vector<Imf::Rgba> yc_rows;
  bool luminance_chroma = false;
  int levels = 0, parts = 0;  // of the file
  int level = 0;              // of part 0, the one read (select_level)
  ImageSpec spec;
  std::string format;
  // Tiled files: the tile row last read whole (tile-row index, element
  // size; -1 when none), for the rows of a strip that starts or ends inside
  // a tile row (read_tiles takes whole tile rows only).
  long cached_tile_row = -1;
  int cached_elem = 0;
  std::vector<unsigned char> tile_row;
  FileSignature signature;
};

namespace {
// Text for one line of a description: backslashes, newlines and carriage
// returns escaped (a file name may hold them).
std::string escape_line(const std::string& v) {
  std::string e;
  for (char c : v) {
    if (c == '\\') e += "\\\\";
    else if (c == '\n') e += "\\n";
    else if (c == '\r') e += "\\r";
    else e += c;
  }
  return e;
}
std::string unescape_line(const std::string& e) {
  std::string v;
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (e[i] == '\\' && i + 1 < e.size()) {
      const char n = e[++i];
      v += n == 'n' ? '\n' : n == 'r' ? '\r' : n;
    } else {
      v += e[i];
    }
  }
  return v;
}
// True for the writers whose formats carry metadata in their description
// (kWriters).
bool carries_in_description(const std::string& format);
}  // namespace

namespace {
// A decoder's reason, named by its kind: a file that ends early says it is
// truncated, whatever the library's wording.
std::string failure(const std::string& why) {
  std::string low = why;
  std::transform(low.begin(), low.end(), low.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* eof : {"end of file", "premature", "truncat", "short read"})
    if (low.find(eof) != std::string::npos) return "truncated file (" + why + ")";
  return why;
}

// The header fields a reading relies on, as one line for comparison and
// for messages.
std::string describe(const ImageSpec& s, const std::string& format) {
  std::ostringstream d;
  d << s.width << " x " << s.height << " at (" << s.x << ", " << s.y << ") of " << s.full_width
    << " x " << s.full_height << " at (" << s.full_x << ", " << s.full_y << "), " << s.nchannels
    << " channels";
  for (int c = 0; c < s.nchannels; ++c)
    d << (c ? ", " : " (") << (c < int(s.channelnames.size()) ? s.channelnames[c] : "?") << " "
      << s.channelformat(c).c_str();
  d << ")";
  if (s.tile_width > 0) d << ", tiles " << s.tile_width << " x " << s.tile_height;
  d << ", " << format;
  return d.str();
}

// OpenEXR's chunk kinds: bytes a chunk takes at the least beyond its data
// (its offset-table entry and its header: y and size; tile x, y, levels and
// size; deep: the sample-count table's sizes and the unpacked size), and
// the part number of a multi-part file.
std::uint64_t chunk_overhead(exr_storage_t storage, bool multipart) {
  const std::uint64_t header = storage == EXR_STORAGE_SCANLINE        ? 8
                               : storage == EXR_STORAGE_TILED         ? 20
                               : storage == EXR_STORAGE_DEEP_SCANLINE ? 28
                                                                      : 40;
  return 8 + header + (multipart ? 4 : 0);
}

// The largest ratio of a chunk's decoded bytes to its stored bytes that an
// OpenEXR compression reaches: deflate's limit (1032, for ZIP, ZIPS, PXR24)
// times the 64 samples of a DCT block that DWA codes by one value; RLE (64),
// PIZ (about 450: runs of 255 16-bit symbols in 9 bits) and B44 (11) stay
// below.
constexpr std::uint64_t kMaxCompression = 1032 * 64;

struct ExrContext {
  exr_context_t c = nullptr;
  std::string why;  // the core's first message
  ~ExrContext() {
    if (c) exr_finish(&c);
  }
};

void exr_message(exr_const_context_t c, exr_result_t, const char* msg) {
  void* user = nullptr;
  if (exr_get_user_data(c, &user) == EXR_ERR_SUCCESS && user) {
    std::string& why = *static_cast<std::string*>(user);
    if (why.empty() && msg) {
      why = msg;  // names from the file's bytes: unprintable ones shown as '?'
      for (char& ch : why)
        if (static_cast<unsigned char>(ch) < 0x20 || static_cast<unsigned char>(ch) >= 0x7f) ch = '?';
    }
  }
}

// True when the file begins with OpenEXR's magic number.
bool exr_magic(const std::string& path) {
  unsigned char m[4] = {0, 0, 0, 0};
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::pread(fd, m, 4, 0) == 4;
  ::close(fd);
  return ok && m[0] == 0x76 && m[1] == 0x2f && m[2] == 0x31 && m[3] == 0x01;
}

}  // namespace

// An OpenEXR file checked before any decoder allocates by its header, as
// OpenEXR's exrcheck checks it, through OpenEXR's core (which parses the
// header bounded by the file's size and allocates nothing by its claims):
// every part's chunks must fit in the file's bytes; part 0 (what is read)
// must not be deep, and each of its chunks of level 0 must be in the file
// (no reconstruction of a damaged offset table), whole, and decode to no
// more than any compression can make of its bytes. Returns whether the
// channels are luminance-chroma (Y, RY, BY and optionally A, the chroma
// subsampled), the files read through OpenEXR's RGBA interface.
static bool check_exr(const std::string& path, std::uint64_t file_size) {
  ExrContext ctx;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = &exr_message;
  init.user_data = &ctx.why;
  init.flags |= EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
  auto damaged = [&](const std::string& what) {
    return InputError(path + ": damaged or truncated OpenEXR file: " + what);
  };
  auto truncated = [&](const std::string& what) {
    return InputError(path + ": truncated file: " + what + " (the file has " + std::to_string(file_size) +
                      " bytes)");
  };
  if (exr_start_read(&ctx.c, path.c_str(), &init) != EXR_ERR_SUCCESS) {
    if (ctx.why.find("End of file") != std::string::npos) throw truncated("its OpenEXR header ends early");
    throw damaged("its header does not parse (" + (ctx.why.empty() ? "OpenEXR" : ctx.why) + ")");
  }
  int parts = 0;
  if (exr_get_count(ctx.c, &parts) != EXR_ERR_SUCCESS || parts < 1)
    throw damaged("no part in its header");
  std::uint64_t least = 0;  // bytes every part's chunks take at the least
  for (int p = 0; p < parts; ++p) {
    exr_storage_t storage;
    int32_t chunks = 0;
    if (exr_get_storage(ctx.c, p, &storage) != EXR_ERR_SUCCESS ||
        exr_get_chunk_count(ctx.c, p, &chunks) != EXR_ERR_SUCCESS || chunks < 0)
      throw damaged("part " + std::to_string(p) + " has no valid chunk count (" + ctx.why + ")");
    least += std::uint64_t(chunks) * chunk_overhead(storage, parts > 1);
    if (least > file_size) {
      exr_attr_box2i_t dw{};
      exr_get_data_window(ctx.c, p, &dw);
      std::ostringstream m;
      m << "part " << p << "'s header claims a data window of " << int64_t(dw.max.x) - dw.min.x + 1
        << " x " << int64_t(dw.max.y) - dw.min.y + 1 << " pixels in " << chunks
        << " chunks; with the parts before it that needs at least " << least << " bytes, the file has "
        << file_size;
      throw damaged(m.str());
    }
  }
  exr_storage_t storage;
  exr_get_storage(ctx.c, 0, &storage);
  if (storage == EXR_STORAGE_DEEP_SCANLINE || storage == EXR_STORAGE_DEEP_TILED)
    throw InputError(path + ": deep images are not supported");
  // Part 0's chunks of level 0, each in the file and plausible.
  // (each chunk's own message: the header's are not its)
  auto check_chunk = [&](exr_result_t got, const exr_chunk_info_t& ci, const std::string& which) {
    if (got != EXR_ERR_SUCCESS) {
      // the core names the file's size where a chunk's leader claims more
      // bytes than are left: a cut file
      if (ctx.why.find("file size") != std::string::npos)
        throw truncated(which + " runs past the end of the file (" + ctx.why + ")");
      throw damaged(which + " is missing or damaged (" + (ctx.why.empty() ? "OpenEXR" : ctx.why) + ")");
    }
    if (ci.data_offset > file_size || ci.packed_size > file_size - ci.data_offset)
      throw truncated(which + " runs past the end of the file");
    if (ci.unpacked_size > (ci.packed_size + 1) * kMaxCompression) {
      std::ostringstream m;
      m << which << " claims " << ci.unpacked_size << " bytes of pixels from " << ci.packed_size
        << " stored: beyond any OpenEXR compression";
      throw damaged(m.str());
    }
  };
  exr_attr_box2i_t dw{};
  exr_get_data_window(ctx.c, 0, &dw);
  exr_chunk_info_t ci;
  if (storage == EXR_STORAGE_SCANLINE) {
    int32_t lines = 1;
    if (exr_get_scanlines_per_chunk(ctx.c, 0, &lines) != EXR_ERR_SUCCESS || lines < 1)
      throw damaged("no valid rows per chunk");
    for (int64_t y = dw.min.y; y <= dw.max.y; y += lines) {
      std::memset(&ci, 0, sizeof ci);
      ctx.why.clear();
      check_chunk(exr_read_scanline_chunk_info(ctx.c, 0, int(y), &ci), ci,
                  "the chunk of rows from " + std::to_string(y));
    }
  } else {
    int32_t tw = 0, th = 0, lw = 0, lh = 0;
    if (exr_get_tile_sizes(ctx.c, 0, 0, 0, &tw, &th) != EXR_ERR_SUCCESS ||
        exr_get_level_sizes(ctx.c, 0, 0, 0, &lw, &lh) != EXR_ERR_SUCCESS || tw < 1 || th < 1)
      throw damaged("no valid tile size");
    const int64_t nx = (int64_t(lw) + tw - 1) / tw, ny = (int64_t(lh) + th - 1) / th;
    for (int64_t ty = 0; ty < ny; ++ty)
      for (int64_t tx = 0; tx < nx; ++tx) {
        std::memset(&ci, 0, sizeof ci);
        ctx.why.clear();
        check_chunk(exr_read_tile_chunk_info(ctx.c, 0, int(tx), int(ty), 0, 0, &ci), ci,
                    "tile " + std::to_string(tx) + ", " + std::to_string(ty));
      }
  }
  const exr_attr_chlist_t* ch = nullptr;
  if (parts != 1 || exr_get_channels(ctx.c, 0, &ch) != EXR_ERR_SUCCESS || !ch) return false;
  bool y = false, ry = false, by = false;
  for (int c = 0; c < ch->num_channels; ++c) {
    const exr_attr_chlist_entry_t& e = ch->entries[c];
    const std::string name(e.name.str, std::size_t(std::max(0, e.name.length)));
    const bool sub = e.x_sampling == 2 && e.y_sampling == 2;
    if (name == "Y") y = true;
    else if (name == "RY" && sub) ry = true;
    else if (name == "BY" && sub) by = true;
    else if (name != "A") return false;
  }
  return y && ry && by;
}

void check_path(const std::string& path, bool output) {
  if (path.find('\0') == std::string::npos) return;
  std::string shown;
  for (char c : path) shown += c == '\0' ? std::string("\\0") : std::string(1, c);
  const std::string m = shown + ": a file name cannot hold a NUL character (\\0)";
  if (output) throw OutputError(m);
  throw InputError(m);
}

ImageReader::ImageReader(const std::string& path) : ImageReader(path, FileSignature{}) {}

ImageReader::ImageReader(const std::string& path, const FileSignature& expected)
    : impl_(new Impl), path_(path) {
  check_path(path);
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path + ": no such file");
  if (fs::is_directory(path, ec)) throw InputError(path + ": is a folder, not an image");
  if (!fs::is_regular_file(path, ec))
    throw InputError(path + ": not a regular file (a FIFO, a device or a socket); images are "
                     "read from files");
  // The system's reason first (no permission, too many open files...):
  // OpenImageIO reports any file it cannot open as one it cannot parse.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot open: " + std::strerror(errno));
  struct stat st;
  const int stat_error = ::fstat(fd, &st) == 0 ? 0 : errno;
  ::close(fd);
  if (stat_error) throw InputError(path + ": cannot open: " + std::strerror(stat_error));
  const std::uint64_t size = std::uint64_t(st.st_size);
  if (size == 0) throw InputError(path + ": empty file (0 bytes)");
  // An OpenEXR file's header is checked against its size before any
  // decoder allocates by it (check_exr).
  const bool yc = exr_magic(path) && check_exr(path, size);
  // OpenImageIO first; a file it refuses may be a luminance-chroma OpenEXR,
  // read through OpenEXR's RGBA interface.
  std::string why;
  impl_->in = open_input(path, &why);
  if (!impl_->in) {
    if (!yc) {
      if (why.empty()) why = "not an image OpenImageIO can read";
      throw InputError(path + ": " + failure(why));
    }
    open_luminance_chroma();
  } else {
    impl_->spec = impl_->in->spec();
    impl_->format = impl_->in->format_name();
    // Level 0 of a multi-resolution file, part 0 of a multi-part one.
    ImageSpec probe;
    while (impl_->in->seek_subimage(0, impl_->levels, probe)) ++impl_->levels;
    while (impl_->in->seek_subimage(impl_->parts, 0, probe)) ++impl_->parts;
    impl_->in->seek_subimage(0, 0, probe);
  }
  const ImageSpec& s = impl_->spec;
  if (s.width < 1 || s.height < 1 || s.nchannels < 1) {
    std::ostringstream m;
    m << path << ": empty image (" << s.width << " x " << s.height << ", " << s.nchannels
      << " channels)";
    throw InputError(m.str());
  }
  if (s.depth > 1) throw InputError(path + ": volume images are not supported");
  if (s.deep) throw InputError(path + ": deep images are not supported");
  FileSignature& sig = impl_->signature;
  sig.known = true;
  sig.device = std::uint64_t(st.st_dev);
  sig.inode = std::uint64_t(st.st_ino);
  sig.size = std::uint64_t(st.st_size);
  sig.mtime_ns = std::int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
  sig.header = describe(s, impl_->format);
  if (!expected.known) return;
  if (sig.header != expected.header)
    throw InputError(path + ": changed on disk during the run: it was " + expected.header +
                     ", it is now " + sig.header);
  if (sig.device != expected.device || sig.inode != expected.inode || sig.size != expected.size ||
      sig.mtime_ns != expected.mtime_ns)
    throw InputError(path + ": replaced or modified on disk during the run (another file, size or "
                     "modification time than when it was first opened)");
}

const FileSignature& ImageReader::signature() const { return impl_->signature; }

ImageReader::~ImageReader() { release(); }

void ImageReader::release() {
  if (impl_ && impl_->in) {
    impl_->in->close();
    impl_->in.reset();
  }
  if (impl_) impl_->yc.reset();
}

int ImageReader::levels() const { return std::max(1, impl_->levels); }
int ImageReader::level() const { return impl_->level; }

void ImageReader::select_level(int level) {
  if (level == impl_->level) return;
  if (!impl_->in) {
    if (impl_->luminance_chroma)
      throw InputError(path_ + ": a luminance-chroma file has one level, not level " + std::to_string(level));
    throw std::logic_error(path_ + ": select_level after release()");
  }
  ImageSpec spec;
  if (level < 0 || level >= levels() || !impl_->in->seek_subimage(0, level, spec))
    throw InputError(path_ + ": has no level " + std::to_string(level) + " (it has " +
                     std::to_string(levels()) + ")");
  if (spec.width < 1 || spec.height < 1 || spec.nchannels != impl_->spec.nchannels)
    throw InputError(path_ + ": level " + std::to_string(level) + " is empty or has other channels");
  impl_->spec = spec;
  impl_->level = level;
  impl_->cached_tile_row = -1;
}
int ImageReader::parts() const { return std::max(1, impl_->parts); }
bool ImageReader::luminance_chroma() const { return impl_->luminance_chroma; }

bool ImageReader::is_luminance_chroma(const std::string& path) {
  if (path.find('\0') != std::string::npos) return false;
  try {
    std::error_code ec;
    const std::uint64_t size = fs::file_size(path, ec);
    return !ec && exr_magic(path) && check_exr(path, size);
  } catch (const InputError&) {
    return false;
  }
}

void ImageReader::open_luminance_chroma() {
  try {
    impl_->yc = std::make_unique<Imf::RgbaInputFile>(path_.c_str(), 1);
  } catch (const std::exception& e) {
    throw InputError(path_ + ": " + failure(e.what()));
  }
  const Imath::Box2i dw = impl_->yc->dataWindow(), fw = impl_->yc->displayWindow();
  impl_->yc_alpha = (impl_->yc->channels() & Imf::WRITE_A) != 0;
  ImageSpec s(dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1, impl_->yc_alpha ? 4 : 3,
              TypeDesc::HALF);
  s.x = dw.min.x;
  s.y = dw.min.y;
  s.full_x = fw.min.x;
  s.full_y = fw.min.y;
  s.full_width = fw.max.x - fw.min.x + 1;
  s.full_height = fw.max.y - fw.min.y + 1;
  s.channelnames = impl_->yc_alpha ? std::vector<std::string>{"R", "G", "B", "A"}
                                   : std::vector<std::string>{"R", "G", "B"};
  s.alpha_channel = impl_->yc_alpha ? 3 : -1;
  impl_->spec = s;
  impl_->format = "openexr";
  impl_->luminance_chroma = true;
}

void ImageReader::read_luminance_chroma(long y0, long y1, SampleFormat format, void* rows) {
  const ImageSpec& s = impl_->spec;
  const long w = s.width, C = s.nchannels;
  auto& buf = impl_->yc_rows;
  buf.resize(std::size_t(w) * std::size_t(y1 - y0));
  try {
    // the frame buffer's origin at pixel (x, y) = (0, 0) of the data window
    impl_->yc->setFrameBuffer(buf.data() - s.x - std::ptrdiff_t(s.y + y0) * w, 1, std::size_t(w));
    impl_->yc->readPixels(int(s.y + y0), int(s.y + y1 - 1));
  } catch (const std::exception& e) {
    std::ostringstream m;
    m << path_ << ": cannot read rows " << y0 << " to " << y1 - 1 << ": " << failure(e.what());
    throw InputError(m.str());
  }
  for (std::size_t p = 0; p < buf.size(); ++p) {
    const Imf::Rgba& px = buf[p];
    const half v[4] = {px.r, px.g, px.b, px.a};
    for (long c = 0; c < C; ++c) {
      if (format == SampleFormat::Half)
        static_cast<std::uint16_t*>(rows)[p * C + c] = v[c].bits();
      else
        static_cast<float*>(rows)[p * C + c] = float(v[c]);
    }
  }
}

long ImageReader::width() const { return impl_->spec.width; }
long ImageReader::height() const { return impl_->spec.height; }
int ImageReader::channels() const { return impl_->spec.nchannels; }
long ImageReader::data_x() const { return impl_->spec.x; }
long ImageReader::data_y() const { return impl_->spec.y; }
long ImageReader::full_x() const { return impl_->spec.full_x; }
long ImageReader::full_y() const { return impl_->spec.full_y; }
long ImageReader::full_width() const { return impl_->spec.full_width; }
long ImageReader::full_height() const { return impl_->spec.full_height; }
int ImageReader::alpha_channel() const { return impl_->spec.alpha_channel; }
namespace {
bool integer_type(TypeDesc t) {
  return t.basetype != TypeDesc::HALF && t.basetype != TypeDesc::FLOAT && t.basetype != TypeDesc::DOUBLE;
}
}  // namespace

std::string ImageReader::channel_type(int c) const {
  const ImageSpec& s = impl_->spec;
  return (c < int(s.channelformats.size()) ? s.channelformats[c] : s.format).c_str();
}

int ImageReader::integer_bits() const {
  const ImageSpec& s = impl_->spec;
  std::vector<TypeDesc> types = s.channelformats;
  if (types.empty()) types.push_back(s.format);
  int bits = 0;
  for (TypeDesc t : types) {
    if (!integer_type(t)) return 0;
    bits = std::max(bits, int(t.size()) * 8);
  }
  return bits;
}

Transfer ImageReader::transfer() const {
  const ImageSpec& s = impl_->spec;
  return default_transfer(integer_bits() > 0, s.get_string_attribute("oiio:ColorSpace"),
                          s.get_float_attribute("oiio:Gamma", 0.0f));
}

std::string Transfer::name() const {
  if (kind == Linear) return "linear";
  if (kind == SRGB) return "srgb";
  std::ostringstream m;
  m << "gamma" << gamma;
  return m.str();
}

Transfer parse_transfer(const std::string& spelling) {
  using OIIO::Strutil::iequals;
  if (iequals(spelling, "linear")) return Transfer::linear();
  if (iequals(spelling, "srgb")) return Transfer::srgb();
  if (OIIO::Strutil::istarts_with(spelling, "gamma") && spelling.size() > 5) {
    std::size_t used = 0;
    double g = 0;
    try {
      g = std::stod(spelling.substr(5), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == spelling.size() - 5 && std::isfinite(g) && g > 0)
      return g == 1.0 ? Transfer::linear() : Transfer::power(g);
  }
  throw std::invalid_argument("'" + spelling + "': expected srgb, linear or gammaG (G > 0)");
}

Transfer default_transfer(bool integer_samples, const std::string& colorspace, double gamma) {
  if (!integer_samples) return Transfer::linear();
  using OIIO::Strutil::iequals;
  using OIIO::Strutil::istarts_with;
  for (const char* linear : {"linear", "lin_srgb", "lin_rec709", "scene_linear", "raw"})
    if (iequals(colorspace, linear)) return Transfer::linear();
  double g = 0;
  if (istarts_with(colorspace, "GammaCorrected"))
    g = gamma;
  else if (istarts_with(colorspace, "Gamma"))
    g = OIIO::Strutil::stof(colorspace.substr(5));
  if (g == 1.0) return Transfer::linear();
  if (std::isfinite(g) && g > 0) return Transfer::power(g);
  return Transfer::srgb();
}

std::string ImageReader::format_name() const { return impl_->format; }
std::vector<std::string> ImageReader::channel_names() const { return impl_->spec.channelnames; }
std::string ImageReader::attribute(const std::string& name) const {
  // a key another tool typed as a number (oiiotool --attrib guesses types)
  // is read as the text of its value
  const OIIO::ParamValue* p = impl_->spec.find_attribute(name);
  const std::string named = p ? (p->type() == TypeDesc::STRING ? std::string(p->get_ustring().string())
                                                               : p->get_string())
                              : std::string();
  if (!named.empty()) return named;
  // formats that carry the keys as key=value lines of their description
  // (TIFF, JPEG, HEIF: stage_image writes them there)
  if (!carries_in_description(impl_->format)) return named;
  std::istringstream lines(impl_->spec.get_string_attribute("ImageDescription"));
  std::string line;
  while (std::getline(lines, line))
    if (line.size() > name.size() && line.compare(0, name.size(), name) == 0 && line[name.size()] == '=')
      return unescape_line(line.substr(name.size() + 1));
  return named;
}

long ImageReader::tile_height() const { return std::max(0, impl_->spec.tile_height); }

long ImageReader::preferred_strip() const {
  const long th = impl_->spec.tile_height;
  if (th > 0) return th * std::max(1L, 32 / th);
  // Whole 16-row zip blocks, about 4 MB of half rows: 64 rows up to 10000
  // RGB columns, fewer beyond (memory stays flat for very wide inputs).
  const long row_bytes = long(impl_->spec.width) * impl_->spec.nchannels * 2;
  return std::clamp(16 * ((4L << 20) / std::max(1L, row_bytes) / 16), 16L, 64L);
}

namespace {
// True when every channel is stored as `type`.
bool stored_as(const ImageSpec& s, TypeDesc type) {
  if (s.channelformats.empty()) return s.format == type;
  return std::all_of(s.channelformats.begin(), s.channelformats.end(),
                     [&](TypeDesc t) { return t == type; });
}
}  // namespace

bool ImageReader::stores_half() const { return stored_as(impl_->spec, TypeDesc::HALF); }

void ImageReader::read_rows(long y0, long y1, float* rows) { read(y0, y1, SampleFormat::Float, rows); }

void ImageReader::read_rows_half(long y0, long y1, std::uint16_t* rows) {
  if (!stores_half()) throw std::logic_error(path_ + ": read_rows_half() on samples not stored as half");
  read(y0, y1, SampleFormat::Half, rows);
}

namespace {
[[noreturn]] void read_failed(const std::string& path, long y0, long y1, ImageInput& in) {
  std::string why = in.geterror();
  if (why.empty()) why = "read failed";
  std::ostringstream m;
  m << path << ": cannot read rows " << y0 << " to " << y1 - 1 << ": " << failure(why);
  throw InputError(m.str());
}
}  // namespace

void ImageReader::read(long y0, long y1, SampleFormat format, void* rows) {
  const ImageSpec& s = impl_->spec;
  const TypeDesc type = format == SampleFormat::Half ? TypeDesc::HALF : TypeDesc::FLOAT;
  if (y0 < 0 || y1 > s.height || y1 < y0) {
    std::ostringstream m;
    m << path_ << ": rows [" << y0 << ", " << y1 << ") outside the image";
    throw InputError(m.str());
  }
  if (y1 == y0) return;
  if (impl_->luminance_chroma) {
    if (!impl_->yc) throw std::logic_error(path_ + ": read after release()");
    return read_luminance_chroma(y0, y1, format, rows);
  }
  if (!impl_->in) throw std::logic_error(path_ + ": read after release()");
  // Samples stored as asked are read as stored (TypeDesc::UNKNOWN), straight
  // into `rows`: OpenImageIO 2.4 stages any call that names a type, even the
  // stored one, through a buffer (a fresh one per call for scanlines).
  const TypeDesc asked = stored_as(s, type) ? TypeDesc::UNKNOWN : type;
  ImageInput& in = *impl_->in;
  if (s.tile_width <= 0) {
    if (!in.read_scanlines(0, impl_->level, s.y + y0, s.y + y1, s.z, 0, s.nchannels, asked, rows))
      read_failed(path_, y0, y1, in);
    return;
  }
  // Tiled: read_tiles takes whole tile rows (or the image's last, partial
  // one). Whole tile rows inside [y0, y1) are read into `rows`; a tile row
  // that the strip starts or ends inside is read whole into a one-row cache
  // and its rows copied (a strip's last tile row is the next strip's first).
  const long th = s.tile_height;
  const int elem = format == SampleFormat::Half ? 2 : 4;
  const std::size_t row_bytes = std::size_t(s.width) * s.nchannels * elem;
  auto tiles = [&](long a, long b, void* dst) {
    if (!in.read_tiles(0, impl_->level, s.x, s.x + s.width, s.y + a, s.y + b, s.z, s.z + 1, 0, s.nchannels,
                       asked, dst))
      read_failed(path_, a, b, in);
  };
  auto from_cache = [&](long a, long b) {  // rows [a, b) of one tile row
    const long t = a / th;
    if (impl_->cached_tile_row != t || impl_->cached_elem != elem) {
      const long t0 = t * th, t1 = std::min<long>(s.height, t0 + th);
      impl_->cached_tile_row = -1;
      impl_->tile_row.resize(std::size_t(t1 - t0) * row_bytes);
      tiles(t0, t1, impl_->tile_row.data());
      impl_->cached_tile_row = t;
      impl_->cached_elem = elem;
    }
    std::memcpy(static_cast<unsigned char*>(rows) + std::size_t(a - y0) * row_bytes,
                impl_->tile_row.data() + std::size_t(a - t * th) * row_bytes,
                std::size_t(b - a) * row_bytes);
  };
  long y = y0;
  if (y % th != 0) {  // the head, inside a tile row
    const long b = std::min(y1, (y / th + 1) * th);
    from_cache(y, b);
    y = b;
  }
  const long whole_end = y1 == s.height ? y1 : y1 / th * th;
  if (whole_end > y) {
    tiles(y, whole_end, static_cast<unsigned char*>(rows) + std::size_t(y - y0) * row_bytes);
    y = whole_end;
  }
  if (y < y1) from_cache(y, y1);  // the tail, inside a tile row
}

SampleFormat parse_sample_format(const std::string& spelling) {
  for (SampleFormat f : {SampleFormat::UInt8, SampleFormat::UInt16, SampleFormat::Half, SampleFormat::Float})
    if (spelling == sample_format_name(f)) return f;
  throw std::invalid_argument("sample format '" + spelling + "': expected uint8, uint16, half or float");
}

long decode_strip_rows(const ImageReader& reader) {
  const long row_bytes =
      std::max(1L, reader.width() * reader.channels() * (reader.stores_half() ? 2L : 4L));
  const long rows = std::clamp(16 * ((1L << 20) / row_bytes / 16), 16L, 256L);
  const long th = reader.tile_height();
  return th > 0 ? std::max(th, rows / th * th) : rows;  // whole tile rows
}

namespace {
// OpenImageIO's exr_threads at -1 while it lives: OpenEXR files opened then
// decode in the thread that reads them (the setting applies at opening);
// the former value is restored for later files (the output's compression).
class ExrThreadsOff {
 public:
  ExrThreadsOff() {
    OIIO::getattribute("exr_threads", old_);
    OIIO::attribute("exr_threads", -1);
  }
  ~ExrThreadsOff() { OIIO::attribute("exr_threads", old_); }
  ExrThreadsOff(const ExrThreadsOff&) = delete;
  ExrThreadsOff& operator=(const ExrThreadsOff&) = delete;

 private:
  int old_ = 0;
};
}  // namespace

long read_bands(const std::vector<std::string>& paths, const BandPartition& bands, long strip,
                int workers, bool half, const BandCallbacks& cb) {
  std::vector<BandSource> sources;
  for (const std::string& p : paths) sources.push_back({p, {}});
  return read_bands(sources, bands, strip, workers, half, cb);
}

long read_bands(const std::vector<BandSource>& sources, const BandPartition& bands, long strip,
                int workers, bool half, const BandCallbacks& cb, long first_band) {
  if (strip < 1) throw std::invalid_argument("read_bands(): strip < 1");
  if (first_band < 0 || (first_band > 0 && first_band >= bands.count()))
    throw std::invalid_argument("read_bands(): first band out of range");
  const long base = bands.count() > 0 ? bands.begin(first_band) : 0;  // the sources' first row
  std::vector<std::string> paths;  // the names strips carry
  for (const BandSource& s : sources) paths.push_back(s.name);
  const int T = int(std::clamp<long>(workers, 1, std::max(1L, bands.count() - first_band)));
  std::optional<ExrThreadsOff> off;  // for the readers opened here and by the threads
  if (T > 1) off.emplace();
  std::vector<long> start(1, 0);  // each file's first row in the image
  std::size_t values = 0;         // largest strip
  // Every file's header, one file open at a time; those the first band
  // reads stay open for worker 0 (a decoder freed before the reading raises
  // glibc's dynamic mmap threshold, and the reading's buffers then stay on
  // the heap: a higher peak).
  std::vector<std::unique_ptr<ImageReader>> first_readers(paths.size());
  // What each file was at this first opening: a worker that opens it again
  // reads it only while it still is (buffers are sized by these headers).
  std::vector<FileSignature> signatures(paths.size());
  for (std::size_t f = 0; f < paths.size(); ++f) {
    if (const SampleView& im = sources[f].image) {  // samples in memory
      if (half != im.is_half())
        throw std::logic_error(paths[f] + ": read_bands() with half " + (half ? "on" : "off") +
                               " on samples in memory that are not");
      start.push_back(start.back() + im.height);
      values = std::max(values, std::size_t(std::min(strip, im.height)) * im.row_size());
      continue;
    }
    auto opened = std::make_unique<ImageReader>(paths[f], sources[f].expected);
    const ImageReader& r = *opened;
    signatures[f] = r.signature();
    if (T > 1 && r.format_name() != "openexr")
      throw std::logic_error(r.path() +
                             ": read_bands() with several workers on a file not OpenEXR");
    if (half && !r.stores_half())
      throw std::logic_error(r.path() + ": read_bands() with half on samples not stored as half");
    start.push_back(start.back() + r.height());
    values = std::max(values, std::size_t(std::min(strip, r.height())) * r.width() * r.channels());
    if (bands.count() > 0 && base + start[f] < bands.end(first_band))
      first_readers[f] = std::move(opened);
  }
  // the bands the sources cover
  const long last_band = bands.count() > 0 ? bands.of(std::max(base, base + start.back() - 1)) + 1 : 0;
  if (base + start.back() != (bands.count() > 0 ? bands.end(last_band - 1) : 0) &&
      !(start.back() == 0 && bands.rows() == 0))
    throw std::logic_error("read_bands(): the files hold " + std::to_string(start.back()) +
                           " rows from row " + std::to_string(base) + ", not whole bands of " +
                           std::to_string(bands.rows()));
  std::atomic<long> next{first_band};
  std::atomic<long> stop{LONG_MAX};  // the first band stopped so far
  auto stop_at = [&](long b) {
    long s = stop.load();
    while (b < s && !stop.compare_exchange_weak(s, b)) {
    }
  };
  std::mutex m;
  long error_band = LONG_MAX;
  std::exception_ptr error;
  auto worker = [&](int t) {
    // This worker's readers, opened as its bands reach their files and
    // closed once its bands (taken in increasing order) have passed them:
    // a worker holds the files of one band open, whatever their count.
    std::vector<std::unique_ptr<ImageReader>> readers(paths.size());
    if (t == 0) readers = std::move(first_readers);
    auto reader = [&](std::size_t f) -> ImageReader& {
      for (std::size_t e = 0; e < f; ++e) readers[e].reset();
      if (!readers[f]) readers[f] = std::make_unique<ImageReader>(paths[f], signatures[f]);
      return *readers[f];
    };
    Buffer<std::uint16_t> half_rows(half ? values : 0);  // unset: each strip is read into them
    Buffer<float> float_rows(half ? 0 : values);
    for (;;) {
      const long b = next++;
      if (b >= last_band || b > stop.load()) return;
      try {
        cb.begin(t, b);
        bool whole = true;
        for (long y = bands.begin(b) - base; y < bands.end(b) - base;) {  // the sources' rows
          if (b > stop.load()) return;  // an earlier band stopped
          const std::size_t f = std::upper_bound(start.begin(), start.end(), y) - start.begin() - 1;
          const long y0 = y - start[f];
          // to the end of the file's strip, the band or the file
          const long y1 = std::min({(y0 / strip + 1) * strip, bands.end(b) - base - start[f],
                                    start[f + 1] - start[f]});
          if (const SampleView& im = sources[f].image) {  // copied: the callbacks write in place
            const std::size_t n = std::size_t(y1 - y0) * im.row_size();
            if (im.is_integer()) {  // scaled to [0, 1] as OpenImageIO converts a file's integers
              const TypeDesc t = im.type == SampleType::UInt8 ? TypeDesc::UINT8 : TypeDesc::UINT16;
              for (long r = y0; r < y1; ++r)
                OIIO::convert_pixel_values(t, im.row(r), TypeDesc::FLOAT,
                                           float_rows.data() + std::size_t(r - y0) * im.row_size(),
                                           int(im.row_size()));
            } else
              std::memcpy(half ? static_cast<void*>(half_rows.data()) : float_rows.data(), im.row(y0),
                          n * im.value_bytes());
          }
          else if (half)
            reader(f).read_rows_half(y0, y1, half_rows.data());
          else
            reader(f).read_rows(y0, y1, float_rows.data());
          if (!cb.strip(t, Strip{f, &paths[f], y0, y1, base + y, half ? half_rows.data() : nullptr,
                                 half ? nullptr : float_rows.data()})) {
            whole = false;
            break;
          }
          y = start[f] + y1;
        }
        if (!whole) {
          stop_at(b);
          return;
        }
        cb.end(t, b);
      } catch (...) {
        {
          std::lock_guard<std::mutex> lock(m);
          if (b < error_band) error_band = b, error = std::current_exception();
        }
        stop_at(b);
        return;
      }
    }
  };
  // The workers on the process's worker pool (parallel.h), one part each;
  // their own calls to parallel_for run in them. One worker runs here, so
  // that the stages it calls may use the pool.
  if (T == 1)
    worker(0);
  else
    parallel_for(T, T, [&](long t0, long t1) {
      for (long t = t0; t < t1; ++t) worker(int(t));
    });
  if (error && error_band <= stop.load()) std::rethrow_exception(error);
  return stop.load() == LONG_MAX ? -1 : stop.load();
}

std::string sample_format_name(SampleFormat f) {
  switch (f) {
    case SampleFormat::UInt8: return "uint8";
    case SampleFormat::UInt16: return "uint16";
    case SampleFormat::Half: return "half";
    case SampleFormat::Float: break;
  }
  return "float";
}

namespace {
// A half is infinite or NaN when its exponent bits are all ones.
constexpr std::uint16_t kHalfExponent = 0x7c00;
}  // namespace

#if defined(__x86_64__)
namespace {
bool has_f16c() {
  static const bool f16c = __builtin_cpu_supports("f16c") && __builtin_cpu_supports("avx");
  return f16c;
}

__attribute__((target("avx,f16c"))) bool half_to_float_f16c(const std::uint16_t* in, float* out,
                                                           std::size_t n) {
  const __m128i exponent = _mm_set1_epi16(std::int16_t(kHalfExponent));
  __m128i special = _mm_setzero_si128();
  std::size_t q = 0;
  for (; q + 8 <= n; q += 8) {
    const __m128i h = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + q));
    special = _mm_or_si128(special, _mm_cmpeq_epi16(_mm_and_si128(h, exponent), exponent));
    _mm256_storeu_ps(out + q, _mm256_cvtph_ps(h));
  }
  bool finite = _mm_movemask_epi8(special) == 0;
  for (; q < n; ++q) {
    out[q] = _cvtsh_ss(in[q]);
    finite = finite && (in[q] & kHalfExponent) != kHalfExponent;
  }
  return finite;
}

__attribute__((target("avx,f16c"))) void float_to_half_f16c(const float* in, std::uint16_t* out,
                                                          std::size_t n) {
  std::size_t q = 0;
  for (; q + 8 <= n; q += 8)
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + q),
                     _mm256_cvtps_ph(_mm256_loadu_ps(in + q), _MM_FROUND_TO_NEAREST_INT));
  for (; q < n; ++q) out[q] = _cvtss_sh(in[q], _MM_FROUND_TO_NEAREST_INT);
}
}  // namespace
#endif

void float_to_half(const float* in, std::uint16_t* out, std::size_t n) {
#if defined(__x86_64__)
  if (has_f16c()) return float_to_half_f16c(in, out, n);
#endif
  for (std::size_t q = 0; q < n; ++q) out[q] = imath_float_to_half(in[q]);
}

bool half_to_float(const std::uint16_t* in, float* out, std::size_t n) {
#if defined(__x86_64__)
  if (has_f16c()) return half_to_float_f16c(in, out, n);
#endif
  bool finite = true;
  for (std::size_t q = 0; q < n; ++q) {
    out[q] = imath_half_to_float(in[q]);
    finite = finite && (in[q] & kHalfExponent) != kHalfExponent;
  }
  return finite;
}

void decode_to_linear(const Transfer& t, float* v, std::size_t n, int channels, int alpha,
                      std::size_t k0) {
  if (t.kind == Transfer::Linear) return;
  const std::size_t C = std::size_t(channels);
  for (std::size_t q = 0; q < n; ++q) {
    if (int((k0 + q) % C) == alpha) continue;
    v[q] = t.kind == Transfer::SRGB ? srgb_to_linear(v[q])
                                    : float(std::pow(std::max(0.0, double(v[q])), t.gamma));
  }
}

Image linear_image(const SampleView& v) {
  Image img(v.width, v.height, v.channels);
  const std::size_t n = img.data.size();
  const TypeDesc from = v.type == SampleType::UInt8    ? TypeDesc::UINT8
                        : v.type == SampleType::UInt16 ? TypeDesc::UINT16
                        : v.type == SampleType::Half   ? TypeDesc::HALF
                                                       : TypeDesc::FLOAT;
  for (long r = 0; r < v.height; ++r)  // a row at a time: OpenImageIO counts values in int
    if (!OIIO::convert_pixel_values(from, v.row(r), TypeDesc::FLOAT, img.row(r), int(v.row_size())))
      throw std::logic_error("linear_image(): the samples were not converted");
  decode_to_linear(default_transfer(v.is_integer(), ""), img.data.data(), n, v.channels, -1);
  return img;
}

Image read_image(const std::string& path) {
  ImageReader r(path);
  Image img(r.width(), r.height(), r.channels());
  const long strip = r.preferred_strip();
  const Transfer t = r.transfer();
  for (long y = 0; y < r.height(); y += strip) {
    const long y1 = std::min(r.height(), y + strip);
    r.read_rows(y, y1, img.row(y));
    decode_to_linear(t, img.row(y), std::size_t(y1 - y) * r.width() * r.channels(), r.channels(),
                     r.alpha_channel());
  }
  return img;
}

namespace {
std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::string out_format_name(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext.empty() ? std::string("format's") : ext.substr(1);
}
}  // namespace

void check_output(const std::string& path) {
  check_path(path, true);
  const fs::path p(path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw OutputError(path + ": output folder " + dir.string() + " does not exist");
  const fs::file_status st = fs::symlink_status(p, ec);
  if (fs::is_directory(st)) throw OutputError(path + ": is a folder");
  if (fs::exists(st) && !fs::is_regular_file(st) && !fs::is_symlink(st))
    throw OutputError(path + ": not a regular file (a FIFO, a device or a socket); siproject "
                      "writes a finished file and renames it onto the name");
  if (lower_extension(path) == ".ico")
    throw OutputError(path + ": ICO output is not supported (OpenImageIO 2.4 writes ICO files "
                      "it cannot read back)");
  auto out = ImageOutput::create(path);
  if (!out) {
    const std::string why = OIIO::geterror();
    // OpenImageIO swallows what a writer's constructor throws: no writer and
    // no reason is the allocation that failed
    if (why.empty()) throw std::bad_alloc();
    throw OutputError(path + ": no writer for this name's format (" + why + ")");
  }
  const std::string format = out->format_name();
  if (format == "jpeg2000")
    throw OutputError(path + ": JPEG 2000 output is not supported (OpenImageIO 2.4's writer here "
                      "makes files without their start marker, that do not read back)");
  if (format == "term" || format == "null")
    throw OutputError(path + ": the " + format + " writer makes no image file");
}

namespace {
// What OpenImageIO 2.4's writers hold, measured writer by writer (1 to 6
// channels, sides up to 2^21, each sample type written and read back, a
// named key and a long multi-line ImageDescription written and read back)
// and what their sources take as compression (src/*.imageio/*output.cpp).
// Past the limits, some end the process (DPX asserts on 2 or 5+ channels),
// hang (JPEG past 65500 pixels a side), write another image (JPEG: 2
// channels as 3, 4+ as 3; GIF past 65535; FITS: 5+ channels, one row;
// types they do not hold as another: PNG float as uint8, TIFF half as
// float) or fail once the work is done.
struct WriterLimits {
  const char* format;  // OpenImageIO's name
  const char* name;    // as messages name it
  unsigned channels;   // bit c: c channels held (0: any count)
  long max_side;       // 0: none found
  long min_height;
  unsigned types;      // bit SampleFormat: held (read back as written)
  SampleFormat deflt;  // without -d (an integer type: uint16 for 16-bit inputs where held)
  MetadataCarrier metadata;
  // The compression names the writer takes ("" none), a name with ":N"
  // takes a quality 1..N; the first name with a quality is the one that
  // --quality alone means (the writer's default, or the only one).
  const char* compressions;
};
constexpr unsigned kOneToFour = 0x1e, kGreyRgbRgba = 0x1a, kRgbRgba = 0x18;
constexpr unsigned bit(SampleFormat f) { return 1u << unsigned(f); }
constexpr unsigned kU8 = bit(SampleFormat::UInt8), kU16 = bit(SampleFormat::UInt16),
                   kHalf = bit(SampleFormat::Half), kFloat = bit(SampleFormat::Float);
constexpr SampleFormat kInt = SampleFormat::UInt8, kFlt = SampleFormat::Float;
constexpr auto kNamed = MetadataCarrier::Named, kDesc = MetadataCarrier::Description,
               kNone = MetadataCarrier::None;
constexpr WriterLimits kWriters[] = {
    {"openexr", "OpenEXR", 0, 0, 1, kHalf | kFloat, kFlt, kNamed,
     "zip:9 none rle zips:9 piz pxr24 b44 b44a dwaa:100 dwab:100"},
    {"tiff", "TIFF", 0, 0, 1, kU8 | kU16 | kHalf | kFloat, kInt, kDesc,
     "zip:9 none lzw packbits jpeg:100"},
    {"dpx", "DPX", kGreyRgbRgba, 0, 1, kU8 | kU16 | kFloat, kInt, kNone, ""},
    {"png", "PNG", kOneToFour, 1000000, 1, kU8 | kU16, kInt, kNamed,
     "default filtered huffman rle fixed"},
    {"jpeg", "JPEG", 0x0a, 65500, 1, kU8, kInt, kDesc, "jpeg:100"},
    {"bmp", "BMP", kGreyRgbRgba, 0, 1, kU8, kInt, kNone, ""},
    {"targa", "Targa", kOneToFour, 65535, 1, kU8, kInt, kNone, "none rle"},
    {"pnm", "PNM", 0x0a, 0, 1, kU8, kInt, kNone, ""},  // 16-bit: 8-bit values widened
    {"gif", "GIF", kRgbRgba, 65535, 1, kU8, kInt, kNone, ""},
    {"webp", "WebP", kRgbRgba, 16383, 1, kU8, kInt, kNone, "webp:100 lossless"},
    {"hdr", "Radiance HDR", 0x08, 0, 1, kFloat, kFlt, kNone, ""},
    {"fits", "FITS", kOneToFour, 999999, 2, kU8 | kFloat, kFlt, kNone, ""},
    {"iff", "IFF", kRgbRgba, 8192, 1, kU8 | kU16, kInt, kNone, "rle none"},
    {"zfile", "Zfile", 0x02, 32767, 1, kFloat, kFlt, kNone, ""},
    {"sgi", "SGI", 0, 65534, 1, kU8 | kU16, kInt, kNone, ""},
    {"rla", "RLA", 0, 32768, 1, kU8 | kU16 | kFloat, kInt, kNone, ""},
    {"heif", "HEIF", kRgbRgba, 0, 1, kU8, kInt, kDesc, "heic:100 none"},
};

std::string counts(unsigned mask) {
  std::vector<int> c;
  for (int n = 1; n < 32; ++n)
    if (mask >> n & 1) c.push_back(n);
  if (c.size() > 2 && c.back() - c.front() + 1 == int(c.size()))
    return std::to_string(c.front()) + " to " + std::to_string(c.back());
  std::string s;
  for (std::size_t i = 0; i < c.size(); ++i)
    s += (i == 0 ? "" : i + 1 == c.size() ? " or " : ", ") + std::to_string(c[i]);
  return s;
}

std::string either(const std::vector<std::string>& items) {
  std::string s;
  for (std::size_t i = 0; i < items.size(); ++i)
    s += (i == 0 ? "" : i + 1 == items.size() ? " or " : ", ") + items[i];
  return s;
}

// The limits of the writer OpenImageIO picks for a name (nullptr: none
// known, or no writer, check_output's refusal: *writer false).
const WriterLimits* writer_limits(const std::string& path, bool* writer = nullptr) {
  if (writer) *writer = false;
  if (path.find('\0') != std::string::npos) return nullptr;
  auto out = ImageOutput::create(path);
  if (writer) *writer = bool(out);
  if (!out) return nullptr;
  for (const WriterLimits& l : kWriters)
    if (out->format_name() == std::string(l.format)) return &l;
  return nullptr;
}

bool carries_in_description(const std::string& format) {
  for (const WriterLimits& l : kWriters)
    if (format == l.format) return l.metadata == MetadataCarrier::Description;
  return false;
}

constexpr SampleFormat kAllFormats[] = {SampleFormat::UInt8, SampleFormat::UInt16,
                                        SampleFormat::Half, SampleFormat::Float};

// A writer's compression names: name and the largest quality it takes (0: none).
std::vector<std::pair<std::string, int>> compressions_of(const WriterLimits& l) {
  std::vector<std::pair<std::string, int>> names;
  std::istringstream in(l.compressions);
  std::string word;
  while (in >> word) {
    const std::size_t colon = word.find(':');
    names.emplace_back(word.substr(0, colon),
                       colon == std::string::npos ? 0 : std::stoi(word.substr(colon + 1)));
  }
  return names;
}

std::string describe_compressions(const WriterLimits& l) {
  std::vector<std::string> items;
  for (const auto& [name, q] : compressions_of(l))
    items.push_back(q ? name + " (" + name + ":1 to " + name + ":" + std::to_string(q) + ")" : name);
  return either(items);
}
}  // namespace

void check_output_image(const std::string& path, int channels, long width, long height,
                        bool half) {
  check_path(path, true);
  if (const WriterLimits* found = writer_limits(path)) {
    const WriterLimits& l = *found;
    if (l.channels && (channels < 1 || channels > 31 || !(l.channels >> channels & 1)))
      throw OutputError(path + ": " + l.name + " output holds " + counts(l.channels) +
                        " channels, not " + std::to_string(channels));
    if (l.max_side && (width > l.max_side || height > l.max_side))
      throw OutputError(path + ": " + l.name + " output holds images up to " +
                        std::to_string(l.max_side) + " pixels a side, not " +
                        std::to_string(width) + " x " + std::to_string(height));
    if (height > 0 && height < l.min_height)
      throw OutputError(path + ": " + l.name + " output needs at least " +
                        std::to_string(l.min_height) + " rows, not " + std::to_string(height));
    if (half && !(l.types & kHalf))
      throw OutputError(path + ": " + l.name + " output holds float samples, not half");
  }
}

bool holds_format(const std::string& path, SampleFormat f, std::string* held) {
  bool writer = false;
  const WriterLimits* l = writer_limits(path, &writer);
  const unsigned types = l ? l->types : writer ? ~0u : 0u;
  if (held) {
    std::vector<std::string> names;
    for (SampleFormat t : kAllFormats)
      if (types & bit(t)) names.push_back(sample_format_name(t));
    *held = names.empty() ? std::string("nothing") : either(names);
  }
  return (types & bit(f)) != 0;
}

bool holds_half(const std::string& path) { return holds_format(path, SampleFormat::Half); }

SampleFormat default_sample_format(const std::string& path, bool input_half, int integer_bits) {
  bool writer = false;
  const WriterLimits* l = writer_limits(path, &writer);
  SampleFormat d = SampleFormat::UInt8;
  if (l) {
    d = l->deflt;
  } else {
    const std::string ext = lower_extension(path);
    for (const char* linear : {".exr", ".sxr", ".mxr", ".hdr", ".rgbe", ".pfm", ".fits", ".fit", ".fts"})
      if (ext == linear) d = SampleFormat::Float;
  }
  const unsigned types = l ? l->types : ~0u;
  if (is_integer(d)) return integer_bits >= 16 && (types & kU16) ? SampleFormat::UInt16 : d;
  return input_half && (types & kHalf) ? SampleFormat::Half : SampleFormat::Float;
}

bool is_8bit_format(const std::string& path) { return is_integer(default_sample_format(path)); }

MetadataCarrier metadata_carrier(const std::string& path) {
  const WriterLimits* l = writer_limits(path);
  return l ? l->metadata : MetadataCarrier::Named;
}

Compression parse_compression(const std::string& spelling) {
  Compression c;
  const std::size_t colon = spelling.find(':');
  c.name = spelling.substr(0, colon);
  std::transform(c.name.begin(), c.name.end(), c.name.begin(),
                 [](unsigned char ch) { return std::tolower(ch); });
  if (c.name.empty() || c.name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789") != std::string::npos)
    throw std::invalid_argument("'" + spelling + "': expected NAME or NAME:QUALITY (zip, piz, lzw, "
                                "jpeg:90...)");
  if (colon != std::string::npos) {
    const std::string q = spelling.substr(colon + 1);
    if (q.empty() || q.size() > 3 || q.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(q) < 1 || std::stoi(q) > 100)
      throw std::invalid_argument("'" + spelling + "': the quality after ':' is a whole number 1 to 100");
    c.quality = std::stoi(q);
  }
  return c;
}

void check_write_options(const std::string& path, int channels, SampleFormat format,
                         const Compression& compression) {
  std::string held;
  bool writer = false;
  const WriterLimits* l = writer_limits(path, &writer);
  const std::string fmt = l ? l->name : out_format_name(path);
  if (writer && !holds_format(path, format, &held))
    throw std::invalid_argument(fmt + " output holds " + held + " samples, not " +
                                sample_format_name(format));
  if (compression.quality && (compression.quality < 1 || compression.quality > 100))
    throw std::invalid_argument("quality " + std::to_string(compression.quality) +
                                ": expected 1 to 100");
  if (compression.name.empty() && !compression.quality) return;
  if (!l) throw std::invalid_argument(fmt + " output: no compression is known for its writer");
  const auto names = compressions_of(*l);
  if (names.empty()) throw std::invalid_argument(fmt + " output takes no compression or quality");
  std::string name = compression.name;
  int most = -1;  // the largest quality `name` takes
  if (name.empty()) {
    for (const auto& [n, q] : names)
      if (q && most < 0) name = n, most = q;
    if (most < 0)
      throw std::invalid_argument(fmt + " output takes no quality (its compressions: " +
                                  describe_compressions(*l) + ")");
  } else {
    for (const auto& [n, q] : names)
      if (n == name) most = q;
    if (most < 0)
      throw std::invalid_argument(fmt + " output takes compression " + describe_compressions(*l) +
                                  ", not '" + name + "'");
  }
  if (compression.quality && !most)
    throw std::invalid_argument(fmt + " compression " + name + " takes no quality");
  if (compression.quality > most)
    throw std::invalid_argument(fmt + " compression " + name + " takes a quality 1 to " +
                                std::to_string(most) + ", not " + std::to_string(compression.quality));
  // Where the writer would use another compression than the one named.
  const std::string f = l->format;
  if (f == "tiff" && name == "jpeg" && (format != SampleFormat::UInt8 || channels != 3))
    throw std::invalid_argument("TIFF compression jpeg holds 3-channel uint8 images only (the "
                                "writer would use zip), not " + std::to_string(channels) +
                                "-channel " + sample_format_name(format));
  if (f == "openexr" && (name == "dwaa" || name == "dwab") && channels == 1)
    throw std::invalid_argument("OpenEXR compression " + name + " needs 2 or more channels in a "
                                "scanline file (the writer would use zip for one)");
  if (f == "targa" && name == "rle" && channels < 3)
    throw std::invalid_argument("Targa compression rle holds 3 or 4 channels only (the writer "
                                "writes " + std::to_string(channels) + " uncompressed)");
}

float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float linear_to_srgb(float v) {
  if (!(v > 0)) return 0.0f;
  if (v >= 1) return 1.0f;
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

namespace {

// Writes an OpenImageIO output through a staged file's descriptor. Every
// write is checked (short writes retried, EINTR included) and the first
// error is kept, to be read once the writer is done: format writers do not
// all check what they write (a PNG writer on a full disk reports success),
// and some end the process on a failed write (libjpeg's default error
// exit), so after a failure the writer is told every write succeeded and
// the output is discarded.
class CheckedFile : public OIIO::Filesystem::IOProxy {
 public:
  CheckedFile(const std::string& name, int fd) : IOProxy(name, Write), fd_(fd) {}
  const char* proxytype() const override { return "sis-checked-file"; }
  void close() override { m_mode = Closed; }
  size_t write(const void* buf, size_t size) override {
    const size_t n = pwrite(buf, size, m_pos);
    m_pos += int64_t(n);
    return n;
  }
  size_t pwrite(const void* buf, size_t size, int64_t offset) override {
    const char* p = static_cast<const char*>(buf);
    size_t done = 0;
    while (done < size && !errno_) {
      const ssize_t n = ::pwrite(fd_, p + done, size - done, offset + int64_t(done));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        errno_ = n < 0 ? errno : ENOSPC;
        break;
      }
      done += size_t(n);
    }
    end_ = std::max(end_, offset + int64_t(size));
    return size;
  }
  size_t read(void* buf, size_t size) override {
    const size_t n = pread(buf, size, m_pos);
    m_pos += int64_t(n);
    return n;
  }
  size_t pread(void* buf, size_t size, int64_t offset) override {
    const ssize_t n = ::pread(fd_, buf, size, offset);
    return n < 0 ? 0 : size_t(n);
  }
  size_t size() const override { return size_t(end_); }
  // 0, or the errno of the first failed write
  int failure() const { return errno_; }

 private:
  int fd_;
  int64_t end_ = 0;
  int errno_ = 0;
};

// Writes `spec` + pixels to a staged file beside `path` (committed by the
// caller): never a partial file at `path`, and no temporary file left.
StagedFile stage(const std::string& path, const ImageSpec& spec, TypeDesc data_type,
                 const void* data, const std::string& compression = "") {
  check_output(path);
  check_output_image(path, spec.nchannels, spec.width, spec.height, spec.format == TypeDesc::HALF);
  auto out = ImageOutput::create(path);
  if (!out) {
    const std::string why = OIIO::geterror();
    if (why.empty()) throw std::bad_alloc();  // as in check_output
    throw OutputError(path + ": cannot write this format: " + why);
  }
  StagedFile file(path);
  // Writers that take a proxy write through the checked descriptor; the few
  // that do not (HEIF, SGI, FITS...), and TIFF (OpenImageIO 2.4's TIFF writer
  // makes a file without its image length through any proxy once string
  // attributes are set), write the staged file by its name, which must still
  // be the file created for them.
  const std::string ext = lower_extension(path);
  const bool through_proxy = out->supports("ioproxy") && ext != ".tif" && ext != ".tiff";
  CheckedFile proxy(file.temporary(), file.fd());
  const bool ok = (!through_proxy || out->set_ioproxy(&proxy)) &&
                  out->open(file.temporary(), spec) && out->write_image(data_type, data) &&
                  out->close();
  const std::string why = out->geterror();
  out.reset();
  if (proxy.failure()) throw OutputError(path + ": cannot write: " + std::strerror(proxy.failure()));
  if (!ok) throw OutputError(path + ": " + (why.empty() ? "write failed" : why));
  if (!through_proxy) {
    struct stat a, b;
    if (::fstat(file.fd(), &a) != 0 || ::lstat(file.temporary().c_str(), &b) != 0 ||
        a.st_dev != b.st_dev || a.st_ino != b.st_ino)
      throw OutputError(path + ": the staged file " + file.temporary() + " was replaced while written");
  }
  file.close();
  // What was written reads back as what was meant: its header (every
  // format), and its pixels where the writer's own writes went unchecked.
  std::string back_why;
  auto back = open_input(file.temporary(), &back_why);
  // (a format may add channels: GIF reads back as RGBA)
  bool readable = back && back->spec().width == spec.width && back->spec().height == spec.height &&
                  back->spec().nchannels >= spec.nchannels;
  if (readable && !through_proxy) {
    std::vector<float> all(std::size_t(spec.width) * spec.height * back->spec().nchannels);
    readable = back->read_image(0, 0, 0, back->spec().nchannels, TypeDesc::FLOAT, all.data());
  }
  // The compression asked, where the file says which it has (OpenEXR, TIFF).
  std::string wrote;
  if (readable && !compression.empty() &&
      (back->format_name() == std::string("openexr") || back->format_name() == std::string("tiff"))) {
    wrote = back->spec().get_string_attribute("compression");
    if (OIIO::Strutil::iequals(wrote, compression)) wrote.clear();
  }
  if (back) {
    back_why = back->geterror();
    back->close();
  }
  if (!wrote.empty())
    throw OutputError(path + ": the " + out_format_name(path) + " writer used compression " + wrote +
                      ", not " + compression + "; nothing written");
  if (!readable)
    throw OutputError(path + ": the " + out_format_name(path) + " writer made a file that does "
                      "not read back" + (back_why.empty() ? "" : " (" + back_why + ")") +
                      "; nothing written");
  return file;
}

}  // namespace

void write_image(const std::string& path, const Image& image,
                 const std::vector<std::string>& channel_names, const Metadata& metadata,
                 int alpha_channel, const WriteOptions& options) {
  stage_image(path, image, channel_names, metadata, alpha_channel, options).commit();
}


StagedFile stage_image(const std::string& path, const Image& image,
                       const std::vector<std::string>& channel_names, const Metadata& metadata,
                       int alpha_channel, const WriteOptions& options) {
  if (image.width < 1 || image.height < 1 || image.channels < 1)
    throw OutputError(path + ": refusing to write an empty image");
  check_path(path, true);
  const SampleFormat format = options.format ? *options.format : default_sample_format(path);
  try {
    check_write_options(path, image.channels, format, options.compression);
  } catch (const std::invalid_argument& e) {
    throw OutputError(path + ": " + e.what());
  }
  static const TypeDesc kStored[] = {TypeDesc::UINT8, TypeDesc::UINT16, TypeDesc::HALF, TypeDesc::FLOAT};
  const TypeDesc stored = kStored[int(format)];
  ImageSpec spec(int(image.width), int(image.height), image.channels, stored);
  if (int(channel_names.size()) == image.channels) spec.channelnames = channel_names;
  if (alpha_channel >= 0 && alpha_channel < image.channels) spec.alpha_channel = alpha_channel;
  for (const auto& [k, v] : metadata) spec.attribute(k, v);
  if (metadata_carrier(path) == MetadataCarrier::Description) {
    // the namespaced keys the writer drops, as key=value lines
    std::string text = spec.get_string_attribute("ImageDescription");
    for (const auto& [k, v] : metadata)
      if (k.find(':') != std::string::npos)
        text += (text.empty() ? "" : "\n") + k + "=" + escape_line(v);
    if (!text.empty()) spec.attribute("ImageDescription", text);
  }
  const Compression& c = options.compression;
  std::string compression = c.name;
  if (!c.name.empty() || c.quality) {
    if (compression.empty()) {  // the writer's name that takes a quality (check_write_options)
      const WriterLimits* l = writer_limits(path);
      for (const auto& [n, q] : compressions_of(*l))
        if (q && compression.empty()) compression = n;
    }
    spec.attribute("compression", compression);
    if (c.quality) spec.attribute("CompressionQuality", c.quality);
  }
  if (stored == TypeDesc::HALF) {  // converted here: OpenImageIO's conversion is serial and slower
    const WriterLimits* l = writer_limits(path);
    if (l && l->format == std::string("tiff"))
      spec.attribute("tiff:half", 1);  // else OpenImageIO's TIFF writer stores float
    Buffer<std::uint16_t> half(image.data.size());  // unset: every value converted
    float_to_half(image.data.data(), half.data(), half.size());
    return stage(path, spec, TypeDesc::HALF, half.data(), compression);
  }
  if (!is_integer(format)) return stage(path, spec, TypeDesc::FLOAT, image.data.data(), compression);
  // Integer samples: colour channels sRGB-encoded (after dividing out
  // premultiplied alpha), alpha linear; everything clamped to [0, 1];
  // OpenImageIO rounds to the integer type.
  spec.attribute("oiio:ColorSpace", "sRGB");
  if (spec.alpha_channel >= 0) spec.attribute("oiio:UnassociatedAlpha", 1);
  const int C = image.channels, a = spec.alpha_channel;
  std::vector<float> enc(image.data.size());
  for (std::size_t p = 0; p < image.data.size() / C; ++p) {
    const float* in = image.data.data() + p * C;
    const float alpha = a >= 0 ? std::clamp(in[a], 0.0f, 1.0f) : 1.0f;
    for (int c = 0; c < C; ++c) {
      if (c == a)
        enc[p * C + c] = alpha;
      else
        enc[p * C + c] = linear_to_srgb(a >= 0 ? (alpha > 0 ? in[c] / alpha : 0.0f) : in[c]);
    }
  }
  return stage(path, spec, TypeDesc::FLOAT, enc.data(), compression);
}

StagedFile stage_mip_image(const std::string& path, const std::vector<Image>& levels,
                           const std::vector<std::string>& channel_names, const Metadata& metadata,
                           int alpha_channel, SampleFormat format, int tile_size) {
  if (levels.empty()) throw OutputError(path + ": a MIP-map needs at least one level");
  check_output(path);
  if (!holds_coefficients(path))
    throw OutputError(path + ": a MIP-mapped texture is written as OpenEXR (.exr)");
  if (format != SampleFormat::Half && format != SampleFormat::Float)
    throw OutputError(path + ": a MIP-mapped OpenEXR holds half or float samples");
  const TypeDesc stored = format == SampleFormat::Half ? TypeDesc::HALF : TypeDesc::FLOAT;
  const Image& top = levels.front();
  check_output_image(path, top.channels, top.width, top.height, stored == TypeDesc::HALF);
  auto out = ImageOutput::create(path);
  if (!out) throw OutputError(path + ": cannot write OpenEXR: " + OIIO::geterror());
  StagedFile file(path);
  CheckedFile proxy(file.temporary(), file.fd());
  bool ok = out->set_ioproxy(&proxy);
  for (std::size_t j = 0; ok && j < levels.size(); ++j) {
    const Image& level = levels[j];
    ImageSpec spec(int(level.width), int(level.height), level.channels, stored);
    spec.tile_width = spec.tile_height = tile_size;
    if (int(channel_names.size()) == level.channels) spec.channelnames = channel_names;
    if (alpha_channel >= 0 && alpha_channel < level.channels) spec.alpha_channel = alpha_channel;
    spec.attribute("textureformat", "Plain Texture");
    spec.attribute("openexr:levelmode", 1);     // MIPMAP_LEVELS
    spec.attribute("openexr:roundingmode", 0);  // ROUND_DOWN, as maketx
    for (const auto& [k, v] : metadata) spec.attribute(k, v);
    ok = out->open(file.temporary(), spec, j == 0 ? ImageOutput::Create : ImageOutput::AppendMIPLevel);
    if (!ok) break;
    if (stored == TypeDesc::HALF) {
      Buffer<std::uint16_t> half(level.data.size());
      float_to_half(level.data.data(), half.data(), half.size());
      ok = out->write_image(TypeDesc::HALF, half.data());
    } else {
      ok = out->write_image(TypeDesc::FLOAT, level.data.data());
    }
  }
  ok = ok && out->close();
  const std::string why = out->geterror();
  out.reset();
  if (proxy.failure()) throw OutputError(path + ": cannot write: " + std::strerror(proxy.failure()));
  if (!ok) throw OutputError(path + ": " + (why.empty() ? "write failed" : why));
  file.close();
  // read back: every level there, of its size
  std::string back_why;
  auto back = open_input(file.temporary(), &back_why);
  bool readable = back != nullptr;
  for (std::size_t j = 0; readable && j < levels.size(); ++j)
    readable = back->seek_subimage(0, int(j)) && back->spec().width == levels[j].width &&
               back->spec().height == levels[j].height;
  if (readable) readable = !back->seek_subimage(0, int(levels.size()));
  if (back) back->close();
  if (!readable)
    throw OutputError(path + ": the OpenEXR writer made a MIP-map that does not read back as its " +
                      std::to_string(levels.size()) + " levels" +
                      (back_why.empty() ? "" : " (" + back_why + ")") + "; nothing written");
  return file;
}

void write_coefficients(const std::string& path, const Coefficients& k,
                        const std::vector<std::string>& channel_names, const Metadata& extra) {
  stage_coefficients(path, k, channel_names, extra).commit();
}

bool holds_coefficients(const std::string& path) {
  if (path.find('\0') != std::string::npos) return false;
  auto out = ImageOutput::create(path);
  return out && out->format_name() == std::string("openexr");
}

namespace {
// A coefficient file's metadata: everything Coefficients holds.
Metadata coefficient_metadata(const Coefficients& k, const Metadata& extra) {
  const auto num = metadata_number;
  // the space's own keys (lattice, storage, origin, matrix, generator, degree)
  Metadata md = visit_space(k, [&](auto space) { return space.metadata(k); });
  md.insert(md.begin(), {"sis:coefficients", "1"});
  md.insert(md.end(), {
      {"sis:boundary", boundary_name(k.boundary)},
      {"sis:method", k.min_error ? "min-error" : "conventional"},
      {"sis:image_width", num(k.image_width)},
      {"sis:image_height", num(k.image_height)},
      // what they are of
      {"sis:input", k.input.label},
      {"sis:input_format", k.input.half ? "half" : "float"},
      {"sis:input_transfer", k.input.transfer.name()},
      {"sis:highlight_compress", k.highlight_compressed ? "1" : "0"},
  });
  // the alpha channel by index (a name the reader does not take for alpha,
  // such as a layer's "diffuse.A", keeps its role)
  if (k.alpha >= 0 && k.alpha < k.c.channels) md.push_back({"sis:alpha", std::to_string(k.alpha)});
  for (const auto& [key, value] : extra) {
    bool replaced = false;
    for (auto& kv : md)
      if (kv.first == key) kv.second = value, replaced = true;
    if (!replaced) md.push_back({key, value});
  }
  return md;
}

Image coefficient_grid(const Coefficients& k) {
  Image grid(k.c.width, k.c.height, k.c.channels);
  for (std::size_t q = 0; q < grid.data.size(); ++q) grid.data[q] = static_cast<float>(k.c.data[q]);
  return grid;
}

void refuse_non_coefficient_format(const std::string& path) {
  check_path(path, true);
  if (!holds_coefficients(path))
    throw OutputError(path + ": coefficient files are OpenEXR (.exr); this format cannot hold "
                      "their metadata and signed float coefficients");
}
}  // namespace

StagedFile stage_coefficients(const std::string& path, const Coefficients& k,
                              const std::vector<std::string>& channel_names,
                              const Metadata& extra) {
  refuse_non_coefficient_format(path);
  return stage_image(path, coefficient_grid(k),
                     channel_names.empty() ? k.channel_names : channel_names,
                     coefficient_metadata(k, extra), k.alpha);
}

StagedFile stage_mip_coefficients(const std::string& path,
                                  const std::vector<const Coefficients*>& levels) {
  refuse_non_coefficient_format(path);
  if (levels.empty()) throw OutputError(path + ": a pyramid's coefficient file needs a level");
  const Coefficients& top = *levels.front();
  std::string sizes;
  for (const Coefficients* k : levels)
    sizes += (sizes.empty() ? "" : " ") + metadata_number(k->image_width) + "x" +
             metadata_number(k->image_height);
  const Metadata frame_keys = {{"sis:image_width", ""}, {"sis:image_height", ""}};
  const Metadata common = coefficient_metadata(top, frame_keys);
  std::vector<Image> grids;
  for (std::size_t j = 0; j < levels.size(); ++j) {
    const Coefficients& k = *levels[j];
    // one header for every level: each level's keys are level 0's but its frame
    if (coefficient_metadata(k, frame_keys) != common || k.channel_names != top.channel_names)
      throw OutputError(path + ": level " + std::to_string(j) + "'s coefficients are not of level "
                        "0's space; one MIP-mapped file holds one space's levels");
    grids.push_back(coefficient_grid(k));
  }
  Metadata md = coefficient_metadata(top, {});
  md.push_back({"sis:mip_levels", std::to_string(levels.size())});
  md.push_back({"sis:mip_sizes", sizes});
  return stage_mip_image(path, grids, top.channel_names, md, top.alpha, SampleFormat::Float);
}

int coefficient_levels(const ImageReader& r) {
  return r.attribute("sis:mip_sizes").empty() ? 1 : r.levels();
}

namespace {
// The largest frame side a coefficient file may record (OpenImageIO's
// images have int sides).
constexpr double kMaxFrame = 2147483647.0;
}  // namespace

bool is_coefficient_file(const ImageReader& r) { return r.attribute("sis:coefficients") == "1"; }

Coefficients read_coefficients(ImageReader& r) {
  if (!is_coefficient_file(r)) throw InputError(r.path() + ": not a coefficient file");
  auto numbers = [&](const std::string& key, std::size_t count) {
    std::istringstream s(r.attribute(key));
    std::vector<double> v;
    double x;
    while (s >> x) v.push_back(x);
    if (v.size() != count) throw InputError(r.path() + ": coefficient file metadata " + key + " is malformed");
    return v;
  };
  Coefficients k;
  try {
    const auto o = numbers("sis:lattice_origin", 2);
    const auto L = numbers("sis:lattice_matrix", 4);
    k.lattice = Lattice({o[0], o[1]}, {L[0], L[1], L[2], L[3]});
    // the space's own metadata, read by the space its sis:lattice names
    const std::string lattice = r.attribute("sis:lattice");
    const Attributes attribute = [&](const std::string& key) { return r.attribute(key); };
    if (!visit_lattice_name(lattice, [&](auto space) { space.read_metadata(attribute, k); }))
      throw std::invalid_argument("sis:lattice '" + lattice + "': expected cartesian or hexagonal");
    k.boundary = parse_boundary(r.attribute("sis:boundary"));
    const std::string method = r.attribute("sis:method");
    if (method != "min-error" && method != "conventional")
      throw std::invalid_argument("sis:method '" + method + "': expected min-error or conventional");
    k.min_error = method == "min-error";
    for (const char* flag : {"sis:highlight_compress"}) {
      const std::string v = r.attribute(flag);
      if (!v.empty() && v != "0" && v != "1")
        throw std::invalid_argument(std::string(flag) + " '" + v + "': expected 0 or 1");
    }
    k.highlight_compressed = r.attribute("sis:highlight_compress") == "1";
    const std::string input_format = r.attribute("sis:input_format");
    if (!input_format.empty() && input_format != "half" && input_format != "float")
      throw std::invalid_argument("sis:input_format '" + input_format + "': expected half or float");
    k.input.half = input_format == "half";
    k.input.label = r.attribute("sis:input");
    const std::string transfer = r.attribute("sis:input_transfer");
    try {
      k.input.transfer = transfer.empty() ? Transfer::linear() : parse_transfer(transfer);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("sis:input_transfer ") + e.what());
    }
    k.image_width = numbers("sis:image_width", 1)[0];
    k.image_height = numbers("sis:image_height", 1)[0];
    if (const std::string sizes = r.attribute("sis:mip_sizes"); !sizes.empty()) {
      // a pyramid's file: the selected level's frame
      std::istringstream s(sizes);
      std::vector<std::pair<double, double>> frames;
      for (std::string wh; s >> wh;) {
        const auto x = wh.find('x');
        double w = 0, h = 0;
        if (x == std::string::npos) throw std::invalid_argument("sis:mip_sizes '" + sizes + "' is malformed");
        std::istringstream(wh.substr(0, x)) >> w;
        std::istringstream(wh.substr(x + 1)) >> h;
        frames.push_back({w, h});
      }
      if (long(frames.size()) != r.levels() || r.attribute("sis:mip_levels") != std::to_string(r.levels()))
        throw std::invalid_argument("sis:mip_sizes and sis:mip_levels name " +
                                    std::to_string(frames.size()) + " levels; the file has " +
                                    std::to_string(r.levels()));
      std::tie(k.image_width, k.image_height) = frames[std::size_t(r.level())];
    }
    if (!(k.image_width >= 1 && k.image_height >= 1 && k.image_width <= kMaxFrame &&
          k.image_height <= kMaxFrame))
      throw std::invalid_argument("sis:image_width and sis:image_height must lie in [1, " +
                                  std::to_string(long(kMaxFrame)) + "]");
    const double det = k.lattice.determinant();
    if (!std::isfinite(o[0]) || !std::isfinite(o[1]) || !std::isfinite(det) || !(det != 0))
      throw std::invalid_argument("sis:lattice_origin and sis:lattice_matrix must be finite, the "
                                  "matrix invertible");
    // the lattice covers the frame: its origin lies within a frame of it
    if (std::abs(o[0]) > 2 * k.image_width + 1 || std::abs(o[1]) > 2 * k.image_height + 1)
      throw std::invalid_argument("sis:lattice_origin places the lattice away from the frame");
  } catch (const std::invalid_argument& e) {
    throw InputError(r.path() + ": coefficient file metadata: " + e.what());
  }
  Image grid(r.width(), r.height(), r.channels());
  for (long y = 0; y < r.height(); y += r.preferred_strip())
    r.read_rows(y, std::min(r.height(), y + r.preferred_strip()), grid.row(y));
  k.c = Grid<double>(grid.width, grid.height, grid.channels);
  k.channel_names = r.channel_names();
  k.alpha = r.alpha_channel();
  if (const std::string a = r.attribute("sis:alpha"); !a.empty()) {
    long channel = -1;
    const auto [end, ec] = std::from_chars(a.data(), a.data() + a.size(), channel);
    if (ec != std::errc() || end != a.data() + a.size() || channel < 0 ||
        channel >= k.c.channels)
      throw InputError(r.path() + ": coefficient file metadata: sis:alpha '" + a +
                       "': expected a channel index in [0, " + std::to_string(k.c.channels - 1) +
                       "]");
    k.alpha = int(channel);
  }
  for (std::size_t q = 0; q < grid.data.size(); ++q) k.c.data[q] = grid.data[q];
  try {
    visit_space(k, [&](auto space) { space.check_grid(k); });
  } catch (const std::invalid_argument& e) {
    throw InputError(r.path() + ": " + e.what());
  }
  return k;
}

}  // namespace sis
