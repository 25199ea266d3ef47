#include "sis/acquisition.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>

#include "sis/box_spline.h"
#include "sis/coefficients.h"
#include "sis/parallel.h"

namespace sis {

namespace {

// The knots of a kernel's polynomial pieces in [-radius, radius] (none for
// the kernels that are not piecewise polynomials).
std::vector<double> kernel_knots(const Kernel& kernel) {
  std::vector<double> t;
  if (kernel.kind() == KernelKind::BSpline)
    for (int i = 0; i <= kernel.degree() + 1; ++i) t.push_back(-0.5 * (kernel.degree() + 1) + i);
  else if (kernel.kind() == KernelKind::Mitchell)
    for (int i = -2; i <= 2; ++i) t.push_back(i);
  return t;
}

// Rows of the input's model that an upsampled axis reaches from one sample:
// the cubic interpolation prefilter's impulse response is truncated where
// it falls below 2^-64 of its peak (|z|^L, z = sqrt(3) - 2).
constexpr long kModelReach = 36;

// An axis whose samples are sparser than the lattice (step > h: upsampling),
// where the point sum would not be an inner product. The samples f_i are
// modelled by their cubic spline interpolant under the boundary rule,
// f(x) = sum_k c_k b3((x - x_k) / step), x_k = (k + 1/2) step, c = p * f
// with p the interpolation prefilter (p[m] = (1 - z) / (1 + z) z^|m|, the
// inverse of the sampled cubic B-spline), and that model is projected
// exactly: r[n] = sum_k G[n][k] c_k with G[n][k] = (1/h) int b3((x - x_k) /
// step) phi((x - p_n) / h) dx, by Gauss-Legendre on the pieces between both
// functions' knots (exact for piecewise polynomials). The weight of sample j
// is sum_k G[n][k] p[k - j], over the extended indices, folded by the rule.
// The model reproduces polynomials of degree 3: a flat image stays flat, a
// ramp stays a ramp. Conventional methods: the same, normalised below.
AxisWeights model_axis(int axis, long coefficients, long samples, double extent,
                       const Lattice& lattice, const Kernel& kernel, Boundary boundary) {
  const double step = extent / samples;
  const double h = lattice.axis_step(axis);
  const double R = kernel.radius();
  const double z = bspline_prefilter_poles(1).at(0);
  const double gain = (1 - z) / (1 + z);
  std::vector<double> p(kModelReach + 1);
  for (long m = 0; m <= kModelReach; ++m) p[m] = gain * std::pow(z, double(m));
  std::vector<double> gx, gw;
  gauss_legendre01(8, gx, gw);  // exact to degree 15; b3 phi has degree <= 10
  const std::vector<double> knots = kernel_knots(kernel);
  const bool polynomial = !knots.empty();
  // G[n][k] for the model's k under phi_n: [k0, k0 + g.size())
  auto model_row = [&](long n, long& k0, std::vector<double>& g) {
    const double pn = lattice.axis_position(axis, n);
    k0 = long(std::ceil((pn - R * h) / step - 2.5));
    const long k1 = long(std::floor((pn + R * h) / step + 1.5));
    g.assign(std::size_t(std::max(0L, k1 - k0 + 1)), 0.0);
    std::vector<double> cut;
    for (long k = k0; k <= k1; ++k) {
      const double xk = (k + 0.5) * step;
      cut.clear();
      cut.push_back(-R);
      cut.push_back(R);
      for (double t : knots) cut.push_back(t);
      for (int m = -2; m <= 2; ++m) cut.push_back((xk - pn + m * step) / h);
      std::sort(cut.begin(), cut.end());
      double sum = 0;
      for (std::size_t q = 0; q + 1 < cut.size(); ++q) {
        const double a = std::max(-R, cut[q]), b = std::min(R, cut[q + 1]);
        if (!(b > a)) continue;
        // non-polynomial kernels: pieces of at most half a step
        const int parts = polynomial ? 1 : std::max(1, int(std::ceil((b - a) / 0.5)));
        const double len = (b - a) / parts;
        for (int part = 0; part < parts; ++part)
          for (std::size_t i = 0; i < gx.size(); ++i) {
            const double t = a + (part + gx[i]) * len;
            sum += gw[i] * len * bspline(3, (pn + h * t - xk) / step) * kernel.eval(t);
          }
      }
      g[std::size_t(k - k0)] = sum;
    }
  };
  long cached = -1, k0 = 0;
  std::vector<double> g;
  auto range = [&](long n) {
    model_row(n, k0, g);
    cached = n;
    return std::pair<long, long>(k0 - kModelReach, k0 + long(g.size()) - 1 + kModelReach);
  };
  auto weight = [&](long n, long j) {
    if (n != cached) range(n);
    double w = 0;
    for (std::size_t q = 0; q < g.size(); ++q) {
      const long d = std::labs(k0 + long(q) - j);
      if (d <= kModelReach) w += g[q] * p[std::size_t(d)];
    }
    return w;
  };
  return make_axis_weights(coefficients, samples, boundary, range, weight);
}

// An axis whose samples are denser than the lattice but not a whole number
// of them per lattice step (h / step not an integer), where the point sum is
// not a quadrature of the inner product (a coefficient's support holds
// different counts of samples from cell to cell). The samples are modelled
// by their 4-point cubic Lagrange interpolant under the boundary rule,
// f(x) = sum_j f_j L(u - j), u = x / step - 1/2, L the piecewise cubic
// cardinal function of support [-2, 2] (lagrange4), and the model is
// integrated exactly against the generator: the weight of sample j is
// (step / h) int L(u - j) phi(((u + 1/2) step - p_n) / h) du, by 6-point
// Gauss-Legendre on the pieces between the model's knots (the integers u)
// and the generator's (exact: degree <= 3 + 7 on each piece; the kernels
// that are not piecewise polynomials in pieces of at most half a lattice
// step), over the extended indices, folded by the rule. The model
// reproduces polynomials of degree 3: a flat image stays flat, a ramp a
// ramp. A coefficient's entries are those of its support plus 2 samples
// either side.
AxisWeights lagrange_axis(int axis, long coefficients, long samples, double extent,
                          const Lattice& lattice, const Kernel& kernel, Boundary boundary) {
  const double step = extent / samples;
  const double h = lattice.axis_step(axis);
  const double R = kernel.radius();
  const double scale = step / h;  // du in lattice units
  std::vector<double> gx, gw;
  gauss_legendre01(6, gx, gw);
  const std::vector<double> knots = kernel_knots(kernel);
  const bool polynomial = !knots.empty();
  long cached = -1, j0 = 0;
  std::vector<double> g, cut;
  auto build = [&](long n) {
    const double pn = lattice.axis_position(axis, n);
    auto u_of = [&](double t) { return (pn + t * h) / step - 0.5; };
    const double ulo = u_of(-R), uhi = u_of(R);
    j0 = long(std::floor(ulo)) - 1;
    const long j1 = long(std::floor(uhi)) + 2;
    g.assign(std::size_t(j1 - j0 + 1), 0.0);
    cut.clear();
    cut.push_back(ulo);
    cut.push_back(uhi);
    for (long m = long(std::floor(ulo)) + 1; m <= long(std::floor(uhi)); ++m) cut.push_back(double(m));
    for (double t : knots) cut.push_back(u_of(t));
    std::sort(cut.begin(), cut.end());
    for (std::size_t q = 0; q + 1 < cut.size(); ++q) {
      const double a = std::max(ulo, cut[q]), b = std::min(uhi, cut[q + 1]);
      if (!(b > a)) continue;
      const long m = long(std::floor(0.5 * (a + b)));  // the piece's model interval [m, m + 1]
      const int parts = polynomial ? 1 : std::max(1, int(std::ceil((b - a) * scale / 0.5)));
      const double len = (b - a) / parts;
      double* w = g.data() + (m - 1 - j0);
      for (int part = 0; part < parts; ++part)
        for (std::size_t i = 0; i < gx.size(); ++i) {
          const double u = a + (part + gx[i]) * len;
          const double v = scale * gw[i] * len * kernel.eval(((u + 0.5) * step - pn) / h);
          const auto L = lagrange4(u - double(m));
          for (int k = 0; k < 4; ++k) w[k] += v * L[k];
        }
    }
    cached = n;
  };
  auto range = [&](long n) {
    build(n);
    return std::pair<long, long>(j0, j0 + long(g.size()) - 1);
  };
  auto weight = [&](long n, long j) {
    if (n != cached) build(n);
    return g[std::size_t(j - j0)];
  };
  return make_axis_weights(coefficients, samples, boundary, range, weight);
}

// Whether the point sum over the samples is the exact inner product (for
// the polynomials the generator reproduces, docs/design.md section 10): the
// samples at least as dense as the lattice, a whole number of them per
// lattice step (h / step within 1e-9 of an integer: the ratio of integer
// sizes, computed in double).
bool point_sum_exact(double step, double h) {
  const double q = h / step, k = std::round(q);
  return k >= 1 && std::abs(q - k) <= 1e-9 * q;
}

// Weights from the samples (i + 1/2) * step, i in [0, samples), to the
// coefficients n along one axis of a separable lattice: the point sum where
// it is exact (point_sum_exact), the projected Lagrange model of
// lagrange_axis() where the samples are denser but not a whole number per
// step, the projected spline model of model_axis() where they are sparser.
// Conventional methods: the same weights, normalised to sum 1.
AxisWeights acquisition_axis(int axis, long coefficients, long samples, double extent,
                             const Lattice& lattice, const Kernel& kernel, Boundary boundary,
                             Method method) {
  const double step = extent / samples;  // sample spacing, output pixels
  const double h = lattice.axis_step(axis);
  const double support = kernel.radius() * h;
  if (step > h || !point_sum_exact(step, h)) {
    AxisWeights w = step > h
                        ? model_axis(axis, coefficients, samples, extent, lattice, kernel, boundary)
                        : lagrange_axis(axis, coefficients, samples, extent, lattice, kernel, boundary);
    if (method == Method::Conventional)
      for (long n = 0; n < coefficients; ++n) {
        const double s = w.sum(n);
        for (long e = w.begin(n); e < w.end(n); ++e) w.weight[e] /= s;
      }
    return w;
  }
  auto range = [&](long n) {
    const double p = lattice.axis_position(axis, n);
    return std::pair<long, long>(static_cast<long>(std::ceil((p - support) / step - 0.5)),
                                 static_cast<long>(std::floor((p + support) / step - 0.5)));
  };
  // Quadrature weight step / h makes r[n] an inner product in lattice units.
  const double scale = (method == Method::MinError) ? step / h : 1.0;
  auto weight = [&](long n, long i) {
    const double p = lattice.axis_position(axis, n);
    return scale * kernel.eval(((i + 0.5) * step - p) / h);
  };
  AxisWeights w = make_axis_weights(coefficients, samples, boundary, range, weight);
  if (method == Method::Conventional) {
    for (long n = 0; n < coefficients; ++n) {
      const double s = w.sum(n);
      if (!(s > 0)) {
        std::ostringstream m;
        m << "conventional acquisition(): no input sample under the " << kernel.name()
          << " filter of pixel " << n << " along " << (axis ? "y" : "x") << " (" << samples
          << " samples for " << coefficients << " pixels)";
        throw std::invalid_argument(m.str());
      }
      for (long e = w.begin(n); e < w.end(n); ++e) w.weight[e] /= s;
    }
  }
  return w;
}

// Values of a row handed to the vertical pass per call: the vertical sums of
// a few coefficient rows over one block stay in the first-level cache.
constexpr long kBlock = 512;

// Rows summed together at most (add_scaled_row_group).
constexpr int kGroup = 4;

// Vertical sums and pieces start on 64-byte boundaries (a vector load or
// store that straddles two cache lines costs two); the columns are split
// among the threads at multiples of kAlign values (64 bytes of doubles).
constexpr long kAlign = 8;
template <typename T>
T* aligned(T* p) {
  return reinterpret_cast<T*>((reinterpret_cast<std::uintptr_t>(p) + 63) & ~std::uintptr_t(63));
}

// Rows held in memory: each piece is where it lies.
template <typename T>
auto in_memory(long y0, const T* rows, std::size_t row_size) {
  return [=](long y, long k0, long, T*) { return rows + (y - y0) * row_size + k0; };
}

}  // namespace

AcquisitionPlan::AcquisitionPlan(long input_width, long input_height, int channels,
                                 double image_width, double image_height, const Lattice& lattice,
                                 const Kernel& generator, Boundary boundary, Method method,
                                 long band_rows)
    : channels_(channels),
      image_w_(image_width),
      image_h_(image_height),
      lattice_(lattice),
      generator_(generator),
      boundary_(boundary),
      method_(method) {
  if (input_width < 1 || input_height < 1 || channels < 1) {
    std::ostringstream m;
    m << "AcquisitionPlan(): empty input " << input_width << " x " << input_height << " x "
      << channels;
    throw std::invalid_argument(m.str());
  }
  if (method == Method::MinError && !generator.is_bspline())
    throw std::invalid_argument("AcquisitionPlan(): min-error needs a B-spline generator, not " +
                                generator.name());
  const auto extent = lattice.extent(image_width, image_height);
  wx_ = acquisition_axis(0, extent[0], input_width, image_width, lattice, generator, boundary,
                         method);
  wy_ = acquisition_axis(1, extent[1], input_height, image_height, lattice, generator, boundary,
                         method);
  bands_ = BandPartition(input_height, band_rows < 1 ? kBandRows : band_rows);
}

Acquisition::Acquisition(const AcquisitionPlan& plan, int threads)
    : plan_(plan), threads_(threads < 1 ? 1 : threads), ended_(plan.bands().count(), 0) {
  const AxisWeights& wy = plan.weights_y();
  const BandPartition& bands = plan.bands();
  // Unset: the horizontal passes write every row but those that no input
  // row reaches, zeroed here (their pages are first touched by the threads,
  // not by a serial fill).
  acc_ = Grid<double>(plan.coefficients_x(), plan.coefficients_y(), plan.channels(), kUnset);
  std::vector<std::vector<long>> row_bands(plan.coefficients_y());
  for (long n = 0; n < plan.coefficients_y(); ++n) {
    if (wy.begin(n) == wy.end(n)) std::fill(acc_.row(n), acc_.row(n) + acc_.row_size(), 0.0);
    for (long e = wy.begin(n); e < wy.end(n); ++e) {  // increasing rows, so increasing bands
      const long b = bands.of(wy.index[e]);
      if (row_bands[n].empty() || row_bands[n].back() != b) row_bands[n].push_back(b);
    }
  }
  slots_ = BandSlots<double>(row_bands, bands.count(), acc_.row_size());
}

Acquisition::~Acquisition() = default;

void Acquisition::add_rows(long y0, long y1, const float* rows) {
  const std::size_t row_size = std::size_t(plan_.input_width()) * plan_.channels();
  add_in_order<float>(y0, y1, in_memory(y0, rows, row_size));
}
void Acquisition::add_rows(long y0, long y1, const double* rows) {
  const std::size_t row_size = std::size_t(plan_.input_width()) * plan_.channels();
  add_in_order<double>(y0, y1, in_memory(y0, rows, row_size));
}
void Acquisition::add_rows(long y0, long y1, const PieceSource& piece) {
  add_in_order<float>(y0, y1, piece);
}

// Rows in order: band after band, each ended as its last row comes.
template <typename T, typename Piece>
void Acquisition::add_in_order(long y0, long y1, const Piece& piece) {
  if (y0 != next_row_ || y1 < y0 || y1 > plan_.input_height()) {
    std::ostringstream m;
    m << "Acquisition::add_rows(): rows [" << y0 << ", " << y1 << ") out of order (next row "
      << next_row_ << " of " << plan_.input_height() << ")";
    throw std::logic_error(m.str());
  }
  if (!in_order_) in_order_ = std::make_unique<Band>(*this, threads_);
  for (long y = y0; y < y1;) {
    if (in_order_->band_ < 0) in_order_->begin(plan_.bands().of(y));
    const long e = std::min(y1, in_order_->y1_);
    in_order_->add<T>(y, e, piece);
    if (e == in_order_->y1_) in_order_->end();
    y = e;
  }
  next_row_ = y1;
}

Coefficients Acquisition::finish() {
  const long ended = std::count(ended_.begin(), ended_.end(), 1);
  if (ended != long(ended_.size())) {
    std::ostringstream m;
    m << "Acquisition::finish(): only " << ended << " of " << ended_.size()
      << " bands of rows were added (next row " << next_row_ << " of " << plan_.input_height()
      << ")";
    throw std::logic_error(m.str());
  }
  in_order_.reset();
  slots_ = BandSlots<double>();
  Coefficients out;
  out.c = std::move(acc_);
  out.lattice = plan_.lattice();
  out.space = CartesianSpace{plan_.generator()};
  out.boundary = plan_.boundary();
  out.min_error = plan_.method() == Method::MinError;
  out.image_width = plan_.image_width();
  out.image_height = plan_.image_height();
  return out;
}

Acquisition::Band::Band(Acquisition& whole, int threads)
    : whole_(whole),
      threads_(threads < 1 ? 1 : threads),
      cursor_(whole.plan_.coefficients_y()),
      first_(whole.plan_.coefficients_y()),
      end_(whole.plan_.coefficients_y()),
      dest_(whole.plan_.coefficients_y()),
      sums_(whole.plan_.coefficients_y()) {}

Acquisition::Band::~Band() = default;

void Acquisition::Band::begin(long band) {
  const AcquisitionPlan& plan = whole_.plan_;
  if (band_ >= 0 || band < 0 || band >= plan.bands().count() || whole_.ended_[band]) {
    std::ostringstream m;
    m << "Acquisition::Band::begin(" << band << "): "
      << (band_ >= 0 ? "band " + std::to_string(band_) + " not ended"
                     : band < 0 || band >= plan.bands().count() ? "no such band" : "band taken before");
    throw std::logic_error(m.str());
  }
  band_ = band;
  y0_ = next_row_ = plan.bands().begin(band);
  y1_ = plan.bands().end(band);
  const AxisWeights& wy = plan.weights_y();
  active_.clear();
  for (long n = 0; n < plan.coefficients_y(); ++n) {
    const long* rows = wy.index.data();
    const long e0 = std::lower_bound(rows + wy.begin(n), rows + wy.end(n), y0_) - rows;
    const long e1 = std::lower_bound(rows + e0, rows + wy.end(n), y1_) - rows;
    if (e0 == e1) continue;
    active_.push_back(n);
    cursor_[n] = first_[n] = e0;
    end_[n] = e1;
    double* slot = whole_.slots_.slot(n, band);
    dest_[n] = slot ? slot : whole_.acc_.row(n);
  }
}

void Acquisition::Band::add_rows(long y0, long y1, const float* rows) {
  const std::size_t row_size = std::size_t(whole_.plan_.input_width()) * whole_.plan_.channels();
  add<float>(y0, y1, in_memory(y0, rows, row_size));
}
void Acquisition::Band::add_rows(long y0, long y1, const PieceSource& piece) { add<float>(y0, y1, piece); }

// The horizontal pass of the complete rows, targets [n0, n1) of part `part`.
void Acquisition::Band::filter_complete(long part, long parts) {
  const AcquisitionPlan& plan = whole_.plan_;
  const long ncx = plan.coefficients_x();
  const long n0 = ncx * part / parts, n1 = ncx * (part + 1) / parts;
  for (long m : complete_)
    apply_weights(plan.weights_x(), sums_of(m), plan.channels(), n0, n1, dest_[m]);
}

// Row m's vertical sum, at the first 64-byte boundary of its buffer.
double* Acquisition::Band::sums_of(long m) { return aligned(sums_[m].data()); }

void Acquisition::Band::release_complete() {
  for (long m : complete_) spare_.push_back(std::move(sums_[m]));
  complete_.clear();
}

// piece(y, k0, k1, scratch) -> const T*: values [k0, k1) of input row y.
template <typename T, typename Piece>
void Acquisition::Band::add(long y0, long y1, const Piece& piece) {
  const AcquisitionPlan& plan = whole_.plan_;
  if (band_ < 0 || y0 != next_row_ || y1 < y0 || y1 > y1_) {
    std::ostringstream m;
    m << "Acquisition::Band::add_rows(): rows [" << y0 << ", " << y1 << ") ";
    if (band_ < 0)
      m << "outside a band (begin() first)";
    else
      m << "out of order (next row " << next_row_ << " of band " << band_ << ", rows [" << y0_
        << ", " << y1_ << "))";
    throw std::logic_error(m.str());
  }
  const long values = plan.input_width() * plan.channels();
  const AxisWeights& wy = plan.weights_y();

  // Per row of the strip: the coefficient rows it adds to (their vertical
  // sums and weights), those it starts last (its term is their first in
  // the band: assigned, not added, so reused sum buffers need no zeroing);
  // rows summed to the band's end here are filtered in the next call.
  const long nrows = y1 - y0;
  if (long(rows_.size()) < nrows) rows_.resize(nrows);
  for (long r = 0; r < nrows; ++r) {
    RowTargets& t = rows_[r];
    t.sums.clear();
    t.weights.clear();
    t.start_sums.clear();
    t.start_weights.clear();
  }
  std::vector<long> completed;
  for (long n : active_) {
    long e = cursor_[n];
    if (e == end_[n] || wy.index[e] >= y1) continue;
    if (sums_[n].empty()) {
      if (spare_.empty()) {
        sums_[n].resize(values + 64 / sizeof(double));
      } else {
        sums_[n] = std::move(spare_.back());
        spare_.pop_back();
      }
    }
    for (; e < end_[n] && wy.index[e] < y1; ++e) {
      RowTargets& t = rows_[wy.index[e] - y0];
      const bool start = e == first_[n];
      (start ? t.start_sums : t.sums).push_back(sums_of(n));
      (start ? t.start_weights : t.weights).push_back(wy.weight[e]);
    }
    cursor_[n] = e;
    if (e == end_[n]) completed.push_back(n);
  }
  // The started sums after the others; then runs of up to kGroup rows that
  // add to the same sums, the later ones starting none, go to the vertical
  // sums together (each sum loaded and stored once per run).
  for (long r = 0; r < nrows; ++r) {
    RowTargets& t = rows_[r];
    t.sums.insert(t.sums.end(), t.start_sums.begin(), t.start_sums.end());
    t.weights.insert(t.weights.end(), t.start_weights.begin(), t.start_weights.end());
  }
  for (long r = 0; r < nrows;) {
    int g = 1;
    while (g < kGroup && r + g < nrows && rows_[r + g].start_sums.empty() && rows_[r + g].sums == rows_[r].sums) ++g;
    rows_[r].group = g;
    r += g;
  }

  // Each part: its share of the targets of the rows completed before, then
  // its share of the columns of this strip's rows (from a multiple of
  // kAlign, so that vectors stay within cache lines), block by block, row by
  // row in increasing order.
  const long parts = std::min<long>(threads_, std::max(1L, values / kBlock));
  auto split = [&](long part) { return part == parts ? values : values * part / parts / kAlign * kAlign; };
  const std::size_t room = (kGroup * kBlock * sizeof(T) + 64) / sizeof(double);  // a part's pieces
  if (scratch_.size() < parts * room) scratch_.resize(parts * room);
  auto run = [&](long p0, long p1) {
    T* scratch = aligned(reinterpret_cast<T*>(scratch_.data() + p0 * room));
    for (long part = p0; part < p1; ++part) {
      filter_complete(part, parts);
      const long k0 = split(part), k1 = split(part + 1);
      for (long b = k0; b < k1; b += kBlock) {
        const long len = std::min(k1, b + kBlock) - b;
        for (long r = 0; r < nrows; r += rows_[r].group) {
          const int g = rows_[r].group;
          const T* x[kGroup];
          const double* w[kGroup];
          for (int i = 0; i < g; ++i) {
            x[i] = piece(y0 + r + i, b, b + len, scratch + i * kBlock);
            w[i] = rows_[r + i].weights.data();
          }
          const RowTargets& t = rows_[r];
          add_scaled_row_group(t.sums.data(), w, int(t.sums.size()), int(t.start_sums.size()), b, x,
                               g, len);
        }
      }
    }
  };
  if (parts == 1)
    run(0, 1);
  else
    parallel_for(parts, threads_, run);
  release_complete();
  complete_ = std::move(completed);
  next_row_ = y1;
}

void Acquisition::Band::end() {
  if (band_ < 0 || next_row_ != y1_) {
    std::ostringstream m;
    m << "Acquisition::Band::end(): ";
    if (band_ < 0)
      m << "no band begun";
    else
      m << "band " << band_ << " has rows [" << y0_ << ", " << y1_ << "), added up to " << next_row_;
    throw std::logic_error(m.str());
  }
  if (threads_ == 1) {
    filter_complete(0, 1);
  } else {
    parallel_for(threads_, threads_, [&](long p0, long p1) {
      for (long part = p0; part < p1; ++part) filter_complete(part, threads_);
    });
  }
  release_complete();
  const long b = band_;
  band_ = -1;
  whole_.ended_[b] = 1;
  whole_.slots_.ended(b, [&](long n, const double* slot) { whole_.merge_slot(n, slot); });
}

void Acquisition::merge_slot(long n, const double* slot) {
  double* row = acc_.row(n);
  for (std::size_t q = 0; q < acc_.row_size(); ++q) row[q] += slot[q];
}

BandPartial<double> Acquisition::partial(std::vector<long>* taken) const {
  taken->clear();
  for (long b = 0; b < long(ended_.size()); ++b)
    if (ended_[b]) taken->push_back(b);
  return slots_.partial(*taken, [&](long n, double* out) {
    std::copy(acc_.row(n), acc_.row(n) + acc_.row_size(), out);
  });
}

void Acquisition::absorb(const BandPartial<double>& p, const std::vector<long>& taken) {
  for (long b : taken)
    if (b < 0 || b >= long(ended_.size()) || ended_[b])
      throw std::invalid_argument("band " + std::to_string(b) + " out of range or already taken");
  slots_.absorb(
      p, taken,
      [&](long n, const double* v) { std::copy(v, v + acc_.row_size(), acc_.row(n)); },
      [&](long n, const double* slot) { merge_slot(n, slot); });
  for (long b : taken) ended_[b] = 1;
}

namespace {
template <typename T>
Coefficients acquire_grid(const Grid<T>& input, const AcquisitionPlan& plan, int threads) {
  if (input.width != plan.input_width() || input.height != plan.input_height() ||
      input.channels != plan.channels())
    throw std::invalid_argument("acquire(): image size does not match the plan");
  Acquisition a(plan, threads);
  const long strip = 64;
  for (long y = 0; y < input.height; y += strip) {
    const long y1 = std::min(input.height, y + strip);
    a.add_rows(y, y1, input.row(y));
  }
  return a.finish();
}
}  // namespace

Coefficients acquire(const Image& input, const AcquisitionPlan& plan, int threads) {
  return acquire_grid(input, plan, threads);
}
Coefficients acquire(const Grid<double>& input, const AcquisitionPlan& plan, int threads) {
  return acquire_grid(input, plan, threads);
}

}  // namespace sis
