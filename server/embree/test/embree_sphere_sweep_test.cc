#include "server/embree/embree_sphere_sweep.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <vector>

#include "server/embree/aimed_segments.h"
#include "server/embree/test/embree_test_support.h"
#include "server/geometry/sphere_sweep.h"
#include "server/net/test/count_allocations.h"

namespace hapticd::embree {
namespace {

using geometry::SphereSweepHit;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string Describe(const SphereSweepHit& h) {
  return "{hit " + std::to_string(h.hit) + ", t " + std::to_string(h.t) + ", triangle " +
         std::to_string(h.triangle) + "}";
}

// The backend sweep of radius r equals the native one: same hit, t and point; the same
// triangle (then the same normal and feature) or another one whose own sweep blocks at
// exactly that t with the point, normal and feature reported (a tie).
::testing::AssertionResult SameSweep(const TriangleMesh& mesh, const Vector3& a, const Vector3& b,
                                     double r, const SphereSweepHit& native,
                                     const SphereSweepHit& backend) {
  if (native.hit != backend.hit || native.t != backend.t) {
    return ::testing::AssertionFailure() << "native " << Describe(native) << " backend "
                                         << Describe(backend);
  }
  if (!native.hit) return ::testing::AssertionSuccess();
  if (native.triangle == backend.triangle) {
    if (native.point != backend.point) return ::testing::AssertionFailure() << "different point";
    if (native.normal == backend.normal && native.feature == backend.feature) {
      return ::testing::AssertionSuccess();
    }
    return ::testing::AssertionFailure() << "same triangle, different normal or feature";
  }
  const SphereSweepHit tie =
      geometry::SweepSphereTriangle(mesh.triangle(backend.triangle), a, b, r);
  if (tie.hit && tie.t == native.t && tie.point == backend.point && tie.normal == backend.normal &&
      tie.feature == backend.feature) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "native " << Describe(native) << " backend "
                                       << Describe(backend) << " is not a tie";
}

class EmbreeSphereSweepTest : public ::testing::Test {
 protected:
  std::shared_ptr<const EmbreeDevice> device_ = std::make_shared<const EmbreeDevice>();
};

// Random sweeps, long and short, on every test mesh equal the native point sweep.
TEST_F(EmbreeSphereSweepTest, RandomSweepsEqualNative) {
  std::mt19937_64 rng(51);
  for (const NamedMesh& named : TestMeshes()) {
    SCOPED_TRACE(named.name);
    auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeMesh mesh(device_, bvh);
    int hits = 0, total = 0;
    for (const auto& [a, b] : RandomSegments(*named.mesh, 20000, rng)) {
      const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, a, b, 0);
      ASSERT_TRUE(SameSweep(*named.mesh, a, b, 0, native, SweepPointMesh(mesh, a, b)))
          << "a " << a.transpose() << " b " << b.transpose();
      hits += native.hit ? 1 : 0;
      ++total;
    }
    // both kinds of answer were exercised
    EXPECT_GT(hits, total / 10);
    EXPECT_LT(hits, total * 9 / 10);
  }
}

// Starts exactly on triangles' planes: from every vertex of the icosphere and the torus
// (on the plane of each triangle around it) and from exact points of the box's faces,
// towards random ends in and out: the r = 0 rules agree with native, and blocks at once,
// blocks later and misses all occur.
TEST_F(EmbreeSphereSweepTest, StartsOnAFacePlaneEqualNative) {
  std::mt19937_64 rng(52);
  std::uniform_real_distribution<double> unit(-1, 1);
  auto ball = Share(geometry::MakeIcosphere(9, 1.0));
  auto torus = Share(geometry::MakeTorus(1.0, 0.35, 36, 18));
  auto box = Share(geometry::MakeBoxMesh({0.5, 1, 0.75}, 4));
  int at_start = 0, later = 0, misses = 0;
  for (const auto& shape : {ball, torus, box}) {
    auto bvh = std::make_shared<const geometry::MeshBvh>(shape);
    const EmbreeMesh mesh(device_, bvh);
    // the vertices, and for the box dyadic points of its faces
    std::vector<Vector3> starts(shape->vertices().begin(), shape->vertices().end());
    if (shape == box) {
      std::uniform_int_distribution<int> sixteenth(-8, 8);
      for (int k = 0; k < 600; ++k) {
        Vector3 s(sixteenth(rng) / 16.0, 2 * sixteenth(rng) / 16.0, 1.5 * sixteenth(rng) / 16.0);
        const int axis = k % 3;
        s[axis] = (k / 3) % 2 == 0 ? shape->bounds().max[axis] : shape->bounds().min[axis];
        starts.push_back(s);
      }
    }
    for (const Vector3& a : starts) {
      // outwards, inwards, through the centre (across the torus' hole) and random, short
      // and long
      const Vector3 out = a - shape->bounds().center();
      for (const Vector3& d : {Vector3(0.3 * out), Vector3(-0.3 * out), Vector3(-2 * out),
                               Vector3(unit(rng), unit(rng), unit(rng)),
                               Vector3(0.05 * Vector3(unit(rng), unit(rng), unit(rng)))}) {
        const Vector3 b = a + d;
        const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, a, b, 0);
        ASSERT_TRUE(SameSweep(*shape, a, b, 0, native, SweepPointMesh(mesh, a, b)))
            << "a " << a.transpose() << " b " << b.transpose();
        at_start += native.hit && native.t == 0 ? 1 : 0;
        later += native.hit && native.t > 0 ? 1 : 0;
        misses += native.hit ? 0 : 1;
      }
    }
  }
  EXPECT_GT(at_start, 100);
  EXPECT_GT(later, 10);
  EXPECT_GT(misses, 100);
}

