#pragma once
// Analog acquisition: inner products of the image with each shifted
// generator, r[n] = <f, phi(. - x_n)>, from point samples of a supersampled
// image, or (conventional methods) the normalised weighted average
// p[n] = sum_i w_i f_i / sum_i w_i with w_i = FILTER(x_i - x_n).
//
// Input sample (i, j) of a W_in x H_in image covering image_width x
// image_height output pixels sits at ((i + 1/2) dx, (j + 1/2) dy) with
// dx = image_width / W_in: any real ratio per axis. Per axis, the weights
// (docs/design.md section 10): where the lattice step holds a whole number
// of samples, the plain sum, r[n] = dx dy sum_i f_i phi(x_i - x_n), over
// every sample of the boundary-extended image in the support; where it
// holds more samples but not a whole number, the exact inner product of
// the samples' 4-point cubic Lagrange interpolant with phi; where it holds
// fewer (upsampling), that of their cubic spline interpolant. Rows stream
// through: each row is read once and added to every coefficient whose
// support holds it.
#include <functional>
#include <memory>
#include <vector>

#include "sis/bands.h"
#include "sis/image.h"
#include "sis/weights.h"

namespace sis {

enum class Method { MinError, Conventional };

// Everything that depends only on sizes and options.
class AcquisitionPlan {
 public:
  // band_rows: the input rows per band, which fix the order of the sums
  // (Acquisition); < 1: kBandRows.
  AcquisitionPlan(long input_width, long input_height, int channels, double image_width,
                  double image_height, const Lattice& lattice, const Kernel& generator,
                  Boundary boundary, Method method, long band_rows = 0);

  long input_width() const { return wx_.sources; }
  long input_height() const { return wy_.sources; }
  int channels() const { return channels_; }
  long coefficients_x() const { return wx_.targets; }
  long coefficients_y() const { return wy_.targets; }
  const AxisWeights& weights_x() const { return wx_; }
  const AxisWeights& weights_y() const { return wy_; }
  const Lattice& lattice() const { return lattice_; }
  const Kernel& generator() const { return generator_; }
  Boundary boundary() const { return boundary_; }
  Method method() const { return method_; }
  double image_width() const { return image_w_; }
  double image_height() const { return image_h_; }
  const BandPartition& bands() const { return bands_; }

 private:
  int channels_;
  double image_w_, image_h_;
  Lattice lattice_;
  Kernel generator_;
  Boundary boundary_;
  Method method_;
  AxisWeights wx_, wy_;  // targets: coefficient columns / rows; sources: input columns / rows
  BandPartition bands_;  // of the input rows
};

// Streams rows through a plan: the whole image in order (add_rows), or
// band by band on several threads at once (Band). The result does not
// depend on the strip sizes, the thread count or the path.
//
// Order of the sums (every path keeps it, so float rows, double rows and
// rows from a function give the same bits): the input rows fall into the
// plan's bands. Within band b, each coefficient row's vertical sum s_m =
// sum_j wy[m][j] f_j over its input rows j of the band in increasing j
// (elementwise over the row, split among the threads by columns), then its
// horizontal pass r_b[n][m] = sum_i wx[n][i] s_m[i] as four interleaved
// partial sums combined as (p0 + p1) + (p2 + p3). A coefficient row whose
// input rows lie in one band is that band's r_b; one whose input rows lie in
// several is the sum of their r_b in band order. The vertical pass is
// elementwise, so it runs on whole vectors whatever the channel count; a
// coefficient row is filtered horizontally once complete, in the next call.
class Acquisition {
 public:
  explicit Acquisition(const AcquisitionPlan& plan, int threads = 1);
  ~Acquisition();
  Acquisition(const Acquisition&) = delete;
  Acquisition& operator=(const Acquisition&) = delete;
  // Rows [y0, y1) of the input, interleaved, W_in * channels per row. Rows
  // must arrive in order, each once (and not with Band).
  void add_rows(long y0, long y1, const float* rows);
  void add_rows(long y0, long y1, const double* rows);
  // Rows [y0, y1) from a function, in pieces: piece(y, k0, k1, scratch)
  // returns values [k0, k1) of input row y (W_in * channels values per
  // row), written into scratch (room for k1 - k0 floats) or held elsewhere.
  // The pieces of a row are disjoint and cover it; each is asked for once,
  // on the worker threads, pieces of different columns at once (the same
  // columns in increasing row order), so that per-row work (decoding,
  // checks) runs in parallel with the sums.
  using PieceSource = std::function<const float*(long y, long k0, long k1, float* scratch)>;
  void add_rows(long y0, long y1, const PieceSource& piece);
  long next_row() const { return next_row_; }

