#include "server/embree/embree_segment_queries.h"

#include <gtest/gtest.h>

#include <iostream>
#include <string>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <thread>
#include <vector>

#include "server/embree/embree_triangle_scene.h"
#include "server/embree/test/embree_test_support.h"

// Counts heap allocations made by this program's own code (operator new), so a test can
// show that the queries allocate nothing. GCC cannot see that the replaced new and
// delete pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<long> g_allocations{0};
}  // namespace
void* operator new(size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* memory = std::malloc(size == 0 ? 1 : size)) return memory;
  throw std::bad_alloc();
}
void operator delete(void* memory) noexcept { std::free(memory); }
void operator delete(void* memory, size_t) noexcept { std::free(memory); }

namespace hapticd::embree {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

class EmbreeSegmentQueriesTest : public ::testing::Test {
 protected:
  std::shared_ptr<const EmbreeDevice> device_ = std::make_shared<const EmbreeDevice>();
};

// Random segments, long and short, on every test mesh: first hit and occlusion equal the
// native exact answers.
TEST_F(EmbreeSegmentQueriesTest, RandomSegmentsEqualNative) {
  std::mt19937_64 rng(11);
  for (const NamedMesh& named : TestMeshes()) {
    SCOPED_TRACE(named.name);
    auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeMesh mesh(device_, bvh);
    int hits = 0;
    for (const auto& [p, q] : RandomSegments(*named.mesh, 10000, rng)) {
      const SegmentMeshHit native = geometry::FindFirstSegmentHit(*bvh, p, q);
      ASSERT_TRUE(SameHit(*named.mesh, p, q, native, FindFirstSegmentHit(mesh, p, q)))
          << "p " << p.transpose() << " q " << q.transpose();
      ASSERT_EQ(SegmentHitsMesh(mesh, p, q), native.hit) << "p " << p.transpose();
      hits += native.hit ? 1 : 0;
    }
    // both kinds of answer were exercised
    EXPECT_GT(hits, 2000);
    EXPECT_LT(hits, 18000);
  }
}

// Raw Embree (float, no confirmation) agrees with the exact answer within single
// precision on random segments: the same hit or miss for all but a handful, and t to
// float accuracy where both hit.
TEST_F(EmbreeSegmentQueriesTest, RawEmbreeAgreesWithinSinglePrecision) {
  std::mt19937_64 rng(12);
  for (const NamedMesh& named : TestMeshes()) {
    SCOPED_TRACE(named.name);
    auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeTriangleScene raw(device_, named.mesh);
    const double magnitude = named.mesh->bounds().max.cwiseAbs().maxCoeff() + named.mesh->size();
    int disagreements = 0, segments = 0;
    for (const auto& [p, q] : RandomSegments(*named.mesh, 3000, rng)) {
      ++segments;
      const SegmentMeshHit native = geometry::FindFirstSegmentHit(*bvh, p, q);
      const SegmentMeshHit answer = CastSegmentUnconfirmed(raw, p, q);
      if (native.hit != answer.hit) {
        ++disagreements;
        continue;
      }
      if (!native.hit) continue;
      // float ulps of the coordinates, as a distance along the segment
      EXPECT_NEAR(answer.t * (q - p).norm(), native.t * (q - p).norm(), 1e-5 * magnitude);
    }
    EXPECT_LE(disagreements, segments / 1000) << disagreements << " of " << segments;
  }
}

// Hand-built touching and degenerate cases on a box whose vertices are exact.
TEST_F(EmbreeSegmentQueriesTest, TouchingAndGrazingCasesEqualNative) {
  auto box = Share(geometry::MakeBoxMesh({0.5, 1, 0.75}, 4));
  auto bvh = std::make_shared<const geometry::MeshBvh>(box);
  const EmbreeMesh mesh(device_, bvh);
  const double top = 0.75;
  struct Case {
    const char* name;
    Vector3 p, q;
    bool hit;
  };
  const Case cases[] = {
      {"ends on the top face", {0.1, 0.2, 2}, {0.1, 0.2, top}, true},
      {"starts on the top face", {0.1, 0.2, top}, {0.1, 0.2, 2}, true},
      {"lies in the top face", {0.1, 0.2, top}, {0.3, -0.1, top}, false},
      {"through a box corner", {1, 1.5, 1.25}, {0, 0.5, 0.25}, true},
      {"through a grid vertex", {0, 0, 2}, {0, 0, 0}, true},
      {"through a grid edge", {0.125, 0, 2}, {0.125, 0, 0}, true},
      {"grazes the top face at 1e-12", {-0.4, 0.1, top + 1e-12}, {0.4, 0.1, top - 1e-12}, true},
      {"on the top plane, dips 1e-15", {-0.4, 0.1, top}, {0.4, 0.1, top - 1e-15}, true},
      {"above the top face by 1e-15", {-0.4, 0.1, top + 1e-15}, {0.4, 0.1, top + 1e-15}, false},
      {"along a box edge, through its corners", {0.5, -2, top}, {0.5, 2, top}, true},
      {"misses beside", {0.5 + 1e-12, -2, top + 1e-12}, {0.5 + 1e-12, 2, 0}, false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const SegmentMeshHit native = geometry::FindFirstSegmentHit(*bvh, c.p, c.q);
    EXPECT_EQ(native.hit, c.hit);
    EXPECT_TRUE(SameHit(*box, c.p, c.q, native, FindFirstSegmentHit(mesh, c.p, c.q)));
    EXPECT_EQ(SegmentHitsMesh(mesh, c.p, c.q), native.hit);
  }
}

// NaN, infinite or zero-length input misses at once; far segments (beyond the trust
// bound) are answered natively and still equal the native answer.
TEST_F(EmbreeSegmentQueriesTest, BadAndFarInput) {
  auto sphere = Share(geometry::MakeIcosphere(6, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(sphere);
  const EmbreeMesh mesh(device_, bvh);
  const Vector3 bad[] = {{kNan, 0, 0}, {0, kInf, 0}, {0, 0, -kInf}};
  for (const Vector3& b : bad) {
    EXPECT_FALSE(FindFirstSegmentHit(mesh, b, Vector3::Zero()).hit);
    EXPECT_FALSE(FindFirstSegmentHit(mesh, Vector3(2, 0, 0), b).hit);
    EXPECT_FALSE(SegmentHitsMesh(mesh, b, Vector3::Zero()));
  }
  EXPECT_FALSE(FindFirstSegmentHit(mesh, Vector3(1, 0, 0), Vector3(1, 0, 0)).hit);

  const Vector3 far_p(1e6, 0.01, 0), far_q(-1e6, 0.02, 0);
  ASSERT_FALSE(mesh.IsTrustedSegment(far_p, far_q));
  const SegmentMeshHit native = geometry::FindFirstSegmentHit(*bvh, far_p, far_q);
  EXPECT_TRUE(native.hit);
  EXPECT_TRUE(SameHit(*sphere, far_p, far_q, native, FindFirstSegmentHit(mesh, far_p, far_q)));
  EXPECT_TRUE(SegmentHitsMesh(mesh, far_p, far_q));

  // many NaN queries in a row neither crash nor hang
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> unit(-2, 2);
  int hits = 0;
  for (int i = 0; i < 100000; ++i) {
    const Vector3 p(unit(rng), kNan, unit(rng));
    hits += FindFirstSegmentHit(mesh, p, -p).hit ? 1 : 0;
  }
  EXPECT_EQ(hits, 0);
}

// Packets of every width, with bad and far lanes mixed in, give the single answers.
// Packets of every width and fill, with bad lanes among them, answer as single queries
// do, on the device's kernels.
void ExpectPacketsEqualSingleQueries(const std::shared_ptr<const EmbreeDevice>& device) {
  auto torus = Share(geometry::MakeTorus(1.0, 0.35, 36, 18));
  auto bvh = std::make_shared<const geometry::MeshBvh>(torus);
  const EmbreeMesh mesh(device, bvh);
  std::mt19937_64 rng(14);
  const auto segments = RandomSegments(*torus, 300, rng);
  std::vector<Vector3> p, q;
  for (const auto& [a, b] : segments) {
    p.push_back(a);
    q.push_back(b);
  }
  // a NaN lane, a zero-length lane, a far lane
  p[5] = Vector3(kNan, 0, 0);
  q[9] = p[9];
  p[20] = Vector3(1e7, 0.1, 0.1);
  q[20] = Vector3(-1e7, 0.1, 0.1);
  for (const size_t n : {0, 1, 3, 4, 5, 8, 9, 16, 17, 40, 600}) {
    SCOPED_TRACE(n);
    std::vector<SegmentMeshHit> out(n, SegmentMeshHit{true, 0.5, 7, 0, 0});
    FindFirstSegmentHits(mesh, std::span(p).first(n), std::span(q).first(n), out);
    for (size_t i = 0; i < n; ++i) {
      ASSERT_TRUE(SameHit(*torus, p[i], q[i], geometry::FindFirstSegmentHit(*bvh, p[i], q[i]), out[i]))
          << "segment " << i;
    }
  }
  // the shortest span decides how many are answered
  std::vector<SegmentMeshHit> out(10, SegmentMeshHit{true, 0.5, 7, 0, 0});
  FindFirstSegmentHits(mesh, std::span(p).first(4), std::span(q).first(10), out);
  EXPECT_TRUE(out[4].hit && out[4].t == 0.5 && out[4].triangle == 7);
}

TEST_F(EmbreeSegmentQueriesTest, PacketsEqualSingleQueries) { ExpectPacketsEqualSingleQueries(device_); }

// Embree picks its kernels by CPU at run time, and the wide ones load the packet and its
// valid mask with aligned instructions: every kernel this CPU can run answers packets
// alike. Each max_isa caps the choice; the ones above this CPU's best repeat it.
TEST_F(EmbreeSegmentQueriesTest, PacketsEqualSingleQueriesOnEveryKernelOfThisCpu) {
  std::vector<std::string> kernels;
  for (const std::string isa : {"sse2", "sse4.2", "avx", "avx2", "avx512"}) {
    const std::string config = "max_isa=" + isa;
    SCOPED_TRACE(config);
    kernels.push_back(ReportEmbreeIsa(config).kernels);
    ExpectPacketsEqualSingleQueries(std::make_shared<const EmbreeDevice>(config));
  }
  // the cap was obeyed: the narrowest is SSE2 on any x86-64
  EXPECT_EQ(kernels.front(), "SSE2");
  std::cout << "kernels exercised:";
  for (const std::string& kernel : kernels) std::cout << ' ' << kernel;
  std::cout << '\n';
}

// Concurrent queries on one mesh give the answers of a single thread.
TEST_F(EmbreeSegmentQueriesTest, ConcurrentQueriesAgree) {
  auto sphere = Share(geometry::MakeIcosphere(12, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(sphere);
  const EmbreeMesh mesh(device_, bvh);
  std::mt19937_64 rng(15);
  const auto segments = RandomSegments(*sphere, 2000, rng);
  std::vector<SegmentMeshHit> expected;
  for (const auto& [p, q] : segments) expected.push_back(FindFirstSegmentHit(mesh, p, q));
  std::atomic<int> mismatches{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k) {
    threads.emplace_back([&] {
      for (size_t i = 0; i < segments.size(); ++i) {
        const SegmentMeshHit h = FindFirstSegmentHit(mesh, segments[i].first, segments[i].second);
        if (h.hit != expected[i].hit || h.t != expected[i].t) ++mismatches;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(mismatches.load(), 0);
}

// The queries allocate nothing (operator new is counted above; Embree's own heap is not).
TEST_F(EmbreeSegmentQueriesTest, QueriesDoNotAllocate) {
  auto sphere = Share(geometry::MakeIcosphere(9, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(sphere);
  const EmbreeMesh mesh(device_, bvh);
  std::mt19937_64 rng(16);
  const auto segments = RandomSegments(*sphere, 200, rng);
  std::vector<Vector3> p, q;
  for (const auto& [a, b] : segments) {
    p.push_back(a);
    q.push_back(b);
  }
  std::vector<SegmentMeshHit> out(p.size());
  const long before = g_allocations.load();
  int hits = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    hits += FindFirstSegmentHit(mesh, p[i], q[i]).hit ? 1 : 0;
    hits += SegmentHitsMesh(mesh, p[i], q[i]) ? 1 : 0;
  }
  FindFirstSegmentHits(mesh, p, q, out);
  EXPECT_EQ(g_allocations.load(), before);
  EXPECT_GT(hits, 0);
}

}  // namespace
}  // namespace hapticd::embree
