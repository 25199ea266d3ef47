#include "sis/time.h"

#include <algorithm>
#include <cmath>
#include <fstream>
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

// Acquisition of the Linear and Cubic models on [lo, hi] (the span widened
// to the B-splines' knots, lo and hi knots): A[i][k] = (1/S) integral over
// [lo, hi] of L_k(t) b_D(t/S - m) dt for m = first + i, over the model's
// pieces [t_k, t_k+1] (and [lo, t_0], [t_K-1, hi] on the nearest gap's
// polynomial, extended), L_k the Lagrange basis of the piece's nodes. Each
// piece of the integrand is a polynomial of degree <= 3 + 3 between the
// B-spline's knots: gauss4 is exact.
void acquire_interpolated(const std::vector<double>& t, double lo_all, double hi_all, int degree,
                          double step, int first, int count, TimeModel model,
                          std::vector<std::vector<double>>& A) {
  const int K = static_cast<int>(t.size());
  const int q = model == TimeModel::Linear ? 1 : std::min(3, K - 1);  // nodes q + 1
  const double r = 0.5 * (degree + 1);
  for (int piece = -1; piece < K; ++piece) {
    // piece -1: [lo, t_0]; piece k: [t_k, t_k+1]; piece K-1: [t_K-1, hi]
    const double lo = piece < 0 ? lo_all : t[piece];
    const double hi = piece + 1 >= K ? hi_all : t[piece + 1];
    if (!(hi > lo)) continue;
    const int gap = std::clamp(piece, 0, K - 2);                  // the gap whose polynomial
    const int j0 = std::clamp(gap - (q - 1) / 2, 0, K - 1 - q);  // nodes j0 .. j0 + q
    auto basis = [&](int k, double x) {
      double v = 1;
      for (int j = j0; j <= j0 + q; ++j)
        if (j != k) v *= (x - t[j]) / (t[k] - t[j]);
      return v;
    };
    for (int i = 0; i < count; ++i) {
      const int m = first + i;
      if (!(step * (m + r) > lo && step * (m - r) < hi)) continue;
      std::vector<double> bp;
      for (int j = 0; j <= degree + 1; ++j) bp.push_back(step * (m - r + j));
      for (int k = j0; k <= j0 + q; ++k)
        A[i][k] += piecewise_integral(
                       [&](double x) { return basis(k, x) * bspline(degree, x / step - m); }, lo,
                       hi, bp) /
                   step;
    }
  }
}

