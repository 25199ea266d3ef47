#include "sis/hex_prefilter.h"

#include <fftw3.h>

#include <cmath>
#include <complex>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "fftw_planner.h"
#include "sis/weights.h"

namespace sis {

namespace {

constexpr double kPi = 3.14159265358979323846;
using cplx = std::complex<double>;

// An FFTW-aligned buffer of n complex values (or 2n doubles).
struct ComplexBuffer {
  explicit ComplexBuffer(long n) : data(fftw_alloc_complex(std::max(1L, n))) {
    if (!data) throw std::bad_alloc();
  }
  ~ComplexBuffer() { fftw_free(data); }
  ComplexBuffer(const ComplexBuffer&) = delete;
  ComplexBuffer& operator=(const ComplexBuffer&) = delete;
  cplx* c() { return reinterpret_cast<cplx*>(data); }
  double* real() { return reinterpret_cast<double*>(data); }
  fftw_complex* data;
};

}  // namespace

HexPrefilterPlan::HexPrefilterPlan(int order, long Q, long R) : Q_(Q), R_(R), H_(Q / 2 + 1) {
  init(BoxSpline::hexagonal(order).autocorrelation());
}

HexPrefilterPlan::HexPrefilterPlan(const std::vector<HexTap>& taps, long Q, long R)
    : Q_(Q), R_(R), H_(Q / 2 + 1) {
  init(taps);
}

void HexPrefilterPlan::init(const std::vector<HexTap>& taps) {
  const long Q = Q_, R = R_;
  if (Q < 1 || R < 2 || R % 2 != 0) {
    std::ostringstream m;
    m << "HexPrefilterPlan(): a " << Q << " x " << R
      << " grid is not an offset-row grid (rows must be even and positive)";
    throw std::invalid_argument(m.str());
  }
  // A(m1, m2) = sum_k2 Re(exp(i theta2 k2) S_k2(theta1)),
  // S_k2(theta1) = sum_k1 a[k1, k2] exp(i theta1 (k1 + k2/2)).
  std::map<int, std::vector<HexTap>> by_row;
  for (const HexTap& t : taps) by_row[t.k2].push_back(t);
  std::vector<int> k2s;
  for (const auto& [k2, row] : by_row) k2s.push_back(k2);
  std::vector<cplx> e2(std::size_t(R) * k2s.size());
  for (long m2 = 0; m2 < R; ++m2)
    for (std::size_t q = 0; q < k2s.size(); ++q)
      e2[m2 * k2s.size() + q] = std::polar(1.0, 2 * kPi * double(m2) * k2s[q] / double(R));
  divisor_.resize(std::size_t(H_) * R);
  std::vector<cplx> S(k2s.size());
  for (long m1 = 0; m1 < H_; ++m1) {
    const double theta1 = 2 * kPi * double(m1) / double(Q);
    for (std::size_t q = 0; q < k2s.size(); ++q) {
      S[q] = 0;
      for (const HexTap& t : by_row[k2s[q]])
        S[q] += t.value * std::polar(1.0, theta1 * (t.k1 + 0.5 * t.k2));
    }
    for (long m2 = 0; m2 < R; ++m2) {
      double A = 0;
      for (std::size_t q = 0; q < k2s.size(); ++q) A += (e2[m2 * k2s.size() + q] * S[q]).real();
      divisor_[std::size_t(m1) * R + m2] = double(Q) * double(R) * A;
    }
  }
  ComplexBuffer in(Q), out(H_), col(R);
  std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
  r2c_ = fftw_plan_dft_r2c_1d(int(Q), in.real(), out.data, FFTW_ESTIMATE);
  c2r_ = fftw_plan_dft_c2r_1d(int(Q), out.data, in.real(), FFTW_ESTIMATE);
  forward_ = fftw_plan_dft_1d(int(R), col.data, col.data, FFTW_FORWARD, FFTW_ESTIMATE);
  backward_ = fftw_plan_dft_1d(int(R), col.data, col.data, FFTW_BACKWARD, FFTW_ESTIMATE);
  if (!r2c_ || !c2r_ || !forward_ || !backward_)
    throw std::runtime_error("HexPrefilterPlan(): FFTW planning failed");
}

HexPrefilterPlan::~HexPrefilterPlan() {
  std::lock_guard<std::mutex> lock(detail::fftw_planner_mutex());
  for (void* p : {r2c_, c2r_, forward_, backward_})
    if (p) fftw_destroy_plan(static_cast<fftw_plan>(p));
}

void HexPrefilterPlan::execute(Grid<double>& r, int threads) const {
  if (r.width != Q_ || r.height != R_) {
    std::ostringstream m;
    m << "HexPrefilterPlan::execute(): grid " << r.width << " x " << r.height
      << " does not match the plan's " << Q_ << " x " << R_;
    throw std::invalid_argument(m.str());
  }
  const int C = r.channels;
  const long Q = Q_, R = R_, H = H_;
  std::vector<cplx> twist(H);  // exp(-i pi m1 / Q): odd rows sit half a step right
  for (long m1 = 0; m1 < H; ++m1) twist[m1] = std::polar(1.0, -kPi * double(m1) / double(Q));
  std::vector<cplx> spectrum(std::size_t(H) * R);  // [m1][row], one channel at a time
  for (int c = 0; c < C; ++c) {
    parallel_for(R, threads, [&](long j0, long j1) {
      ComplexBuffer in(Q), out(H);
      for (long j = j0; j < j1; ++j) {
        const double* row = r.row(j) + c;
        for (long i = 0; i < Q; ++i) in.real()[i] = row[std::size_t(i) * C];
        fftw_execute_dft_r2c(static_cast<fftw_plan>(r2c_), in.real(), out.data);
        for (long m1 = 0; m1 < H; ++m1)
          spectrum[std::size_t(m1) * R + j] = (j & 1) ? out.c()[m1] * twist[m1] : out.c()[m1];
      }
    });
    parallel_for(H, threads, [&](long m0, long m1end) {
      ComplexBuffer col(R);
      for (long m1 = m0; m1 < m1end; ++m1) {
        cplx* s = spectrum.data() + std::size_t(m1) * R;
        std::copy(s, s + R, col.c());
        fftw_execute_dft(static_cast<fftw_plan>(forward_), col.data, col.data);
        for (long m2 = 0; m2 < R; ++m2) col.c()[m2] /= divisor(m1, m2);
        fftw_execute_dft(static_cast<fftw_plan>(backward_), col.data, col.data);
        std::copy(col.c(), col.c() + R, s);
      }
    });
    parallel_for(R, threads, [&](long j0, long j1) {
      ComplexBuffer in(Q), out(H);
      for (long j = j0; j < j1; ++j) {
        for (long m1 = 0; m1 < H; ++m1) {
          const cplx v = spectrum[std::size_t(m1) * R + j];
          out.c()[m1] = (j & 1) ? v * std::conj(twist[m1]) : v;
        }
        fftw_execute_dft_c2r(static_cast<fftw_plan>(c2r_), out.data, in.real());
        double* row = r.row(j) + c;
        for (long i = 0; i < Q; ++i) row[std::size_t(i) * C] = in.real()[i];
      }
    });
  }
}

void hex_prefilter(Coefficients& k, int threads) {
  if (!k.min_error)
    throw std::invalid_argument("hex_prefilter(): the hexagonal lattice has min-error only");
  const HexLayout layout = hex_layout(k);
  const HexPrefilterPlan plan(hex_generator(k).order(), layout.columns, layout.rows);
  plan.execute(k.c, threads);
}

}  // namespace sis
