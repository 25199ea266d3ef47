#pragma once
// Scattered samples for the scattered tests of both lattices: uniform
// random positions and values, and jittered samples of a smooth image.
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "sis/scattered.h"

namespace sis::test {

// f must throw std::invalid_argument whose message contains `part`.
inline void expect_error(const std::function<void()>& f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no error, expected one containing '" << part << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

// The Cartesian space of the degree-`degree` B-spline on a W x H frame.
inline ScatteredTarget target(double W, double H, int degree, Boundary b) {
  ScatteredTarget t;
  t.width = W;
  t.height = H;
  t.space = CartesianSpace{Kernel::bspline(degree)};
  t.boundary = b;
  return t;
}

// Uniform in [0, 1), 53 bits.
inline double uniform(std::mt19937_64& g) { return double(g() >> 11) * 0x1p-53; }

// n samples at uniform positions in [0, W] x [0, H], `channels` values in
// [-0.3, 0.7) each, and weights in [0.5, 1.5) where `weighted`.
inline ScatteredSamples random_samples(long n, int channels, double W, double H,
                                       std::uint64_t seed, bool weighted = false) {
  std::mt19937_64 g(seed);
  ScatteredSamples s;
  s.channels = channels;
  for (long i = 0; i < n; ++i) {
    s.positions.push_back(W * uniform(g));
    s.positions.push_back(H * uniform(g));
    for (int c = 0; c < channels; ++c) s.values.push_back(uniform(g) - 0.3);
    if (weighted) s.weights.push_back(0.5 + uniform(g));
  }
  return s;
}

// A smooth image.
inline double smooth(double x, double y) {
  return 0.5 + 0.3 * std::sin(0.9 * x + 0.4) * std::cos(0.7 * y);
}

// Jittered samples, s x s per pixel (one uniform in each cell of the
// s-grid), of the smooth image.
inline ScatteredSamples jittered(long W, long H, int s, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  ScatteredSamples smp;
  for (long j = 0; j < H * s; ++j)
    for (long i = 0; i < W * s; ++i) {
      const double x = (i + uniform(g)) / s, y = (j + uniform(g)) / s;
      smp.positions.push_back(x);
      smp.positions.push_back(y);
      smp.values.push_back(smooth(x, y));
      smp.weights.push_back(1.0 / (s * s));
    }
  return smp;
}

// The variational rule at lambda (or by GCV), `iterations` CG iterations
// with no early stop, gives the same bits, lambda and GCV scores at 1, 2
// and 3 threads.
inline void expect_variational_same_bits_for_any_thread_count(const ScatteredSamples& s,
                                                               const ScatteredTarget& t,
                                                               int iterations) {
  for (std::optional<double> lambda : {std::optional<double>(0.3), std::optional<double>()}) {
    ScatteredOptions o;
    o.rule = ScatteredRule::Variational;
    o.lambda = lambda;
    o.variational_iterations = iterations;
    o.variational_tolerance = 0;
    ScatteredReport r1;
    o.threads = 1;
    const Coefficients a = project_scattered(s, t, o, &r1);
    for (int threads : {2, 3}) {
      o.threads = threads;
      ScatteredReport rn;
      const Coefficients b = project_scattered(s, t, o, &rn);
      ASSERT_EQ(a.c.data.size(), b.c.data.size());
      for (std::size_t e = 0; e < a.c.data.size(); ++e)
        ASSERT_EQ(a.c.data[e], b.c.data[e]) << threads << " threads, element " << e;
      EXPECT_EQ(r1.lambda, rn.lambda);
      EXPECT_EQ(r1.gcv, rn.gcv);
    }
  }
}

}  // namespace sis::test
