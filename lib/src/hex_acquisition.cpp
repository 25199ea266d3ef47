#include "sis/hex_acquisition.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "sis/parallel.h"
#include "sis/weights.h"

namespace sis {

HexQuadrature parse_hex_quadrature(const std::string& s) {
  if (s == "point") return HexQuadrature::Point;
  if (s == "cell") return HexQuadrature::Cell;
  throw std::invalid_argument("unknown quadrature '" + s + "' (expected point or cell)");
}

std::string hex_quadrature_name(HexQuadrature q) {
  return q == HexQuadrature::Point ? "point" : "cell";
}

HexAcquisitionPlan::HexAcquisitionPlan(long input_width, long input_height, int channels,
                                       double image_width, double image_height,
                                       const HexLayout& layout, int order, Boundary boundary,
                                       HexQuadrature quadrature)
    : win_(input_width),
      hin_(input_height),
      channels_(channels),
      image_w_(image_width),
      image_h_(image_height),
      layout_(layout),
      spline_(&BoxSpline::hexagonal(order)),
      boundary_(boundary),
      quadrature_(quadrature) {
  if (input_width < 1 || input_height < 1 || channels < 1 || !(image_width > 0) ||
      !(image_height > 0)) {
    std::ostringstream m;
    m << "HexAcquisitionPlan(): empty input " << input_width << " x " << input_height << " x "
      << channels << " or frame " << image_width << " x " << image_height;
    throw std::invalid_argument(m.str());
  }
  if (!layout.lattice.is_hexagonal() || layout.columns < 1 || layout.rows < 2 ||
      layout.rows % 2 != 0)
    throw std::invalid_argument("HexAcquisitionPlan(): layout is not an offset-row grid on a "
                                "hexagonal lattice");
  dx_ = image_width / input_width;
  dy_ = image_height / input_height;
  scale_ = dx_ * dy_ / std::abs(layout.lattice.determinant());
  const double n = spline_->radius(), h = layout.step(), hy = layout.row_step();
  const Vec2 o = layout.lattice.origin();
  // Extended columns: every sample (with the cell rule: every cell) meeting
  // some coefficient's support.
  const bool cell = quadrature == HexQuadrature::Cell;
  const double rx = n * h + (cell ? 0.5 * dx_ : 0.0), ry = n * hy + (cell ? 0.5 * dy_ : 0.0);
  const double xmin = o.x - rx, xmax = o.x + h * (layout.columns - 0.5) + rx;
  q0_ = static_cast<long>(std::ceil(xmin / dx_ - 0.5));
  const long q1 = static_cast<long>(std::floor(xmax / dx_ - 0.5));
  for (long q = q0_; q <= q1; ++q) colmap_.push_back(extend_index(q, win_, boundary));
  // Extended rows, grouped by the input row they copy.
  const double ymin = o.y - ry, ymax = o.y + hy * (layout.rows - 1) + ry;
  const long e0 = static_cast<long>(std::ceil(ymin / dy_ - 0.5));
  const long e1 = static_cast<long>(std::floor(ymax / dy_ - 0.5));
  images_.resize(hin_);
  for (long e = e0; e <= e1; ++e) images_[extend_index(e, hin_, boundary)].push_back(e);
}

namespace {
constexpr long kHexBandRows = 256;  // as kBandRows: the bands the files are read in

// The point rule along one sample row for one coefficient: a[c] += scale *
// s(t) * src[q][c] for its m samples at t = t0, t0 + step, ... (t by repeated
// addition), those outside the slice's support skipped. The slice's degree
// (3 order - 2) and the channel count (CC, 0 = C at run time) are fixed at
// compile time; t only grows, so the piece is found by stepping forward.
template <int Order, int CC, typename S>
void slice_terms(const BoxSplineSlice& s, double t, double step, double scale, long m,
                 const S* src, double* a, int C) {
  constexpr int D = 3 * Order - 2;
  const int Cn = CC > 0 ? CC : C;
  const double hw = s.half_width;
  double sum[CC > 0 ? CC : 1];
  if constexpr (CC > 0)
    for (int c = 0; c < CC; ++c) sum[c] = a[c];
  int p = 0;
  for (long q = 0; q < m; ++q, t += step, src += Cn) {
    if (!(std::abs(t) < hw)) continue;
    while (p + 1 < s.pieces && t >= s.lo[p + 1]) ++p;
    const double w = t - s.shift[p];
    const auto& k = s.coef[p];
    double y = k[D];
    for (int d = D - 1; d >= 0; --d) y = y * w + k[d];
    const double wgt = scale * y;
    if constexpr (CC > 0) {
      for (int c = 0; c < CC; ++c) sum[c] += wgt * src[c];
    } else {
      for (int c = 0; c < Cn; ++c) a[c] += wgt * src[c];
    }
  }
  if constexpr (CC > 0)
    for (int c = 0; c < CC; ++c) a[c] = sum[c];
}
}  // namespace

HexAcquisition::HexAcquisition(const HexAcquisitionPlan& plan, int threads, long band_rows)
    : plan_(plan),
      threads_(threads < 1 ? 1 : threads),
      acc_(plan.layout().columns, plan.layout().rows, plan.channels()),
      bands_(plan.input_height(), band_rows < 1 ? kHexBandRows : band_rows),
      row_bands_(plan.layout().rows),
      done_(plan.layout().rows, 0),
      ended_(bands_.count(), 0) {
  for (long b = 0; b < bands_.count(); ++b)
    for (long j : reached(bands_.begin(b), bands_.end(b))) row_bands_[j].push_back(b);
}

HexAcquisition::~HexAcquisition() = default;

std::vector<long> HexAcquisition::reached(long y0, long y1) const {
  const HexLayout& L = plan_.layout();
  const BoxSpline& B = plan_.generator();
  const long R = L.rows;
  const double n = B.radius(), hy = L.row_step(), dy = plan_.sample_dy();
  const Vec2 o = L.lattice.origin();
  const bool cell = plan_.quadrature() == HexQuadrature::Cell;
  const double cv = cell ? 0.5 * dy / hy : 0.0;
  std::vector<char> touched(R, 0);
  for (long k = y0; k < y1; ++k)
    for (long e : plan_.row_images(k)) {
      const double u = ((e + 0.5) * dy - o.y) / hy;
      const long j0 = std::max(0L, static_cast<long>(std::floor(u - n - cv)));
      const long j1 = std::min(R - 1, static_cast<long>(std::ceil(u + n + cv)));
      for (long j = j0; j <= j1; ++j) touched[j] = 1;
    }
  std::vector<long> work;
  for (long j = 0; j < R; ++j)
    if (touched[j]) work.push_back(j);
  return work;
}

template <typename T>
void HexAcquisition::extend(long y0, long y1, const T* rows, std::vector<T>& ext,
                            int threads) const {
  const int C = plan_.channels();
  const long win = plan_.input_width();
  const std::vector<long>& colmap = plan_.column_source();
  const long wext = static_cast<long>(colmap.size());
  const std::size_t erow = std::size_t(wext) * C;
  ext.resize(erow * (y1 - y0));
  parallel_for(y1 - y0, threads, [&](long r0, long r1) {
    for (long r = r0; r < r1; ++r) {
      const T* in = rows + std::size_t(r) * win * C;
      T* out = ext.data() + erow * r;
      for (long q = 0; q < wext; ++q)
        for (int c = 0; c < C; ++c) out[std::size_t(q) * C + c] = in[std::size_t(colmap[q]) * C + c];
    }
  });
}

template <typename S>
void HexAcquisition::accumulate(const S* strip, long y0, long y1, const std::vector<long>& work,
                                int threads) {
  if (work.empty()) return;
  const HexLayout& L = plan_.layout();
  const BoxSpline& B = plan_.generator();
  const int C = plan_.channels();
  const long Q = L.columns;
  const double n = B.radius(), h = L.step(), hy = L.row_step(), dx = plan_.sample_dx(),
               dy = plan_.sample_dy(), scale = plan_.quadrature_weight();
  const Vec2 o = L.lattice.origin();
  const long q0 = plan_.first_column();
  const std::vector<long>& colmap = plan_.column_source();
  const long qlast = q0 + static_cast<long>(colmap.size()) - 1;
  const std::size_t erow = colmap.size() * std::size_t(C);
  // Half a cell in steps and rows (cell rule), zero for the point rule.
  const bool cell = plan_.quadrature() == HexQuadrature::Cell;
  const double ct = cell ? 0.5 * dx / h : 0.0, cv = cell ? 0.5 * dy / hy : 0.0;
  // Each coefficient row adds the strip's rows (and their boundary images) in
  // its support, in order; a fixed channel count lets the inner loop unroll.
  auto rows_into = [&](auto channels) {
    constexpr int CC = decltype(channels)::value;
    const int Cn = CC > 0 ? CC : C;
    parallel_for(static_cast<long>(work.size()), threads, [&](long w0, long w1) {
      BoxSplineSlice s;
      BoxSplineBand band;
      const double inv_h = 1.0 / h, step = dx / h;
      // The strip columns [qa, qb] whose sample centres lie within reach of xn.
      auto columns = [&](double xn, double reach) {
        return std::pair<long, long>(
            std::max(q0, static_cast<long>(std::ceil((xn - reach) / dx - 0.5))),
            std::min(qlast, static_cast<long>(std::floor((xn + reach) / dx - 0.5))));
      };
      for (long w = w0; w < w1; ++w) {
        const long j = work[w];
        double* acc = acc_.row(j);
        const double yj = o.y + hy * j, xj = o.x + 0.5 * h * double(j & 1);
        for (long k = y0; k < y1; ++k) {
          const S* ext = strip + erow * (k - y0);
          for (long e : plan_.row_images(k)) {
            const double v = ((e + 0.5) * dy - yj) / hy;
            if (cell) {
              // weight of sample q: the integral of M over its cell in (t, v),
              // Y(right edge) - Y(left edge) of the band [v - cv, v + cv]
              if (!(std::abs(v) < n + cv)) continue;
              band.build(B, v - cv, v + cv);
              if (band.empty()) continue;
              const double reach = (n + ct) * h;
              for (long i = 0; i < Q; ++i) {
                const double xn = xj + h * i;
                const auto [qa, qb] = columns(xn, reach);
                double* a = acc + std::size_t(i) * Cn;
                double t = (qa * dx - xn) * inv_h;  // left edge of cell qa
                std::size_t hint = 0;
                double left = band.antiderivative(t, hint);
                for (long q = qa; q <= qb; ++q) {
                  t += step;
                  const double right = band.antiderivative(t, hint);
                  const double wgt = right - left;
                  left = right;
                  const S* src = ext + std::size_t(q - q0) * Cn;
                  for (int c = 0; c < Cn; ++c) a[c] += wgt * src[c];
                }
              }
              continue;
            }
            if (!(std::abs(v) < n)) continue;
            B.slice(v, s);
            const double reach = s.half_width * h;
            for (long i = 0; i < Q; ++i) {
              const double xn = xj + h * i;
              const auto [qa, qb] = columns(xn, reach);
              const double t0 = ((qa + 0.5) * dx - xn) * inv_h;
              double* a = acc + std::size_t(i) * Cn;
              const S* src = ext + std::size_t(qa - q0) * Cn;
              const long m = qb - qa + 1;
              if (m < 1) continue;
              if (B.order() == 1)
                slice_terms<1, CC>(s, t0, step, scale, m, src, a, Cn);
              else
                slice_terms<kMaxBoxSplineOrder, CC>(s, t0, step, scale, m, src, a, Cn);
            }
          }
        }
      }
    });
  };
  switch (C) {
    case 1: rows_into(std::integral_constant<int, 1>()); break;
    case 3: rows_into(std::integral_constant<int, 3>()); break;
    case 4: rows_into(std::integral_constant<int, 4>()); break;
    default: rows_into(std::integral_constant<int, 0>()); break;
  }
}

void HexAcquisition::add_rows(long y0, long y1, const float* rows) { add_in_order(y0, y1, rows); }
void HexAcquisition::add_rows(long y0, long y1, const double* rows) { add_in_order(y0, y1, rows); }

template <typename T>
void HexAcquisition::add_in_order(long y0, long y1, const T* rows) {
  if (!in_order_) in_order_ = std::make_unique<Band>(*this, threads_);
  if (y0 != next_row_ || y1 < y0 || y1 > plan_.input_height()) {
    std::ostringstream m;
    m << "HexAcquisition::add_rows(): rows [" << y0 << ", " << y1 << ") out of order (next row "
      << next_row_ << " of " << plan_.input_height() << ")";
    throw std::logic_error(m.str());
  }
  for (long y = y0; y < y1;) {
    const long b = bands_.of(y), e = std::min(y1, bands_.end(b));
    if (y == bands_.begin(b)) in_order_->begin(b);
    in_order_->add(y, e, rows + std::size_t(y - y0) * plan_.input_width() * plan_.channels());
    if (e == bands_.end(b)) in_order_->end();
    y = e;
  }
  next_row_ = y1;
}

void HexAcquisition::abandon() {
  std::lock_guard<std::mutex> lock(m_);
  abandoned_ = true;
  cv_.notify_all();
}

HexAcquisition::Band::Band(HexAcquisition& whole, int threads)
    : whole_(whole), threads_(threads < 1 ? 1 : threads), state_(whole.plan_.layout().rows, 0) {}

HexAcquisition::Band::~Band() = default;

void HexAcquisition::Band::begin(long band) {
  if (band_ >= 0) throw std::logic_error("HexAcquisition::Band::begin(): the last band did not end");
  if (band < 0 || band >= whole_.bands_.count() || whole_.ended_[band])
    throw std::logic_error("HexAcquisition::Band::begin(): band " + std::to_string(band) +
                           " is not one left to take");
  band_ = band;
  next_row_ = whole_.bands_.begin(band);
}

void HexAcquisition::Band::add_rows(long y0, long y1, const float* rows) { add(y0, y1, rows); }
void HexAcquisition::Band::add_rows(long y0, long y1, const double* rows) { add(y0, y1, rows); }

template <typename T>
void HexAcquisition::Band::add(long y0, long y1, const T* rows) {
  if (band_ < 0 || y0 != next_row_ || y1 > whole_.bands_.end(band_) || y1 < y0)
    throw std::logic_error("HexAcquisition::Band::add_rows(): rows out of the band's order");
  if (y1 == y0) return;
  std::vector<T>& ext = extended<T>();
  whole_.extend(y0, y1, rows, ext, threads_);
  // The coefficient rows it reaches: added to now where the earlier bands
  // that reach them are done with them (decided at the band's first touch),
  // else kept for end().
  std::vector<long> now, later;
  {
    std::lock_guard<std::mutex> lock(whole_.m_);
    for (long j : whole_.reached(y0, y1)) {
      if (!state_[j]) {
        const auto& rb = whole_.row_bands_[j];
        const long position = long(std::find(rb.begin(), rb.end(), band_) - rb.begin());
        state_[j] = whole_.done_[j] == position ? 1 : 2;
        touched_.push_back(j);
      }
      (state_[j] == 1 ? now : later).push_back(j);
    }
  }
  whole_.accumulate(ext.data(), y0, y1, now, threads_);
  if (!later.empty()) {
    // only the rows that reach them (rows between that do not add nothing)
    long a = y1, b = y0;
    for (long k = y0; k < y1; ++k)
      for (long j : whole_.reached(k, k + 1))
        if (std::binary_search(later.begin(), later.end(), j)) {
          a = std::min(a, k);
          b = std::max(b, k + 1);
          break;
        }
    const std::size_t erow = whole_.plan_.column_source().size() * std::size_t(whole_.plan_.channels());
    Kept k{a, b, {}, {}, later};
    if constexpr (std::is_same_v<T, float>)
      k.ext_f.assign(ext.begin() + (a - y0) * erow, ext.begin() + (b - y0) * erow);
    else
      k.ext_d.assign(ext.begin() + (a - y0) * erow, ext.begin() + (b - y0) * erow);
    if (b > a) kept_.push_back(std::move(k));
  }
  next_row_ = y1;
}

void HexAcquisition::Band::end() {
  if (band_ < 0 || next_row_ != whole_.bands_.end(band_))
    throw std::logic_error("HexAcquisition::Band::end(): the band's rows are not all added");
  // The kept rows' terms, once the earlier bands are done with their rows.
  std::vector<long> deferred;
  for (long j : touched_)
    if (state_[j] == 2) deferred.push_back(j);
  for (long j : deferred) {
    const auto& rb = whole_.row_bands_[j];
    const int position = int(std::find(rb.begin(), rb.end(), band_) - rb.begin());
    {
      std::unique_lock<std::mutex> lock(whole_.m_);
      whole_.cv_.wait(lock, [&] { return whole_.done_[j] == position || whole_.abandoned_; });
      if (whole_.done_[j] != position)
        throw std::runtime_error("HexAcquisition::Band::end(): an earlier band was abandoned");
    }
    const std::vector<long> one{j};
    for (const Kept& k : kept_) {
      if (std::find(k.rows.begin(), k.rows.end(), j) == k.rows.end()) continue;
      if (!k.ext_f.empty())
        whole_.accumulate(k.ext_f.data(), k.y0, k.y1, one, threads_);
      else
        whole_.accumulate(k.ext_d.data(), k.y0, k.y1, one, threads_);
    }
  }
  {
    std::lock_guard<std::mutex> lock(whole_.m_);
    for (long j : touched_) ++whole_.done_[j];
    whole_.ended_[band_] = 1;
  }
  whole_.cv_.notify_all();
  for (long j : touched_) state_[j] = 0;
  touched_.clear();
  kept_.clear();
  band_ = -1;
}

Coefficients HexAcquisition::finish() {
  const bool all = std::all_of(ended_.begin(), ended_.end(), [](char e) { return e != 0; });
  if (!all && next_row_ != plan_.input_height()) {
    std::ostringstream m;
    m << "HexAcquisition::finish(): only " << next_row_ << " of " << plan_.input_height()
      << " rows were added";
    throw std::logic_error(m.str());
  }
  Coefficients out;
  out.c = std::move(acc_);
  out.lattice = plan_.layout().lattice;
  out.box_spline = &plan_.generator();
  out.boundary = plan_.boundary();
  out.min_error = true;
  out.image_width = plan_.image_width();
  out.image_height = plan_.image_height();
  return out;
}

namespace {
template <typename T>
Coefficients acquire_grid(const Grid<T>& input, const HexAcquisitionPlan& plan, int threads) {
  if (input.width != plan.input_width() || input.height != plan.input_height() ||
      input.channels != plan.channels())
    throw std::invalid_argument("acquire(): image size does not match the hexagonal plan");
  HexAcquisition a(plan, threads);
  const long strip = 64;
  for (long y = 0; y < input.height; y += strip)
    a.add_rows(y, std::min(input.height, y + strip), input.row(y));
  return a.finish();
}
}  // namespace

Coefficients acquire(const Image& input, const HexAcquisitionPlan& plan, int threads) {
  return acquire_grid(input, plan, threads);
}
Coefficients acquire(const Grid<double>& input, const HexAcquisitionPlan& plan, int threads) {
  return acquire_grid(input, plan, threads);
}

}  // namespace sis
