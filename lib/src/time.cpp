#include "sis/time.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "sis/generator.h"

namespace sis {

namespace {

std::string num(double x) {
  std::ostringstream o;
  o.precision(17);
  o << x;
  return o.str();
}

// 4-point Gauss-Legendre on [lo, hi]: exact for polynomials of degree <= 7
// (a shutter piece of degree <= 3 times a B-spline piece of degree <= 3).
template <class F>
double gauss4(F f, double lo, double hi) {
  static const double x[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                              0.8611363115940526};
  static const double w[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                              0.3478548451374538};
  const double c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  double s = 0;
  for (int i = 0; i < 4; ++i) s += w[i] * f(c + h * x[i]);
  return s * h;
}

// Integral of f over [lo, hi], split at the sorted breakpoints.
template <class F>
double piecewise_integral(F f, double lo, double hi, std::vector<double> bp) {
  bp.push_back(lo);
  bp.push_back(hi);
  std::sort(bp.begin(), bp.end());
  double s = 0;
  for (size_t i = 0; i + 1 < bp.size(); ++i) {
    const double a = std::max(lo, bp[i]), b = std::min(hi, bp[i + 1]);
    if (b > a) s += gauss4(f, a, b);
  }
  return s;
}

}  // namespace

void Shutter::check() const {
  if (!(angle > 0 && angle <= 360))
    throw std::invalid_argument("shutter: angle " + num(angle) + " outside (0, 360]");
  if (!std::isfinite(phase)) throw std::invalid_argument("shutter: phase is not finite");
  if (curve == ShutterCurve::Table) {
    if (table_u.size() < 2 || table_u.size() != table_weight.size())
      throw std::invalid_argument("shutter: a curve table needs at least two (u, weight) rows");
    double total = 0;
    for (size_t i = 0; i < table_u.size(); ++i) {
      if (!(table_u[i] >= 0 && table_u[i] <= 1))
        throw std::invalid_argument("shutter: table time " + num(table_u[i]) + " outside [0, 1]");
      if (i > 0 && !(table_u[i] > table_u[i - 1]))
        throw std::invalid_argument("shutter: table times not increasing at row " +
                                    std::to_string(i + 1));
      if (!(table_weight[i] >= 0) || !std::isfinite(table_weight[i]))
        throw std::invalid_argument("shutter: table weight " + num(table_weight[i]) +
                                    " is negative or not finite");
      total += table_weight[i];
    }
    if (!(total > 0)) throw std::invalid_argument("shutter: table weights are all zero");
  }
}

double Shutter::open(double T, double fps) const { return T + phase / 360.0 / fps; }
double Shutter::close(double T, double fps) const { return T + (phase + angle) / 360.0 / fps; }

double Shutter::weight(double t, double T, double fps) const {
  const double o = open(T, fps), c = close(T, fps);
  if (t < o || t >= c) return 0;
  const double u = (t - o) / (c - o);
  switch (curve) {
    case ShutterCurve::Box: return 1;
    case ShutterCurve::Tent: return bspline(1, 2 * u - 1);
    case ShutterCurve::Cubic: return bspline(3, 4 * u - 2);
    case ShutterCurve::Table: {
      if (u < table_u.front() || u > table_u.back()) return 0;
      size_t i = std::upper_bound(table_u.begin(), table_u.end(), u) - table_u.begin();
      if (i >= table_u.size()) return table_weight.back();
      const double f = (u - table_u[i - 1]) / (table_u[i] - table_u[i - 1]);
      return (1 - f) * table_weight[i - 1] + f * table_weight[i];
    }
  }
  return 0;
}

std::vector<double> Shutter::breakpoints(double T, double fps) const {
  const double o = open(T, fps), c = close(T, fps);
  std::vector<double> bp = {o, c};
  if (curve == ShutterCurve::Tent) bp.push_back(0.5 * (o + c));
  if (curve == ShutterCurve::Cubic)
    for (int j = 1; j < 4; ++j) bp.push_back(o + j * (c - o) / 4);
  if (curve == ShutterCurve::Table)
    for (double u : table_u) bp.push_back(o + u * (c - o));
  return bp;
}

Shutter parse_shutter(const std::string& angle_phase, const std::string& curve) {
  Shutter s;
  const auto colon = angle_phase.find(':');
  auto parse = [&](const std::string& text, const char* what) {
    size_t used = 0;
    double v;
    try {
      v = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size() || !std::isfinite(v))
      throw std::invalid_argument("--shutter: " + std::string(what) + " '" + text +
                                  "' is not a number");
    return v;
  };
  s.angle = parse(angle_phase.substr(0, colon), "angle");
  if (colon != std::string::npos) s.phase = parse(angle_phase.substr(colon + 1), "phase");
  if (curve == "box") {
    s.curve = ShutterCurve::Box;
  } else if (curve == "tent") {
    s.curve = ShutterCurve::Tent;
  } else if (curve == "cubic") {
    s.curve = ShutterCurve::Cubic;
  } else {
    s.curve = ShutterCurve::Table;
    std::ifstream in(curve);
    if (!in) throw std::invalid_argument("--shutter-curve: cannot read '" + curve + "'");
    std::string line;
    int row = 0;
    while (std::getline(in, line)) {
      ++row;
      const auto h = line.find('#');
      if (h != std::string::npos) line.resize(h);
      std::istringstream ls(line);
      double u, w;
      if (!(ls >> u)) continue;
      std::string rest;
      if (!(ls >> w) || (ls >> rest))
        throw std::invalid_argument("--shutter-curve: " + curve + " line " + std::to_string(row) +
                                    ": expected two numbers (time in [0, 1], weight)");
      s.table_u.push_back(u);
      s.table_weight.push_back(w);
    }
    try {
      s.check();
    } catch (const std::exception& e) {
      throw std::invalid_argument("--shutter-curve: " + curve + ": " + e.what());
    }
  }
  try {
    s.check();
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("--shutter: ") + e.what());
  }
  return s;
}

