#include "server/geometry/box_box.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "server/geometry/segment_triangle.h"
#include "server/geometry/test/box_surface.h"
#include "server/geometry/test/non_finite.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

// The 12 edges as corner-index pairs that differ in one bit.
std::array<std::array<int, 2>, 12> EdgeCorners() {
  std::array<std::array<int, 2>, 12> edges;
  int n = 0;
  for (int k = 0; k < 8; ++k) {
    for (int i = 0; i < 3; ++i) {
      if (!((k >> i) & 1)) edges[n++] = {k, k | (1 << i)};
    }
  }
  return edges;
}

bool ContainsPoint(const Box& box, const Vector3& p) {
  const Vector3 local = box.rotation.transpose() * (p - box.center);
  return (local.array().abs() <= box.half_extents.array()).all();
}

// Oracle independent of the separating axis test: two convex polyhedra intersect iff
// an edge of one crosses a face of the other or a vertex of one lies in the other.
bool OracleOverlap(const Box& a, const Box& b) {
  for (const auto& [p, q] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
    for (int k = 0; k < 8; ++k) {
      if (ContainsPoint(*q, Corner(*p, k))) return true;
    }
    const std::array<Triangle, 12> faces = FaceTriangles(*q);
    for (const auto& [i, j] : EdgeCorners()) {
      const Vector3 e0 = Corner(*p, i);
      const Vector3 e1 = Corner(*p, j);
      for (const Triangle& t : faces) {
        if (IntersectSegmentTriangleWatertight(e0, e1, t).hit) return true;
      }
    }
  }
  return false;
}

Box Scaled(const Box& box, double factor) {
  return {box.center, box.rotation, box.half_extents * factor};
}

// The oracle's answer when it does not change with the boxes grown or shrunk by a
// relative 1e-7; -1 when the pair is that close to touching.
int RobustOracle(const Box& a, const Box& b) {
  const bool shrunk = OracleOverlap(Scaled(a, 1 - 1e-7), Scaled(b, 1 - 1e-7));
  const bool grown = OracleOverlap(Scaled(a, 1 + 1e-7), Scaled(b, 1 + 1e-7));
  return shrunk == grown ? shrunk : -1;
}

// True when one of the six face normals separates the boxes' projections (corners
// projected directly): the pairs where it is false and the boxes are apart need an
// edge-edge axis.
bool FaceAxisSeparates(const Box& a, const Box& b) {
  for (const Box* box : {&a, &b}) {
    for (int axis = 0; axis < 3; ++axis) {
      const Vector3 n = box->rotation.col(axis);
      double lo_a = std::numeric_limits<double>::infinity(), hi_a = -lo_a;
      double lo_b = lo_a, hi_b = hi_a;
      for (int k = 0; k < 8; ++k) {
        lo_a = std::min(lo_a, n.dot(Corner(a, k)));
        hi_a = std::max(hi_a, n.dot(Corner(a, k)));
        lo_b = std::min(lo_b, n.dot(Corner(b, k)));
        hi_b = std::max(hi_b, n.dot(Corner(b, k)));
      }
      if (hi_a < lo_b || hi_b < lo_a) return true;
    }
  }
  return false;
}

Box RandomBox(std::mt19937_64& rng, double spread) {
  std::uniform_real_distribution<double> coord(-spread, spread);
  std::uniform_real_distribution<double> extent(0.05, 1);
  return {{coord(rng), coord(rng), coord(rng)}, RandomRotation(rng),
          {extent(rng), extent(rng), extent(rng)}};
}

const Box kUnit{{0, 0, 0}, Matrix3::Identity(), {1, 1, 1}};

TEST(BoxBoxTest, AxisAlignedSeparatedAndOverlapping) {
  EXPECT_FALSE(BoxesOverlap(kUnit, {{2.5, 0, 0}, Matrix3::Identity(), {0.25, 1, 1}}));
  EXPECT_TRUE(BoxesOverlap(kUnit, {{2, 0, 0}, Matrix3::Identity(), {1.5, 0.25, 0.25}}));
  EXPECT_TRUE(BoxesOverlap(kUnit, {{0, 0, 0}, Matrix3::Identity(), {0.5, 0.5, 0.5}}));
}

