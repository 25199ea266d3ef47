#include "sis/boundary.h"

#include <stdexcept>

namespace sis {

Boundary parse_boundary(const std::string& s) {
  if (s == "mirror") return Boundary::Mirror;
  if (s == "periodic") return Boundary::Periodic;
  throw std::invalid_argument("unknown boundary rule '" + s + "' (expected mirror or periodic)");
}

std::string boundary_name(Boundary b) { return b == Boundary::Mirror ? "mirror" : "periodic"; }

}  // namespace sis