// The r = 0 rules by hand on the box's top face (z = 0.75, normal +z), whose vertices and
// these points are exact.
TEST_F(EmbreeSphereSweepTest, FacePlaneRulesOnTheBox) {
  auto box = Share(geometry::MakeBoxMesh({0.5, 1, 0.75}, 4));
  auto bvh = std::make_shared<const geometry::MeshBvh>(box);
  const EmbreeMesh mesh(device_, bvh);
  const double top = 0.75;
  struct Case {
    const char* name;
    Vector3 a, b;
    bool hit;
    double t;
    Vector3 normal;
  };
  const Vector3 up = Vector3::UnitZ();
  const Case cases[] = {
      {"on the face, moving out", {0.1, 0.2, top}, {0.1, 0.2, 1}, false, 0, up},
      {"on the face, moving in", {0.1, 0.2, top}, {0.1, 0.2, 0.5}, true, 0, up},
      {"on a grid vertex, moving in", {0, 0.5, top}, {0.05, 0.45, 0.5}, true, 0, up},
      {"in the face's plane, across grid edges", {-0.4, -0.9, top}, {0.4, 0.9, top}, false, 0, up},
      {"along a grid edge", {0, -0.9, top}, {0, 0.9, top}, false, 0, up},
      {"in the plane, over the box's edge", {0.25, 0.1, top}, {0.75, 0.1, top}, true, 0.5,
       -Vector3::UnitX()},
      {"down onto the face", {0.1, 0.2, 1.75}, {0.1, 0.2, -0.25}, true, 0.5, up},
      {"ending on the face", {0.1, 0.2, 1}, {0.1, 0.2, top}, true, 1, up},
      {"1e-15 above, sliding", {-0.4, 0.1, top + 1e-15}, {0.4, 0.1, top + 1e-15}, false, 0, up},
      {"on the plane, dipping 1e-15", {-0.4, 0.1, top}, {0.4, 0.1, top - 1e-15}, true, 0, up},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, c.a, c.b, 0);
    const SphereSweepHit backend = SweepPointMesh(mesh, c.a, c.b);
    EXPECT_TRUE(SameSweep(*box, c.a, c.b, 0, native, backend));
    ASSERT_EQ(backend.hit, c.hit);
    if (!c.hit) continue;
    EXPECT_EQ(backend.t, c.t);
    EXPECT_EQ(backend.normal, c.normal);
    EXPECT_EQ(backend.point, c.t == 0 ? c.a : c.t == 1 ? c.b : Vector3(c.a + c.t * (c.b - c.a)));
  }
}

