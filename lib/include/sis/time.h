#pragma once
// Time: the temporal half of the separable space-time generator
// (docs/design.md section "Space and time"). The generator is the spatial
// generator times a temporal B-spline b_D(t/S - m) of degree D (0..3) on a
// temporal lattice of step S seconds. Sub-frames are point samples in time;
// everything here is linear, so an output frame is a weighted sum of the
// sub-frames' spatial coefficients, with the weights computed here once per
// output frame (plan), independent of the image.
#include <functional>
#include <string>
#include <vector>

namespace sis {

constexpr int kMaxTimeDegree = 3;

enum class ShutterCurve { Box, Tent, Cubic, Table };

// How the sub-frames, point samples in time, stand for f between their
// times in the temporal acquisition: Hold (each sub-frame constant over its
// own cell, what the plain average assumes), Linear (the piecewise-linear
// interpolant of the sub-frames) or Cubic (on each gap between sub-frames the
// cubic through the four nearest sub-frames, Lagrange's; uneven times
// allowed; three sub-frames give the quadratic, two the line). The first and
// last cells are covered by the nearest gap's polynomial. Hold reproduces
// constants, Linear polynomials of degree 1, Cubic of degree 3.
enum class TimeModel { Hold, Linear, Cubic };
const char* time_model_name(TimeModel model);  // "hold" | "linear" | "cubic"
// Throws std::invalid_argument naming --time-model on another spelling.
TimeModel parse_time_model(const std::string& spelling);

// A shutter: open on [T + phase/360/fps, T + (phase+angle)/360/fps) for the
// output frame at time T, with a weight curve over the open interval.
struct Shutter {
  double angle = 180;  // degrees, in (0, 360]
  double phase = 0;    // degrees
  ShutterCurve curve = ShutterCurve::Box;
  // Table: u in [0, 1] across the open shutter (increasing) and weight >= 0,
  // interpolated linearly, zero outside [u_first, u_last].
  std::vector<double> table_u, table_weight;

  // Throws when the angle is outside (0, 360] or the table is malformed.
  void check() const;
  // Open interval [open, close) of the frame at time T.
  double open(double T, double fps) const;
  double close(double T, double fps) const;
  // Weight at time t of the frame at time T (zero outside the interval).
  double weight(double t, double T, double fps) const;
  // Breakpoints of the weight (its pieces are polynomials of degree <= 3).
  std::vector<double> breakpoints(double T, double fps) const;
};

// "box" | "tent" | "cubic"; anything else is read as a table file of two
// columns (u, weight); throws naming the file on a bad or missing table.
Shutter parse_shutter(const std::string& angle_phase, const std::string& curve);

// Quadrature weights of the sub-frame times t (increasing, at least two): each
// sub-frame's own cell, between the midpoints to its neighbours; the first and
// last cells extend by half the neighbouring gap. Sum = the span b - a.
std::vector<double> time_quadrature_weights(const std::vector<double>& t);
// The span [a, b] covered by the cells.
void time_span(const std::vector<double>& t, double& a, double& b);

// Throws when the times are too few, non-finite, not increasing or duplicated.
void check_times(const std::vector<double>& t);

// The temporal projection of K sub-frames at times t onto the degree-D
// B-splines of step S: coefficients m = first .. first+count-1 (every
// B-spline whose support meets the span [a, b]). Acquisition
//   c~[m] = (1/S) integral g(t) b_D((t - origin)/S - m) dt,
// g the model of the sub-frames (TimeModel). Hold: each sub-frame over its
// own cell (time_quadrature_weights; a constant in time is exact for uneven
// times), exactly from the cumulative B-spline, the cells mirrored about a
// and b (exact while the span is longer than a B-spline support); the
// prefilter the folded Gram system sum_n a[m-n] c[n] = c~[m] (a =
// autocorrelation of b_D, indices outside the range folded back by the
// mirror rule c[first-1-j] = c[first+j]). Linear and cubic: each polynomial
// piece of g times b_D integrated exactly (Gauss-Legendre, 4 points) over
// [a, b] alone, on a lattice with knots at both ends of the span, and the
// Gram matrix of the B-splines on [a, b] (no mirror, no extrapolation).
// Either system is solved exactly by banded Cholesky (symmetric positive
// definite). Memory: A sparse (each coefficient holds the sub-frames under
// its support) and G banded, so linear in the number of sub-frames.
class TimeProjection {
 public:
  TimeProjection(std::vector<double> times, int degree, double step, TimeModel model);
  const std::vector<double>& times() const { return t_; }
  int degree() const { return degree_; }
  // The lattice: coefficient m's B-spline is b_D((t - origin) / step - m).
  // Hold: origin 0 and the step asked. Linear, cubic: knots at both ends of
  // the span, the step asked rounded to a whole number of steps across it.
  double step() const { return step_; }
  double origin() const { return origin_; }
  TimeModel model() const { return model_; }
  int first() const { return first_; }
  int count() const { return count_; }
  // Coefficients of scalar samples f(t_k): G^-1 A f.
  std::vector<double> coefficients(const std::vector<double>& f) const;
  // The sub-frames' weights of a linear functional of the coefficients,
  // sum_m w[m - first] c[m] = sum_k u[k] f(t_k): u = A^T G^-1 w (G symmetric).
  std::vector<double> subframe_weights(std::vector<double> w) const;

 private:
  // A, the acquisition, sparse: row i holds the sub-frames k0 .. k0 + v.size() - 1
  // under coefficient first + i's support (and its mirror images at the ends)
  struct Row {
    int k0 = 0;
    std::vector<double> v;
  };
  void add(int i, int k, double v);
  void acquire_hold(double a, double b);
  void acquire_interpolated(double lo, double hi);
  void factor(const std::function<double(int, int)>& gram);
  void solve(std::vector<double>& x) const;  // x <- G^-1 x

  std::vector<double> t_;
  int degree_;
  double step_;
  double origin_ = 0;
  TimeModel model_;
  int first_ = 0, count_ = 0;
  std::vector<Row> rows_;
  // G's banded Cholesky factor: row i's entries j = i - bw .. i
  int bw_ = 0;
  std::vector<double> L_;
};

// Temporal display weights of the frame at time T:
//   w_m = integral s(t) b_D((t - origin)/S - m) dt / integral s(t) dt,
// exact (Gauss-Legendre on each polynomial piece), for m = first..first+count-1.
std::vector<double> display_weights(const Shutter& s, double T, double fps, int degree,
                                    double step, int first, int count, double origin = 0);

// Sub-frame weights of the frame at time T for the space-time method:
// u = TimeProjection::subframe_weights(display weights); the frame is
// sum_k u_k (spatial coefficients k).
// Throws when the shutter is not inside the sub-frames' span.
std::vector<double> frame_weights(const TimeProjection& p, const Shutter& s, double T,
                                  double fps);

// The conventional counterpart: the sub-frames whose times fall within the
// open shutter, weighted by the curve, normalised to sum 1. Throws when no
// sub-frame falls inside.
std::vector<double> conventional_frame_weights(const std::vector<double>& t, const Shutter& s,
                                               double T, double fps);

// Output frames k (time k/fps) whose shutter lies inside the span [a, b].
void default_frames(const std::vector<double>& t, const Shutter& s, double fps, int& first,
                    int& last);

}  // namespace sis
