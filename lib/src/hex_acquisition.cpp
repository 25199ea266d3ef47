#include "sis/hex_acquisition.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "sis/parallel.h"
#include "sis/weights.h"
#include "value_width.h"

namespace sis {

void HexAcquisitionPlan::AlignedGrid::rows_of(long e, double dy, double oy, double row_step,
                                              std::vector<std::pair<long, double>>& out) const {
  out.clear();
  const double dya = row_step / s2;
  // Aligned row r takes taps first(r) .. first(r) + 3, first(r) = floor(Y_r / dy - 1/2) - 1.
  const long r0 = static_cast<long>(std::floor(((e - 2.5) * dy - oy) / dya)) - 1;
  const long r1 = static_cast<long>(std::ceil(((e + 2.5) * dy - oy) / dya)) + 1;
  for (long r = r0; r <= r1; ++r) {
    const auto [first, f] = lagrange_base((oy + r * dya) / dy - 0.5);
    if (e < first || e > first + 3) continue;
    out.emplace_back(r, lagrange4(f)[e - first]);
  }
}

HexAcquisitionPlan::HexAcquisitionPlan(long input_width, long input_height, int channels,
                                       double image_width, double image_height,
                                       const HexLayout& layout, int order, Boundary boundary)
    : win_(input_width),
      hin_(input_height),
      channels_(channels),
      image_w_(image_width),
      image_h_(image_height),
      layout_(layout),
      spline_(&BoxSpline::hexagonal(order)),
      boundary_(boundary) {
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
  init_aligned();
}

namespace {
// The aligned grid's columns per lattice step (even) and rows per lattice
// row, and the columns held for `columns` lattice columns of order n.
struct AlignedSteps {
  int s1, s2;
  long columns;
};
AlignedSteps aligned_steps(double h, double hy, double dx, double dy, int n, long columns) {
  AlignedSteps a;
  a.s1 = std::max(2, 2 * static_cast<int>(std::lround(h / dx / 2)));
  a.s2 = std::max(1, static_cast<int>(std::lround(hy / dy)));
  a.columns = a.s1 * (columns - 1) + a.s1 / 2 + 2 * (n * a.s1) + 1;
  return a;
}
constexpr long kHexBandRows = 256;  // as kBandRows: the bands the files are read in
// Rows interpolated along x at once, at most: the interpolated piece stays
// small whatever the band's strips (a row of the aligned grid can be many
// times an input row when the frame is small against the lattice's margin).
constexpr long kPieceRows = 16;
}  // namespace

double hex_acquisition_bytes(long input_width, long input_height, int channels,
                             double image_width, double image_height, const HexLayout& layout,
                             int order, int bands_at_once, long band_rows, int sample_bytes) {
  const double dx = image_width / input_width, dy = image_height / input_height;
  const AlignedSteps a =
      aligned_steps(layout.step(), layout.row_step(), dx, dy, order, layout.columns);
  const double wt = 2.0 * order * a.s1 + 1, trows = 2.0 * order * a.s2 - 1;
  // the plan: the table and its rows' bounds; per aligned column its taps
  // (and the first taps while they are made) and the columns' sources; per
  // input row its boundary images (a vector each, with the allocator's
  // overhead), the extended rows the table reaches
  const double columns = double(a.columns);
  const double extended_rows =
      (layout.rows - 1 + 2.0 * order) * layout.row_step() / dy + 8;
  const double plan = trows * (wt * 8 + 8) + columns * (8 + 32 + 8) +
                      (columns * (layout.step() / a.s1) / dx + 8) * 8 +
                      double(input_height) * 48 + extended_rows * 8;
  // per band at once: a piece of interpolated rows, the per-coefficient-row
  // state, each thread's combined table row
  const double rows = band_rows < 1 ? kHexBandRows : band_rows;
  const double band = kPieceRows * columns * channels * sample_bytes + double(layout.rows) * 16 +
                      wt * 8;
  // The slots: a coefficient row's inputs span (2 n - 1) lattice rows and
  // the 4 taps of the vertical interpolation on each side, so a band
  // boundary (the wrap of the periodic rule one more) lies in at most
  // 2 n + 1 + 4 dy / hy + 1 coefficient rows' spans; each of them has a slot
  // per boundary it holds, of a coefficient row's values in double.
  const double boundaries = std::ceil(input_height / rows) + 1;
  const double slots = boundaries * (2.0 * order + 2 + 4 * dy / layout.row_step()) *
                       double(layout.columns) * channels * 8;
  return plan + (bands_at_once < 1 ? 1 : bands_at_once) * band + slots +
         double(layout.rows) * 8 * (input_height / rows + 4);
}

void HexAcquisitionPlan::init_aligned() {
  AlignedGrid& g = aligned_;
  const int n = spline_->order();
  const double h = layout_.step(), hy = layout_.row_step();
  const Vec2 o = layout_.lattice.origin();
  const AlignedSteps steps = aligned_steps(h, hy, dx_, dy_, n, layout_.columns);
  g.s1 = steps.s1;
  g.s2 = steps.s2;
  g.half = n * g.s1;
  g.reach = n * g.s2;
  const double dxa = h / g.s1, dya = hy / g.s2;
  // Every lattice point of stored row j sits on aligned column
  // s1 i + (s1 / 2)(j mod 2) and row s2 j; the table reaches half columns and
  // reach - 1 rows around it.
  g.m0 = -g.half;
  g.columns = steps.columns;
  std::vector<long> first(g.columns);
  g.x_weight.resize(g.columns);
  long qlo = 0, qhi = -1;
  for (long m = 0; m < g.columns; ++m) {
    const auto [q, f] = lagrange_base((o.x + (g.m0 + m) * dxa) / dx_ - 0.5);
    first[m] = q;
    g.x_weight[m] = lagrange4(f);
    if (m == 0 || q < qlo) qlo = q;
    if (m == 0 || q + 3 > qhi) qhi = q + 3;
  }
  q0_ = qlo;
  for (long q = qlo; q <= qhi; ++q) colmap_.push_back(extend_index(q, win_, boundary_));
  g.x_first.resize(g.columns);
  for (long m = 0; m < g.columns; ++m) g.x_first[m] = first[m] - q0_;
  // The table: M_n at (t dxa, dr dya) from the lattice point, t in lattice
  // steps t / s1 and v = dr / s2 rows, times dxa dya / |det L| = 1 / (s1 s2).
  const int wt = 2 * g.half + 1;
  g.table.assign(std::size_t(2 * g.reach - 1) * wt, 0.0);
  BoxSplineSlice slice;
  for (int dr = -g.reach + 1; dr < g.reach; ++dr) {
    spline_->slice(double(dr) / g.s2, slice);
    for (int t = -g.half; t <= g.half; ++t) {
      const double u = double(t) / g.s1;
      if (!(std::abs(u) < slice.half_width)) continue;
      g.table[std::size_t(dr + g.reach - 1) * wt + (t + g.half)] =
          slice.eval(u) / (double(g.s1) * g.s2);
    }
  }
  g.first.assign(2 * g.reach - 1, wt);
  g.last.assign(2 * g.reach - 1, -1);
  for (int row = 0; row < 2 * g.reach - 1; ++row)
    for (int t = 0; t < wt; ++t)
      if (g.table[std::size_t(row) * wt + t] != 0.0) {
        g.first[row] = std::min(g.first[row], t);
        g.last[row] = std::max(g.last[row], t);
      }
  // Extended rows: every tap of an aligned row the table reaches.
  const long r_lo = -(g.reach - 1), r_hi = long(g.s2) * (layout_.rows - 1) + g.reach - 1;
  const long e0 = lagrange_base((o.y + r_lo * dya) / dy_ - 0.5).first;
  const long e1 = lagrange_base((o.y + r_hi * dya) / dy_ - 0.5).first + 3;
  images_.resize(hin_);
  for (long e = e0; e <= e1; ++e) images_[extend_index(e, hin_, boundary_)].push_back(e);
}

HexAcquisition::HexAcquisition(const HexAcquisitionPlan& plan, int threads, long band_rows)
    : plan_(plan),
      threads_(threads < 1 ? 1 : threads),
      acc_(plan.layout().columns, plan.layout().rows, plan.channels()),
      bands_(plan.input_height(), band_rows < 1 ? kHexBandRows : band_rows),
      ended_(bands_.count()) {
  for (auto& e : ended_) e = 0;
  std::vector<std::vector<long>> row_bands(plan.layout().rows);  // ascending: b increases
  for (long b = 0; b < bands_.count(); ++b)
    for (long j : reached(bands_.begin(b), bands_.end(b))) row_bands[j].push_back(b);
  slots_ = BandSlots<double>(row_bands, bands_.count(), acc_.row_size());
}

HexAcquisition::~HexAcquisition() = default;

std::vector<long> HexAcquisition::reached(long y0, long y1) const {
  const HexLayout& L = plan_.layout();
  const long R = L.rows;
  const double hy = L.row_step(), dy = plan_.sample_dy();
  const Vec2 o = L.lattice.origin();
  const auto& g = plan_.aligned();
  std::vector<char> touched(R, 0);
  std::vector<std::pair<long, double>> rows;
  for (long k = y0; k < y1; ++k)
    for (long e : plan_.row_images(k)) {
      g.rows_of(e, dy, o.y, hy, rows);
      for (const auto& [r, w] : rows) {
        // lattice rows j with |r - s2 j| < reach
        const long j0 = std::max(0L, static_cast<long>(std::floor(double(r - g.reach) / g.s2)) + 1);
        const long j1 = std::min(R - 1, static_cast<long>(std::ceil(double(r + g.reach) / g.s2)) - 1);
        for (long j = j0; j <= j1; ++j) touched[j] = 1;
      }
    }
  std::vector<long> work;
  for (long j = 0; j < R; ++j)
    if (touched[j]) work.push_back(j);
  return work;
}

template <typename T>
void HexAcquisition::interpolate(long y0, long y1, const T* rows, std::vector<T>& out,
                                 int threads) const {
  const int C = plan_.channels();
  const long win = plan_.input_width();
  const auto& g = plan_.aligned();
  const std::vector<long>& colmap = plan_.column_source();
  const std::size_t orow = std::size_t(g.columns) * C;
  out.resize(orow * (y1 - y0));
  // A column's 4 taps are 4 neighbouring input columns but near the edges,
  // where the boundary rule folds them: there they are gathered one by one.
  auto rows_of = [&](auto channels) {
    constexpr int CC = decltype(channels)::value;
    const int Cn = CC > 0 ? CC : C;
    parallel_for(y1 - y0, threads, [&](long r0, long r1) {
      for (long r = r0; r < r1; ++r) {
        const T* in = rows + std::size_t(r) * win * Cn;
        T* o = out.data() + orow * r;
        for (long m = 0; m < g.columns; ++m, o += Cn) {
          const long* q = colmap.data() + g.x_first[m];
          const auto& w = g.x_weight[m];
          if (q[1] == q[0] + 1 && q[2] == q[0] + 2 && q[3] == q[0] + 3) {
            const T* p = in + q[0] * Cn;
            for (int c = 0; c < Cn; ++c)
              o[c] = static_cast<T>(w[0] * p[c] + w[1] * p[Cn + c] + w[2] * p[2 * Cn + c] +
                                    w[3] * p[3 * Cn + c]);
          } else {
            for (int c = 0; c < Cn; ++c)
              o[c] = static_cast<T>(w[0] * in[q[0] * Cn + c] + w[1] * in[q[1] * Cn + c] +
                                    w[2] * in[q[2] * Cn + c] + w[3] * in[q[3] * Cn + c]);
          }
        }
      }
    });
  };
  with_width(C, rows_of);
}

std::size_t HexAcquisition::strip_row_size() const {
  return std::size_t(plan_.aligned().columns) * plan_.channels();
}

namespace {
// Coefficient row j takes, from each extended row e of the strip
// (interpolated along x onto the aligned columns), the table rows of the
// aligned rows e serves weighted by e's vertical tap: one row of at most
// 2 half + 1 weights, applied at every lattice point of the row.
template <int CC, typename S>
void aligned_terms(const double* u, int n, const S* src, double* a, int C) {
  const int Cn = CC > 0 ? CC : C;
  double sum[CC > 0 ? CC : 1];
  if constexpr (CC > 0)
    for (int c = 0; c < CC; ++c) sum[c] = a[c];
  for (int t = 0; t < n; ++t, src += Cn) {
    const double w = u[t];
    if constexpr (CC > 0) {
      for (int c = 0; c < CC; ++c) sum[c] += w * src[c];
    } else {
      for (int c = 0; c < Cn; ++c) a[c] += w * src[c];
    }
  }
  if constexpr (CC > 0)
    for (int c = 0; c < CC; ++c) a[c] = sum[c];
}

// aligned_terms for four lattice points of a row at once (coefficients a,
// a + CC, a + 2 CC, a + 3 CC; their strips `stride` values apart): each
// point's sums in the same order as aligned_terms, so the same bits, with
// the four points' additions interleaved so that they do not wait on each
// other.
template <int CC, typename S>
void aligned_terms4(const double* u, int n, const S* src, std::size_t stride, double* a) {
  double s0[CC], s1[CC], s2[CC], s3[CC];
  for (int c = 0; c < CC; ++c) {
    s0[c] = a[c];
    s1[c] = a[CC + c];
    s2[c] = a[2 * CC + c];
    s3[c] = a[3 * CC + c];
  }
  const S* p0 = src;
  const S* p1 = src + stride;
  const S* p2 = src + 2 * stride;
  const S* p3 = src + 3 * stride;
  for (int t = 0; t < n; ++t, p0 += CC, p1 += CC, p2 += CC, p3 += CC) {
    const double w = u[t];
    for (int c = 0; c < CC; ++c) {
      s0[c] += w * p0[c];
      s1[c] += w * p1[c];
      s2[c] += w * p2[c];
      s3[c] += w * p3[c];
    }
  }
  for (int c = 0; c < CC; ++c) {
    a[c] = s0[c];
    a[CC + c] = s1[c];
    a[2 * CC + c] = s2[c];
    a[3 * CC + c] = s3[c];
  }
}

}  // namespace

template <typename S>
void HexAcquisition::accumulate(const S* strip, long y0, long y1, const std::vector<long>& work,
                                double* const* dest, int threads) {
  if (work.empty()) return;
  const HexLayout& L = plan_.layout();
  const int C = plan_.channels();
  const long Q = L.columns;
  const double hy = L.row_step(), dy = plan_.sample_dy();
  const Vec2 o = L.lattice.origin();
  const std::size_t erow = strip_row_size();
  const auto& g = plan_.aligned();
  const int wt = 2 * g.half + 1;
  auto rows_into = [&](auto channels) {
    constexpr int CC = decltype(channels)::value;
    const int Cn = CC > 0 ? CC : C;
    parallel_for(static_cast<long>(work.size()), threads, [&](long w0, long w1) {
      std::vector<std::pair<long, double>> rows;
      std::vector<double> u(wt);
      for (long w = w0; w < w1; ++w) {
        const long j = work[w];
        double* acc = dest[j];
        const long shift = (g.s1 / 2) * (j & 1);
        for (long k = y0; k < y1; ++k) {
          const S* hk = strip + erow * (k - y0);
          for (long e : plan_.row_images(k)) {
            g.rows_of(e, dy, o.y, hy, rows);
            std::fill(u.begin(), u.end(), 0.0);
            int lo = wt, hi = -1;  // the nonzero taps of u
            for (const auto& [r, ly] : rows) {
              const long dr = r - long(g.s2) * j;
              if (dr <= -g.reach || dr >= g.reach || ly == 0.0) continue;
              const std::size_t row = std::size_t(dr + g.reach - 1);
              const double* t = g.table.data() + row * wt;
              for (int q = g.first[row]; q <= g.last[row]; ++q) u[q] += ly * t[q];
              lo = std::min(lo, g.first[row]);
              hi = std::max(hi, g.last[row]);
            }
            if (hi < lo) continue;
            long i = 0;
            if constexpr (CC > 0)
              for (; i + 4 <= Q; i += 4)
                aligned_terms4<CC>(u.data() + lo, hi - lo + 1,
                                   hk + std::size_t(g.s1 * i + shift + lo) * Cn,
                                   std::size_t(g.s1) * Cn, acc + std::size_t(i) * Cn);
            for (; i < Q; ++i)
              aligned_terms<CC>(u.data() + lo, hi - lo + 1,
                                hk + std::size_t(g.s1 * i + shift + lo) * Cn,
                                acc + std::size_t(i) * Cn, Cn);
          }
        }
      }
    });
  };
  with_width(C, rows_into);
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

HexAcquisition::Band::Band(HexAcquisition& whole, int threads)
    : whole_(whole), threads_(threads < 1 ? 1 : threads), dest_(whole.plan_.layout().rows, nullptr) {}

HexAcquisition::Band::~Band() = default;

void HexAcquisition::Band::begin(long band) {
  if (band_ >= 0) throw std::logic_error("HexAcquisition::Band::begin(): the last band did not end");
  char untaken = 0;
  if (band < 0 || band >= whole_.bands_.count() ||
      !whole_.ended_[band].compare_exchange_strong(untaken, 1))
    throw std::logic_error("HexAcquisition::Band::begin(): band " + std::to_string(band) +
                           " is not one left to take");
  band_ = band;
  next_row_ = whole_.bands_.begin(band);
}

void HexAcquisition::Band::add_rows(long y0, long y1, const float* rows) { add(y0, y1, rows); }
void HexAcquisition::Band::add_rows(long y0, long y1, const double* rows) { add(y0, y1, rows); }

template <typename T>
void HexAcquisition::add_pieces(long y0, long y1, const T* rows, const std::vector<long>& js,
                                double* const* dest, std::vector<T>& ext, int threads) {
  const std::size_t in_row = std::size_t(plan_.input_width()) * plan_.channels();
  for (long y = y0; y < y1; y += kPieceRows) {
    const long e = std::min(y1, y + kPieceRows);
    interpolate(y, e, rows + (y - y0) * in_row, ext, threads);
    accumulate(ext.data(), y, e, js, dest, threads);
  }
}

template <typename T>
void HexAcquisition::Band::add(long y0, long y1, const T* rows) {
  if (band_ < 0 || y0 != next_row_ || y1 > whole_.bands_.end(band_) || y1 < y0)
    throw std::logic_error("HexAcquisition::Band::add_rows(): rows out of the band's order");
  if (y1 == y0) return;
  // The coefficient rows it reaches, each at its first touch given its
  // destination: the row itself for its first band (zero until then), else
  // this band's slot, zeroed.
  const std::vector<long> js = whole_.reached(y0, y1);
  for (long j : js) {
    if (dest_[j]) continue;
    double* slot = whole_.slots_.slot(j, band_);
    if (slot) std::fill(slot, slot + whole_.acc_.row_size(), 0.0);
    dest_[j] = slot ? slot : whole_.acc_.row(j);
    touched_.push_back(j);
  }
  whole_.add_pieces(y0, y1, rows, js, dest_.data(), extended<T>(), threads_);
  next_row_ = y1;
}

void HexAcquisition::Band::end() {
  if (band_ < 0 || next_row_ != whole_.bands_.end(band_))
    throw std::logic_error("HexAcquisition::Band::end(): the band's rows are not all added");
  for (long j : touched_) dest_[j] = nullptr;
  touched_.clear();
  const long b = band_;
  band_ = -1;
  whole_.ended_[b] = 2;
  Grid<double>& acc = whole_.acc_;
  whole_.slots_.ended(b, [&](long j, const double* slot) {
    double* row = acc.row(j);
    for (std::size_t q = 0; q < acc.row_size(); ++q) row[q] += slot[q];
  });
}

BandPartial<double> HexAcquisition::partial(std::vector<long>* taken) const {
  taken->clear();
  for (long b = 0; b < long(ended_.size()); ++b) {
    if (ended_[b] == 1) throw std::logic_error("HexAcquisition::partial(): a band in progress");
    if (ended_[b] == 2) taken->push_back(b);
  }
  return slots_.partial(*taken, [&](long j, double* out) {
    std::copy(acc_.row(j), acc_.row(j) + acc_.row_size(), out);
  });
}

void HexAcquisition::absorb(const BandPartial<double>& p, const std::vector<long>& taken) {
  for (long b : taken)
    if (b < 0 || b >= long(ended_.size()) || ended_[b] != 0)
      throw std::invalid_argument("band " + std::to_string(b) + " out of range or already taken");
  slots_.absorb(
      p, taken,
      [&](long j, const double* v) { std::copy(v, v + acc_.row_size(), acc_.row(j)); },
      [&](long j, const double* slot) {
        double* row = acc_.row(j);
        for (std::size_t q = 0; q < acc_.row_size(); ++q) row[q] += slot[q];
      });
  for (long b : taken) ended_[b] = 2;
}

Coefficients HexAcquisition::finish() {
  const long ended =
      std::count_if(ended_.begin(), ended_.end(), [](const std::atomic<char>& e) { return e == 2; });
  if (ended != long(ended_.size())) {
    std::ostringstream m;
    m << "HexAcquisition::finish(): only " << ended << " of " << ended_.size()
      << " bands of rows were added (next row " << next_row_ << " of " << plan_.input_height()
      << ")";
    throw std::logic_error(m.str());
  }
  in_order_.reset();
  slots_ = BandSlots<double>();
  Coefficients out;
  out.c = std::move(acc_);
  out.lattice = plan_.layout().lattice;
  out.space = HexagonalSpace{plan_.generator().order(), 1.0 / std::abs(out.lattice.determinant())};
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