// Sweeps aimed exactly through vertices and edge midpoints of the closed meshes, steep and
// grazing: never a leak, and the native answer exactly.
TEST_F(EmbreeSphereSweepTest, AimedThroughVerticesAndEdgesNeverLeaks) {
  std::mt19937_64 rng(53);
  int aims = 0, hits = 0, leaks = 0;
  for (const NamedMesh& named : TestMeshes()) {
    if (named.name == "soup") continue;  // aimed segments need a closed surface
    auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeMesh mesh(device_, bvh);
    for (const double max_angle : {1.2, 1.55}) {
      SCOPED_TRACE(named.name + " max angle " + std::to_string(max_angle));
      AimedSegmentOptions options;
      options.per_target = 2;
      options.max_angle = max_angle;
      for (const AimedSegment& s : MakeAimedSegments(*named.mesh, options, rng)) {
        const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, s.p, s.q, 0);
        const SphereSweepHit backend = SweepPointMesh(mesh, s.p, s.q);
        ASSERT_TRUE(SameSweep(*named.mesh, s.p, s.q, 0, native, backend))
            << "a " << s.p.transpose() << " b " << s.q.transpose();
        leaks += native.hit && !backend.hit ? 1 : 0;
        hits += native.hit ? 1 : 0;
        ++aims;
      }
    }
  }
  EXPECT_EQ(leaks, 0);
  // nearly every aimed sweep is stopped at its feature
  EXPECT_GT(hits, aims * 9 / 10);
}

// NaN, infinite or motionless input misses at once; sweeps beyond the trust bound are
// answered natively and equal the native answer.
TEST_F(EmbreeSphereSweepTest, BadAndFarInput) {
  auto sphere = Share(geometry::MakeIcosphere(6, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(sphere);
  const EmbreeMesh mesh(device_, bvh);
  for (const Vector3& bad : {Vector3(kNan, 0, 0), Vector3(0, kInf, 0), Vector3(0, 0, -kInf)}) {
    EXPECT_FALSE(SweepPointMesh(mesh, bad, Vector3::Zero()).hit);
    EXPECT_FALSE(SweepPointMesh(mesh, Vector3(2, 0, 0), bad).hit);
  }
  EXPECT_FALSE(SweepPointMesh(mesh, Vector3(1, 0, 0), Vector3(1, 0, 0)).hit);

  const Vector3 far_a(1e6, 0.01, 0), far_b(-1e6, 0.02, 0);
  ASSERT_FALSE(mesh.IsTrustedSegment(far_a, far_b));
  const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, far_a, far_b, 0);
  EXPECT_TRUE(native.hit);
  EXPECT_TRUE(SameSweep(*sphere, far_a, far_b, 0, native, SweepPointMesh(mesh, far_a, far_b)));

  // many NaN sweeps in a row neither crash nor hang
  std::mt19937_64 rng(54);
  std::uniform_real_distribution<double> unit(-2, 2);
  int hits = 0;
  for (int i = 0; i < 100000; ++i) {
    const Vector3 a(unit(rng), unit(rng), kNan);
    hits += SweepPointMesh(mesh, a, -a).hit ? 1 : 0;
  }
  EXPECT_EQ(hits, 0);
}

// Spheres of radii from below the point threshold to a fifth of the mesh, on random
// sweeps long and short, on every test mesh: the native sweep's answer.
TEST_F(EmbreeSphereSweepTest, RandomSphereSweepsEqualNative) {
  std::mt19937_64 rng(56);
  for (const NamedMesh& named : TestMeshes()) {
    auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeMesh mesh(device_, bvh);
    const double size = named.mesh->size();
    for (const double r : {1e-14 * size, 0.002 * size, 0.02 * size, 0.2 * size}) {
      SCOPED_TRACE(named.name + " r " + std::to_string(r));
      int hits = 0, at_start = 0, total = 0;
      for (const auto& [a, b] : RandomSegments(*named.mesh, 1500, rng)) {
        const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, a, b, r);
        ASSERT_TRUE(SameSweep(*named.mesh, a, b, r, native, SweepSphereMesh(mesh, a, b, r)))
            << "a " << a.transpose() << " b " << b.transpose();
        hits += native.hit ? 1 : 0;
        at_start += native.hit && native.t == 0 ? 1 : 0;
        ++total;
      }
      EXPECT_GT(hits, total / 20);
      EXPECT_LT(hits, total * 19 / 20);
      if (r > 0.01 * size) {
        EXPECT_GT(at_start, 0);
      }
    }
  }
}

