#pragma once
// Coefficients on the hexagonal lattice (docs/design.md section 7): storage,
// placement on the frame, boundary rule, and how Coefficients records them.
//
// Storage: offset rows. Stored coefficient (i, j) of a columns x rows grid
// sits at
//   x_ij = o + h (i + (j mod 2)/2, (sqrt(3)/2) j),
// o the lattice origin, h its step: row j is the lattice row n2 = j, odd rows
// are shifted right by half a step (lattice index n = (i - floor(j/2), j)).
//
// Placement (hex_layout): a lattice point at the frame centre (W/2, H/2), so
// the lattice shares the frame's mirror symmetries x -> W - x, y -> H - y;
// the grid covers the frame plus a margin of m lattice steps on every side
// (every stored row, even or odd, reaches at least m h beyond each edge), and
// o is moved to the first stored coefficient. rows is even; columns and rows
// are rounded up (extra columns on the right, rows at the bottom) to products
// of 2, 3, 5 and 7, the sizes FFTW transforms fastest.
//
// Boundary: the input is extended beyond the frame by the acquisition's rule
// (mirror or periodic, as on the Cartesian lattice) and every stored
// coefficient, margin included, is the inner product with the extended image.
// The coefficients themselves are periodic on the grid: period columns h in x
// and rows (sqrt(3)/2) h in y, a lattice vector because rows is even. The
// prefilter solves the Gram system with that periodic rule, and evaluation
// beyond the grid wraps with it. Where the grid's period is not the extended
// image's, the wrap is a seam at the grid's edge; its effect on the
// coefficients decays geometrically away from it (hex_default_margin), so
// inside the frame the result is the projection of the extended image up to
// that decayed seam error. Where the frame tiles the lattice's period the
// rule is exact.
//
// Coefficients records a hexagonal approximation as: lattice = the hexagonal
// lattice with o at stored (0, 0); c = the offset-row grid; generator =
// Kernel::bspline(3n - 2), the box spline's polynomial degree (1: hex-hat,
// 4: hex-quartic); boundary = the input's extension rule.
#include <string>

#include "sis/coefficients.h"
#include "sis/box_spline.h"
#include "sis/image.h"

namespace sis {

struct HexLayout {
  Lattice lattice = Lattice::hexagonal();
  long columns = 0, rows = 0;

  double step() const { return lattice.matrix()[0]; }      // h
  double row_step() const { return lattice.matrix()[3]; }  // (sqrt(3)/2) h
  // Position of stored (i, j); any integers (periodic images beyond the grid).
  Vec2 position(long i, long j) const {
    const Vec2 o = lattice.origin();
    return {o.x + step() * (i + 0.5 * double(j & 1)), o.y + row_step() * j};
  }
  // Stored index of (i, j) under the periodic rule.
  long wrap_column(long i) const {
    return (i >= 0 && i < columns) ? i : ((i % columns) + columns) % columns;
  }
  long wrap_row(long j) const { return (j >= 0 && j < rows) ? j : ((j % rows) + rows) % rows; }
};

// Margin in lattice steps for generator order n: 10 for the hat, 20 for the
// quartic. The seam's effect decays like rho^d at d steps from the grid's edge
// (rho about 0.2 for the hat, 0.48 for the quartic); with these margins it is
// below 1e-7 of the seam's jump everywhere in the frame, its edges included
// (test HexProjection.SeamEffectBelowFloatResolution).
int hex_default_margin(int order);

// The layout for a frame of image_width x image_height output pixels.
// margin in lattice steps, >= 0.
HexLayout hex_layout(double density, double image_width, double image_height, int margin);

// The layout of stored coefficients; throws std::invalid_argument unless the
// lattice is hexagonal and the grid has an even number of rows.
HexLayout hex_layout(const Coefficients& coefficients);

// Generator of a hexagonal approximation: the box spline whose degree
// Coefficients::generator records. Throws unless it is 1 or 4.
const BoxSpline& hex_generator(const Coefficients& coefficients);  // its box_spline

}  // namespace sis