// Solves G P = A in place (Gaussian elimination with partial pivoting; the
// systems are small: the span over the step plus degree + 1 rows).
void solve_in_place(std::vector<std::vector<double>>& G, std::vector<std::vector<double>>& P) {
  const int n = static_cast<int>(G.size());
  const size_t K = P.empty() ? 0 : P[0].size();
  for (int c = 0; c < n; ++c) {
    int p = c;
    for (int i = c + 1; i < n; ++i)
      if (std::abs(G[i][c]) > std::abs(G[p][c])) p = i;
    std::swap(G[c], G[p]);
    std::swap(P[c], P[p]);
    for (int i = c + 1; i < n; ++i) {
      const double f = G[i][c] / G[c][c];
      if (f == 0) continue;
      for (int j = c; j < n; ++j) G[i][j] -= f * G[c][j];
      for (size_t k = 0; k < K; ++k) P[i][k] -= f * P[c][k];
    }
  }
  for (int c = n - 1; c >= 0; --c) {
    for (size_t k = 0; k < K; ++k) {
      double s = P[c][k];
      for (int j = c + 1; j < n; ++j) s -= G[c][j] * P[j][k];
      P[c][k] = s / G[c][c];
    }
  }
}

}  // namespace

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
  const size_t K = t_.size();
  if (model_ != TimeModel::Hold) {
    // The interpolating models: the least-squares projection of the model on
    // [lo, hi], the span widened to the nearest knots of the B-splines
    // (knots at S (n + delta), delta 0 for odd degrees, 1/2 for even ones),
    // the model extended there by its end polynomials; every B-spline meeting
    // (lo, hi) overlaps it by a whole knot interval or more (a well-posed
    // Gram matrix), and polynomials the model and the space both hold are
    // reproduced on the whole span, ends included.
    const double delta = degree % 2 ? 0.0 : 0.5;
    const int na = static_cast<int>(std::floor(a / step - delta));
    const int nb = static_cast<int>(std::ceil(b / step - delta));
    const double lo = step * (na + delta), hi = step * (nb + delta);
    first_ = na + 1 - (degree + 1) / 2;
    const int last = nb + degree / 2;
    count_ = last - first_ + 1;
    std::vector<std::vector<double>> A(count_, std::vector<double>(K, 0.0));
    acquire_interpolated(t_, lo, hi, degree, step, first_, count_, model_, A);
    std::vector<std::vector<double>> G(count_, std::vector<double>(count_, 0.0));
    for (int i = 0; i < count_; ++i)
      for (int j = std::max(0, i - degree); j <= std::min(count_ - 1, i + degree); ++j) {
        const int m = first_ + i, n = first_ + j;
        const double s0 = std::max(lo, step * (std::max(m, n) - r));
        const double s1 = std::min(hi, step * (std::min(m, n) + r));
        if (!(s1 > s0)) continue;
        std::vector<double> bp;
        for (int k = 0; k <= degree + 1; ++k) bp.push_back(step * (m - r + k));
        G[i][j] = piecewise_integral(
                      [&](double x) {
                        return bspline(degree, x / step - m) * bspline(degree, x / step - n);
                      },
                      s0, s1, bp) /
                  step;
      }
    P_ = std::move(A);
    solve_in_place(G, P_);
    return;
  }
  // every m with (m - r, m + r) meeting (a/S, b/S)
  first_ = static_cast<int>(std::floor(a / step - r)) + 1;
  const int last = static_cast<int>(std::ceil(b / step + r)) - 1;
  count_ = last - first_ + 1;
  // acquisition: each sub-frame held over its own cell, the cells mirrored
  // about a and b; (1/S) integral of b_D(t/S - m) over a cell, exactly, from
  // the cumulative B-spline
  std::vector<std::vector<double>> A(count_, std::vector<double>(K, 0.0));
  for (int i = 0; i < count_; ++i) {
    const int m = first_ + i;
    auto cell = [&](double lo, double hi) {
      return bspline_cumulative(degree, hi / step - m) - bspline_cumulative(degree, lo / step - m);
    };
    for (size_t k = 0; k < K; ++k) {
      const double lo = k == 0 ? a : 0.5 * (t_[k - 1] + t_[k]);
      const double hi = k + 1 == K ? b : 0.5 * (t_[k] + t_[k + 1]);
      A[i][k] = cell(lo, hi) + cell(2 * a - hi, 2 * a - lo) + cell(2 * b - hi, 2 * b - lo);
    }
  }
  // Gram matrix with mirror folding of the indices outside [0, count)
  const std::vector<double> ac = bspline_autocorrelation(degree);
  auto fold = [&](int j) {
    while (j < 0 || j >= count_) {
      if (j < 0) j = -1 - j;
      if (j >= count_) j = 2 * count_ - 1 - j;
    }
    return j;
  };
  std::vector<std::vector<double>> G(count_, std::vector<double>(count_, 0.0));
  for (int i = 0; i < count_; ++i)
    for (int d = -degree; d <= degree; ++d) G[i][fold(i + d)] += ac[std::abs(d)];
  P_ = std::move(A);
  solve_in_place(G, P_);
}

std::vector<double> TimeProjection::coefficients(const std::vector<double>& f) const {
  if (f.size() != t_.size())
    throw std::invalid_argument("TimeProjection::coefficients(): " + std::to_string(f.size()) +
                                " values for " + std::to_string(t_.size()) + " sub-frames");
  std::vector<double> c(count_, 0.0);
  for (int i = 0; i < count_; ++i)
    for (size_t k = 0; k < f.size(); ++k) c[i] += P_[i][k] * f[k];
  return c;
}

std::vector<double> display_weights(const Shutter& s, double T, double fps, int degree,
                                    double step, int first, int count) {
  s.check();
  const double o = s.open(T, fps), c = s.close(T, fps);
  const std::vector<double> sbp = s.breakpoints(T, fps);
  const double total =
      piecewise_integral([&](double t) { return s.weight(t, T, fps); }, o, c, sbp);
  std::vector<double> w(count, 0.0);
  const double r = 0.5 * (degree + 1);
  for (int i = 0; i < count; ++i) {
    const int m = first + i;
    const double lo = std::max(o, step * (m - r)), hi = std::min(c, step * (m + r));
    if (!(hi > lo)) continue;
    std::vector<double> bp = sbp;
    for (int j = 0; j <= degree + 1; ++j) bp.push_back(step * (m - r + j));
    w[i] = piecewise_integral(
               [&](double t) { return s.weight(t, T, fps) * bspline(degree, t / step - m); }, lo,
               hi, bp) /
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
  if (o < a - slack || c > b + slack)
    throw std::invalid_argument("time: the shutter of the frame at " + num(T) + " s, [" + num(o) +
                                ", " + num(c) + "), is outside the sub-frames' span [" + num(a) +
                                ", " + num(b) + "]");
}
}  // namespace

std::vector<double> frame_weights(const TimeProjection& p, const Shutter& s, double T,
                                  double fps) {
  const auto& P = p.matrix();
  const size_t K = P.empty() ? 0 : P[0].size();
  check_inside(p.times(), s, T, fps);
  const std::vector<double> w =
      display_weights(s, T, fps, p.degree(), p.step(), p.first(), p.count());
  std::vector<double> u(K, 0.0);
  for (int i = 0; i < p.count(); ++i)
    for (size_t k = 0; k < K; ++k) u[k] += w[i] * P[i][k];
  return u;
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
