#include "server/geometry/exact_predicates.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace hapticd::geometry {
namespace {

using Int3 = std::array<__int128, 3>;

// Oracle: the orientation of integer points, computed exactly in 128-bit integers.
int OrientInt(const Int3& a, const Int3& b, const Int3& c, const Int3& d) {
  const Int3 u{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const Int3 v{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const Int3 w{d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  const __int128 det = (u[1] * v[2] - u[2] * v[1]) * w[0] + (u[2] * v[0] - u[0] * v[2]) * w[1] +
                       (u[0] * v[1] - u[1] * v[0]) * w[2];
  return (det > 0) - (det < 0);
}

// Integer point scaled by 2^exponent: exact in double, so the oracle applies.
Vector3 ToDouble(const Int3& p, int exponent) {
  return {std::ldexp(static_cast<double>(p[0]), exponent),
          std::ldexp(static_cast<double>(p[1]), exponent),
          std::ldexp(static_cast<double>(p[2]), exponent)};
}

TEST(Orient3d, RightHandedNormalSideIsPositive) {
  const Vector3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_EQ(Orient3d(a, b, c, Vector3(0.2, 0.2, 1)), 1);
  EXPECT_EQ(Orient3d(a, b, c, Vector3(0.2, 0.2, -1)), -1);
  EXPECT_EQ(Orient3d(a, b, c, Vector3(5, -3, 0)), 0);
}

TEST(Orient3d, SwappingTwoArgumentsFlipsTheSign) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> x(-1, 1);
  for (int i = 0; i < 1000; ++i) {
    const Vector3 a(x(rng), x(rng), x(rng)), b(x(rng), x(rng), x(rng));
    const Vector3 c(x(rng), x(rng), x(rng));
    // d nearly on the plane, to force the exact path
    const Vector3 d = a + 0.3 * (b - a) + 0.6 * (c - a);
    const int s = Orient3d(a, b, c, d);
    EXPECT_EQ(Orient3d(b, a, c, d), -s);
    EXPECT_EQ(Orient3d(a, c, b, d), -s);
    EXPECT_EQ(Orient3d(a, b, d, c), -s);
    EXPECT_EQ(Orient3d(d, b, c, a), -s);
  }
}

// Near-coplanar integer points (an exactly coplanar point nudged by at most one unit)
// at several scales, against the exact integer oracle.
TEST(Orient3d, MatchesTheExactOracleOnNearCoplanarPoints) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int64_t> coord(-(1 << 19), 1 << 19);
  std::uniform_int_distribution<int64_t> small(-64, 64);
  std::uniform_int_distribution<int64_t> nudge(-1, 1);
  std::uniform_int_distribution<int> exponent(-60, 10);
  int zero_count = 0;
  for (int i = 0; i < 20000; ++i) {
    const Int3 a{coord(rng), coord(rng), coord(rng)};
    const Int3 b{coord(rng), coord(rng), coord(rng)};
    const Int3 c{coord(rng), coord(rng), coord(rng)};
    const __int128 s = small(rng), t = small(rng);
    Int3 d;
    for (int k = 0; k < 3; ++k) d[k] = a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]) + nudge(rng);
    const int e = exponent(rng);
    const int expected = OrientInt(a, b, c, d);
    zero_count += expected == 0;
    ASSERT_EQ(Orient3d(ToDouble(a, e), ToDouble(b, e), ToDouble(c, e), ToDouble(d, e)), expected)
        << "case " << i;
  }
  // the generator must exercise the exact zero case often
  EXPECT_GT(zero_count, 500);
}

TEST(Orient2d, MatchesNearCollinearClassic) {
  // Shewchuk's example: points a hair off the line y = x.
  const double ulp = std::ldexp(1.0, -53);
  for (int i = 0; i < 16; ++i) {
    for (int j = 0; j < 16; ++j) {
      const Vector2 a(0.5 + i * ulp, 0.5 + j * ulp);
      const int expected = (j > i) - (j < i);  // above the line turns counter-clockwise
      EXPECT_EQ(Orient2d(Vector2(12, 12), Vector2(24, 24), a), expected) << i << "," << j;
    }
  }
}

TEST(OrientLineEdge, AgreesWithOrient3dForExactDirections) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int64_t> coord(-1000, 1000);
  for (int i = 0; i < 5000; ++i) {
    const Int3 o{coord(rng), coord(rng), coord(rng)}, q{coord(rng), coord(rng), coord(rng)};
    const Int3 a{coord(rng), coord(rng), coord(rng)}, b{coord(rng), coord(rng), coord(rng)};
    const Vector3 dir = ToDouble(q, 0) - ToDouble(o, 0);  // exact: small integers
    // dir . ((a - o) x (b - o)) = orient3d(o, q, a, b)
    EXPECT_EQ(OrientLineEdge(ToDouble(o, 0), dir, ToDouble(a, 0), ToDouble(b, 0)),
              OrientInt(o, q, a, b));
    EXPECT_EQ(OrientLineEdge(ToDouble(o, 0), dir, ToDouble(b, 0), ToDouble(a, 0)),
              -OrientInt(o, q, a, b));
  }
}

TEST(IsDegenerateTriangle, DetectsExactCollinearity) {
  EXPECT_TRUE(IsDegenerateTriangle(Vector3(-0.625, -0.375, -0.4375), Vector3(-0.5, -0.25, -1.3125),
                                   Vector3(-0.75, -0.5, 0.4375)));
  EXPECT_TRUE(IsDegenerateTriangle(Vector3(1, 1, 1), Vector3(1, 1, 1), Vector3(1, 1, 1)));
  EXPECT_FALSE(IsDegenerateTriangle(Vector3(0, 0, 0), Vector3(1, 0, 0), Vector3(0, 1e-300, 0)));
}

TEST(ExactPredicates, NonFiniteInputNeitherCrashesNorHangs) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Vector3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  const int s1 = Orient3d(a, b, c, Vector3(nan, 0, 0));
  const int s2 = Orient3d(a, b, c, Vector3(inf, -inf, 0));
  EXPECT_GE(s1, -1);
  EXPECT_LE(s1, 1);
  EXPECT_GE(s2, -1);
  EXPECT_LE(s2, 1);
}

}  // namespace
}  // namespace hapticd::geometry
