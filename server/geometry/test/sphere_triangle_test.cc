#include "server/geometry/sphere_triangle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace hapticd::geometry {
namespace {

const Triangle kTri{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};

// Independent distance oracle: the convex function |c - x(u, v)|² minimised over the
// triangle by nested golden-section searches (on v for each u), no region logic.
double OracleDistance(const Vector3& c, const Triangle& t) {
  const auto golden = [](double lo, double hi, auto&& f) {
    const double r = (std::sqrt(5.0) - 1) / 2;
    double m1 = hi - r * (hi - lo), m2 = lo + r * (hi - lo);
    double f1 = f(m1), f2 = f(m2);
    for (int i = 0; i < 80; ++i) {
      if (f1 <= f2) {
        hi = m2, m2 = m1, f2 = f1, m1 = hi - r * (hi - lo), f1 = f(m1);
      } else {
        lo = m1, m1 = m2, f1 = f2, m2 = lo + r * (hi - lo), f2 = f(m2);
      }
    }
    return std::min({f(lo), f(hi), f(0.5 * (lo + hi))});
  };
  const auto along_v = [&](double u) {
    return golden(0, 1 - u, [&](double v) {
      return (c - (t.v0 + u * (t.v1 - t.v0) + v * (t.v2 - t.v0))).squaredNorm();
    });
  };
  return std::sqrt(golden(0, 1, along_v));
}

TEST(SphereTriangle, TouchingFaceFromAboveAndBelow) {
  SphereTriangleContact c = CalcSphereTriangleContact({{1, 1, 2}, 2}, kTri);
  EXPECT_TRUE(c.touching);
  EXPECT_EQ(c.depth, 0);
  EXPECT_EQ(c.distance, 2);
  EXPECT_EQ(c.normal, Vector3(0, 0, 1));
  EXPECT_EQ(c.point, Vector3(1, 1, 0));
  EXPECT_EQ(c.feature, TriangleFeature::kFace);
  EXPECT_DOUBLE_EQ(c.u, 0.25);
  EXPECT_DOUBLE_EQ(c.v, 0.25);
  EXPECT_FALSE(c.centre_on_triangle);

  c = CalcSphereTriangleContact({{1, 1, -0.5}, 2}, kTri);
  EXPECT_TRUE(c.touching);
  EXPECT_EQ(c.depth, 1.5);
  EXPECT_EQ(c.normal, Vector3(0, 0, -1));
}

TEST(SphereTriangle, SeparatedReportsTheGap) {
  const SphereTriangleContact c = CalcSphereTriangleContact({{1, 1, 3}, 1}, kTri);
  EXPECT_FALSE(c.touching);
  EXPECT_EQ(c.depth, -2);
  EXPECT_EQ(c.normal, Vector3(0, 0, 1));
}

TEST(SphereTriangle, NearAnEdgeOrAVertex) {
  // beside edge v0-v1 (y = 0), below and out: normal from the edge point to the centre
  SphereTriangleContact c = CalcSphereTriangleContact({{2, -3, -4}, 5}, kTri);
  EXPECT_TRUE(c.touching);
  EXPECT_EQ(c.feature, TriangleFeature::kEdge01);
  EXPECT_EQ(c.point, Vector3(2, 0, 0));
  EXPECT_DOUBLE_EQ(c.depth, 0);
  EXPECT_NEAR((c.normal - Vector3(0, -0.6, -0.8)).norm(), 0, 1e-15);
  EXPECT_DOUBLE_EQ(c.u, 0.5);
  EXPECT_DOUBLE_EQ(c.v, 0);
  // beyond vertex v2
  c = CalcSphereTriangleContact({{0, 7, 4}, 4.5}, kTri);
  EXPECT_EQ(c.feature, TriangleFeature::kVertex2);
  EXPECT_EQ(c.point, Vector3(0, 4, 0));
  EXPECT_DOUBLE_EQ(c.distance, 5);
  EXPECT_FALSE(c.touching);
  EXPECT_NEAR((c.normal - Vector3(0, 0.6, 0.8)).norm(), 0, 1e-15);
}

TEST(SphereTriangle, CentreOnTheTriangleUsesTheFaceNormal) {
  for (const Vector3& centre : {Vector3(1, 1, 0), Vector3(2, 0, 0), Vector3(2, 2, 0),
                                Vector3(0, 0, 0), Vector3(0, 4, 0)}) {
    const SphereTriangleContact c = CalcSphereTriangleContact({centre, 0.5}, kTri);
    EXPECT_TRUE(c.centre_on_triangle) << centre.transpose();
    EXPECT_TRUE(c.touching);
    EXPECT_EQ(c.distance, 0);
    EXPECT_EQ(c.depth, 0.5);
    EXPECT_EQ(c.normal, Vector3(0, 0, 1));
    EXPECT_EQ(c.point, centre);
  }
  // the reversed triangle's face normal points the other way
  const Triangle flipped{kTri.v0, kTri.v2, kTri.v1};
  EXPECT_EQ(CalcSphereTriangleContact({{1, 1, 0}, 1}, flipped).normal, Vector3(0, 0, -1));
  // in the plane but just outside: an in-plane push, not the face normal
  const double tiny = std::ldexp(1.0, -40);
  const SphereTriangleContact out = CalcSphereTriangleContact({{2, -tiny, 0}, 1}, kTri);
  EXPECT_FALSE(out.centre_on_triangle);
  EXPECT_NEAR((out.normal - Vector3(0, -1, 0)).norm(), 0, 1e-12);
  EXPECT_EQ(out.feature, TriangleFeature::kEdge01);
}

TEST(SphereTriangle, TinyHeightOverTheFaceKeepsAnExactNormal) {
  // the projection's rounding (about 1e-16 in x, y) dwarfs the height: the normal
  // must still be exactly the face normal, on the centre's side
  const double tiny = std::ldexp(1.0, -200);
  const Triangle t{{0.1, 0.2, 0}, {3.7, 0.3, 0}, {0.3, 2.9, 0}};
  SphereTriangleContact c = CalcSphereTriangleContact({{1.0 / 3, 0.7, tiny}, 1}, t);
  EXPECT_EQ(c.feature, TriangleFeature::kFace);
  EXPECT_EQ(c.normal, Vector3(0, 0, 1));
  EXPECT_FALSE(c.centre_on_triangle);
  c = CalcSphereTriangleContact({{1.0 / 3, 0.7, -tiny}, 1}, t);
  EXPECT_EQ(c.normal, Vector3(0, 0, -1));
}

// Pushing the sphere out along the normal by the depth leaves it just touching, on
// random configurations; the distance agrees with an independent oracle; the contact
// point lies on the triangle; rigid motions change nothing.
TEST(SphereTriangle, RandomContactsAreConsistent) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 4000; ++n) {
    const Triangle t{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    const Sphere s{{1.5 * u(rng), 1.5 * u(rng), 1.5 * u(rng)}, 0.5 * (1 + u(rng))};
    const SphereTriangleContact c = CalcSphereTriangleContact(s, t);
    EXPECT_NEAR(c.distance, OracleDistance(s.center, t), 1e-9) << "case " << n;
    EXPECT_EQ(c.touching, c.depth >= 0);
    EXPECT_DOUBLE_EQ(c.depth, s.radius - c.distance);
    EXPECT_NEAR(c.normal.norm(), 1, 1e-14);
    // point is the barycentric combination and the centre sits along the normal
    const Vector3 from_uv = (1 - c.u - c.v) * t.v0 + c.u * t.v1 + c.v * t.v2;
    EXPECT_LE((from_uv - c.point).norm(), 1e-12);
    EXPECT_LE((c.point + c.distance * c.normal - s.center).norm(), 1e-12) << "case " << n;
    // pushed out by the depth: just touching
    const Sphere pushed{s.center + c.depth * c.normal, s.radius};
    EXPECT_NEAR(CalcSphereTriangleContact(pushed, t).depth, 0, 1e-12) << "case " << n;

    // a rigid motion of both moves the contact with them
    const Matrix3 rot = Eigen::AngleAxisd(u(rng) * 3, Vector3(u(rng), u(rng), u(rng)).normalized())
                            .toRotationMatrix();
    const Vector3 shift(u(rng) * 10, u(rng) * 10, u(rng) * 10);
    const auto move = [&](const Vector3& p) { return Vector3(rot * p + shift); };
    const SphereTriangleContact m =
        CalcSphereTriangleContact({move(s.center), s.radius}, {move(t.v0), move(t.v1), move(t.v2)});
    EXPECT_NEAR(m.depth, c.depth, 1e-12);
    EXPECT_LE((m.point - move(c.point)).norm(), 1e-12);
    EXPECT_LE((m.normal - rot * c.normal).norm(), 1e-9);
    EXPECT_EQ(m.feature, c.feature);
  }
}

TEST(SphereTriangle, NonFiniteInputReportsNoContact) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {nan, inf, -inf}) {
    EXPECT_FALSE(CalcSphereTriangleContact({{bad, 0, 0}, 1}, kTri).touching);
    EXPECT_FALSE(CalcSphereTriangleContact({{0, 0, 0}, bad}, kTri).touching);
    const Triangle t{{0, 0, 0}, {bad, 0, 0}, {0, 4, 0}};
    EXPECT_FALSE(CalcSphereTriangleContact({{1, 1, 0}, 1}, t).touching);
  }
}

TEST(SphereTriangle, DegenerateTriangleStillGivesDistance) {
  const Triangle line{{0, 0, 0}, {2, 0, 0}, {4, 0, 0}};
  const SphereTriangleContact c = CalcSphereTriangleContact({{3, 0, 1}, 2}, line);
  EXPECT_DOUBLE_EQ(c.distance, 1);
  EXPECT_TRUE(c.touching);
  EXPECT_NEAR(c.normal.norm(), 1, 1e-15);
}

}  // namespace
}  // namespace hapticd::geometry
