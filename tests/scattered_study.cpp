// The scattered-samples study (docs/design.md section 11): min-error cubic
// at 256^2 of the zone plate (closed form, K = 0.7 pi 256), jittered samples
// at 4 and 16 rays per pixel, continuous L2 error against the closed form;
// time per sample of the normalised pass (its checks included) against the
// grid acquisition of the same rays on a regular grid, on one thread and on
// all of them, medians of `runs` in this process; the fit's passes, time and
// memory. The same on the hexagonal lattice (hex-hat and hex-quartic at
// density 1, against the hexagonal grid acquisition of the regular grid).
// With `times`, only the time per sample of the normalised pass against the
// grid acquisition, for 1 and 3 channels.
// Usage: scattered_study [runs (default 7)] [cartesian|hex (default both)] [times]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include <string>

#include "sis/hex_projection.h"
#include "sis/metrics.h"
#include "sis/projection.h"
#include "sis/scattered.h"

using namespace sis;

static int runs = 7;

static double seconds(const std::function<void()>& f) {
  std::vector<double> t;
  for (int r = 0; r < runs; ++r) {
    const auto a = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// Jittered samples at s x s per pixel of the zone plate (K) on W x H, C
// channels (channel c: the zone plate times 1 + c / 4), and the regular grid
// of the same rays; weights 1 / s^2.
static void jittered(long W, long H, int s, int C, double K, ScatteredSamples& smp, Image& grid) {
  std::mt19937_64 g(1);
  smp = ScatteredSamples{};
  smp.channels = C;
  grid = Image(W * s, H * s, C);
  for (long j = 0; j < H * s; ++j)
    for (long i = 0; i < W * s; ++i) {
      const double z = zoneplate(K, W, H, (i + 0.5) / s, (j + 0.5) / s);
      const double x = (i + double(g() >> 11) * 0x1p-53) / s;
      const double y = (j + double(g() >> 11) * 0x1p-53) / s;
      const double v = zoneplate(K, W, H, x, y);
      smp.positions.push_back(x);
      smp.positions.push_back(y);
      for (int c = 0; c < C; ++c) {
        grid.at(i, j, c) = float(z * (1 + 0.25 * c));
        smp.values.push_back(float(v * (1 + 0.25 * c)));
      }
      smp.weights.push_back(1.0 / (s * s));
    }
}

// The time per sample of the normalised pass (checks included) against the
// grid acquisition of the same rays, on one thread and on all, both lattices
// as `which` says, 1 and 3 channels.
static void times(const std::string& which, long W, long H, double K, int all) {
  ScatteredSamples smp;
  Image grid;
  for (int C : {1, 3})
    for (int s : {2, 4}) {
      jittered(W, H, s, C, K, smp, grid);
      const double n = double(W * s) * H * s;
      for (int space = 0; space < 3; ++space) {
        if ((space == 0 && which == "hex") || (space > 0 && which == "cartesian")) continue;
        ScatteredTarget t;
        t.width = W;
        t.height = H;
        std::function<void(int)> acquire_grid;
        const char* name = "cubic";
        std::unique_ptr<AcquisitionPlan> plan;
        std::unique_ptr<HexAcquisitionPlan> hplan;
        if (space == 0) {
          plan = std::make_unique<AcquisitionPlan>(W * s, H * s, C, W, H, Lattice::cartesian(),
                                                   Kernel::bspline(3), Boundary::Mirror,
                                                   Method::MinError);
          acquire_grid = [&](int threads) { acquire(grid, *plan, threads); };
        } else {
          const int order = space;
          name = order == 1 ? "hex-hat" : "hex-quartic";
          t.space = HexagonalSpace{order, 1.0};
          hplan = std::make_unique<HexAcquisitionPlan>(
              W * s, H * s, C, W, H, hex_layout(1.0, W, H, hex_default_margin(order)), order,
              Boundary::Mirror);
          acquire_grid = [&](int threads) { acquire(grid, *hplan, threads); };
        }
        for (int threads : {1, all}) {
          const double t_scat = seconds([&] {
            ScatteredAcquisition a(t, C, threads);
            a.add(smp);
          });
          const double t_grid = seconds([&] { acquire_grid(threads); });
          std::printf("%-11s %d channel%s %2d rays/px  %d thread%s  time per sample: normalised "
                      "pass %.2f ns, grid acquisition %.2f ns, ratio %.2f\n",
                      name, C, C > 1 ? "s" : " ", s * s, threads, threads > 1 ? "s" : " ",
                      1e9 * t_scat / n, 1e9 * t_grid / n, t_scat / t_grid);
          if (all == 1) break;
        }
      }
    }
}

int main(int argc, char** argv) {
  if (argc > 1) runs = std::max(1, std::atoi(argv[1]));
  const std::string which = argc > 2 ? argv[2] : "both";
  const int all = std::max(1, int(std::thread::hardware_concurrency()));
  const long W = 256, H = 256;
  const double K = 0.7 * M_PI * 256;
  if (argc > 3 && std::string(argv[3]) == "times") {
    times(which, W, H, K, all);
    return 0;
  }
  ScatteredTarget target;
  target.width = W;
  target.height = H;
  for (int s : {2, 4}) {
    if (which == "hex") break;
    std::mt19937_64 g(1);
    ScatteredSamples smp;
    Image grid(W * s, H * s, 1);
    for (long j = 0; j < H * s; ++j)
      for (long i = 0; i < W * s; ++i) {
        grid.at(i, j, 0) = float(zoneplate(K, W, H, (i + 0.5) / s, (j + 0.5) / s));
        const double x = (i + double(g() >> 11) * 0x1p-53) / s;
        const double y = (j + double(g() >> 11) * 0x1p-53) / s;
        smp.positions.push_back(x);
        smp.positions.push_back(y);
        smp.values.push_back(float(zoneplate(K, W, H, x, y)));
        smp.weights.push_back(1.0 / (s * s));
      }
    ProjectionOptions po;
    const Coefficients kg = project(grid, W, H, po);
    std::printf("%d rays/px  regular grid           L2 %.5f\n", s * s, zoneplate_l2_error(kg, K, 8));
    for (ScatteredRule rule : {ScatteredRule::PlainSum, ScatteredRule::NormalisedSum}) {
      ScatteredOptions o;
      o.rule = rule;
      std::printf("%d rays/px  jittered %-12s  L2 %.5f\n", s * s, scattered_rule_name(rule),
                  zoneplate_l2_error(project_scattered(smp, target, o), K, 8));
    }
    for (int it : {1, 2, 5, 10, 20})
      for (int threads : {1, all}) {
        if (threads == all && it != 5 && all > 1) continue;
        ScatteredOptions o;
        o.rule = ScatteredRule::LeastSquares;
        o.iterations = it;
        o.threads = threads;
        ScatteredReport rep;
        Coefficients k;
        const double t = seconds([&] { k = project_scattered(smp, target, o, &rep); });
        std::printf("%d rays/px  jittered fit %2d it     L2 %.5f  passes %ld  %.3f s  %.1f MB  (%d thread%s)\n",
                    s * s, rep.iterations, zoneplate_l2_error(k, K, 8), rep.passes, t, rep.bytes / 1e6,
                    threads, threads > 1 ? "s" : "");
        if (all == 1) break;
      }
    const double n = double(W * s) * H * s;
    AcquisitionPlan plan(W * s, H * s, 1, W, H, Lattice::cartesian(), Kernel::bspline(3),
                         Boundary::Mirror, Method::MinError);
    for (int threads : {1, all}) {
      const double t_scat = seconds([&] {
        ScatteredAcquisition a(target, 1, threads);
        a.add(smp);
      });
      const double t_grid = seconds([&] { acquire(grid, plan, threads); });
      std::printf("%d rays/px  %d thread%s  time per sample: normalised pass %.2f ns (checks included), "
                  "grid acquisition %.2f ns, ratio %.2f\n",
                  s * s, threads, threads > 1 ? "s" : "", 1e9 * t_scat / n, 1e9 * t_grid / n,
                  t_scat / t_grid);
      if (all == 1) break;
    }
  }
  if (which == "cartesian") return 0;
  for (int order : {1, 2})
    for (int s : {2, 4}) {
      std::mt19937_64 g(1);
      ScatteredSamples smp;
      Image grid(W * s, H * s, 1);
      for (long j = 0; j < H * s; ++j)
        for (long i = 0; i < W * s; ++i) {
          grid.at(i, j, 0) = float(zoneplate(K, W, H, (i + 0.5) / s, (j + 0.5) / s));
          const double x = (i + double(g() >> 11) * 0x1p-53) / s;
          const double y = (j + double(g() >> 11) * 0x1p-53) / s;
          smp.positions.push_back(x);
          smp.positions.push_back(y);
          smp.values.push_back(float(zoneplate(K, W, H, x, y)));
          smp.weights.push_back(1.0 / (s * s));
        }
      const char* name = order == 1 ? "hex-hat" : "hex-quartic";
      ScatteredTarget ht = target;
      ht.space = HexagonalSpace{order, 1.0};
      HexProjectionOptions po;
      po.order = order;
      const Coefficients kg = project_hexagonal(grid, W, H, po);
      std::printf("%s %d rays/px  regular grid           L2 %.5f\n", name, s * s,
                  zoneplate_l2_error(kg, K, 8));
      for (ScatteredRule rule : {ScatteredRule::PlainSum, ScatteredRule::NormalisedSum}) {
        ScatteredOptions o;
        o.rule = rule;
        std::printf("%s %d rays/px  jittered %-12s  L2 %.5f\n", name, s * s,
                    scattered_rule_name(rule), zoneplate_l2_error(project_scattered(smp, ht, o), K, 8));
      }
      for (int it : {1, 2, 5, 20}) {
        ScatteredOptions o;
        o.rule = ScatteredRule::LeastSquares;
        o.iterations = it;
        ScatteredReport rep;
        Coefficients k;
        const double t = seconds([&] { k = project_scattered(smp, ht, o, &rep); });
        std::printf("%s %d rays/px  jittered fit %2d it     L2 %.5f  passes %ld  %.3f s  %.1f MB  (1 thread)\n",
                    name, s * s, rep.iterations, zoneplate_l2_error(k, K, 8), rep.passes, t,
                    rep.bytes / 1e6);
      }
      const double n = double(W * s) * H * s;
      const int margin = hex_default_margin(order);
      const HexAcquisitionPlan plan(W * s, H * s, 1, W, H, hex_layout(1.0, W, H, margin), order,
                                    Boundary::Mirror);
      for (int threads : {1, all}) {
        const double t_scat = seconds([&] {
          ScatteredAcquisition a(ht, 1, threads);
          a.add(smp);
        });
        const double t_grid = seconds([&] { acquire(grid, plan, threads); });
        std::printf("%s %d rays/px  %d thread%s  time per sample: normalised pass %.2f ns (checks "
                    "included), grid acquisition %.2f ns, ratio %.2f\n",
                    name, s * s, threads, threads > 1 ? "s" : "", 1e9 * t_scat / n, 1e9 * t_grid / n,
                    t_scat / t_grid);
        if (all == 1) break;
      }
    }
}
