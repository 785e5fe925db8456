// Segments aimed exactly through vertices and edge midpoints: raw Embree leaks on some
// (reported, not asserted: it is Embree's behaviour), the backend on none, and its
// answers equal the exact native ones.

#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

#include "server/embree/aimed_segments.h"
#include "server/embree/embree_segment_queries.h"
#include "server/embree/embree_triangle_scene.h"
#include "server/embree/test/embree_test_support.h"

namespace hapticd::embree {
namespace {

struct LeakCase {
  const char* name;
  double max_angle;  // from the feature's normal: up to nearly grazing
};

TEST(EmbreeLeakTest, AimedSegmentsNeverLeakThroughTheBackend) {
  auto device = std::make_shared<const EmbreeDevice>();
  std::mt19937_64 rng(41);
  int raw_leaks = 0, raw_fast_leaks = 0, exact_hits = 0, segments_total = 0;
  for (const NamedMesh& named : TestMeshes()) {
    if (named.name == "soup") continue;  // aimed segments need a closed surface
    for (const LeakCase& c : {LeakCase{"steep", 1.2}, LeakCase{"grazing", 1.55}}) {
      SCOPED_TRACE(named.name + " " + c.name);
      auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
      const EmbreeMesh mesh(device, bvh);
      const EmbreeTriangleScene robust(device, named.mesh, {.robust = true});
      const EmbreeTriangleScene fast(device, named.mesh, {.robust = false});
      AimedSegmentOptions options;
      options.per_target = 3;
      options.max_angle = c.max_angle;
      const std::vector<AimedSegment> segments = MakeAimedSegments(*named.mesh, options, rng);
      std::vector<Vector3> p, q;
      for (const AimedSegment& s : segments) {
        p.push_back(s.p);
        q.push_back(s.q);
      }
      std::vector<SegmentMeshHit> packets(segments.size());
      FindFirstSegmentHits(mesh, p, q, packets);
      int leaks = 0;
      for (size_t i = 0; i < segments.size(); ++i) {
        const SegmentMeshHit exact = geometry::FindFirstSegmentHit(*bvh, p[i], q[i]);
        const SegmentMeshHit single = FindFirstSegmentHit(mesh, p[i], q[i]);
        leaks += IsLeak(exact, single, p[i], q[i]) || IsLeak(exact, packets[i], p[i], q[i]) ? 1 : 0;
        ASSERT_TRUE(SameHit(*named.mesh, p[i], q[i], exact, single)) << "segment " << i;
        ASSERT_TRUE(SameHit(*named.mesh, p[i], q[i], exact, packets[i])) << "segment " << i;
        ASSERT_EQ(SegmentHitsMesh(mesh, p[i], q[i]), exact.hit) << "segment " << i;
        raw_leaks += IsLeak(exact, CastSegmentUnconfirmed(robust, p[i], q[i]), p[i], q[i]) ? 1 : 0;
        raw_fast_leaks += IsLeak(exact, CastSegmentUnconfirmed(fast, p[i], q[i]), p[i], q[i]) ? 1 : 0;
        exact_hits += exact.hit ? 1 : 0;
      }
      EXPECT_EQ(leaks, 0);
      segments_total += static_cast<int>(segments.size());
    }
  }
  // nearly every aimed segment enters the surface at its feature
  EXPECT_GT(exact_hits, segments_total * 9 / 10);
  ::testing::Test::RecordProperty("segments", segments_total);
  ::testing::Test::RecordProperty("raw_embree_robust_leaks", raw_leaks);
  ::testing::Test::RecordProperty("raw_embree_not_robust_leaks", raw_fast_leaks);
  std::printf("aimed segments %d, exact hits %d; raw Embree leaks: robust %d, not robust %d; "
              "backend 0\n", segments_total, exact_hits, raw_leaks, raw_fast_leaks);
}

}  // namespace
}  // namespace hapticd::embree
