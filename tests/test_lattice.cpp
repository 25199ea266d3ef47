// Lattice and coordinate conventions (docs/design.md section 2).
#include <gtest/gtest.h>

#include <cmath>

#include "sis/boundary.h"
#include "sis/lattice.h"

using namespace sis;

TEST(Lattice, CartesianCoefficientsSitOnPixelCentres) {
  const Lattice L = Lattice::cartesian();
  for (int n1 = -3; n1 < 5; ++n1)
    for (int n2 = -2; n2 < 4; ++n2) {
      const Vec2 p = L.position(n1, n2);
      EXPECT_EQ(p.x, n1 + 0.5);
      EXPECT_EQ(p.y, n2 + 0.5);
      const Vec2 u = L.coordinates(p);
      EXPECT_NEAR(u.x, n1, 1e-15);
      EXPECT_NEAR(u.y, n2, 1e-15);
    }
  EXPECT_TRUE(L.separable());
  const auto e = L.extent(640, 480);
  EXPECT_EQ(e[0], 640);
  EXPECT_EQ(e[1], 480);
  EXPECT_THROW(Lattice::cartesian(3, 1).extent(640, 480), std::invalid_argument);
}

TEST(Lattice, GeneralMatrixRoundTrip) {
  const double h = std::sqrt(2 / std::sqrt(3.0));
  const Lattice hex({0.5, 0.5}, {h, h / 2, 0, h * std::sqrt(3.0) / 2});
  EXPECT_FALSE(hex.separable());
  EXPECT_NEAR(hex.determinant(), 1.0, 1e-14);  // same density as the pixels
  for (double a : {-2.0, 0.0, 3.5})
    for (double b : {-1.0, 0.25, 7.0}) {
      const Vec2 u = hex.coordinates(hex.position(a, b));
      EXPECT_NEAR(u.x, a, 1e-13);
      EXPECT_NEAR(u.y, b, 1e-13);
    }
  EXPECT_THROW(Lattice({0, 0}, {1, 2, 2, 4}), std::invalid_argument);
}

TEST(Boundary, MirrorIsHalfSampleSymmetricAndPeriodicWraps) {
  const long n = 5;
  EXPECT_EQ(extend_index(-1, n, Boundary::Mirror), 0);
  EXPECT_EQ(extend_index(-2, n, Boundary::Mirror), 1);
  EXPECT_EQ(extend_index(5, n, Boundary::Mirror), 4);
  EXPECT_EQ(extend_index(6, n, Boundary::Mirror), 3);
  EXPECT_EQ(extend_index(-11, n, Boundary::Mirror), 0);  // period 2n
  EXPECT_EQ(extend_index(-1, n, Boundary::Periodic), 4);
  EXPECT_EQ(extend_index(7, n, Boundary::Periodic), 2);
  for (long i = -30; i < 30; ++i) {
    EXPECT_EQ(extend_index(i, n, Boundary::Mirror), extend_index(-1 - i, n, Boundary::Mirror));
    EXPECT_EQ(extend_index(i, n, Boundary::Periodic), extend_index(i + n, n, Boundary::Periodic));
  }
  EXPECT_EQ(parse_boundary("mirror"), Boundary::Mirror);
  EXPECT_THROW(parse_boundary("reflect"), std::invalid_argument);
}
