// The gathered triangles' nearest-point search passes triangles over by lower bounds of
// their distance; a bound met exactly by the answer must still let its triangle be tried.
#include "server/query/gathered_mesh.h"

#include <gtest/gtest.h>

#include <array>

namespace hapticd::query {
namespace {

using geometry::PrepareTriangle;
using geometry::PreparedTriangle;
using geometry::Triangle;

// p lies beyond the apex of `apex_first` (the corner farthest from its centroid),
// straight out from the centroid: the height over its plane beside the bounding circle
// is exactly its distance, 5 mm, met at the apex. `decoy` has the nearer box (it spans
// p's foot on its plane, 1.5 mm away) and is tried first, but its edge nearest the foot
// runs diagonally 4.77 mm from it: it lies 10 nm farther than apex_first. Only a bound
// no tighter than the truth (by more than 10 nm) leaves apex_first to be tried, and then
// found nearer.
TEST(FindGatheredClosestPoint, TriesATriangleWhoseBoundIsExactlyItsDistance) {
  const Vector3 p(0.003, 0, 0.004);
  const Triangle apex_first{Vector3(0, 0, 0), Vector3(-0.01, -0.002, 0), Vector3(-0.01, 0.002, 0)};
  // in the plane x = 4.5 mm: an edge along the diagonal through the point
  // sqrt(5.00001² - 1.5²) mm from the foot (0, 4 mm), the third corner beyond it
  const Triangle decoy{Vector3(0.0045, 0.017514827427031393, -0.0067694438204305048),
                       Vector3(0.0045, -0.010769443820430505, 0.021514827427031393),
                       Vector3(0.0045, 0.024585895238896868, 0.028585895238896868)};
  for (const bool decoy_first : {true, false}) {
    SCOPED_TRACE(decoy_first ? "decoy first in the span" : "decoy second");
    const std::array<PreparedTriangle, 2> triangles =
        decoy_first ? std::array{PrepareTriangle(decoy, 7), PrepareTriangle(apex_first, 3)}
                    : std::array{PrepareTriangle(apex_first, 3), PrepareTriangle(decoy, 7)};
    const GatheredMesh near{triangles, geometry::Capsule{p, p, 0.05}};
    const auto closest = FindGatheredClosestPoint(near, p, 1.0);
    ASSERT_TRUE(closest.has_value());
    ASSERT_TRUE(closest->found);
    EXPECT_EQ(closest->triangle, 3);
    EXPECT_EQ(closest->point, Vector3::Zero());
    EXPECT_NEAR(closest->distance, 0.005, 1e-15);
  }
}

}  // namespace
}  // namespace hapticd::query