  // Takes bands: begin(b), the band's rows in order (add_rows as above,
  // rows of band b only), end(). Several Bands of one Acquisition may run
  // at once on different threads, each band taken once, in any order.
  class Band {
   public:
    // Its sums split among `threads` by columns.
    explicit Band(Acquisition& whole, int threads = 1);
    ~Band();
    Band(const Band&) = delete;
    Band& operator=(const Band&) = delete;
    void begin(long band);
    void add_rows(long y0, long y1, const float* rows);
    void add_rows(long y0, long y1, const PieceSource& piece);
    long next_row() const { return next_row_; }
    void end();

   private:
    friend class Acquisition;
    Acquisition& whole_;
    int threads_;
    long band_ = -1, y0_ = 0, y1_ = 0, next_row_ = 0;
    // Per coefficient row: next entry of weights_y, its band's first and
    // end entries, where its result goes; the rows with entries in the band.
    std::vector<long> cursor_, first_, end_;
    std::vector<double*> dest_;
    std::vector<long> active_;
    std::vector<std::vector<double>> sums_;   // per coefficient row: its vertical sum while open
    std::vector<std::vector<double>> spare_;  // released sums, reused
    std::vector<long> complete_;              // rows summed, not yet filtered horizontally
    // Per row of the strip being added: the sums it adds to (those it starts,
    // start_sums, last), their weights, and the rows summed with it from here
    // (group).
    struct RowTargets {
      std::vector<double*> sums, start_sums;
      std::vector<double> weights, start_weights;
      int group = 1;
    };
    std::vector<RowTargets> rows_;  // kept between strips, as their capacity
    std::vector<double> scratch_;   // the pieces of each part's rows
    template <typename T, typename Piece>
    void add(long y0, long y1, const Piece& piece);
    void filter_complete(long part, long parts);
    void release_complete();
    double* sums_of(long m);
  };

  // The acquired coefficients r[n] (min-error) or pixels p[n] (conventional),
  // once every row is added (or every band ended, or absorbed).
  Coefficients finish();

  // The sums of the bands ended so far (sis/bands.h), none in progress;
  // *taken: those bands, ascending.
  BandPartial<double> partial(std::vector<long>* taken) const;
  // Takes in the partial of bands `taken` from an Acquisition of the same
  // plan, as if those bands had ended here. Throws std::invalid_argument
  // when a band is out of range or already here, or the partial is not of
  // those bands.
  void absorb(const BandPartial<double>& p, const std::vector<long>& taken);

 private:
  void merge_slot(long n, const double* slot);
  template <typename T, typename Piece>
  void add_in_order(long y0, long y1, const Piece& piece);
  const AcquisitionPlan& plan_;
  int threads_;
  long next_row_ = 0;
  Grid<double> acc_;
  BandSlots<double> slots_;     // of the coefficient rows several bands add to
  std::vector<char> ended_;     // per band
  std::unique_ptr<Band> in_order_;  // add_rows' bands
};

// Convenience: acquires a whole in-memory image.
Coefficients acquire(const Image& input, const AcquisitionPlan& plan, int threads = 1);
Coefficients acquire(const Grid<double>& input, const AcquisitionPlan& plan, int threads = 1);

}  // namespace sis
