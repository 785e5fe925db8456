#include "server/geometry/sphere_sphere.h"
#include "server/geometry/test/non_finite.h"
#include "server/geometry/test/random_geometry.h"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace hapticd::geometry {
namespace {

constexpr double kTol = 1e-12;

// The witness points sit on the surfaces, |distance| apart, along the normal.
void ExpectConsistent(const Sphere& a, const Sphere& b, const SphereSphereResult& r) {
  const double scale = 1 + a.radius + b.radius + (b.center - a.center).norm();
  EXPECT_NEAR(r.normal.norm(), 1.0, kTol);
  EXPECT_NEAR((r.point_a - a.center).norm(), a.radius, kTol * scale);
  EXPECT_NEAR((r.point_b - b.center).norm(), b.radius, kTol * scale);
  EXPECT_LT((r.point_b - r.point_a - r.distance * r.normal).norm(), kTol * scale);
  EXPECT_EQ(r.intersect, r.distance <= 0);
}

TEST(SphereSphereTest, SeparatedAlongX) {
  const Sphere a{{0, 0, 0}, 1};
  const Sphere b{{3, 0, 0}, 0.5};
  const SphereSphereResult r = CollideSpheres(a, b);
  EXPECT_FALSE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, 1.5);
  EXPECT_EQ(r.normal, Vector3(1, 0, 0));
  EXPECT_EQ(r.point_a, Vector3(1, 0, 0));
  EXPECT_EQ(r.point_b, Vector3(2.5, 0, 0));
}

TEST(SphereSphereTest, OverlappingReportsMinusDepth) {
  const Sphere a{{0, 0, 0}, 1};
  const Sphere b{{0, 1.5, 0}, 1};
  const SphereSphereResult r = CollideSpheres(a, b);
  EXPECT_TRUE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, -0.5);
  EXPECT_EQ(r.normal, Vector3(0, 1, 0));
  EXPECT_EQ(r.point_a, Vector3(0, 1, 0));
  EXPECT_EQ(r.point_b, Vector3(0, 0.5, 0));
}

// One sphere inside the other: depth = ra + rb - d, the translation to separate.
TEST(SphereSphereTest, ContainedSphere) {
  const Sphere a{{0, 0, 0}, 2};
  const Sphere b{{0, 0, 0.5}, 0.25};
  const SphereSphereResult r = CollideSpheres(a, b);
  EXPECT_TRUE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, -1.75);
  EXPECT_EQ(r.normal, Vector3(0, 0, 1));
}

// Concentric: the documented axis +x, depth ra + rb.
TEST(SphereSphereTest, ConcentricPicksPlusX) {
  const Sphere a{{0.25, -1, 3}, 0.5};
  const Sphere b{{0.25, -1, 3}, 0.75};
  const SphereSphereResult r = CollideSpheres(a, b);
  EXPECT_TRUE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, -1.25);
  EXPECT_EQ(r.normal, Vector3(1, 0, 0));
  ExpectConsistent(a, b, r);
}

// Touching with dyadic data: |(3, 4, 12) / 16| = 13/16 = 0.25 + 0.5625.
TEST(SphereSphereTest, TouchingIsContactWithZeroDistance) {
  const Sphere a{{1, 2, 3}, 0.25};
  const Sphere b{Vector3(1, 2, 3) + Vector3(3, 4, 12) / 16, 0.5625};
  const SphereSphereResult r = CollideSpheres(a, b);
  EXPECT_TRUE(r.intersect);
  EXPECT_EQ(r.distance, 0.0);
  EXPECT_EQ(CompareCenterDistanceToRadiusSum(a, b), 0);
  // One ulp less radius: apart; one ulp more: overlapping.
  Sphere smaller = b;
  smaller.radius = std::nextafter(b.radius, 0.0);
  EXPECT_FALSE(CollideSpheres(a, smaller).intersect);
  EXPECT_GT(CollideSpheres(a, smaller).distance, 0);
  Sphere larger = b;
  larger.radius = std::nextafter(b.radius, 1.0);
  EXPECT_TRUE(CollideSpheres(a, larger).intersect);
}