void check_times(const std::vector<double>& t) {
  if (t.size() < 2)
    throw std::invalid_argument("time: " + std::to_string(t.size()) +
                                " sub-frame(s); space-time projection needs at least two");
  for (size_t k = 0; k < t.size(); ++k) {
    if (!std::isfinite(t[k]))
      throw std::invalid_argument("time: sub-frame " + std::to_string(k) + " time is not finite");
    if (k > 0 && t[k] == t[k - 1])
      throw std::invalid_argument("time: sub-frames " + std::to_string(k - 1) + " and " +
                                  std::to_string(k) + " have the same time " + num(t[k]));
    if (k > 0 && t[k] < t[k - 1])
      throw std::invalid_argument("time: sub-frame " + std::to_string(k) + " time " + num(t[k]) +
                                  " is before the previous one " + num(t[k - 1]));
  }
}

void time_span(const std::vector<double>& t, double& a, double& b) {
  check_times(t);
  const size_t K = t.size();
  a = t[0] - 0.5 * (t[1] - t[0]);
  b = t[K - 1] + 0.5 * (t[K - 1] - t[K - 2]);
}

std::vector<double> time_quadrature_weights(const std::vector<double>& t) {
  double a, b;
  time_span(t, a, b);
  const size_t K = t.size();
  std::vector<double> q(K);
  for (size_t k = 0; k < K; ++k) {
    const double lo = k == 0 ? a : 0.5 * (t[k - 1] + t[k]);
    const double hi = k + 1 == K ? b : 0.5 * (t[k] + t[k + 1]);
    q[k] = hi - lo;
  }
  return q;
}

const char* time_model_name(TimeModel model) {
  switch (model) {
    case TimeModel::Hold: return "hold";
    case TimeModel::Linear: return "linear";
    case TimeModel::Cubic: return "cubic";
  }
  return "?";
}

