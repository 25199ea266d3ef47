#pragma once
// Digital prefilter: c = r * a^{-1}, with a[k] = <phi, phi(. - k)> the
// autocorrelation of the B-spline generator (docs/design.md section 3). In 2-D the
// spectrum factors, A(w1, w2) = A_d(w1) A_d(w2), so the prefilter runs as
// 1-D passes along rows then columns.
//   mirror:   DCT-II, divide by A_d(pi k / n), DCT-III; each DCT of length n
//             runs as one real DFT of length n (FFTW r2c / c2r, SIMD codelets)
//             of the permuted sequence (x0, x2, x4, ..., x3, x1), turned by
//             e^{-+ i pi k / 2n} (Makhoul's algorithm)
//   periodic: real DFT (FFTW r2c), divide by A_d(2 pi k / n), inverse (c2r)
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
  // workspace_size() doubles, FFTW-aligned (FftwBuffer).
  void execute(double* x, long stride, double* work) const;
  // The position of sample k of a line in the workspace: the order the
  // transform takes (Makhoul's permutation for the mirror FFT, else k).
  long slot(long k) const { return slot_[k]; }
  // Filters in place the line held in work, sample k at slot(k) (the rest
  // of the workspace is scratch); work is aligned as an FftwBuffer's start.
  void filter(double* work) const;
  long workspace_size() const;

 private:
  int degree_;
  long n_;
  Boundary boundary_;
  PrefilterMethod method_;
  void* forward_ = nullptr;   // fftw_plan
  void* backward_ = nullptr;  // fftw_plan
  // per real-DFT bin k in [0, n/2]: the turn e^{-i pi k / 2n} (mirror) and
  // the factors 1 / (n A_d) of its real and imaginary parts
  std::vector<double> cos_, sin_, scale_re_, scale_im_;
  std::vector<long> slot_;
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
