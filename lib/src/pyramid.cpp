// Pyramids (sis/pyramid.h): maketx's level sizes, the levels as targets of
// one reading.
#include "sis/pyramid.h"

#include <string>
#include <variant>

namespace sis {

std::vector<std::pair<long, long>> pyramid_sizes(long width, long height) {
  if (width < 1 || height < 1)
    throw RequestError("--mip: an output of " + std::to_string(width) + " x " +
                       std::to_string(height) + " pixels has no level");
  std::vector<std::pair<long, long>> sizes{{width, height}};
  while (width > 1 || height > 1) {
    width = std::max(1L, width / 2);
    height = std::max(1L, height / 2);
    sizes.push_back({width, height});
  }
  return sizes;
}

std::vector<ProjectionRequest> pyramid_requests(const ProjectionRequest& level0) {
  if (std::holds_alternative<HexagonalSpace>(level0.space))
    throw RequestError("--mip: the hexagonal lattice has no pyramid (its levels are not made); "
                       "use --lattice cartesian");
  std::vector<ProjectionRequest> levels;
  for (const auto& [w, h] : pyramid_sizes(level0.width, level0.height)) {
    levels.push_back(level0);
    if (levels.size() > 1) levels.back().inputs.clear();
    levels.back().width = w;
    levels.back().height = h;
  }
  return levels;
}

std::vector<Projection> project_pyramid(const ProjectionRequest& level0) {
  return project(pyramid_requests(level0));
}

}  // namespace sis
