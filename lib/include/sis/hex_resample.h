#pragma once
// Resampling on the hexagonal lattice: samples the continuous approximation
// f_app(x) = sum_n c[n] M_n(L^{-1} (x - x_n)) at the Cartesian pixels of a
// final image, coefficients periodic on their offset-row grid
// (sis/hex_lattice.h). Final pixel (i, j) of a W x H image over a frame of
// image_width x image_height output pixels has centre ((i + 1/2) sx, (j + 1/2) sy),
// sx = image_width / W; display offsets are in final pixels (resample.h).
// Points: along each final row, one horizontal slice of M_n per coefficient
// row and vertical offset (BoxSplineSlice). PixelAverage: exact. For each
// final row [c, d] and coefficient row, the band integral of M_n over those
// heights, Z(t) = int M_n(t - v/2, v) dv, is a piecewise polynomial of degree
// 3n - 1 in the horizontal offset t (built exactly from vertical line
// integrals, each exact by Gauss-Legendre between its knots); the pixel
// [a, b] x [c, d] weighs c[n] by the integral of Z over [a, b] (its
// antiderivative's difference) over the pixel's area.
#include "sis/hex_lattice.h"
#include "sis/resample.h"

namespace sis {

// f_app at one point (direct evaluation; for tests and probes).
double hex_evaluate(const Coefficients& coefficients, Vec2 x, int channel = 0);

// The final image of out_width x out_height pixels.
Image hex_resample(const Coefficients& coefficients, const Display& display, long out_width,
                   long out_height, int threads = 1);

}  // namespace sis
