#pragma once
// Digital prefilter: c = r * a^{-1}, with a[k] = <phi, phi(. - k)> the
// autocorrelation of the B-spline generator (DESIGN.md section 3). In 2-D the
// spectrum factors, A(w1, w2) = A_d(w1) A_d(w2), so the prefilter runs as
// 1-D passes along rows then columns.
//   mirror:   DCT-II (FFTW REDFT10), divide by A_d(pi k / n), DCT-III (REDFT01), / 2n
//   periodic: DFT (FFTW R2HC), divide by A_d(2 pi k / n), inverse (HC2R), / n
// The recursive form runs the causal/anti-causal pole pairs of 1/A_d on the
// boundary-extended sequence, exactly (periodic initial conditions).
#include <memory>
#include <vector>

#include "sis/image.h"

namespace sis {

enum class PrefilterMethod { FFT, Recursive };

// One axis of length n: plan (FFTW plan, spectrum divisors) built once.
class PrefilterPlan1D {
 public:
  PrefilterPlan1D(int degree, long n, Boundary boundary, PrefilterMethod method);
  ~PrefilterPlan1D();
  PrefilterPlan1D(const PrefilterPlan1D&) = delete;
  PrefilterPlan1D& operator=(const PrefilterPlan1D&) = delete;

  long size() const { return n_; }
  // Filters x[0], x[stride], ..., x[(n-1) stride] in place. work must hold
  // workspace_size() doubles, allocated with allocate_workspace().
  void execute(double* x, long stride, double* work) const;
  long workspace_size() const;

 private:
  int degree_;
  long n_;
  Boundary boundary_;
  PrefilterMethod method_;
  void* forward_ = nullptr;   // fftw_plan
  void* backward_ = nullptr;  // fftw_plan
  std::vector<double> divisor_;  // spectrum times the transform pair's scale
  std::vector<double> poles_;
  double gain_ = 1.0;
};

// Allocates an FFTW-aligned workspace.
struct FftwBuffer {
  explicit FftwBuffer(long n);
  ~FftwBuffer();
  FftwBuffer(const FftwBuffer&) = delete;
  FftwBuffer& operator=(const FftwBuffer&) = delete;
  double* data;
};

// The 2-D prefilter for a coefficient grid of nx x ny.
class PrefilterPlan {
 public:
  PrefilterPlan(int degree, long nx, long ny, Boundary boundary,
                PrefilterMethod method = PrefilterMethod::FFT);
  // Replaces r by c = r * a^{-1} in every channel. Bit-identical for any
  // thread count.
  void execute(Grid<double>& r, int threads = 1) const;

 private:
  PrefilterPlan1D x_, y_;
};

// Convenience: prefilters acquired coefficients in place (no-op for the
// conventional methods and for degree 0, whose autocorrelation is delta).
void prefilter(Coefficients& coefficients, int threads = 1,
               PrefilterMethod method = PrefilterMethod::FFT);

}  // namespace sis
