// Microbenchmarks (Google Benchmark) of the three stages: acquisition,
// prefilter (FFT against recursive) and resampling. Not a test: run
// build/tests/microbench (make microbench).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <random>

#include "sis/engine.h"
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

// Three levels of a pyramid (1000^2, 500^2, 250^2, min-error cubic) from a
// 4000 x 4000 RGB image, in memory (file 0) or a half OpenEXR file written
// to the temporary folder (file 1, OpenImageIO's default compression), on 2
// threads: one reading feeding the three sinks (one_read 1) against three
// projections (one_read 0).
void BM_Targets(benchmark::State& state) {
  static const Image in = noise_image(4000, 4000, 3);
  static const std::string file = [] {
    const std::string p = (std::filesystem::temp_directory_path() / "sis_microbench_targets.exr").string();
    write_image(p, in, {}, {}, -1, WriteOptions(SampleFormat::Half));
    std::atexit([] { std::filesystem::remove(std::filesystem::temp_directory_path() / "sis_microbench_targets.exr"); });
    return p;
  }();
  std::vector<ProjectionRequest> all;
  for (long side : {1000L, 500L, 250L}) {
    ProjectionRequest rq;
    if (all.empty())
      rq.inputs = {state.range(1) ? ProjectionInput::file(file) : ProjectionInput::memory(in)};
    rq.width = rq.height = side;
    rq.threads = 2;
    all.push_back(rq);
  }
  for (auto _ : state) {
    if (state.range(0)) {
      benchmark::DoNotOptimize(project(all));
    } else {
      for (ProjectionRequest rq : all) {
        rq.inputs = all.front().inputs;
        benchmark::DoNotOptimize(project(rq));
      }
    }
  }
  state.SetItemsProcessed(state.iterations() * in.width * in.height);
}
BENCHMARK(BM_Targets)->ArgNames({"one_read", "file"})->ArgsProduct({{0, 1}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
