#include "sis/prefilter.h"

#include <fftw3.h>

#include <cmath>
#include <mutex>
#include <stdexcept>

#include "fftw_planner.h"
#include "sis/hex_prefilter.h"
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
}  // namespace

FftwBuffer::FftwBuffer(long n) : data(fftw_alloc_real(std::max(1L, n))) {
  if (!data) throw std::bad_alloc();
}
FftwBuffer::~FftwBuffer() { fftw_free(data); }

PrefilterPlan1D::PrefilterPlan1D(int degree, long n, Boundary boundary, PrefilterMethod method)
    : degree_(degree), n_(n), boundary_(boundary), method_(method) {
  if (n < 1) throw std::invalid_argument("PrefilterPlan1D(): length " + std::to_string(n) + " < 1");
  if (method == PrefilterMethod::Recursive) {
    poles_ = bspline_prefilter_poles(degree);
    for (double z : poles_) gain_ *= (1 - z) * (1 - z);
    return;
  }
  divisor_.resize(n);
  if (boundary == Boundary::Mirror) {
    for (long k = 0; k < n; ++k)
      divisor_[k] = 2.0 * n * bspline_autocorrelation_spectrum(degree, kPi * k / n);
  } else {
    for (long k = 0; k < n; ++k)
      divisor_[k] = double(n) * bspline_autocorrelation_spectrum(degree, 2 * kPi * std::min(k, n - k) / n);
  }
  FftwBuffer buf(n);
  std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
  const int len = static_cast<int>(n);
  const bool mirror = boundary == Boundary::Mirror;
  forward_ = fftw_plan_r2r_1d(len, buf.data, buf.data, mirror ? FFTW_REDFT10 : FFTW_R2HC,
                              FFTW_ESTIMATE);
  backward_ = fftw_plan_r2r_1d(len, buf.data, buf.data, mirror ? FFTW_REDFT01 : FFTW_HC2R,
                               FFTW_ESTIMATE);
  if (!forward_ || !backward_) throw std::runtime_error("PrefilterPlan1D(): FFTW planning failed");
}

PrefilterPlan1D::~PrefilterPlan1D() {
  std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
  if (forward_) fftw_destroy_plan(static_cast<fftw_plan>(forward_));
  if (backward_) fftw_destroy_plan(static_cast<fftw_plan>(backward_));
}

long PrefilterPlan1D::workspace_size() const {
  return boundary_ == Boundary::Mirror ? 2 * n_ : n_;
}

void PrefilterPlan1D::execute(double* x, long stride, double* work) const {
  const long n = n_;
  if (method_ == PrefilterMethod::FFT) {
    for (long k = 0; k < n; ++k) work[k] = x[k * stride];
    fftw_execute_r2r(static_cast<fftw_plan>(forward_), work, work);
    for (long k = 0; k < n; ++k) work[k] /= divisor_[k];
    fftw_execute_r2r(static_cast<fftw_plan>(backward_), work, work);
    for (long k = 0; k < n; ++k) x[k * stride] = work[k];
    return;
  }
  // Recursive: one period of the extended sequence (2n for mirror, n for
  // periodic); each pole pair runs causal then anti-causal with exact
  // periodic initial values y[0] = sum_k z^k e[-k] / (1 - z^P).
  const long P = workspace_size();
  double* e = work;
  for (long k = 0; k < n; ++k) e[k] = x[k * stride];
  for (long k = n; k < P; ++k) e[k] = x[(P - 1 - k) * stride];
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
  for (long k = 0; k < n; ++k) x[k * stride] = gain_ * e[k];
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
  parallel_for(W * C, threads, [&](long k0, long k1) {
    FftwBuffer work(y_.workspace_size());
    for (long k = k0; k < k1; ++k) y_.execute(r.data.data() + k, W * C, work.data);
  });
}

void prefilter(Coefficients& coefficients, int threads, PrefilterMethod method) {
  if (!coefficients.min_error || coefficients.generator.degree() == 0) return;
  if (coefficients.lattice.is_hexagonal()) {
    if (method != PrefilterMethod::FFT)
      throw std::invalid_argument("prefilter(): the hexagonal lattice has the FFT prefilter only");
    hex_prefilter(coefficients, threads);
    return;
  }
  if (!coefficients.lattice.separable())
    throw std::invalid_argument("prefilter(): only separable lattices are supported");
  PrefilterPlan plan(coefficients.generator.degree(), coefficients.c.width, coefficients.c.height,
                     coefficients.boundary, method);
  plan.execute(coefficients.c, threads);
}

}  // namespace sis