TimeModel parse_time_model(const std::string& spelling) {
  if (spelling == "hold") return TimeModel::Hold;
  if (spelling == "linear") return TimeModel::Linear;
  if (spelling == "cubic") return TimeModel::Cubic;
  throw std::invalid_argument("--time-model: '" + spelling +
                              "' is not a model (hold, linear or cubic)");
}

namespace {

// The first k in [lo, hi) with pred(k) true, pred monotone (false then true);
// hi when none.
template <class P>
int first_true(int lo, int hi, P pred) {
  while (lo < hi) {
    const int mid = lo + (hi - lo) / 2;
    if (pred(mid)) hi = mid; else lo = mid + 1;
  }
  return lo;
}

}  // namespace

void TimeProjection::add(int i, int k, double v) {
  Row& row = rows_[i];
  if (row.v.empty()) {
    row.k0 = k;
    row.v.push_back(v);
    return;
  }
  if (k < row.k0) {
    row.v.insert(row.v.begin(), static_cast<size_t>(row.k0 - k), 0.0);
    row.k0 = k;
  }
  const size_t at = static_cast<size_t>(k - row.k0);
  if (at >= row.v.size()) row.v.resize(at + 1, 0.0);
  row.v[at] += v;
}

// Acquisition of the Linear and Cubic models on the span [lo, hi] = [a, b]
// (both knots): A[i][k] = (1/S) integral over [lo, hi] of
// L_k(t) b_D((t - origin)/S - m) dt for m = first + i, over the model's
// pieces [t_k, t_k+1] (and the half cells [lo, t_0], [t_K-1, hi] on the
// nearest gap's polynomial), L_k the Lagrange basis of the piece's nodes. Each
// piece of the integrand is a polynomial of degree <= 3 + 3 between the
// B-spline's knots: gauss4 is exact. Only the pieces under row i's support.
void TimeProjection::acquire_interpolated(double lo_all, double hi_all) {
  const std::vector<double>& t = t_;
  const int K = static_cast<int>(t.size());
  const int q = model_ == TimeModel::Linear ? 1 : std::min(3, K - 1);  // nodes q + 1
  const double r = 0.5 * (degree_ + 1), S = step_;
  for (int i = 0; i < count_; ++i) {
    const int m = first_ + i;
    const double s0 = std::max(lo_all, origin_ + S * (m - r));
    const double s1 = std::min(hi_all, origin_ + S * (m + r));
    if (!(s1 > s0)) continue;
    // pieces -1 .. K-1 meeting (s0, s1): piece p spans [t_p, t_p+1]
    const int p0 = first_true(0, K, [&](int k) { return t[k] > s0; }) - 1;
    const int p1 = first_true(0, K, [&](int k) { return t[k] >= s1; }) - 1;
    std::vector<double> bp;
    for (int j = 0; j <= degree_ + 1; ++j) bp.push_back(origin_ + S * (m - r + j));
    for (int piece = p0; piece <= p1; ++piece) {
      const double lo = std::max(s0, piece < 0 ? lo_all : t[piece]);
      const double hi = std::min(s1, piece + 1 >= K ? hi_all : t[piece + 1]);
      if (!(hi > lo)) continue;
      const int gap = std::clamp(piece, 0, K - 2);                  // the gap whose polynomial
      const int j0 = std::clamp(gap - (q - 1) / 2, 0, K - 1 - q);  // nodes j0 .. j0 + q
      for (int k = j0; k <= j0 + q; ++k) {
        auto basis = [&](double x) {
          double v = 1;
          for (int j = j0; j <= j0 + q; ++j)
            if (j != k) v *= (x - t[j]) / (t[k] - t[j]);
          return v;
        };
        add(i, k,
            piecewise_integral(
                [&](double x) { return basis(x) * bspline(degree_, (x - origin_) / S - m); }, lo,
                hi, bp) /
                S);
      }
    }
  }
}

