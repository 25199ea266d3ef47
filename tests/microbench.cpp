// Microbenchmarks (Google Benchmark) of the three stages: acquisition,
// prefilter (FFT against recursive) and resampling. Not a test: run
// build/tests/microbench (make microbench).
#include <benchmark/benchmark.h>

#include <random>

#include "sis/projection.h"

using namespace sis;

namespace {

Image noise_image(long w, long h, int c) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0, 1);
  Image img(w, h, c);
  for (float& v : img.data) v = u(rng);
  return img;
}

// Acquisition of a 4000 x 4000 RGB image onto 1000 x 1000 coefficients.
void BM_Acquisition(benchmark::State& state) {
  const int degree = int(state.range(0)), threads = int(state.range(1));
  static const Image in = noise_image(4000, 4000, 3);
  const AcquisitionPlan plan(in.width, in.height, 3, 1000, 1000, Lattice::cartesian(),
                             Kernel::bspline(degree), Boundary::Mirror, Method::MinError);
  for (auto _ : state) benchmark::DoNotOptimize(acquire(in, plan, threads));
  state.SetItemsProcessed(state.iterations() * in.width * in.height);
}
BENCHMARK(BM_Acquisition)->ArgsProduct({{1, 3}, {1, 2}})->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Prefilter(benchmark::State& state) {
  const int degree = int(state.range(0));
  const auto method = state.range(1) ? PrefilterMethod::Recursive : PrefilterMethod::FFT;
  const Boundary boundary = state.range(2) ? Boundary::Periodic : Boundary::Mirror;
  const PrefilterPlan plan(degree, 1000, 1000, boundary, method);
  Grid<double> r(1000, 1000, 3);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0, 1);
  for (double& v : r.data) v = u(rng);
  for (auto _ : state) {
    Grid<double> c = r;
    plan.execute(c, 1);
    benchmark::DoNotOptimize(c.data.data());
  }
}
BENCHMARK(BM_Prefilter)
    ->ArgNames({"degree", "recursive", "periodic"})
    ->ArgsProduct({{1, 3}, {0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

void BM_Resample(benchmark::State& state) {
  const int degree = int(state.range(0));
  const Display display = state.range(1) ? Display::antialiased_2x2() : Display::centred();
  ProjectionOptions o;
  o.generator = Kernel::bspline(degree);
  const Coefficients k = project(noise_image(1000, 1000, 3), 1000, 1000, o);
  for (auto _ : state) benchmark::DoNotOptimize(resample(k, display, 1000, 1000, 1));
}
BENCHMARK(BM_Resample)->ArgNames({"degree", "2x2"})->ArgsProduct({{1, 3}, {0, 1}})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