// Zero radii: two points. Coincident points touch; distinct points do not.
TEST(SphereSphereTest, PointSpheres) {
  const Sphere p{{1, 1, 1}, 0};
  EXPECT_TRUE(CollideSpheres(p, p).intersect);
  EXPECT_EQ(CollideSpheres(p, p).distance, 0.0);
  EXPECT_FALSE(CollideSpheres(p, Sphere{{1, 1, 2}, 0}).intersect);
  EXPECT_FALSE(CollideSpheres(p, Sphere{{1, 1, std::nextafter(1.0, 2.0)}, 0}).intersect);
}

// Exact decision against integer arithmetic. Coordinates are integers below 2^52
// times 2^-30 (exact doubles, and so are their differences); the squares need up to
// 104 bits, and radii nudged by one or two units change (ra + rb)^2 in the 52nd bit,
// so a plain floating-point comparison goes wrong there. Touching pairs come from
// Pythagorean quadruples (m^2 + n^2 - p^2 - q^2, 2(mq + np), 2(nq - mp)), of length
// m^2 + n^2 + p^2 + q^2.
TEST(SphereSphereTest, ExactAgainstIntegerOracleNearTouching) {
  std::mt19937_64 rng(20240611);
  std::uniform_int_distribution<int64_t> small(-(int64_t{1} << 25), int64_t{1} << 25);
  std::uniform_int_distribution<int64_t> offset(-(int64_t{1} << 50), int64_t{1} << 50);
  std::uniform_int_distribution<int> nudge(-2, 2);
  const double unit = std::ldexp(1.0, -30);
  const auto to_double = [unit](int64_t x, int64_t y, int64_t z) -> Vector3 {
    return Vector3(static_cast<double>(x), static_cast<double>(y), static_cast<double>(z)) * unit;
  };
  int touching = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const int64_t m = small(rng), n = small(rng), p = small(rng), q = small(rng);
    const int64_t dx = m * m + n * n - p * p - q * q;
    const int64_t dy = 2 * (m * q + n * p);
    const int64_t dz = 2 * (n * q - m * p);
    const int64_t length = m * m + n * n + p * p + q * q;
    if (length == 0) continue;
    std::uniform_int_distribution<int64_t> split(0, length);
    const int64_t ra = split(rng);
    const int64_t rb = length - ra + nudge(rng);
    if (rb < 0) continue;
    const int64_t ax = offset(rng), ay = offset(rng), az = offset(rng);
    const Sphere a{to_double(ax, ay, az), static_cast<double>(ra) * unit};
    const Sphere b{to_double(ax + dx, ay + dy, az + dz), static_cast<double>(rb) * unit};
    // Exact sign of d^2 - (ra + rb)^2 in 128-bit integers.
    const __int128 d2 = static_cast<__int128>(dx) * dx + static_cast<__int128>(dy) * dy +
                        static_cast<__int128>(dz) * dz;
    const __int128 s = static_cast<__int128>(ra) + rb;
    const __int128 diff = d2 - s * s;
    const int expected = diff > 0 ? 1 : (diff < 0 ? -1 : 0);
    touching += expected == 0;
    ASSERT_EQ(CompareCenterDistanceToRadiusSum(a, b), expected) << "trial " << trial;
    ASSERT_EQ(CompareCenterDistanceToRadiusSum(b, a), expected);
    ASSERT_EQ(CollideSpheres(a, b).intersect, expected <= 0);
  }
  EXPECT_GT(touching, 2000);
}

// Random pairs: the distance against |cb - ca| - ra - rb, witnesses on the surfaces.
TEST(SphereSphereTest, RandomPairsAgreeWithFormula) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> coord(-2, 2);
  std::uniform_real_distribution<double> radius(0, 1.5);
  for (int trial = 0; trial < 20000; ++trial) {
    const Sphere a{{coord(rng), coord(rng), coord(rng)}, radius(rng)};
    const Sphere b{{coord(rng), coord(rng), coord(rng)}, radius(rng)};
    const SphereSphereResult r = CollideSpheres(a, b);
    const double d = std::sqrt((b.center - a.center).array().square().sum());
    const double expected = d - a.radius - b.radius;
    ASSERT_NEAR(r.distance, expected, kTol * 10);
    if (std::abs(expected) > 1e-12) {
      ASSERT_EQ(r.intersect, expected < 0);
    }
    ExpectConsistent(a, b, r);
  }
}

