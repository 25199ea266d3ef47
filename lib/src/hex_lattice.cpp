#include "sis/hex_lattice.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sis {

namespace {
// The smallest m >= n, a multiple of `multiple`, whose prime factors are
// 2, 3, 5 and 7: sizes FFTW transforms fastest.
long fft_friendly(long n, long multiple) {
  for (long m = std::max(n, multiple);; ++m) {
    if (m % multiple != 0) continue;
    long r = m;
    for (long p : {2, 3, 5, 7})
      while (r % p == 0) r /= p;
    if (r == 1) return m;
  }
}
}  // namespace

int hex_default_margin(int order) {
  if (order == 1) return 10;
  if (order == 2) return 20;
  throw std::invalid_argument("hex_default_margin(): order " + std::to_string(order) +
                              " outside [1, " + std::to_string(kMaxBoxSplineOrder) + "]");
}

HexLayout hex_layout(double density, double image_width, double image_height, int margin) {
  if (!(image_width > 0) || !(image_height > 0) || margin < 0) {
    std::ostringstream m;
    m << "hex_layout(): frame " << image_width << " x " << image_height << " and margin "
      << margin << " must be positive";
    throw std::invalid_argument(m.str());
  }
  const Lattice base = Lattice::hexagonal(density);
  const double h = base.matrix()[0], hy = base.matrix()[3], M = margin * h;
  // Stored row jc holds the lattice point at the frame centre; row 0 lies at
  // least M above the frame, row rows - 1 at least M below it.
  const long jc = static_cast<long>(std::ceil((0.5 * image_height + M) / hy));
  const long rows = fft_friendly(2 * jc + 2, 2);
  // Column ic of row jc sits at W/2; every row starts at least M left of the
  // frame (odd rows start h/2 right of even ones) and ends M right of it.
  const double parity = 0.5 * double(jc & 1);
  const long ic = static_cast<long>(std::ceil((0.5 * image_width + M) / h + 0.5 - parity));
  const Vec2 o{0.5 * image_width - h * (ic + parity), 0.5 * image_height - hy * jc};
  const long columns =
      fft_friendly(static_cast<long>(std::ceil((image_width + M - o.x) / h)) + 1, 1);
  HexLayout layout;
  layout.lattice = Lattice::hexagonal(density, o);
  layout.columns = columns;
  layout.rows = rows;
  return layout;
}

HexLayout hex_layout(const Coefficients& k) {
  if (!k.lattice.is_hexagonal())
    throw std::invalid_argument("hex_layout(): lattice is not hexagonal (" +
                                k.lattice.description() + ")");
  if (k.c.width < 1 || k.c.height < 2 || k.c.height % 2 != 0) {
    std::ostringstream m;
    m << "hex_layout(): a " << k.c.width << " x " << k.c.height
      << " grid is not an offset-row grid (rows must be even)";
    throw std::invalid_argument(m.str());
  }
  HexLayout layout;
  layout.lattice = k.lattice;
  layout.columns = k.c.width;
  layout.rows = k.c.height;
  return layout;
}

const BoxSpline& hex_generator(const Coefficients& k) {
  const auto* hex = std::get_if<HexagonalSpace>(&k.space);
  if (!hex) throw std::invalid_argument("hex_generator(): coefficients of the " + space_name(k.space) +
                                        " space have no box spline");
  return BoxSpline::hexagonal(hex->order);
}



}  // namespace sis