// Acquisition of the hold: each sub-frame held over its own cell, the cells
// mirrored about a and b; (1/S) integral of b_D(t/S - m) over a cell,
// exactly, from the cumulative B-spline. Only the cells under row i's
// support and its two mirror images.
void TimeProjection::acquire_hold(double a, double b) {
  const std::vector<double>& t = t_;
  const int K = static_cast<int>(t.size());
  const double r = 0.5 * (degree_ + 1), S = step_;
  auto cell_lo = [&](int k) { return k == 0 ? a : 0.5 * (t[k - 1] + t[k]); };
  auto cell_hi = [&](int k) { return k + 1 == K ? b : 0.5 * (t[k] + t[k + 1]); };
  for (int i = 0; i < count_; ++i) {
    const int m = first_ + i;
    auto cell = [&](double lo, double hi) {
      return bspline_cumulative(degree_, hi / S - m) - bspline_cumulative(degree_, lo / S - m);
    };
    // the cells meeting the support or one of its images about a and b
    int k0 = K, k1 = -1;
    auto cover = [&](double x0, double x1) {
      x0 = std::max(x0, a);
      x1 = std::min(x1, b);
      if (!(x1 > x0)) return;
      k0 = std::min(k0, first_true(0, K, [&](int k) { return cell_hi(k) > x0; }));
      k1 = std::max(k1, first_true(0, K, [&](int k) { return cell_lo(k) >= x1; }) - 1);
    };
    cover(S * (m - r), S * (m + r));
    cover(2 * a - S * (m + r), 2 * a - S * (m - r));
    cover(2 * b - S * (m + r), 2 * b - S * (m - r));
    for (int k = k0; k <= k1; ++k) {
      const double lo = cell_lo(k), hi = cell_hi(k);
      add(i, k, cell(lo, hi) + cell(2 * a - hi, 2 * a - lo) + cell(2 * b - hi, 2 * b - lo));
    }
  }
}

void TimeProjection::factor(const std::function<double(int, int)>& gram) {
  // banded Cholesky of the Gram matrix (symmetric positive definite: the
  // Gram matrix of independent functions, or the folded autocorrelation,
  // which the DCT-II diagonalises with the positive spectrum of b_D's
  // autocorrelation); every entry within the band |i - j| <= bw
  bw_ = std::min(degree_, count_ - 1);
  const int w = bw_ + 1;
  L_.assign(static_cast<size_t>(count_) * w, 0.0);
  auto at = [&](int i, int j) -> double& { return L_[static_cast<size_t>(i) * w + (j - i + bw_)]; };
  for (int i = 0; i < count_; ++i)
    for (int j = std::max(0, i - bw_); j <= i; ++j) {
      double s = gram(i, j);
      for (int k = std::max(0, i - bw_); k < j; ++k) s -= at(i, k) * at(j, k);
      if (i == j) {
        if (!(s > 0))
          throw std::invalid_argument("TimeProjection(): the temporal Gram matrix is singular");
        at(i, i) = std::sqrt(s);
      } else {
        at(i, j) = s / at(j, j);
      }
    }
}

void TimeProjection::solve(std::vector<double>& x) const {
  const int w = bw_ + 1;
  auto at = [&](int i, int j) { return L_[static_cast<size_t>(i) * w + (j - i + bw_)]; };
  for (int i = 0; i < count_; ++i) {
    double s = x[i];
    for (int k = std::max(0, i - bw_); k < i; ++k) s -= at(i, k) * x[k];
    x[i] = s / at(i, i);
  }
  for (int i = count_ - 1; i >= 0; --i) {
    double s = x[i];
    for (int k = i + 1; k <= std::min(count_ - 1, i + bw_); ++k) s -= at(k, i) * x[k];
    x[i] = s / at(i, i);
  }
}

