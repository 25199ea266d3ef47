#pragma once
// Analog acquisition: inner products of the image with each shifted
// generator, r[n] = <f, phi(. - x_n)>, from point samples of a supersampled
// image, or (conventional methods) the normalised weighted average
// p[n] = sum_i w_i f_i / sum_i w_i with w_i = FILTER(x_i - x_n).
//
// Input sample (i, j) of a W_in x H_in image covering image_width x
// image_height output pixels sits at ((i + 1/2) dx, (j + 1/2) dy) with
// dx = image_width / W_in: any real ratio per axis. The quadrature is the
// plain sum, r[n] = dx dy sum_i f_i phi(x_i - x_n), over every sample of the
// boundary-extended image in the support. Rows stream through: each row is
// read once and added to every coefficient whose support holds it.
#include <functional>
#include <vector>

#include "sis/image.h"
#include "sis/weights.h"

namespace sis {

enum class Method { MinError, Conventional };

// Everything that depends only on sizes and options.
class AcquisitionPlan {
 public:
  AcquisitionPlan(long input_width, long input_height, int channels, double image_width,
                  double image_height, const Lattice& lattice, const Kernel& generator,
                  Boundary boundary, Method method);

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

 private:
  int channels_;
  double image_w_, image_h_;
  Lattice lattice_;
  Kernel generator_;
  Boundary boundary_;
  Method method_;
  AxisWeights wx_, wy_;  // targets: coefficient columns / rows; sources: input columns / rows
};

// Streams rows through a plan. Rows must arrive in order, each once.
// The result does not depend on the strip sizes or the thread count.
//
// Order of the sums (every path keeps it, so float rows, double rows and
// rows from a function give the same bits): each coefficient row's
// vertical sum s_m = sum_j wy[m][j] f_j over its input rows j in increasing
// j (elementwise over the row, split among the threads by columns), then
// each coefficient r[n][m] = sum_i wx[n][i] s_m[i] as four interleaved
// partial sums combined as (p0 + p1) + (p2 + p3). The vertical pass is
// elementwise, so it runs on whole vectors whatever the channel count; a
// coefficient row is filtered horizontally once complete, in the next call.
class Acquisition {
 public:
  explicit Acquisition(const AcquisitionPlan& plan, int threads = 1);
  // Rows [y0, y1) of the input, interleaved, W_in * channels per row.
  void add_rows(long y0, long y1, const float* rows);
  void add_rows(long y0, long y1, const double* rows);
  // Rows [y0, y1) from a function, in pieces: piece(y, k0, k1, scratch)
  // returns values [k0, k1) of input row y (W_in * channels values per
  // row), written into scratch (room for k1 - k0 floats) or held elsewhere.
  // The pieces of a row are disjoint and cover it; each is asked for once,
  // on the worker threads, pieces of different columns at once (the same
  // columns in increasing row order), so that per-row work (decoding,
  // checks) runs in parallel with the sums. A source may prefetch the same
  // columns of a later row (prefetch.h): the next calls will ask for them.
  using PieceSource = std::function<const float*(long y, long k0, long k1, float* scratch)>;
  void add_rows(long y0, long y1, const PieceSource& piece);
  long next_row() const { return next_row_; }
  // The acquired coefficients r[n] (min-error) or pixels p[n] (conventional).
  Coefficients finish();

 private:
  const AcquisitionPlan& plan_;
  int threads_;
  long next_row_ = 0;
  Grid<double> acc_;
  std::vector<long> cursor_;               // per coefficient row: next entry of weights_y
  std::vector<std::vector<double>> sums_;  // per coefficient row: its vertical sum while open
  std::vector<std::vector<double>> spare_; // released sums, reused
  std::vector<long> complete_;             // rows summed, not yet filtered horizontally
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

// Convenience: acquires a whole in-memory image.
Coefficients acquire(const Image& input, const AcquisitionPlan& plan, int threads = 1);
Coefficients acquire(const Grid<double>& input, const AcquisitionPlan& plan, int threads = 1);

}  // namespace sis
