// Projection from scattered samples (sis/scattered.h, docs/design.md section 11).
#include "sis/scattered.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

namespace sis {
namespace {

// At most this many taps per axis: a radius of 7.5 lattice steps (degree 14).
constexpr int kMaxTaps = 16;

// The taps of one axis for one sample: extended indices m folded into
// [0, n) by the boundary rule, and phi(u - m) with u the sample's lattice
// coordinate (closed forms for the B-splines of degree <= 3).
struct AxisTaps {
  int count = 0;
  long index[kMaxTaps];
  double weight[kMaxTaps];
};

void axis_taps(const Kernel& k, double u, long n, Boundary boundary, AxisTaps& t) {
  long m0;
  if (k.is_bspline() && k.degree() <= 3) {
    const int d = k.degree();
    if (d == 0) {
      m0 = long(std::floor(u + 0.5));
      t.count = 1;
      t.weight[0] = 1.0;
    } else if (d == 1) {
      const double b = std::floor(u), f = u - b;
      m0 = long(b);
      t.count = 2;
      t.weight[0] = 1 - f;
      t.weight[1] = f;
    } else if (d == 2) {
      const double b = std::floor(u + 0.5), g = u - b;
      m0 = long(b) - 1;
      t.count = 3;
      t.weight[0] = 0.5 * (0.5 - g) * (0.5 - g);
      t.weight[1] = 0.75 - g * g;
      t.weight[2] = 0.5 * (0.5 + g) * (0.5 + g);
    } else {
      const double b = std::floor(u), f = u - b, f2 = f * f, f3 = f2 * f, g = 1 - f;
      m0 = long(b) - 1;
      t.count = 4;
      t.weight[0] = g * g * g / 6;
      t.weight[1] = (4 - 6 * f2 + 3 * f3) / 6;
      t.weight[2] = (1 + 3 * f + 3 * f2 - 3 * f3) / 6;
      t.weight[3] = f3 / 6;
    }
  } else {
    const double R = k.radius();
    m0 = long(std::ceil(u - R));
    const long m1 = long(std::floor(u + R));
    t.count = int(m1 - m0 + 1);
    for (int j = 0; j < t.count; ++j) t.weight[j] = k.eval(u - double(m0 + j));
  }
  for (int j = 0; j < t.count; ++j) t.index[j] = extend_index(m0 + j, n, boundary);
}

struct Geometry {
  long nx, ny;
  double ox, oy, hx, hy;
};

Geometry geometry(const ScatteredTarget& t) {
  if (!(t.width > 0) || !(t.height > 0) || !std::isfinite(t.width) || !std::isfinite(t.height))
    throw std::invalid_argument("scattered projection: the frame must have a finite positive size");
  const Lattice& L = t.lattice;
  if (!L.separable())
    throw std::invalid_argument("scattered projection: the lattice must be Cartesian (separable)");
  const auto e = L.extent(t.width, t.height);
  Geometry g{e[0], e[1], L.origin().x, L.origin().y, L.axis_step(0), L.axis_step(1)};
  if (std::abs(g.ox - g.hx / 2) > 1e-12 * g.hx || std::abs(g.oy - g.hy / 2) > 1e-12 * g.hy)
    throw std::invalid_argument(
        "scattered projection: the lattice's origin must be half a step in (coefficients centred in "
        "their cells), as the boundary rule folds about the frame's edges");
  if (t.generator.radius() * 2 + 1 > kMaxTaps)
    throw std::invalid_argument("scattered projection: generator " + t.generator.name() +
                                " is too wide");
  if (t.method == Method::MinError && !t.generator.is_bspline())
    throw std::invalid_argument("scattered projection: min-error needs a B-spline generator, not " +
                                t.generator.name());
  return g;
}

[[noreturn]] void bad_sample(long i, const std::string& what) {
  std::ostringstream s;
  s << "scattered samples: sample " << i << ' ' << what;
  throw std::invalid_argument(s.str());
}

void check(const ScatteredSamples& s, const ScatteredTarget& t, int channels) {
  if (s.channels < 1) throw std::invalid_argument("scattered samples: channels must be >= 1");
  if (s.channels != channels) {
    std::ostringstream m;
    m << "scattered samples: " << s.channels << " channels, the acquisition has " << channels;
    throw std::invalid_argument(m.str());
  }
  if (s.positions.size() % 2 != 0)
    throw std::invalid_argument("scattered samples: positions hold " +
                                std::to_string(s.positions.size()) +
                                " numbers, not two (x, y) per sample");
  const long n = s.count();
  auto count_error = [&](const char* what, std::size_t got, std::size_t want) {
    std::ostringstream m;
    m << "scattered samples: " << what << " hold " << got << " numbers, expected " << want
      << " for " << n << " samples";
    throw std::invalid_argument(m.str());
  };
  if (s.values.size() != std::size_t(n) * s.channels)
    count_error("values", s.values.size(), std::size_t(n) * s.channels);
  if (!s.weights.empty() && s.weights.size() != std::size_t(n))
    count_error("weights", s.weights.size(), std::size_t(n));
  if (!s.times.empty() && s.times.size() != std::size_t(n))
    count_error("times", s.times.size(), std::size_t(n));
  for (long i = 0; i < n; ++i) {
    const double x = s.positions[2 * i], y = s.positions[2 * i + 1];
    if (!std::isfinite(x) || !std::isfinite(y)) bad_sample(i, "has a non-finite position");
    if (x < 0 || x > t.width || y < 0 || y > t.height) {
      std::ostringstream m;
      m << "at (" << x << ", " << y << ") lies outside the frame [0, " << t.width << "] x [0, "
        << t.height << "]";
      bad_sample(i, m.str());
    }
    if (!s.weights.empty() && !(std::isfinite(s.weights[i]) && s.weights[i] > 0))
      bad_sample(i, "has weight " + std::to_string(s.weights[i]) + " (must be finite and > 0)");
    for (int c = 0; c < s.channels; ++c)
      if (!std::isfinite(s.values[std::size_t(i) * s.channels + c]))
        bad_sample(i, "has a non-finite value in channel " + std::to_string(c));
  }
}

double sample_weight(const ScatteredSamples& s, const ScatteredTarget& t, long i) {
  return s.weights.empty() ? t.width * t.height / double(s.count()) : s.weights[i];
}

// For every sample in order: visit(i, w_i, taps_x, taps_y).
template <typename F>
void for_each_sample(const ScatteredSamples& s, const ScatteredTarget& t, const Geometry& g,
                     F&& visit) {
  AxisTaps tx, ty;
  const long n = s.count();
  for (long i = 0; i < n; ++i) {
    axis_taps(t.generator, (s.positions[2 * i] - g.ox) / g.hx, g.nx, t.boundary, tx);
    axis_taps(t.generator, (s.positions[2 * i + 1] - g.oy) / g.hy, g.ny, t.boundary, ty);
    visit(i, sample_weight(s, t, i), tx, ty);
  }
}

// out += sum_i w_i v_i phi_i,n (the splat), v_i = values[i * C ...]; and
// where given, weights += sum_i w_i phi_i,n in the same pass.
void splat(const ScatteredSamples& s, const ScatteredTarget& t, const Geometry& g,
           const double* values, Grid<double>& out, Grid<double>* weights = nullptr) {
  const int C = out.channels;
  for_each_sample(s, t, g, [&](long i, double w, const AxisTaps& tx, const AxisTaps& ty) {
    const double* v = values + std::size_t(i) * C;
    for (int b = 0; b < ty.count; ++b) {
      double* row = out.row(ty.index[b]);
      double* wrow = weights ? weights->row(ty.index[b]) : nullptr;
      const double wy = w * ty.weight[b];
      for (int a = 0; a < tx.count; ++a) {
        const double ww = wy * tx.weight[a];
        double* o = row + tx.index[a] * C;
        for (int c = 0; c < C; ++c) o[c] += ww * v[c];
        if (wrow) wrow[tx.index[a]] += ww;
      }
    }
  });
}

// f_app at every sample, channel fastest.
void evaluate(const ScatteredSamples& s, const ScatteredTarget& t, const Geometry& g,
              const Grid<double>& c, double* out) {
  const int C = c.channels;
  for_each_sample(s, t, g, [&](long i, double, const AxisTaps& tx, const AxisTaps& ty) {
    double* v = out + std::size_t(i) * C;
    for (int k = 0; k < C; ++k) v[k] = 0;
    for (int b = 0; b < ty.count; ++b) {
      const double* row = c.row(ty.index[b]);
      for (int a = 0; a < tx.count; ++a) {
        const double ww = ty.weight[b] * tx.weight[a];
        const double* p = row + tx.index[a] * C;
        for (int k = 0; k < C; ++k) v[k] += ww * p[k];
      }
    }
  });
}

Coefficients make_coefficients(const ScatteredTarget& t, Grid<double> c) {
  Coefficients k;
  k.c = std::move(c);
  k.lattice = t.lattice;
  k.generator = t.generator;
  k.boundary = t.boundary;
  k.min_error = t.method == Method::MinError;
  k.image_width = t.width;
  k.image_height = t.height;
  return k;
}

}  // namespace

Sample ScatteredSamples::sample(long i) const {
  Sample s;
  s.position = {positions[2 * i], positions[2 * i + 1]};
  s.weight = weights.empty() ? 0.0 : weights[i];
  s.time = times.empty() ? 0.0 : times[i];
  return s;
}

const char* scattered_rule_name(ScatteredRule rule) {
  switch (rule) {
    case ScatteredRule::NormalisedSum: return "normalised";
    case ScatteredRule::LeastSquares: return "fit";
    case ScatteredRule::PlainSum: return "plain";
  }
  return "?";
}

ScatteredRule parse_scattered_rule(const std::string& spelling) {
  if (spelling == "normalised") return ScatteredRule::NormalisedSum;
  if (spelling == "fit") return ScatteredRule::LeastSquares;
  if (spelling == "plain") return ScatteredRule::PlainSum;
  throw std::invalid_argument("unknown scattered rule '" + spelling +
                              "' (expected normalised, fit or plain)");
}

ScatteredAcquisition::ScatteredAcquisition(const ScatteredTarget& target, int channels)
    : target_(target), channels_(channels) {
  if (channels < 1) throw std::invalid_argument("scattered acquisition: channels must be >= 1");
  const Geometry g = geometry(target_);
  num_ = Grid<double>(g.nx, g.ny, channels);
  den_ = Grid<double>(g.nx, g.ny, 1);
}

std::size_t ScatteredAcquisition::bytes() const {
  return (num_.data.size() + den_.data.size()) * sizeof(double);
}

void ScatteredAcquisition::add(const ScatteredSamples& s) {
  check(s, target_, channels_);
  splat(s, target_, geometry(target_), s.values.data(), num_, &den_);
}

Coefficients ScatteredAcquisition::finish(ScatteredRule rule) const {
  if (rule == ScatteredRule::LeastSquares)
    throw std::invalid_argument(
        "scattered acquisition: the least-squares fit needs every sample again "
        "(project_scattered), not one pass");
  const bool min_error = target_.method == Method::MinError;
  if (!min_error && rule != ScatteredRule::NormalisedSum)
    throw std::invalid_argument(
        std::string("scattered projection: the conventional method takes the normalised weighted "
                    "average, not the ") + scattered_rule_name(rule) + " rule");
  const Geometry g = geometry(target_);
  Grid<double> r(g.nx, g.ny, channels_);
  // In lattice units the inner product of a flat 1 with phi is int phi
  // (1 for the B-splines); the plain sum's lattice-unit scale is 1 / (hx hy).
  const double integral = target_.generator.integral() * target_.generator.integral();
  const double plain = 1.0 / (g.hx * g.hy);
  for (long y = 0; y < g.ny; ++y)
    for (long x = 0; x < g.nx; ++x) {
      const double d = den_.at(x, y, 0);
      if (rule == ScatteredRule::PlainSum) {
        for (int c = 0; c < channels_; ++c) r.at(x, y, c) = num_.at(x, y, c) * plain;
        continue;
      }
      if (!(d > 0)) {
        std::ostringstream m;
        m << "scattered projection: coefficient (" << x << ", " << y
          << ") has weight sum " << d
          << " (no sample in its generator's support; the normalised rule needs one there)";
        throw std::invalid_argument(m.str());
      }
      const double scale = min_error ? integral / d : 1.0 / d;
      for (int c = 0; c < channels_; ++c) r.at(x, y, c) = num_.at(x, y, c) * scale;
    }
  Coefficients k = make_coefficients(target_, std::move(r));
  if (min_error) prefilter(k, 1, target_.prefilter);
  return k;
}

std::vector<double> evaluate_at_samples(const Coefficients& k, const ScatteredSamples& samples) {
  ScatteredTarget t;
  t.width = k.image_width;
  t.height = k.image_height;
  t.lattice = k.lattice;
  t.generator = k.generator;
  t.boundary = k.boundary;
  t.method = k.min_error ? Method::MinError : Method::Conventional;
  if (k.box_spline) throw std::invalid_argument("evaluate_at_samples: Cartesian coefficients only");
  const Geometry g = geometry(t);
  check(samples, t, k.c.channels);
  std::vector<double> out(std::size_t(samples.count()) * k.c.channels);
  evaluate(samples, t, g, k.c, out.data());
  return out;
}

Coefficients project_scattered(const ScatteredSamples& samples, const ScatteredTarget& target,
                               const ScatteredOptions& options, ScatteredReport* report) {
  ScatteredAcquisition acq(target, samples.channels);
  acq.add(samples);
  const ScatteredRule first =
      options.rule == ScatteredRule::LeastSquares ? ScatteredRule::NormalisedSum : options.rule;
  if (target.method != Method::MinError && options.rule != ScatteredRule::NormalisedSum)
    throw std::invalid_argument(
        std::string("scattered projection: the conventional method takes the normalised weighted "
                    "average, not the ") + scattered_rule_name(options.rule) + " rule");
  Coefficients k = acq.finish(first);
  ScatteredReport rep;
  rep.passes = 1;
  rep.bytes = acq.bytes();
  if (options.rule == ScatteredRule::LeastSquares) {
    if (options.iterations < 0 || !(options.tolerance >= 0))
      throw std::invalid_argument(
          "scattered projection: the fit's iterations and tolerance must be >= 0");
    const Geometry g = geometry(target);
    const int C = samples.channels;
    const long N = samples.count();
    // b = sum_i w_i f_i phi_i,n is the numerator of the pass above.
    const Grid<double>& b = acq.numerator();
    Grid<double>& x = k.c;
    Grid<double> r(g.nx, g.ny, C), z(g.nx, g.ny, C), p(g.nx, g.ny, C), q(g.nx, g.ny, C);
    std::vector<double> at(std::size_t(N) * C);
    const int degree = target.generator.degree();
    std::unique_ptr<PrefilterPlan> plan;
    if (degree > 0)
      plan = std::make_unique<PrefilterPlan>(degree, g.nx, g.ny, target.boundary, target.prefilter);
    const double area = g.hx * g.hy;  // G ~ (hx hy) a
    auto apply_G = [&](const Grid<double>& v, Grid<double>& out) {
      evaluate(samples, target, g, v, at.data());
      std::fill(out.data.begin(), out.data.end(), 0.0);
      splat(samples, target, g, at.data(), out);
      rep.passes += 2;
    };
    auto precondition = [&](const Grid<double>& in, Grid<double>& out) {
      for (std::size_t e = 0; e < in.data.size(); ++e) out.data[e] = in.data[e] / area;
      if (plan) plan->execute(out, 1);
    };
    auto dots = [&](const Grid<double>& u, const Grid<double>& v) {
      std::vector<double> s(C, 0.0);
      for (std::size_t e = 0; e < u.data.size(); ++e) s[e % C] += u.data[e] * v.data[e];
      return s;
    };
    apply_G(x, q);
    for (std::size_t e = 0; e < r.data.size(); ++e) r.data[e] = b.data[e] - q.data[e];
    const std::vector<double> bb = dots(b, b);
    std::vector<double> rr = dots(r, r);
    auto done = [&] {
      for (int c = 0; c < C; ++c)
        if (rr[c] > options.tolerance * options.tolerance * bb[c]) return false;
      return true;
    };
    precondition(r, z);
    p.data = z.data;
    std::vector<double> rz = dots(r, z);
    int it = 0;
    while (it < options.iterations && !done()) {
      apply_G(p, q);
      const std::vector<double> pq = dots(p, q);
      std::vector<double> alpha(C, 0.0);
      for (int c = 0; c < C; ++c) alpha[c] = pq[c] > 0 ? rz[c] / pq[c] : 0.0;
      for (std::size_t e = 0; e < x.data.size(); ++e) {
        const int c = int(e % C);
        x.data[e] += alpha[c] * p.data[e];
        r.data[e] -= alpha[c] * q.data[e];
      }
      ++it;
      rr = dots(r, r);
      if (it == options.iterations || done()) break;
      precondition(r, z);
      const std::vector<double> rz_new = dots(r, z);
      for (std::size_t e = 0; e < p.data.size(); ++e) {
        const int c = int(e % C);
        const double beta = rz[c] > 0 ? rz_new[c] / rz[c] : 0.0;
        p.data[e] = z.data[e] + beta * p.data[e];
      }
      rz = rz_new;
    }
    rep.iterations = it;
    rep.residual.resize(C);
    for (int c = 0; c < C; ++c) rep.residual[c] = bb[c] > 0 ? std::sqrt(rr[c] / bb[c]) : 0.0;
    rep.bytes += (r.data.size() * 4) * sizeof(double) + at.size() * sizeof(double);
  }
  if (report) *report = rep;
  return k;
}

}  // namespace sis
