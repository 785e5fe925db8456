#include "server/geometry/aabb.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

namespace hapticd::geometry {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const Aabb kBox{{-1, -2, -3}, {1, 2, 3}};

TEST(AabbDistance, PointDistanceExactly) {
  EXPECT_EQ(CalcPointAabbDistanceSquared({0, 0, 0}, kBox), 0);
  EXPECT_EQ(CalcPointAabbDistanceSquared({1, 2, 3}, kBox), 0);  // a corner: on the closed box
  EXPECT_EQ(CalcPointAabbDistanceSquared({3, 0, 0}, kBox), 4);
  EXPECT_EQ(CalcPointAabbDistanceSquared({-2, 4, 5}, kBox), 1 + 4 + 4);
  // an unbounded side is never nearer than the others; the empty box is infinitely far
  const Aabb slab{{-kInf, -kInf, 0}, {kInf, kInf, 1}};
  EXPECT_EQ(CalcPointAabbDistanceSquared({1e300, -1e300, 3}, slab), 4);
  EXPECT_EQ(CalcPointAabbDistanceSquared({0, 0, 0}, Aabb::Empty()), kInf);
}

TEST(AabbDistance, BoxDistanceExactly) {
  EXPECT_EQ(CalcAabbAabbDistanceSquared(kBox, kBox), 0);
  EXPECT_EQ(CalcAabbAabbDistanceSquared(kBox, {{1, 2, 3}, {5, 5, 5}}), 0);  // sharing a corner
  EXPECT_EQ(CalcAabbAabbDistanceSquared(kBox, {{3, -1, -1}, {4, 1, 1}}), 4);
  EXPECT_EQ(CalcAabbAabbDistanceSquared({{3, 4, 5}, {6, 6, 6}}, kBox), 4 + 4 + 4);
  const Aabb slab{{-kInf, -kInf, 0}, {kInf, kInf, 1}};
  EXPECT_EQ(CalcAabbAabbDistanceSquared(slab, {{7, 7, 3}, {8, 8, 4}}), 4);
  EXPECT_EQ(CalcAabbAabbDistanceSquared(kBox, Aabb::Empty()), kInf);
  EXPECT_EQ(CalcAabbAabbDistanceSquared(Aabb::Empty(), kBox), kInf);
}

// Against the clamped closest point, and the box distance against its Minkowski
// difference's distance from the origin; both symmetric in the boxes.
TEST(AabbDistance, AgreesWithClosestPointsOnRandomBoxes) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> coordinate(-4, 4);
  const auto random_box = [&] {
    const Vector3 p(coordinate(rng), coordinate(rng), coordinate(rng));
    const Vector3 q(coordinate(rng), coordinate(rng), coordinate(rng));
    return Aabb{p.cwiseMin(q), p.cwiseMax(q)};
  };
  for (int i = 0; i < 2000; ++i) {
    const Aabb x = random_box();
    const Aabb y = random_box();
    const Vector3 p(coordinate(rng), coordinate(rng), coordinate(rng));
    Vector3 clamped;
    for (int k = 0; k < 3; ++k) clamped[k] = std::clamp(p[k], x.min[k], x.max[k]);
    EXPECT_NEAR(CalcPointAabbDistanceSquared(p, x), (p - clamped).squaredNorm(), 1e-12) << i;
    const Aabb difference{x.min - y.max, x.max - y.min};
    EXPECT_NEAR(CalcAabbAabbDistanceSquared(x, y), CalcPointAabbDistanceSquared(Vector3::Zero(), difference), 1e-12)
        << i;
    EXPECT_EQ(CalcAabbAabbDistanceSquared(x, y), CalcAabbAabbDistanceSquared(y, x)) << i;
  }
}

}  // namespace
}  // namespace hapticd::geometry
