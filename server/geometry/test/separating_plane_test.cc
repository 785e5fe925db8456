#include "server/geometry/separating_plane.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "server/geometry/gjk.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

std::vector<Vector3> Cube(const Vector3& lo, const Vector3& hi) {
  std::vector<Vector3> corners;
  for (int i = 0; i < 8; ++i) corners.push_back(Vector3(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z()));
  return corners;
}

// Every point of a strictly below the plane, every point of b strictly above it.
void ExpectSeparates(const SeparatingPlane& s, const std::vector<Vector3>& a, const std::vector<Vector3>& b) {
  ASSERT_TRUE(s.found);
  EXPECT_NEAR(s.normal.norm(), 1, 1e-15);
  EXPECT_GT(s.margin, 0);
  for (const Vector3& p : a) EXPECT_LE(s.normal.dot(p) - s.offset, -s.margin * (1 - 1e-9));
  for (const Vector3& p : b) EXPECT_GE(s.normal.dot(p) - s.offset, s.margin * (1 - 1e-9));
}

TEST(SeparatingPlane, CubesApart) {
  const auto a = Cube(Vector3(0, 0, 0), Vector3(1, 1, 1));
  const auto b = Cube(Vector3(1.5, 0.25, -0.5), Vector3(2.5, 1.25, 0.5));
  const SeparatingPlane s = FindSeparatingPlane(a, b, 1);
  ExpectSeparates(s, a, b);
  // the only separating direction family here leans on +x
  EXPECT_GT(s.normal.x(), 0);
  // reversed, the plane flips
  const SeparatingPlane r = FindSeparatingPlane(b, a, 1);
  ExpectSeparates(r, b, a);
  EXPECT_LT(r.normal.x(), 0);
}

TEST(SeparatingPlane, TouchingAndOverlappingCubesHaveNone) {
  const auto a = Cube(Vector3(0, 0, 0), Vector3(1, 1, 1));
  // sharing a face, an edge, a corner; then overlapping
  EXPECT_FALSE(FindSeparatingPlane(a, Cube(Vector3(1, 0, 0), Vector3(2, 1, 1)), 2).found);
  EXPECT_FALSE(FindSeparatingPlane(a, Cube(Vector3(1, 1, 0), Vector3(2, 2, 1)), 2).found);
  EXPECT_FALSE(FindSeparatingPlane(a, Cube(Vector3(1, 1, 1), Vector3(2, 2, 2)), 2).found);
  EXPECT_FALSE(FindSeparatingPlane(a, Cube(Vector3(0.5, 0.5, 0.5), Vector3(2, 2, 2)), 2).found);
  // a gap of 2^-20 is still a gap
  EXPECT_TRUE(FindSeparatingPlane(a, Cube(Vector3(1 + std::ldexp(1.0, -20), 0, 0), Vector3(2, 1, 1)), 2).found);
}

TEST(SeparatingPlane, ExistsExactlyWhenGjkSeparates) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> u(0, 1);
  int separated = 0, overlapping = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::vector<Vector3> a = RandomBall(rng, 4 + trial % 40, 0.3 + u(rng), Vector3::Zero());
    const Vector3 offset(3 * u(rng), u(rng) - 0.5, u(rng) - 0.5);
    const std::vector<Vector3> b = RandomBall(rng, 4 + (trial * 3) % 40, 0.3 + u(rng), offset);
    const GjkResult gjk = CalcGjkDistance(PointSetSupport(a), PointSetSupport(b));
    // skip the rare pairs within 1e-9 of contact, where rounding may decide either way
    if (std::abs(gjk.distance) < 1e-9 && !gjk.intersect) continue;
    const SeparatingPlane s = FindSeparatingPlane(a, b, trial);
    ASSERT_EQ(s.found, !gjk.intersect) << trial;
    if (s.found) {
      ++separated;
      ExpectSeparates(s, a, b);
      // no plane can clear both sets by more than half their distance
      EXPECT_LE(s.margin, 0.5 * gjk.distance * (1 + 1e-12));
    } else {
      ++overlapping;
    }
    // the seed changes the work, never the answer
    EXPECT_EQ(FindSeparatingPlane(a, b, trial + 1000).found, s.found);
  }
  EXPECT_GT(separated, 100);
  EXPECT_GT(overlapping, 100);
}

TEST(SeparatingPlane, PointsAndDegenerateSets) {
  const std::vector<Vector3> p = {Vector3(1, 2, 3)}, q = {Vector3(1, 2, 4)};
  const SeparatingPlane s = FindSeparatingPlane(p, q, 5);
  ExpectSeparates(s, p, q);
  // any tilt separates two points; the plane passes midway between them
  EXPECT_NEAR(s.normal.dot(Vector3(1, 2, 3.5)), s.offset, 1e-12);
  EXPECT_FALSE(FindSeparatingPlane(p, p, 5).found);
  // two crossing segments touch; parallel ones apart do not
  const std::vector<Vector3> s1 = {Vector3(-1, 0, 0), Vector3(1, 0, 0)}, s2 = {Vector3(0, -1, 0), Vector3(0, 1, 0)};
  EXPECT_FALSE(FindSeparatingPlane(s1, s2, 5).found);
  const std::vector<Vector3> s3 = {Vector3(-1, 0, 0.5), Vector3(1, 0, 0.5)};
  ExpectSeparates(FindSeparatingPlane(s1, s3, 5), s1, s3);
}

TEST(SeparatingPlane, BadInputFindsNothingAndEnds) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Vector3> a = {Vector3(0, 0, 0), Vector3(nan, 0, 0)}, b = {Vector3(3, 0, 0)};
  EXPECT_FALSE(FindSeparatingPlane(a, b, 1).found);
  EXPECT_FALSE(FindSeparatingPlane({}, b, 1).found);
  const std::vector<Vector3> inf = {Vector3(0, std::numeric_limits<double>::infinity(), 0)};
  EXPECT_FALSE(FindSeparatingPlane(inf, b, 1).found);
}

}  // namespace
}  // namespace hapticd::geometry