// Swapping the arguments flips the normal and swaps the witnesses.
TEST(SphereSphereTest, SwapFlipsNormal) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coord(-2, 2);
  std::uniform_real_distribution<double> radius(0, 1.5);
  for (int trial = 0; trial < 1000; ++trial) {
    const Sphere a{{coord(rng), coord(rng), coord(rng)}, radius(rng)};
    const Sphere b{{coord(rng), coord(rng), coord(rng)}, radius(rng)};
    const SphereSphereResult ab = CollideSpheres(a, b);
    const SphereSphereResult ba = CollideSpheres(b, a);
    EXPECT_EQ(ab.intersect, ba.intersect);
    EXPECT_EQ(ab.distance, ba.distance);
    EXPECT_LT((ab.normal + ba.normal).norm(), kTol);
    EXPECT_LT((ab.point_a - ba.point_b).norm(), kTol);
  }
}

// A rigid motion of both spheres moves the answer with them.
TEST(SphereSphereTest, RigidMotionInvariance) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> coord(-2, 2);
  std::uniform_real_distribution<double> radius(0.01, 1.5);
  for (int trial = 0; trial < 1000; ++trial) {
    const Sphere a{{coord(rng), coord(rng), coord(rng)}, radius(rng)};
    const Sphere b{{coord(rng), coord(rng), coord(rng)}, radius(rng)};
    const Matrix3 R = RandomRotation(rng);
    const Vector3 t(coord(rng) * 100, coord(rng) * 100, coord(rng) * 100);
    const Sphere ma{R * a.center + t, a.radius};
    const Sphere mb{R * b.center + t, b.radius};
    const SphereSphereResult r = CollideSpheres(a, b);
    const SphereSphereResult m = CollideSpheres(ma, mb);
    EXPECT_NEAR(m.distance, r.distance, 1e-11);
    EXPECT_TRUE((m.normal - R * r.normal).norm() < 1e-9);
  }
}

// NaN and infinity: no crash, no hang; the answer is unspecified.
// The answer to non-finite input: no contact, every field zero, so finite.
void ExpectNonFiniteAnswer(const SphereSphereResult& r) {
  EXPECT_FALSE(r.intersect);
  EXPECT_EQ(r.distance, 0.0);
  EXPECT_EQ(r.normal, Vector3::Zero());
  EXPECT_EQ(r.point_a, Vector3::Zero());
  EXPECT_EQ(r.point_b, Vector3::Zero());
}

// A NaN or infinity in any field of either sphere gives that answer, also where the
// finite spheres overlap (here a sphere and itself); the exact sign says "apart".
TEST(SphereSphereTest, NonFiniteInputIsNoContact) {
  const double inf = std::numeric_limits<double>::infinity();
  const Sphere good{{0, 0, 0}, 1};
  ASSERT_TRUE(CollideSpheres(good, good).intersect);
  std::vector<Sphere> bad = WithOneNonFiniteField(good);
  ASSERT_EQ(bad.size(), 12u);  // 4 fields (centre, radius) x 3 values
  bad.push_back({{0, -inf, 0}, inf});
  bad.push_back({{inf, inf, inf}, 1});
  for (std::size_t i = 0; i < bad.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "case " << i);
    ExpectNonFiniteAnswer(CollideSpheres(good, bad[i]));
    ExpectNonFiniteAnswer(CollideSpheres(bad[i], good));
    ExpectNonFiniteAnswer(CollideSpheres(bad[i], bad[i]));
    EXPECT_EQ(CompareCenterDistanceToRadiusSum(bad[i], good), 1);
    EXPECT_EQ(CompareCenterDistanceToRadiusSum(good, bad[i]), 1);
  }
}

}  // namespace
}  // namespace hapticd::geometry
