#pragma once
// Analog acquisition on the hexagonal lattice: the inner products
// r[n] = <f, phi(. - x_n)> / |det L| for every stored coefficient of a
// HexLayout (margin included), from point samples of a supersampled image.
// Samples as in acquisition.h: input sample (i, j) of a W_in x H_in image
// covering image_width x image_height output pixels sits at
// ((i + 1/2) dx, (j + 1/2) dy), dx = image_width / W_in; the image is
// extended beyond the frame by the boundary rule. The normalisation by
// |det L| makes the Gram the lattice's (a[0] = 1/2 for the hat), as on the
// Cartesian lattice.
//
// Quadrature (docs/design.md section 10): a square sample grid is
// incommensurate with the hexagonal lattice, so the plain sum over the
// samples is not exact for polynomials. The sum is exact for f of degree
// < 2n on a grid aligned with the lattice, spacings h / s1 with s1 even and
// (sqrt(3)/2) h / s2: there M_n's transform vanishes to order 2n on the
// whole dual of the grid but 0. So each input row is interpolated along x
// onto the aligned columns X_m = o.x + m h / s1, then the rows along y onto
// the aligned rows Y_r = o.y + r (sqrt(3)/2) h / s2, both by 4-point cubic
// Lagrange interpolation (exact for cubics), and the plain sum runs over
// the aligned grid:
//   r[n] = sum_g M_n(L^{-1} (g - x_n)) f~(g) / (s1 s2),
// whose weights are one table for every lattice point (the points lie on
// the grid). s1 is the even integer and s2 the integer nearest the input's
// samples per step and per row (at least 2 and 1), so the grid is about as
// dense as the input. Exact for every polynomial of degree < 2n (linear for
// the hat, cubic for the quartic) at every lattice point whose support and
// interpolation taps lie inside the input, whatever the factor and the
// alignment (to rounding: rows interpolated from float samples are kept in
// float, a rounding of 6e-8). Each input row adds terms to the coefficient
// rows in input row order: its vertical interpolation weights are folded
// into the table rows it serves.
//
// Rows stream through: each input row is read once and added to every
// coefficient whose support holds it or one of its boundary images.
#include <array>
#include <atomic>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "sis/bands.h"
#include "sis/hex_lattice.h"

namespace sis {

class HexAcquisitionPlan {
 public:
  HexAcquisitionPlan(long input_width, long input_height, int channels, double image_width,
                     double image_height, const HexLayout& layout, int order, Boundary boundary);

  long input_width() const { return win_; }
  long input_height() const { return hin_; }
  int channels() const { return channels_; }
  const HexLayout& layout() const { return layout_; }
  const BoxSpline& generator() const { return *spline_; }
  Boundary boundary() const { return boundary_; }
  double image_width() const { return image_w_; }
  double image_height() const { return image_h_; }
  double sample_dx() const { return dx_; }
  double sample_dy() const { return dy_; }
  // First extended column and the source column of each extended column.
  long first_column() const { return q0_; }
  const std::vector<long>& column_source() const { return colmap_; }
  // Extended rows (boundary images) of input row k, increasing.
  const std::vector<long>& row_images(long k) const { return images_[k]; }

  // The aligned grid.
  struct AlignedGrid {
    int s1 = 0, s2 = 0;  // aligned columns per step, rows per lattice row
    long m0 = 0;         // first aligned column held: X_m0
    long columns = 0;    // aligned columns held
    // Per held column: the extended input column (minus first_column()) of
    // its first of 4 Lagrange taps, and the taps' weights.
    std::vector<long> x_first;
    std::vector<std::array<double, 4>> x_weight;
    int half = 0;   // table half width in columns, n s1
    int reach = 0;  // table half height in rows: |dr| < reach = n s2
    // weight of aligned offset (t, dr) from a lattice point:
    // table[(dr + reach - 1) * (2 half + 1) + t + half] = M_n / (s1 s2)
    std::vector<double> table;
    std::vector<int> first, last;  // per table row: its first and last nonzero t + half
    // The aligned rows r whose vertical taps include extended row e, with
    // the tap's weight, r increasing.
    void rows_of(long e, double dy, double oy, double row_step,
                 std::vector<std::pair<long, double>>& out) const;
  };
  const AlignedGrid& aligned() const { return aligned_; }