// A ball resting exactly on the box's top face (z = 0.75 + r, exact in binary) slides
// across its grid edges and vertices without being stopped, and is stopped at once when
// it moves down; over the box's edge it meets the side. Both backends alike.
TEST_F(EmbreeSphereSweepTest, RestingSphereSlidesAndPressesAsNatively) {
  auto box = Share(geometry::MakeBoxMesh({0.5, 1, 0.75}, 4));
  auto bvh = std::make_shared<const geometry::MeshBvh>(box);
  const EmbreeMesh mesh(device_, bvh);
  const double r = 0.125;
  const double z = 0.75 + r;
  struct Case {
    const char* name;
    Vector3 a, b;
    bool hit;
    double t;
  };
  const Case cases[] = {
      {"sliding across grid edges", {-0.4, -0.9, z}, {0.4, 0.9, z}, false, 0},
      {"sliding along a grid edge", {0, -0.9, z}, {0, 0.9, z}, false, 0},
      {"lifting off", {0.1, 0.2, z}, {0.1, 0.2, 1.5}, false, 0},
      {"pressing down", {0.1, 0.2, z}, {0.1, 0.2, 0.5}, true, 0},
      {"dropping from above", {0.1, 0.2, z + 1}, {0.1, 0.2, z - 1}, true, 0.5},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, c.a, c.b, r);
    const SphereSweepHit backend = SweepSphereMesh(mesh, c.a, c.b, r);
    EXPECT_TRUE(SameSweep(*box, c.a, c.b, r, native, backend));
    ASSERT_EQ(backend.hit, c.hit);
    if (c.hit) {
      EXPECT_EQ(backend.t, c.t);
    }
  }
}

// r = 0 is the point sweep; r < 0, a NaN or infinite radius, or NaN ends miss at once; a
// radius beyond the trust bound is answered natively, with the native answer.
TEST_F(EmbreeSphereSweepTest, SphereSweepBadAndFarInput) {
  auto sphere = Share(geometry::MakeIcosphere(6, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(sphere);
  const EmbreeMesh mesh(device_, bvh);
  const Vector3 a(2, 0.1, 0), b(-2, 0.2, 0.1);
  EXPECT_TRUE(SameSweep(*sphere, a, b, 0, SweepPointMesh(mesh, a, b), SweepSphereMesh(mesh, a, b, 0)));
  for (const double r : {-0.1, -kInf, kInf, kNan}) {
    EXPECT_FALSE(SweepSphereMesh(mesh, a, b, r).hit) << r;
  }
  EXPECT_FALSE(SweepSphereMesh(mesh, Vector3(kNan, 0, 0), b, 0.1).hit);
  EXPECT_FALSE(SweepSphereMesh(mesh, a, a, 0.1).hit);
  // a trusted segment with a radius beyond the trust bound
  const double huge = 2 * mesh.trust_bound();
  const Vector3 near_a(3, 0.1, 0), near_b(2, 0.1, 0);
  ASSERT_TRUE(mesh.IsTrustedSegment(near_a, near_b));
  const SphereSweepHit native = geometry::SweepSphereMesh(*bvh, near_a, near_b, huge);
  ASSERT_TRUE(native.hit);
  EXPECT_TRUE(SameSweep(*sphere, near_a, near_b, huge, native, SweepSphereMesh(mesh, near_a, near_b, huge)));
  // and an untrusted segment
  const Vector3 far_a(1e6, 0.01, 0), far_b(-1e6, 0.02, 0);
  const SphereSweepHit far = geometry::SweepSphereMesh(*bvh, far_a, far_b, 0.1);
  ASSERT_TRUE(far.hit);
  EXPECT_TRUE(SameSweep(*sphere, far_a, far_b, 0.1, far, SweepSphereMesh(mesh, far_a, far_b, 0.1)));
}

// The sweeps allocate nothing (operator new is counted by count_allocations.h; Embree's
// own heap is not).
TEST_F(EmbreeSphereSweepTest, SweepsDoNotAllocate) {
  auto sphere = Share(geometry::MakeIcosphere(9, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(sphere);
  const EmbreeMesh mesh(device_, bvh);
  std::mt19937_64 rng(55);
  const auto segments = RandomSegments(*sphere, 200, rng);
  const long before = hapticd::testing::AllocationCount();
  int hits = 0;
  for (const auto& [a, b] : segments) {
    hits += SweepPointMesh(mesh, a, b).hit ? 1 : 0;
    hits += SweepSphereMesh(mesh, a, b, 0.01).hit ? 1 : 0;
  }
  EXPECT_EQ(hapticd::testing::AllocationCount(), before);
  EXPECT_GT(hits, 0);
}

}  // namespace
}  // namespace hapticd::embree
