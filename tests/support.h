#pragma once
// Shared test helpers: seeded random images, point sampling of a function,
// a dense solver (the slow direct reference), and running a built tool.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "sis/image.h"

namespace sis::test {

inline const double kPi = std::acos(-1.0);

// Uniform values in [lo, hi), seeded.
inline Image random_image(long w, long h, int c, unsigned seed, float lo = 0, float hi = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Image img(w, h, c);
  for (float& v : img.data) v = u(rng);
  return img;
}

// Uniform values in [-1, 1), seeded.
inline Grid<double> random_grid(long w, long h, int c, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Grid<double> g(w, h, c);
  for (double& v : g.data) v = u(rng);
  return g;
}

// Point samples of f at ((i + 1/2) W / win, (j + 1/2) H / hin): the
// supersampled input of an image of W x H output pixels.
inline Image sample(const std::function<double(double, double, int)>& f, long win, long hin,
                    int channels, double W, double H) {
  Image img(win, hin, channels);
  for (long j = 0; j < hin; ++j)
    for (long i = 0; i < win; ++i)
      for (int c = 0; c < channels; ++c)
        img.at(i, j, c) = static_cast<float>(f((i + 0.5) * W / win, (j + 0.5) * H / hin, c));
  return img;
}

// Solves A x = y (A row-major n x n) by Gaussian elimination with partial
// pivoting.
inline std::vector<double> dense_solve(std::vector<double> A, std::vector<double> y) {
  const std::size_t n = y.size();
  for (std::size_t c = 0; c < n; ++c) {
    std::size_t p = c;
    for (std::size_t r = c + 1; r < n; ++r)
      if (std::abs(A[r * n + c]) > std::abs(A[p * n + c])) p = r;
    for (std::size_t k = 0; k < n; ++k) std::swap(A[c * n + k], A[p * n + k]);
    std::swap(y[c], y[p]);
    for (std::size_t r = c + 1; r < n; ++r) {
      const double f = A[r * n + c] / A[c * n + c];
      for (std::size_t k = c; k < n; ++k) A[r * n + k] -= f * A[c * n + k];
      y[r] -= f * y[c];
    }
  }
  std::vector<double> x(n);
  for (std::size_t c = n; c-- > 0;) {
    double s = y[c];
    for (std::size_t k = c + 1; k < n; ++k) s -= A[c * n + k] * x[k];
    x[c] = s / A[c * n + c];
  }
  return x;
}
// The same, A given by rows.
inline std::vector<double> dense_solve(const std::vector<std::vector<double>>& rows,
                                       std::vector<double> y) {
  std::vector<double> A;
  for (const std::vector<double>& row : rows) A.insert(A.end(), row.begin(), row.end());
  return dense_solve(std::move(A), std::move(y));
}

struct Result {
  int status;
  std::string output;  // stdout and stderr
};

// Runs `tool args` through the shell; its exit status and everything it printed.
inline Result run_tool(const std::string& tool, const std::string& args) {
  const std::string cmd = tool + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int st = pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

// A test with a fresh temporary folder, removed afterwards.
class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/sis-test-XXXXXX";
    dir_ = mkdtemp(tmpl);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string path(const std::string& name) const {
    return (std::filesystem::path(dir_) / name).string();
  }
  // The names in the folder, sorted.
  std::vector<std::string> files() const {
    std::vector<std::string> v;
    for (const auto& e : std::filesystem::directory_iterator(dir_))
      v.push_back(e.path().filename().string());
    std::sort(v.begin(), v.end());
    return v;
  }
  std::string dir_;
};

}  // namespace sis::test
