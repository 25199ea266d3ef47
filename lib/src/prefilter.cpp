#include "sis/prefilter.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <stdexcept>

#include "fftw_planner.h"
#include "sis/coefficients.h"
#include "sis/space.h"
#include "sis/weights.h"

namespace sis {

namespace detail {
std::mutex& fftw_planner_mutex() {
  static std::mutex m;
  return m;
}
}  // namespace detail

namespace {
constexpr double kPi = 3.14159265358979323846;
// Columns filtered together in the column pass: 8 neighbouring doubles of a
// row, 64 bytes (one or two cache lines).
constexpr long kColumns = 8;
}  // namespace

FftwBuffer::FftwBuffer(long n) : data(fftw_alloc_real(std::max(1L, n))) {
  if (!data) throw std::bad_alloc();
}
FftwBuffer::~FftwBuffer() { fftw_free(data); }

namespace {
long pad(long n) { return (n + 7) / 8 * 8; }  // to 64 bytes of doubles
}  // namespace

PrefilterPlan1D::PrefilterPlan1D(int degree, long n, Boundary boundary, PrefilterMethod method)
    : degree_(degree), n_(n), boundary_(boundary), method_(method) {
  if (n < 1) throw std::invalid_argument("PrefilterPlan1D(): length " + std::to_string(n) + " < 1");
  slot_.resize(n);
  for (long k = 0; k < n; ++k) slot_[k] = k;
  if (method == PrefilterMethod::Recursive) {
    poles_ = bspline_prefilter_poles(degree);
    for (double z : poles_) gain_ *= (1 - z) * (1 - z);
    return;
  }
  // Bins k in [0, n/2] of the real DFT. The round trip r2c then c2r scales
  // by n, which the divisors take out.
  const long h = n / 2;
  cos_.assign(h + 1, 1.0);
  sin_.assign(h + 1, 0.0);
  scale_re_.resize(h + 1);
  scale_im_.resize(h + 1);
  const bool mirror = boundary == Boundary::Mirror;
  const std::vector<double> a = bspline_autocorrelation(degree);
  if (mirror)  // v = (x0, x2, x4, ..., x5, x3, x1)
    for (long k = 0; k < n; ++k) slot_[k] = k % 2 ? n - 1 - k / 2 : k / 2;
  for (long k = 0; k <= h; ++k) {
    if (mirror) {
      // The DCT-II bins k and n - k come from DFT bin k of the permuted
      // sequence, turned by e^{-i pi k / 2n}: the real part is X[k], minus
      // the imaginary part X[n - k]; X[k] is divided by A_d(pi k / n) and
      // X[n - k] by A_d(pi (n - k) / n).
      cos_[k] = std::cos(kPi * k / (2.0 * n));
      sin_[k] = std::sin(kPi * k / (2.0 * n));
      scale_re_[k] = 1.0 / (n * bspline_autocorrelation_spectrum(a, kPi * k / n));
      scale_im_[k] = k == 0 ? 0.0 : 1.0 / (n * bspline_autocorrelation_spectrum(a, kPi * (n - k) / n));
    } else {
      scale_re_[k] = scale_im_[k] = 1.0 / (n * bspline_autocorrelation_spectrum(a, 2 * kPi * k / n));
    }
  }
  FftwBuffer buf(workspace_size());
  double* real = buf.data;
  auto* bins = reinterpret_cast<fftw_complex*>(buf.data + pad(n));
  std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
  const int len = static_cast<int>(n);
  forward_ = fftw_plan_dft_r2c_1d(len, real, bins, FFTW_ESTIMATE);
  backward_ = fftw_plan_dft_c2r_1d(len, bins, real, FFTW_ESTIMATE);
  if (!forward_ || !backward_) throw std::runtime_error("PrefilterPlan1D(): FFTW planning failed");
}

PrefilterPlan1D::~PrefilterPlan1D() {
  std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
  if (forward_) fftw_destroy_plan(static_cast<fftw_plan>(forward_));
  if (backward_) fftw_destroy_plan(static_cast<fftw_plan>(backward_));
}

long PrefilterPlan1D::workspace_size() const {
  if (method_ == PrefilterMethod::Recursive) return boundary_ == Boundary::Mirror ? 2 * n_ : n_;
  return pad(n_) + pad(2 * (n_ / 2 + 1));  // the line, its DFT bins
}

void PrefilterPlan1D::execute(double* x, long stride, double* work) const {
  for (long k = 0; k < n_; ++k) work[slot_[k]] = x[k * stride];
  filter(work);
  for (long k = 0; k < n_; ++k) x[k * stride] = work[slot_[k]];
}

void PrefilterPlan1D::filter(double* work) const {
  const long n = n_;
  if (method_ == PrefilterMethod::FFT) {
    // Mirror: the DCT-II through a real DFT of the line in Makhoul's order
    // (slot()), and back.
    auto* bins = reinterpret_cast<fftw_complex*>(work + pad(n));
    fftw_execute_dft_r2c(static_cast<fftw_plan>(forward_), work, bins);
    for (long k = 0; k <= n / 2; ++k) {
      const double c = cos_[k], s = sin_[k];
      const double re = bins[k][0], im = bins[k][1];
      const double a = (c * re + s * im) * scale_re_[k];  // e^{-i theta} V, each part scaled
      const double b = (c * im - s * re) * scale_im_[k];
      bins[k][0] = c * a - s * b;                         // turned back by e^{i theta}
      bins[k][1] = c * b + s * a;
    }
    fftw_execute_dft_c2r(static_cast<fftw_plan>(backward_), bins, work);
    return;
  }
  // Recursive: one period of the extended sequence (2n for mirror, n for
  // periodic); each pole pair runs causal then anti-causal with exact
  // periodic initial values y[0] = sum_k z^k e[-k] / (1 - z^P).
  const long P = workspace_size();
  double* e = work;
  for (long k = n; k < P; ++k) e[k] = e[P - 1 - k];
  for (const double z : poles_) {
    double s = 0, zk = 1;
    for (long k = 0; k < P && std::abs(zk) > 1e-30; ++k, zk *= z) s += zk * e[(P - k) % P];
    e[0] = s / (1 - (std::abs(zk) > 1e-30 ? zk : 0.0));
    for (long k = 1; k < P; ++k) e[k] += z * e[k - 1];
    s = 0;
    zk = 1;
    for (long k = 0; k < P && std::abs(zk) > 1e-30; ++k, zk *= z) s += zk * e[(P - 1 + k) % P];
    e[P - 1] = s / (1 - (std::abs(zk) > 1e-30 ? zk : 0.0));
    for (long k = P - 2; k >= 0; --k) e[k] += z * e[k + 1];
  }
  for (long k = 0; k < n; ++k) e[k] *= gain_;
}

PrefilterPlan::PrefilterPlan(int degree, long nx, long ny, Boundary boundary,
                             PrefilterMethod method)
    : x_(degree, nx, boundary, method), y_(degree, ny, boundary, method) {}

void PrefilterPlan::execute(Grid<double>& r, int threads) const {
  if (r.width != x_.size() || r.height != y_.size())
    throw std::invalid_argument("PrefilterPlan::execute(): grid size does not match the plan");
  const int C = r.channels;
  const long W = r.width, H = r.height;
  parallel_for(H, threads, [&](long y0, long y1) {
    FftwBuffer work(x_.workspace_size());
    for (long y = y0; y < y1; ++y)
      for (int c = 0; c < C; ++c) x_.execute(r.row(y) + c, C, work.data);
  });
  // Columns in blocks of kColumns neighbours: a block's values in a row are
  // contiguous, so each cache line of the grid is fetched about once per
  // pass rather than once per column. Each column's operations are those of
  // execute(), so the bits do not depend on the blocking or the threads.
  const long values = W * C, blocks = (values + kColumns - 1) / kColumns;
  const long ws = (y_.workspace_size() + kColumns - 1) / kColumns * kColumns;  // keeps alignment
  parallel_for(blocks, threads, [&](long b0, long b1) {
    FftwBuffer work(kColumns * ws);
    for (long b = b0; b < b1; ++b) {
      const long k0 = b * kColumns, m = std::min(kColumns, values - k0);
      for (long y = 0; y < H; ++y) {
        const double* row = r.row(y) + k0;
        const long at = y_.slot(y);
        for (long j = 0; j < m; ++j) work.data[j * ws + at] = row[j];
      }
      for (long j = 0; j < m; ++j) y_.filter(work.data + j * ws);
      for (long y = 0; y < H; ++y) {
        double* row = r.row(y) + k0;
        const long at = y_.slot(y);
        for (long j = 0; j < m; ++j) row[j] = work.data[j * ws + at];
      }
    }
  });
}

void prefilter(Coefficients& coefficients, int threads, PrefilterMethod method) {
  visit_space(coefficients, [&](auto space) { space.prefilter(coefficients, threads, method); });
}

void CartesianSpace::prefilter(Coefficients& coefficients, int threads, PrefilterMethod method) {
  if (!coefficients.min_error || coefficients.kernel().degree() == 0) return;
  if (!coefficients.lattice.separable())
    throw std::invalid_argument("prefilter(): only separable lattices are supported");
  PrefilterPlan plan(coefficients.kernel().degree(), coefficients.c.width, coefficients.c.height,
                     coefficients.boundary, method);
  plan.execute(coefficients.c, threads);
}

}  // namespace sis
