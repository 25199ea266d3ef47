#pragma once
// In-memory images and coefficient grids. Pixels are interleaved
// (channel fastest), rows top to bottom, as in the image file.
#include <cstddef>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

#include "sis/boundary.h"
#include "sis/generator.h"
#include "sis/lattice.h"

namespace sis {

// std::allocator, except that a value-initialised element (vector(n),
// resize(n)) is default-initialised: numbers are left unset. Grid's own
// constructor still zeroes; Grid(w, h, c, kUnset) does not, for a grid whose
// every element its first pass writes, so that no serial pass zeroes it
// first and its pages are first touched by the threads that write them.
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  // Only value-initialisation is taken over; construction from arguments
  // falls back to std::allocator_traits' placement new.
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
};

template <typename T>
using Buffer = std::vector<T, DefaultInitAllocator<T>>;

struct Unset {};
inline constexpr Unset kUnset{};

template <typename T>
struct Grid {
  long width = 0, height = 0;
  int channels = 0;
  Buffer<T> data;

  Grid() = default;
  // All elements zero.
  Grid(long w, long h, int c) : width(w), height(h), channels(c), data(std::size_t(w) * h * c, T()) {}
  // Elements unset: the caller writes every one before any is read.
  Grid(long w, long h, int c, Unset) : width(w), height(h), channels(c), data(std::size_t(w) * h * c) {}
  T* row(long y) { return data.data() + std::size_t(y) * width * channels; }
  const T* row(long y) const { return data.data() + std::size_t(y) * width * channels; }
  T& at(long x, long y, int c) { return data[(std::size_t(y) * width + x) * channels + c]; }
  T at(long x, long y, int c) const { return data[(std::size_t(y) * width + x) * channels + c]; }
  std::size_t row_size() const { return std::size_t(width) * channels; }
};

using Image = Grid<float>;

// A float image held elsewhere (an Image, a caller's array), read where it
// is: interleaved rows as Image's. What the measures take.
struct ImageView {
  const float* data = nullptr;
  long width = 0, height = 0;
  int channels = 0;

  ImageView() = default;
  ImageView(const Image& im)  // NOLINT: every Image is such a view
      : data(im.data.data()), width(im.width), height(im.height), channels(im.channels) {}
  ImageView(const float* d, long w, long h, int c) : data(d), width(w), height(h), channels(c) {}
  const float* row(long y) const { return data + std::size_t(y) * width * channels; }
  float at(long x, long y, int c) const { return data[(std::size_t(y) * width + x) * channels + c]; }
};

// The sample types of samples held in memory: float, half (IEEE binary16
// bits), and unsigned integers, which mean what they mean in image files
// (scaled to [0, 1]: v / 255, v / 65535, as OpenImageIO converts them).
enum class SampleType { Float, Half, UInt8, UInt16 };

// Samples held elsewhere (an Image, a caller's array): interleaved rows,
// of one SampleType, read where they are. The owner keeps them alive and
// unchanged while they are read.
struct SampleView {
  const void* data = nullptr;
  long width = 0, height = 0;
  int channels = 0;
  SampleType type = SampleType::Float;

  SampleView() = default;
  SampleView(const Image& im)  // NOLINT: every Image is such a view
      : data(im.data.data()), width(im.width), height(im.height), channels(im.channels) {}
  SampleView(const void* d, long w, long h, int c, bool is_half)
      : data(d), width(w), height(h), channels(c), type(is_half ? SampleType::Half : SampleType::Float) {}
  SampleView(const void* d, long w, long h, int c, SampleType t)
      : data(d), width(w), height(h), channels(c), type(t) {}
  explicit operator bool() const { return data != nullptr; }
  bool is_half() const { return type == SampleType::Half; }
  bool is_integer() const { return type == SampleType::UInt8 || type == SampleType::UInt16; }
  std::size_t row_size() const { return std::size_t(width) * channels; }
  std::size_t value_bytes() const {
    return type == SampleType::UInt8 ? 1 : type == SampleType::Float ? 4 : 2;
  }
  const unsigned char* row(long y) const {
    return static_cast<const unsigned char*>(data) + std::size_t(y) * row_size() * value_bytes();
  }
};

// Coefficients of an approximation live in sis/coefficients.h.
struct Coefficients;

}  // namespace sis
