#pragma once
// Projection from scattered samples (docs/design.md section 11): samples at
// any places in the frame, each weighing the area it stands for, projected
// onto a shift-invariant space of either lattice (sis/space.h): the Cartesian
// space or the hexagonal box-spline space. Two min-error rules, both exact for
// a flat image at any positions and tending to the orthogonal projection as
// the samples densify:
//   NormalisedSum: r[n] = sum_i w_i f_i phi_i,n / sum_i w_i phi_i,n * int phi,
//                  one streaming pass, then the digital prefilter c = r * a^{-1};
//   LeastSquares:  the weighted least-squares fit of the space to the samples,
//                  G c = b, G[n, m] = sum_i w_i phi_i,n phi_i,m,
//                  b[n] = sum_i w_i f_i phi_i,n, by conjugate gradients
//                  preconditioned with a^{-1} from the NormalisedSum's
//                  coefficients; it reproduces every spline of the space.
//   Variational:   the smoothing spline, min sum_i w_i (f_i - f_app(x_i))^2
//                  + lambda J(f_app), J the smoothness functional
//                  (sis/smoothness.h): (G + lambda R) c = b by conjugate
//                  gradients preconditioned with the DCT/DFT diagonal of
//                  hx hy a + lambda R, lambda given or by generalised
//                  cross-validation (docs/design.md section 15). On the
//                  hexagonal lattice: the fit's periodic grid and images,
//                  R the box spline's stencil (HexSmoothnessOperator),
//                  preconditioned with the twisted DFT's diagonal of
//                  |det L| a + lambda R; order 2 refuses hex-hat.
// PlainSum (r[n] = sum_i w_i f_i phi_i,n, then the prefilter) is the unbiased
// but inexact estimate, kept for comparison. The conventional methods take
// the normalised weighted average p[n] = sum_i w_i f_i K_i,n / sum_i w_i K_i,n.
// phi_i,n = phi((x_i - x_n) / h): only the frame's edges fold, by the
// boundary rule, as the grid acquisition folds them (the samples' mirror or
// periodic images). On the hexagonal lattice, as its grid acquisition
// (sis/hex_acquisition.h): every stored coefficient, margin included, sums
// every image of the samples in its support, and the fit's model is the
// coefficients periodic on their offset-row grid (sis/hex_lattice.h), fitted
// to the images in one period of it (docs/design.md section 11).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sis/coefficients.h"
#include "sis/acquisition.h"
#include "sis/space.h"
#include "sis/image.h"
#include "sis/prefilter.h"

