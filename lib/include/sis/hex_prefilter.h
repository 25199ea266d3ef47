#pragma once
// Digital prefilter on the hexagonal lattice: c = r * a^{-1}, a the box
// spline's autocorrelation (BoxSpline::autocorrelation), with the periodic
// rule on the offset-row grid (sis/hex_lattice.h): columns Q, rows R (even).
//
// In the offset-row storage, the lattice neighbour k of (i, j) is at
// horizontal position i + (j mod 2)/2 + k1 + k2/2 and row j + k2. A row DFT
// over the true positions, C_j(m1) = sum_i c[i, j] exp(-2 pi i m1 (i + (j mod 2)/2) / Q),
// is the plain row DFT times the twist exp(-i pi m1 / Q) on odd rows; then a
// column DFT over j makes the Gram convolution diagonal, with
//   A(m1, m2) = sum_k a[k] cos(2 pi (m1 (k1 + k2/2) / Q + m2 k2 / R)).
// Steps (FFTW): real row FFT (r2c), twist odd rows, complex column FFT,
// divide by Q R A, inverse column FFT, untwist, c2r.
#include "sis/hex_lattice.h"

namespace sis {

class HexPrefilterPlan {
 public:
  HexPrefilterPlan(int order, long columns, long rows);
  // Division by any symmetric stencil's spectrum instead of a's:
  // A(m1, m2) = sum_k taps[k] cos(...), which must be positive (the
  // variational rule's preconditioner: |det L| a + lambda R).
  HexPrefilterPlan(const std::vector<HexTap>& taps, long columns, long rows);
  ~HexPrefilterPlan();
  HexPrefilterPlan(const HexPrefilterPlan&) = delete;
  HexPrefilterPlan& operator=(const HexPrefilterPlan&) = delete;

  long columns() const { return Q_; }
  long rows() const { return R_; }
  // Q R A(m1, m2), m1 in [0, Q/2], m2 in [0, R).
  double divisor(long m1, long m2) const { return divisor_[std::size_t(m1) * R_ + m2]; }
  // Replaces r by c = r * a^{-1} in every channel. Bit-identical for any
  // thread count.
  void execute(Grid<double>& r, int threads = 1) const;

 private:
  void init(const std::vector<HexTap>& taps);
  long Q_, R_, H_;  // H_ = Q/2 + 1 row spectrum entries
  std::vector<double> divisor_;
  void* r2c_ = nullptr;       // fftw_plan
  void* c2r_ = nullptr;       // fftw_plan
  void* forward_ = nullptr;   // fftw_plan, columns
  void* backward_ = nullptr;  // fftw_plan, columns
};

// Prefilters acquired hexagonal coefficients in place.
void hex_prefilter(Coefficients& coefficients, int threads = 1);

}  // namespace sis
