#pragma once
// A pyramid: the levels j = 0, 1, 2, ... of one output, level j of about
// 2^-j times level 0's size, each the projection of the render itself onto
// the space at that level's frame (docs/design.md section 14). On this
// project's lattice (coefficients at pixel centres) halving nests the
// spaces only for even degrees, so no level is made from the one above:
// every level's inner products come from the samples, all levels from one
// reading of the inputs (engine.h's project(requests)).
#include <utility>
#include <vector>

#include "sis/engine.h"

namespace sis {

// The levels' sizes as maketx (and oiiotool -otex) makes them, which is
// OpenEXR's MIP-map rule with rounding down: level j is
// max(1, floor(W / 2^j)) x max(1, floor(H / 2^j)), down to and including
// 1 x 1 (floor(log2(max(W, H))) + 1 levels; 37 x 21: 37x21 18x10 9x5 4x2
// 2x1 1x1). Throws RequestError for a side below 1.
std::vector<std::pair<long, long>> pyramid_sizes(long width, long height);

// The levels as the targets of one reading: level 0 is `level0` itself,
// level j the same request (space, method, boundary, prefilter, coefficient
// type) with level j's frame and no inputs of its own. The hexagonal
// lattice is refused (RequestError): its levels are not made here.
std::vector<ProjectionRequest> pyramid_requests(const ProjectionRequest& level0);

// Every level from one reading of level0's inputs: element j is level j,
// bit for bit what project() gives level j's request alone. The memory
// check is of all the levels together.
std::vector<Projection> project_pyramid(const ProjectionRequest& level0);

}  // namespace sis