// Exactly touching face, edge and corner (dyadic data): contact.
TEST(BoxBoxTest, TouchingAxisAlignedIsContact) {
  EXPECT_TRUE(BoxesOverlap(kUnit, {{1.5, 0.25, 0}, Matrix3::Identity(), {0.5, 0.5, 0.5}}));
  EXPECT_TRUE(BoxesOverlap(kUnit, {{1.5, 1.5, 0}, Matrix3::Identity(), {0.5, 0.5, 0.5}}));
  EXPECT_TRUE(BoxesOverlap(kUnit, {{1.5, -1.5, 1.5}, Matrix3::Identity(), {0.5, 0.5, 0.5}}));
  EXPECT_FALSE(BoxesOverlap(kUnit, {{1.5 + 1e-6, 1.5, 0}, Matrix3::Identity(), {0.5, 0.5, 0.5}}));
}

// Rotated boxes touching face to face: the touch is exact only up to rounding, and
// the tolerance must still call it contact. A gap of 1e-6 must not.
TEST(BoxBoxTest, RotatedFaceTouchIsContact) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> extent(0.05, 1);
  std::uniform_real_distribution<double> coord(-100, 100);
  for (int trial = 0; trial < 2000; ++trial) {
    const Matrix3 R = RandomRotation(rng);
    const Vector3 ha(extent(rng), extent(rng), extent(rng));
    const Vector3 hb(extent(rng), extent(rng), extent(rng));
    const int axis = trial % 3;
    const Vector3 lateral(extent(rng) - 0.5, extent(rng) - 0.5, extent(rng) - 0.5);
    Vector3 offset = lateral.cwiseProduct(ha);
    offset[axis] = ha[axis] + hb[axis];
    const Box a{{coord(rng), coord(rng), coord(rng)}, R, ha};
    const Box b{a.center + R * offset, R, hb};
    ASSERT_TRUE(BoxesOverlap(a, b)) << "trial " << trial;
    ASSERT_TRUE(BoxesOverlap(b, a));
    const double size = std::max(ha.maxCoeff(), hb.maxCoeff());
    const Box apart{b.center + R.col(axis) * (1e-6 * size), R, hb};
    ASSERT_FALSE(BoxesOverlap(a, apart)) << "trial " << trial;
  }
}

// Rotated boxes touching edge to edge: the two edges cross at their midpoints.
TEST(BoxBoxTest, RotatedEdgeTouchIsContact) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> extent(0.05, 1);
  int checked = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Box a{{0.5, -0.25, 2}, RandomRotation(rng), {extent(rng), extent(rng), extent(rng)}};
    Box b{{0, 0, 0}, RandomRotation(rng), {extent(rng), extent(rng), extent(rng)}};
    const int i = trial % 3;
    const int j = (trial / 3) % 3;
    const Vector3 cross = a.rotation.col(i).cross(b.rotation.col(j));
    if (cross.norm() < 0.1) continue;
    const Vector3 n = cross.normalized();
    // a's edge along axis i furthest along n, b's edge along axis j furthest along -n.
    Vector3 mid_a = a.center;
    Vector3 to_mid_b = Vector3::Zero();
    for (int k = 0; k < 3; ++k) {
      const Vector3 ak = a.rotation.col(k);
      const Vector3 bk = b.rotation.col(k);
      if (k != i) mid_a += ak * std::copysign(a.half_extents[k], n.dot(ak));
      if (k != j) to_mid_b -= bk * std::copysign(b.half_extents[k], n.dot(bk));
    }
    b.center = mid_a - to_mid_b;
    ASSERT_TRUE(BoxesOverlap(a, b)) << "trial " << trial;
    ASSERT_TRUE(BoxesOverlap(b, a));
    const double size = std::max(a.half_extents.maxCoeff(), b.half_extents.maxCoeff());
    b.center += n * (1e-6 * size);
    ASSERT_FALSE(BoxesOverlap(a, b)) << "trial " << trial;
    ASSERT_EQ(RobustOracle(a, b), 0);
    ++checked;
  }
  EXPECT_GT(checked, 1000);
}

// Parallel and nearly parallel edges: the degenerate cross axes must not separate
// overlapping boxes by rounding noise.
TEST(BoxBoxTest, NearlyParallelBoxesOverlap) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-1e-9, 1e-9);
  for (int trial = 0; trial < 1000; ++trial) {
    const Matrix3 R = RandomRotation(rng);
    const Matrix3 tilt = Eigen::AngleAxisd(angle(rng), Vector3::UnitZ()).toRotationMatrix();
    const Box a{{10, -5, 3}, R, {1, 0.5, 0.25}};
    const Box b{a.center + R * Vector3(1.5, 0.9, 0.4), R * tilt, {1, 0.5, 0.25}};
    ASSERT_TRUE(BoxesOverlap(a, b)) << "trial " << trial;
  }
}