TimeProjection::TimeProjection(std::vector<double> times, int degree, double step,
                               TimeModel model)
    : t_(std::move(times)), degree_(degree), step_(step), model_(model) {
  if (degree < 0 || degree > kMaxTimeDegree)
    throw std::invalid_argument("TimeProjection(): time degree " + std::to_string(degree) +
                                " outside [0, 3]");
  if (!(step > 0) || !std::isfinite(step))
    throw std::invalid_argument("TimeProjection(): time step " + num(step) +
                                " is not a positive number");
  double a, b;
  time_span(t_, a, b);
  const double r = 0.5 * (degree + 1);
  // the lattice must stay a size to hold (and an int to index)
  if ((b - a) / step > 1e7)
    throw std::invalid_argument("--time-step " + num(step) + ": " + num((b - a) / step) +
                                " steps across the sub-frames' span of " + num(b - a) +
                                " s; at most 1e7");
  if (model_ != TimeModel::Hold) {
    // The interpolating models: the least-squares projection of the model on
    // the span [a, b] itself, on a lattice whose knots are a + S' j,
    // j = 0 .. N: N = max(1, round((b - a) / S)) steps of S' = (b - a) / N,
    // the step asked rounded so that both ends of the span are knots. Every
    // B-spline meeting (a, b) overlaps it by a whole knot interval or more (a
    // well-posed Gram matrix), nothing is extrapolated beyond the span, and
    // polynomials the model and the space both hold are reproduced on the
    // whole span, ends included. Coefficient m's centre is origin + S' m.
    const int N = std::max(1, static_cast<int>(std::lround((b - a) / step)));
    step_ = (b - a) / N;
    origin_ = a + step_ * (r - std::floor(r));
    const int fr = static_cast<int>(std::floor(r));
    first_ = fr - degree;  // support (m - fr, m - fr + D + 1) in knot indices meets (0, N)
    count_ = N + degree;
    rows_.assign(count_, Row{});
    acquire_interpolated(a, b);
    const double S = step_, o0 = origin_;
    factor([&](int i, int j) {
      const int m = first_ + i, n = first_ + j;
      const double s0 = std::max(a, o0 + S * (std::max(m, n) - r));
      const double s1 = std::min(b, o0 + S * (std::min(m, n) + r));
      if (!(s1 > s0)) return 0.0;
      std::vector<double> bp;
      for (int k = 0; k <= degree + 1; ++k) bp.push_back(o0 + S * (m - r + k));
      return piecewise_integral(
                 [&](double x) {
                   return bspline(degree, (x - o0) / S - m) * bspline(degree, (x - o0) / S - n);
                 },
                 s0, s1, bp) /
             S;
    });
    return;
  }
  // the hold's cells are mirrored once about each end: exact while the span
  // is longer than a B-spline's support, and refused otherwise (the weights
  // would no longer sum to 1)
  if ((degree + 1) * step > b - a)
    throw std::invalid_argument(
        "time: the hold model needs the sub-frames' span (" + num(b - a) +
        " s) to be longer than a B-spline's support (" + std::to_string(degree + 1) +
        " steps of " + num(step) + " s): a smaller --time-step, a lower --time-degree or more "
        "sub-frames");
  // every m with (m - r, m + r) meeting (a/S, b/S)
  first_ = static_cast<int>(std::floor(a / step - r)) + 1;
  const int last = static_cast<int>(std::ceil(b / step + r)) - 1;
  count_ = last - first_ + 1;
  rows_.assign(count_, Row{});
  acquire_hold(a, b);
  // Gram matrix with mirror folding of the indices outside [0, count)
  const std::vector<double> ac = bspline_autocorrelation(degree);
  auto fold = [&](int j) {
    while (j < 0 || j >= count_) {
      if (j < 0) j = -1 - j;
      if (j >= count_) j = 2 * count_ - 1 - j;
    }
    return j;
  };
  factor([&](int i, int j) {
    double g = 0;
    for (int d = -degree; d <= degree; ++d)
      if (fold(i + d) == j) g += ac[std::abs(d)];
    return g;
  });
}

std::vector<double> TimeProjection::coefficients(const std::vector<double>& f) const {
  if (f.size() != t_.size())
    throw std::invalid_argument("TimeProjection::coefficients(): " + std::to_string(f.size()) +
                                " values for " + std::to_string(t_.size()) + " sub-frames");
  std::vector<double> c(count_, 0.0);
  for (int i = 0; i < count_; ++i)
    for (size_t j = 0; j < rows_[i].v.size(); ++j) c[i] += rows_[i].v[j] * f[rows_[i].k0 + j];
  solve(c);
  return c;
}

