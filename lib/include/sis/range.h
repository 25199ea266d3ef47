#pragma once
// Range control, opt-in remedies for what the orthogonal projection does to
// the range of an image (docs/design.md section 6), each reported, never hidden:
// - highlight compression: OpenImageIO's odd-symmetric log curve (identity
//   below 0.18) applied to the samples before projecting, inverted after;
// - clamps of the displayed samples: at zero, or to the min/max of the input
//   samples under each output pixel (the local input range).
#include <memory>
#include <string>
#include <vector>

#include "sis/bands.h"
#include "sis/image.h"
#include "sis/resample.h"

namespace sis {

// OpenImageIO's rangecompress / rangeexpand (SPI curve), in double.
double highlight_compress(double x);
double highlight_expand(double y);

enum class Clamp { None, Zero, Local };
Clamp parse_clamp(const std::string& spelling);  // none | zero | local
std::string clamp_name(Clamp c);

// Min and max of the input samples whose positions fall in each output pixel
// (of a W x H image over win x hin samples). Per axis: the samples inside
// the pixel's interval or, when there are none (upsampling), the two either
// side of its centre (the samples the value there is interpolated from). Rows stream in order, or band by band (bands.h) on several
// threads at once: an output row whose input rows lie in several bands is
// the min (max) of the bands' ranges, merged in band order (v < a ? v : a):
// the values one band would give, but for the sign of a zero.
class LocalRange {
 public:
  // band_rows: input rows per band (as the acquisition's; < 1: one band).
  LocalRange(long input_width, long input_height, int channels, long width, long height,
             long band_rows = 0);
  ~LocalRange();
  LocalRange(const LocalRange&) = delete;
  LocalRange& operator=(const LocalRange&) = delete;
  // Rows [y0, y1) in order (not with Band).
  void add_rows(long y0, long y1, const float* rows);
  // add_rows in three steps, for callers that split rows by columns. Each
  // output row's range is taken down its input rows first (elementwise, per
  // input column) and across its pixels' columns once complete. open(y0, y1)
  // before rows [y0, y1) (within one band); then fold(y, k0, k1, values) for
  // values [k0, k1) of each of those rows (W_in * channels values per row;
  // calls for disjoint [k0, k1) may run at once, the rows of the same
  // columns in increasing order); then close(y1).
  void open(long y0, long y1);
  void fold(long y, long k0, long k1, const float* values);
  void close(long y1);

  // Takes bands: begin(b), then open / fold / close as above over the
  // band's rows in order, then end(). Bands of one LocalRange may run at
  // once on different threads, each band taken once, in any order.
  class Band {
   public:
    explicit Band(LocalRange& whole);
    ~Band();
    Band(const Band&) = delete;
    Band& operator=(const Band&) = delete;
    void begin(long band);
    void open(long y0, long y1);
    void fold(long y, long k0, long k1, const float* values);
    void close(long y1);
    void end();

   private:
    friend class LocalRange;
    LocalRange& whole_;
    long band_ = -1, y0_ = 0, y1_ = 0, next_row_ = 0;
    // Output rows being taken: per input column, the min and max down their
    // input rows of the band so far (their first is copied, the others
    // folded in); the output rows each row of the open strip goes to.
    struct Open {
      long row;
      std::vector<float> lo, hi;
    };
    struct Target {
      float *lo, *hi;
      bool first;  // the output row's first input row in the band
    };
    std::vector<Open> open_;
    std::vector<std::vector<float>> spare_;           // released columns, reused
    std::vector<std::vector<Target>> strip_targets_;  // per row of the open strip
    long open_y0_ = 0, next_open_ = 0;
  };

  // The ranges: an output row's pixels are set once its last input row is
  // added (unset before).
  const Image& min() const { return min_; }
  const Image& max() const { return max_; }

  // As Acquisition's (sis/acquisition.h): the ranges of the ended bands
  // (each row's min then max), and the partial of another LocalRange of
  // the same sizes taken in.
  BandPartial<float> partial(std::vector<long>* taken) const;
  void absorb(const BandPartial<float>& p, const std::vector<long>& taken);

 private:
  void merge_slot(long o, const float* slot);
  std::vector<char> ended_;  // per band
  std::vector<long> x_begin_, x_end_, y_begin_, y_end_;  // sample index ranges per pixel
  long win_, hin_, width_, height_;
  int channels_;
  BandPartition bands_;
  Image min_, max_;
  BandSlots<float> slots_;  // of the output rows several bands take: min then max
  std::unique_ptr<Band> in_order_;
};

// What the displayed samples do with the range, before any clamp.
struct RangeReport {
  double min = 0, max = 0;  // of the displayed samples
  long negative = 0;        // samples below zero
  long out_of_range = 0;    // samples outside the local input range (beyond 1e-5 of its scale)
  long samples = 0;
};

// Reports on `image` against the local input range (which may be empty: then
// out_of_range is not counted).
RangeReport report_range(const Image& image, const LocalRange* local, int threads = 1);

// Overshoot and undershoot of the displayed min-error approximation of a
// unit step (0 left, 1 right, edge on a pixel boundary), computed exactly
// from the generator: inner products from the B-spline's cumulative
// integral, the prefilter, the display. {max - 1, -min}.
struct StepResponse {
  double overshoot = 0, undershoot = 0;
};
StepResponse step_response(int degree, const Display& display);

// Applies a clamp in place (`local` is needed for Clamp::Local).
void apply_clamp(Image& image, Clamp clamp, const LocalRange* local);

}  // namespace sis
