// Nanoseconds per query for the triangle primitives: segment/ray-triangle (Möller-
// Trumbore and the exact watertight test, filtered and unfiltered, hits and misses
// apart), closest point on a triangle, triangle-triangle, sphere-triangle and capsule-triangle. Inputs are
// generated once per benchmark with a fixed seed, outside the timing loop, and the
// loop cycles through 4096 of them so no single case sits in the branch predictor.

#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "server/geometry/capsule_triangle.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/segment_triangle.h"
#include "server/geometry/sphere_triangle.h"
#include "server/geometry/triangle_triangle.h"

namespace hapticd::geometry {
namespace {

constexpr size_t kCases = 4096;  // a power of two: the index wraps with a mask

Vector3 RandomPoint(std::mt19937_64& rng, double scale = 1) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return {u(rng), u(rng), u(rng)};
}

Triangle RandomTriangle(std::mt19937_64& rng) {
  return {RandomPoint(rng), RandomPoint(rng), RandomPoint(rng)};
}

struct SegmentCase {
  Vector3 p, q;
  Triangle tri;
};

// Segments whose endpoints lie on opposite sides of the triangle's plane (what a
// BVH hands over), kept when they hit (want_hit) or miss.
std::vector<SegmentCase> MakeSegmentCases(bool want_hit) {
  std::mt19937_64 rng(want_hit ? 101 : 102);
  std::vector<SegmentCase> cases;
  while (cases.size() < kCases) {
    SegmentCase c{RandomPoint(rng, 1.5), RandomPoint(rng, 1.5), RandomTriangle(rng)};
    const Vector3 n = (c.tri.v1 - c.tri.v0).cross(c.tri.v2 - c.tri.v0);
    if (n.dot(c.p - c.tri.v0) * n.dot(c.q - c.tri.v0) >= 0) continue;
    if (IntersectSegmentTriangleWatertight(c.p, c.q, c.tri).hit == want_hit) cases.push_back(c);
  }
  return cases;
}

template <TriangleHit (*Query)(const Vector3&, const Vector3&, const Triangle&)>
void RunSegments(benchmark::State& state, bool want_hit) {
  const std::vector<SegmentCase> cases = MakeSegmentCases(want_hit);
  size_t i = 0;
  for (auto _ : state) {
    const SegmentCase& c = cases[i++ & (kCases - 1)];
    benchmark::DoNotOptimize(Query(c.p, c.q, c.tri));
  }
}
void BM_SegmentMollerTrumboreHit(benchmark::State& s) {
  RunSegments<IntersectSegmentTriangle>(s, true);
}
void BM_SegmentMollerTrumboreMiss(benchmark::State& s) {
  RunSegments<IntersectSegmentTriangle>(s, false);
}
void BM_SegmentWatertightHit(benchmark::State& s) {
  RunSegments<IntersectSegmentTriangleWatertight>(s, true);
}
void BM_SegmentWatertightMiss(benchmark::State& s) {
  RunSegments<IntersectSegmentTriangleWatertight>(s, false);
}
// the same decisions from the exact predicates alone (no shared filter)
void BM_SegmentWatertightUnfilteredHit(benchmark::State& s) {
  RunSegments<IntersectSegmentTriangleWatertightUnfiltered>(s, true);
}
void BM_SegmentWatertightUnfilteredMiss(benchmark::State& s) {
  RunSegments<IntersectSegmentTriangleWatertightUnfiltered>(s, false);
}
BENCHMARK(BM_SegmentMollerTrumboreHit);
BENCHMARK(BM_SegmentMollerTrumboreMiss);
BENCHMARK(BM_SegmentWatertightHit);
BENCHMARK(BM_SegmentWatertightMiss);
BENCHMARK(BM_SegmentWatertightUnfilteredHit);
BENCHMARK(BM_SegmentWatertightUnfilteredMiss);

// Rays: the segments' directions, scaled, about half of them hitting.
template <TriangleHit (*Query)(const Vector3&, const Vector3&, const Triangle&)>
void RunRays(benchmark::State& state) {
  std::vector<SegmentCase> cases = MakeSegmentCases(true);
  const std::vector<SegmentCase> misses = MakeSegmentCases(false);
  for (size_t k = 0; k < kCases; k += 2) cases[k] = misses[k];
  for (SegmentCase& c : cases) c.q = 3 * (c.q - c.p);
  size_t i = 0;
  for (auto _ : state) {
    const SegmentCase& c = cases[i++ & (kCases - 1)];
    benchmark::DoNotOptimize(Query(c.p, c.q, c.tri));
  }
}
void BM_RayMollerTrumboreMixed(benchmark::State& s) { RunRays<IntersectRayTriangle>(s); }
void BM_RayWatertightMixed(benchmark::State& s) { RunRays<IntersectRayTriangleWatertight>(s); }
BENCHMARK(BM_RayMollerTrumboreMixed);
BENCHMARK(BM_RayWatertightMixed);

void BM_ClosestPointOnTriangle(benchmark::State& state) {
  std::mt19937_64 rng(103);
  std::vector<std::pair<Vector3, Triangle>> cases;
  for (size_t k = 0; k < kCases; ++k) cases.emplace_back(RandomPoint(rng, 2), RandomTriangle(rng));
  size_t i = 0;
  for (auto _ : state) {
    const auto& [p, tri] = cases[i++ & (kCases - 1)];
    benchmark::DoNotOptimize(FindClosestPointOnTriangle(p, tri));
  }
}
BENCHMARK(BM_ClosestPointOnTriangle);

// Triangle pairs in a shared box: about a third intersect.
std::vector<std::pair<Triangle, Triangle>> MakeTrianglePairs(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::pair<Triangle, Triangle>> cases;
  for (size_t k = 0; k < kCases; ++k) cases.emplace_back(RandomTriangle(rng), RandomTriangle(rng));
  return cases;
}

void BM_TrianglesIntersect(benchmark::State& state) {
  const auto cases = MakeTrianglePairs(104);
  size_t i = 0;
  for (auto _ : state) {
    const auto& [a, b] = cases[i++ & (kCases - 1)];
    benchmark::DoNotOptimize(TrianglesIntersect(a, b));
  }
}
BENCHMARK(BM_TrianglesIntersect);

// With the intersection segment, on intersecting pairs only.
void BM_IntersectTrianglesHits(benchmark::State& state) {
  std::vector<std::pair<Triangle, Triangle>> cases;
  std::mt19937_64 rng(105);
  while (cases.size() < kCases) {
    const Triangle a = RandomTriangle(rng), b = RandomTriangle(rng);
    if (TrianglesIntersect(a, b)) cases.emplace_back(a, b);
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& [a, b] = cases[i++ & (kCases - 1)];
    benchmark::DoNotOptimize(IntersectTriangles(a, b));
  }
}
BENCHMARK(BM_IntersectTrianglesHits);

void BM_SphereTriangle(benchmark::State& state) {
  std::mt19937_64 rng(106);
  std::uniform_real_distribution<double> radius(0.05, 0.5);
  std::vector<std::pair<Sphere, Triangle>> cases;
  for (size_t k = 0; k < kCases; ++k) {
    cases.emplace_back(Sphere{RandomPoint(rng, 1.5), radius(rng)}, RandomTriangle(rng));
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& [s, tri] = cases[i++ & (kCases - 1)];
    benchmark::DoNotOptimize(CalcSphereTriangleContact(s, tri));
  }
}
BENCHMARK(BM_SphereTriangle);

void BM_CapsuleTriangle(benchmark::State& state) {
  std::mt19937_64 rng(107);
  std::uniform_real_distribution<double> radius(0.05, 0.3);
  std::vector<std::pair<Capsule, Triangle>> cases;
  for (size_t k = 0; k < kCases; ++k) {
    const Vector3 p0 = RandomPoint(rng, 1.5);
    cases.emplace_back(Capsule{p0, p0 + RandomPoint(rng, 0.5), radius(rng)}, RandomTriangle(rng));
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& [c, tri] = cases[i++ & (kCases - 1)];
    benchmark::DoNotOptimize(CalcCapsuleTriangleContact(c, tri));
  }
}
BENCHMARK(BM_CapsuleTriangle);

}  // namespace
}  // namespace hapticd::geometry

BENCHMARK_MAIN();