std::vector<double> TimeProjection::subframe_weights(std::vector<double> w) const {
  if (w.size() != static_cast<size_t>(count_))
    throw std::invalid_argument("TimeProjection::subframe_weights(): " + std::to_string(w.size()) +
                                " weights for " + std::to_string(count_) + " coefficients");
  solve(w);  // G is symmetric: G^-T w = G^-1 w
  std::vector<double> u(t_.size(), 0.0);
  for (int i = 0; i < count_; ++i)
    for (size_t j = 0; j < rows_[i].v.size(); ++j) u[rows_[i].k0 + j] += w[i] * rows_[i].v[j];
  return u;
}

std::vector<double> display_weights(const Shutter& s, double T, double fps, int degree,
                                    double step, int first, int count, double origin) {
  s.check();
  const double o = s.open(T, fps), c = s.close(T, fps);
  const std::vector<double> sbp = s.breakpoints(T, fps);
  const double total =
      piecewise_integral([&](double t) { return s.weight(t, T, fps); }, o, c, sbp);
  std::vector<double> w(count, 0.0);
  const double r = 0.5 * (degree + 1);
  for (int i = 0; i < count; ++i) {
    const int m = first + i;
    const double lo = std::max(o, origin + step * (m - r)), hi = std::min(c, origin + step * (m + r));
    if (!(hi > lo)) continue;
    std::vector<double> bp = sbp;
    for (int j = 0; j <= degree + 1; ++j) bp.push_back(origin + step * (m - r + j));
    w[i] = piecewise_integral(
               [&](double t) {
                 return s.weight(t, T, fps) * bspline(degree, (t - origin) / step - m);
               },
               lo, hi, bp) /
           total;
  }
  return w;
}

namespace {
void check_inside(const std::vector<double>& t, const Shutter& s, double T, double fps) {
  double a, b;
  time_span(t, a, b);
  // relative slack 1e-9 of the span: frame times k/fps and sub-frame times
  // computed in double may miss the span's ends by rounding.
  const double slack = 1e-9 * (b - a);
  const double o = s.open(T, fps), c = s.close(T, fps);
  if (!(o >= a - slack && c <= b + slack))  // NaN times fail too
    throw std::invalid_argument("time: the shutter of the frame at " + num(T) + " s, [" + num(o) +
                                ", " + num(c) + "), is outside the sub-frames' span [" + num(a) +
                                ", " + num(b) + "]");
}
}  // namespace

std::vector<double> frame_weights(const TimeProjection& p, const Shutter& s, double T,
                                  double fps) {
  check_inside(p.times(), s, T, fps);
  return p.subframe_weights(
      display_weights(s, T, fps, p.degree(), p.step(), p.first(), p.count(), p.origin()));
}

std::vector<double> conventional_frame_weights(const std::vector<double>& t, const Shutter& s,
                                               double T, double fps) {
  check_inside(t, s, T, fps);
  std::vector<double> u(t.size(), 0.0);
  double total = 0;
  for (size_t k = 0; k < t.size(); ++k) {
    u[k] = s.weight(t[k], T, fps);
    total += u[k];
  }
  if (!(total > 0))
    throw std::invalid_argument("time: no sub-frame falls within the shutter of the frame at " +
                                num(T) + " s");
  for (double& x : u) x /= total;
  return u;
}

void default_frames(const std::vector<double>& t, const Shutter& s, double fps, int& first,
                    int& last) {
  double a, b;
  time_span(t, a, b);
  const double eps = 1e-9;
  first = static_cast<int>(std::ceil(a * fps - s.phase / 360.0 - eps));
  last = static_cast<int>(std::floor(b * fps - (s.phase + s.angle) / 360.0 + eps));
}

}  // namespace sis