 private:
  long win_, hin_;
  int channels_;
  double image_w_, image_h_, dx_, dy_;
  HexLayout layout_;
  const BoxSpline* spline_;
  Boundary boundary_;
  long q0_ = 0;
  std::vector<long> colmap_;
  std::vector<std::vector<long>> images_;
  AlignedGrid aligned_;
  void init_aligned();
};

// Streams rows through a plan: the whole image in order (add_rows), or band
// by band on several threads at once (Band). The result does not depend on
// the strip sizes, the thread count, the path or the order in which bands
// are taken: the contract of the Cartesian Acquisition (sis/bands.h).
//
// Order of the sums: within a band, each coefficient's terms are added in
// increasing input row k (a row's boundary images in increasing extended
// row), from zero. A coefficient row that several bands reach is written by
// its first band, and each later band writes its part into a slot of its
// own; once the row's last band has ended, the slots are added to the row
// in band order. No band waits on another.
class HexAcquisition {
 public:
  // band_rows: input rows per band (< 1: kBandRows, as the Cartesian lattice).
  explicit HexAcquisition(const HexAcquisitionPlan& plan, int threads = 1, long band_rows = 0);
  ~HexAcquisition();
  // Rows [y0, y1) of the input, interleaved, W_in * channels per row. Rows
  // must arrive in order, each once (and not with Band).
  void add_rows(long y0, long y1, const float* rows);
  void add_rows(long y0, long y1, const double* rows);
  long next_row() const { return next_row_; }
  const BandPartition& bands() const { return bands_; }

  // Takes bands: begin(b), the band's rows in order, end(). Bands of one
  // HexAcquisition may run at once on different threads, each taken once,
  // in any order.
  class Band {
   public:
    explicit Band(HexAcquisition& whole, int threads = 1);
    ~Band();
    Band(const Band&) = delete;
    Band& operator=(const Band&) = delete;
    void begin(long band);
    void add_rows(long y0, long y1, const float* rows);
    void add_rows(long y0, long y1, const double* rows);
    void end();

   private:
    friend class HexAcquisition;
    template <typename T>
    void add(long y0, long y1, const T* rows);
    HexAcquisition& whole_;
    int threads_;
    long band_ = -1, next_row_ = 0;
    std::vector<long> touched_;  // coefficient rows it added to
    std::vector<double*> dest_;  // per coefficient row it touched: the row, or its slot
    // the current piece of rows, interpolated along x, in the rows' own type
    std::vector<float> ext_f_;
    std::vector<double> ext_d_;
    template <typename T>
    std::vector<T>& extended() {
      if constexpr (std::is_same_v<T, float>)
        return ext_f_;
      else
        return ext_d_;
    }
  };

  // The acquired r[n] (sis/hex_lattice.h says how Coefficients records them).
  Coefficients finish();
  // As Acquisition's (sis/acquisition.h): the sums of the ended bands, and
  // the partial of another HexAcquisition of the same plan taken in.
  BandPartial<double> partial(std::vector<long>* taken) const;
  void absorb(const BandPartial<double>& p, const std::vector<long>& taken);

 private:
  const HexAcquisitionPlan& plan_;
  int threads_;
  long next_row_ = 0;
  Grid<double> acc_;
  BandPartition bands_;
  std::vector<std::atomic<char>> ended_;  // per band: 0 untaken, 1 taken, 2 ended
  BandSlots<double> slots_;               // of the coefficient rows several bands reach
  std::unique_ptr<Band> in_order_;
  template <typename T>
  void add_in_order(long y0, long y1, const T* rows);
  // The strip: rows [y0, y1) interpolated onto the aligned columns, kept in
  // the samples' own type.
  template <typename T>
  void interpolate(long y0, long y1, const T* rows, std::vector<T>& out, int threads) const;
  std::size_t strip_row_size() const;  // values per interpolated row
  // The coefficient rows rows [y0, y1) reach, in increasing order.
  std::vector<long> reached(long y0, long y1) const;
  // Adds the terms of the interpolated rows [y0, y1) to coefficient rows js,
  // row j's into dest[j].
  template <typename S>
  void accumulate(const S* ext, long y0, long y1, const std::vector<long>& js,
                  double* const* dest, int threads);
  // Input rows [y0, y1) interpolated and added to the coefficient rows js a
  // few rows at a time (into ext), in increasing row order.
  template <typename T>
  void add_pieces(long y0, long y1, const T* rows, const std::vector<long>& js,
                  double* const* dest, std::vector<T>& ext, int threads);
};

// The bytes a HexAcquisition of these sizes allocates besides its
// coefficients, at most, from the sizes alone (before anything is
// allocated): its plan (the table, (2 n s2 - 1)(2 n s1 + 1) weights, grows
// with the input's samples per lattice cell; the column taps; the rows'
// boundary images), the slots of the coefficient rows several bands reach
// and, per band taken at once, a piece of interpolated rows in samples of
// sample_bytes. band_rows < 1: the default bands.
double hex_acquisition_bytes(long input_width, long input_height, int channels,
                             double image_width, double image_height, const HexLayout& layout,
                             int order, int bands_at_once, long band_rows, int sample_bytes);

// Convenience: acquires a whole in-memory image.
Coefficients acquire(const Image& input, const HexAcquisitionPlan& plan, int threads = 1);
Coefficients acquire(const Grid<double>& input, const HexAcquisitionPlan& plan, int threads = 1);

}  // namespace sis