namespace sis {

// One sample: its place in frame coordinates (output pixels; pixel (i, j)
// covers [i, i+1) x [j, j+1)), the area it stands for (output pixels^2) and
// its time (carried, unused for now). Its values are held beside it.
struct Sample {
  Vec2 position;
  double weight = 0;
  double time = 0;
};

// N samples of C channels as arrays (what a caller's (N, 2) and (N, C)
// arrays are): positions x0, y0, x1, y1, ...; values interleaved, channel
// fastest; weights one per sample, or empty for the frame's area / N each;
// times one per sample or empty.
struct ScatteredSamples {
  std::vector<double> positions, values, weights, times;
  int channels = 1;
  long count() const { return long(positions.size() / 2); }
  Sample sample(long i) const;
};

enum class ScatteredRule { NormalisedSum, LeastSquares, PlainSum, Variational };
const char* scattered_rule_name(ScatteredRule rule);  // "normalised" | "fit" | "plain" | "variational"
ScatteredRule parse_scattered_rule(const std::string& spelling);

// The target space: a frame of width x height output pixels and a space
// with its generator, a boundary rule and a method. CartesianSpace: the
// separable `lattice` tiles the frame (coefficient n at (n + 1/2) h);
// min-error needs a B-spline generator. HexagonalSpace: the offset-row grid
// hex_layout(density, width, height, margin) gives (`lattice` unused;
// margin -1: hex_default_margin(order)), the coefficients laid out as the
// grid acquisition lays them; min-error only.
struct ScatteredTarget {
  double width = 0, height = 0;
  Space space = CartesianSpace{Kernel::bspline(3)};
  Lattice lattice = Lattice::cartesian();
  int margin = -1;
  Boundary boundary = Boundary::Mirror;
  Method method = Method::MinError;
  PrefilterMethod prefilter = PrefilterMethod::FFT;
};

struct ScatteredOptions {
  // The fit by default: on the zone plate at 4 rays per pixel it came within
  // 7 % of the regular grid's L2 error, the normalised sum 3.2 times it
  // (docs/design.md section 11).
  ScatteredRule rule = ScatteredRule::LeastSquares;
  // LeastSquares: at most this many preconditioned CG iterations, fewer
  // when the residual's norm falls to tolerance times b's (per channel).
  int iterations = 5;
  double tolerance = 0;
  // Threads of the passes and the prefilter; the result is the same bits
  // for any count.
  int threads = 1;
  // Variational: lambda (frame units: output pixels) >= 0, or empty for
  // generalised cross-validation over lambda = t h^(2 order), t = 10^-6,
  // 10^-5.5, ..., 10^1 (h the larger lattice step), tried from the largest
  // down (warm-started) until the score has risen twice past its lowest, the
  // trace of the hat matrix estimated with gcv_probes Rademacher probes; the functional's
  // order (1 or 2); at most variational_iterations CG iterations, fewer when
  // the residual falls to variational_tolerance times b's.
  std::optional<double> lambda;
  int smoothness = 2;
  int gcv_probes = 4;
  int variational_iterations = 200;
  double variational_tolerance = 1e-9;
};

struct ScatteredReport {
  int iterations = 0;            // CG iterations run (LeastSquares)
  std::vector<double> residual;  // per channel: ||b - G c|| / ||b|| at the end (LeastSquares)
  std::size_t bytes = 0;         // the rule's working grids
  long passes = 0;               // passes over the samples
  double lambda = 0;             // Variational: the lambda used (given or chosen)
  std::vector<std::pair<double, double>> gcv;  // Variational by GCV: (lambda, score) tried
};

// Streams samples into the sums of one pass: numerator sum_i w_i f_i phi_i,n
// per channel and denominator sum_i w_i phi_i,n, each coefficient's terms
// added in the order the samples arrive (the same bits for the same order,
// at any thread count: the threads split the coefficient rows, not the
// samples). Memory: the sums, channels + 1 values a coefficient, whatever
// the number of samples.
class ScatteredAcquisition {
 public:
  ScatteredAcquisition(const ScatteredTarget& target, int channels, int threads = 1);
  // Samples [0, count) of `samples`; throws std::invalid_argument (naming the
  // sample) for counts that do not match, a position outside the frame or
  // non-finite, a weight not finite and > 0, a non-finite value. Counts
  // that do not match leave the sums as they were; after a bad sample (the
  // samples are checked block by block as they are added, so part of the
  // call may be in the sums) add() and finish() refuse (std::logic_error).
  void add(const ScatteredSamples& samples);
  // The coefficients of the rule (NormalisedSum or PlainSum; the
  // conventional methods' average for Method::Conventional), prefiltered
  // where min-error. Throws when a coefficient's weight sum is not > 0
  // (no sample in its support) for the normalised rules.
  Coefficients finish(ScatteredRule rule) const;
  Grid<double> numerator() const;    // channels values a coefficient
  Grid<double> denominator() const;  // one
  std::size_t bytes() const;

 private:
  ScatteredTarget target_;
  int channels_;
  int threads_;
  bool failed_ = false;
  Grid<double> sums_;  // per coefficient: the numerator's channels, then the denominator
};

// The whole projection of the samples (the rule per options; Conventional
// takes the normalised average and refuses another rule).
Coefficients project_scattered(const ScatteredSamples& samples, const ScatteredTarget& target,
                               const ScatteredOptions& options = {},
                               ScatteredReport* report = nullptr);

// The coefficient grid's columns and rows for the target (the frame's
// lattice extent; on the hexagonal lattice the offset-row grid with its
// margin); std::invalid_argument for a target that cannot be projected.
std::pair<long, long> scattered_grid(const ScatteredTarget& target);
// The bytes the rule's working grids and values at the samples take (the
// fit's for the one-pass rules, which take less; the variational rule's with
// its GCV probes as extra channels), from the samples' count and, on the
// hexagonal lattice, their images (positions not checked: a bad one has none).
std::uint64_t scattered_bytes(const ScatteredTarget& target, const ScatteredSamples& samples,
                              const ScatteredOptions& options = {});

// f_app of the coefficients' space at every sample (channel fastest): what
// the fit's residual is measured with. Hexagonal coefficients are periodic
// on their grid (hex_evaluate's rule).
std::vector<double> evaluate_at_samples(const Coefficients& k, const ScatteredSamples& samples,
                                        int threads = 1);

}  // namespace sis
