#pragma once
// The dispatch on the values a coefficient holds (a sample's channels, and
// in the scattered passes the weight sum where the rule keeps one): the
// count as a compile-time constant for 1 to 5, so that the inner loops are
// unrolled, else 0 (any count, at run time).
#include <type_traits>

namespace sis {

template <typename F>
void with_width(int A, F&& f) {
  switch (A) {
    case 1: return f(std::integral_constant<int, 1>{});
    case 2: return f(std::integral_constant<int, 2>{});
    case 3: return f(std::integral_constant<int, 3>{});
    case 4: return f(std::integral_constant<int, 4>{});
    case 5: return f(std::integral_constant<int, 5>{});
    default: return f(std::integral_constant<int, 0>{});
  }
}

}  // namespace sis