// Random pairs, many near contact, against the triangle oracle; symmetric.
TEST(BoxBoxTest, RandomAgainstOracle) {
  std::mt19937_64 rng(4);
  int agreed = 0;
  int overlapping = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const Box a = RandomBox(rng, 1);
    const Box b = RandomBox(rng, 1);
    const bool sat = BoxesOverlap(a, b);
    ASSERT_EQ(sat, BoxesOverlap(b, a)) << "trial " << trial;
    const int oracle = RobustOracle(a, b);
    if (oracle < 0) continue;
    ASSERT_EQ(sat, oracle == 1) << "trial " << trial;
    ++agreed;
    overlapping += sat;
  }
  EXPECT_GT(agreed, 2900);
  EXPECT_GT(overlapping, 500);
  EXPECT_LT(overlapping, agreed - 500);
}

// Pairs placed just apart or just overlapping along a random direction: b slid until
// the oracle flips (bisection), then set 1e-6 of the size to either side.
TEST(BoxBoxTest, NearContactAgainstOracle) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  int edge_edge_only = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Box a = RandomBox(rng, 0);
    Box b = RandomBox(rng, 0);
    const Vector3 u = Vector3(normal(rng), normal(rng), normal(rng)).normalized();
    double lo = 0;
    double hi = 4;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      b.center = mid * u;
      (OracleOverlap(a, b) ? lo : hi) = mid;
    }
    const double size = std::max(a.half_extents.maxCoeff(), b.half_extents.maxCoeff());
    b.center = (hi + 1e-6 * size) * u;
    ASSERT_FALSE(BoxesOverlap(a, b)) << "trial " << trial;
    ASSERT_FALSE(BoxesOverlap(b, a));
    edge_edge_only += !FaceAxisSeparates(a, b);
    b.center = (lo - 1e-6 * size) * u;
    ASSERT_TRUE(BoxesOverlap(a, b)) << "trial " << trial;
    ASSERT_TRUE(BoxesOverlap(b, a));
  }
  // A good share of the separations need an edge-edge axis.
  EXPECT_GT(edge_edge_only, 30);
}

// A rigid motion of both boxes changes nothing (away from contact).
TEST(BoxBoxTest, RigidMotionInvariance) {
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> coord(-100, 100);
  for (int trial = 0; trial < 2000; ++trial) {
    const Box a = RandomBox(rng, 1);
    const Box b = RandomBox(rng, 1);
    if (RobustOracle(a, b) < 0) continue;
    const Matrix3 R = RandomRotation(rng);
    const Vector3 t(coord(rng), coord(rng), coord(rng));
    const Box ma{R * a.center + t, R * a.rotation, a.half_extents};
    const Box mb{R * b.center + t, R * b.rotation, b.half_extents};
    ASSERT_EQ(BoxesOverlap(a, b), BoxesOverlap(ma, mb)) << "trial " << trial;
  }
}

// Flat boxes (a zero half extent) and a point box.
TEST(BoxBoxTest, DegenerateBoxes) {
  const Box sheet{{0, 0, 1}, Matrix3::Identity(), {0.5, 0.5, 0}};
  EXPECT_TRUE(BoxesOverlap(kUnit, sheet));
  const Box point{{1, 1, 1}, Matrix3::Identity(), {0, 0, 0}};
  EXPECT_TRUE(BoxesOverlap(kUnit, point));
  const Box off{{1, 1, 1.001}, Matrix3::Identity(), {0, 0, 0}};
  EXPECT_FALSE(BoxesOverlap(kUnit, off));
}

// A NaN or infinity in any field of either box is no contact, also where the finite
// boxes overlap (here a box and itself).
TEST(BoxBoxTest, NonFiniteInputIsNoContact) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  ASSERT_TRUE(BoxesOverlap(kUnit, kUnit));
  std::vector<Box> bad = WithOneNonFiniteField(kUnit);
  ASSERT_EQ(bad.size(), 45u);  // 15 fields (centre, rotation, half extents) x 3 values
  bad.push_back({{inf, -inf, nan}, Matrix3::Constant(nan), {inf, inf, inf}});
  for (std::size_t i = 0; i < bad.size(); ++i) {
    EXPECT_FALSE(BoxesOverlap(kUnit, bad[i])) << "case " << i;
    EXPECT_FALSE(BoxesOverlap(bad[i], kUnit)) << "case " << i;
    EXPECT_FALSE(BoxesOverlap(bad[i], bad[i])) << "case " << i;
  }
}

}  // namespace
}  // namespace hapticd::geometry
