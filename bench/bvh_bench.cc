// BVH build time and per-query time of the mesh queries at about 10k, 100k and 1M
// triangles, on geodesic spheres and tori. Queries cycle through 4096 inputs made
// beforehand with a fixed seed, all near the surface (where a haptic avatar is):
//   ShortSegment  length 1% of the mesh size, centred within 0.5% of the surface (about
//                 half of them hit)
//   CoherentSegment  the same length, but each segment starts where the last ended, on
//                 a random walk that stays within 0.5% of the surface (a haptic avatar's
//                 motion: consecutive queries touch the same part of the tree)
//   LongSegment   between two random points of the box around the mesh, 1.5x its size
//   ClosestPoint  points within 1% of the size from the surface, infinite radius
//   SphereContacts  radius 1% of the size, centre within 1% of the surface, 64 slots
//   Inside        points within 1% of the size from the surface
// Arguments: /shape (0 sphere, 1 torus) /size (0: ~10k, 1: ~100k, 2: ~1M triangles).

#include <benchmark/benchmark.h>

#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "server/geometry/bvh.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/mesh_queries.h"

namespace hapticd::geometry {
namespace {

constexpr int kNumInputs = 4096;

std::shared_ptr<const TriangleMesh> MakeMesh(int shape, int size) {
  // icosphere: 20 f^2 triangles; torus: 2 M m
  static constexpr int kFrequency[3] = {22, 71, 224};
  static constexpr int kMajor[3] = {100, 316, 1000};
  static constexpr int kMinor[3] = {50, 158, 500};
  if (shape == 0) return std::make_shared<const TriangleMesh>(MakeIcosphere(kFrequency[size], 1.0));
  return std::make_shared<const TriangleMesh>(MakeTorus(1.0, 0.3, kMajor[size], kMinor[size]));
}

// Meshes and BVHs are made once per (shape, size) and kept for the whole run.
const MeshBvh& CachedBvh(const benchmark::State& state) {
  static std::map<std::pair<int, int>, std::unique_ptr<MeshBvh>> cache;
  const int shape = static_cast<int>(state.range(0)), size = static_cast<int>(state.range(1));
  auto& slot = cache[{shape, size}];
  if (!slot) slot = std::make_unique<MeshBvh>(MakeMesh(shape, size));
  return *slot;
}

void SetLabel(benchmark::State& state, const MeshBvh& bvh) {
  state.SetLabel((state.range(0) == 0 ? "icosphere " : "torus ") +
                 std::to_string(bvh.mesh().num_triangles()) + " triangles");
  state.counters["triangles"] = bvh.mesh().num_triangles();
}

// A random point within `offset` (along the face normal) of a random point of the surface.
Vector3 NearSurfacePoint(const MeshBvh& bvh, double offset, std::mt19937_64& rng) {
  std::uniform_int_distribution<int> pick(0, bvh.num_primitives() - 1);
  std::uniform_real_distribution<double> unit(0, 1), signed_unit(-1, 1);
  const int i = pick(rng);
  const Triangle& t = bvh.primitive(i);
  double u = unit(rng), v = unit(rng);
  if (u + v > 1) u = 1 - u, v = 1 - v;
  const Vector3 on = t.v0 + u * (t.v1 - t.v0) + v * (t.v2 - t.v0);
  return on + signed_unit(rng) * offset * bvh.mesh().face_normal(bvh.primitive_triangle(i));
}

// kNumInputs such points, from the given seed.
std::vector<Vector3> NearSurfacePoints(const MeshBvh& bvh, double offset, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Vector3> points;
  for (int k = 0; k < kNumInputs; ++k) points.push_back(NearSurfacePoint(bvh, offset, rng));
  return points;
}

Vector3 RandomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  return Vector3(normal(rng), normal(rng), normal(rng)).normalized();
}

void BM_BvhBuild(benchmark::State& state) {
  const auto mesh = MakeMesh(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  for (auto _ : state) {
    MeshBvh bvh(mesh);
    benchmark::DoNotOptimize(bvh.nodes().data());
  }
  state.SetLabel((state.range(0) == 0 ? "icosphere " : "torus ") +
                 std::to_string(mesh->num_triangles()) + " triangles, 2 threads");
}

// Times FindFirstSegmentHit over the segments in turn (kNumInputs of them).
void TimeFirstHits(benchmark::State& state, const MeshBvh& bvh,
                   const std::vector<std::pair<Vector3, Vector3>>& segments) {
  int k = 0, hits = 0;
  for (auto _ : state) {
    const auto& [p, q] = segments[k++ & (kNumInputs - 1)];
    const SegmentMeshHit hit = FindFirstSegmentHit(bvh, p, q);
    hits += hit.hit;
    benchmark::DoNotOptimize(hit);
  }
  SetLabel(state, bvh);
  state.counters["hit_rate"] = static_cast<double>(hits) / state.iterations();
}

void BM_ShortSegment(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  const double size = bvh.mesh().size();
  std::mt19937_64 rng(1);
  std::vector<std::pair<Vector3, Vector3>> segments;
  for (int k = 0; k < kNumInputs; ++k) {
    const Vector3 mid = NearSurfacePoint(bvh, 0.005 * size, rng);
    const Vector3 half = 0.005 * size * RandomDirection(rng);
    segments.emplace_back(mid - half, mid + half);
  }
  TimeFirstHits(state, bvh, segments);
}

void BM_CoherentSegment(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  const double size = bvh.mesh().size();
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> signed_unit(-1, 1);
  // the walk: a step of 1% of the size, pulled back to within 0.5% of the surface
  std::vector<Vector3> walk = {NearSurfacePoint(bvh, 0.005 * size, rng)};
  while (static_cast<int>(walk.size()) <= kNumInputs) {
    const Vector3 moved = walk.back() + 0.01 * size * RandomDirection(rng);
    const MeshClosestPoint on = FindClosestPointOnMesh(bvh, moved);
    const Vector3 normal = bvh.mesh().face_normal(on.triangle);
    walk.push_back(on.point + 0.005 * size * signed_unit(rng) * normal);
  }
  std::vector<std::pair<Vector3, Vector3>> segments;
  for (int i = 0; i < kNumInputs; ++i) segments.emplace_back(walk[i], walk[i + 1]);
  TimeFirstHits(state, bvh, segments);
}

void BM_LongSegment(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  const Aabb box = bvh.mesh().bounds().Inflated(0.25 * bvh.mesh().size());
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> unit(0, 1);
  auto random_in_box = [&] {
    const Vector3 u(unit(rng), unit(rng), unit(rng));
    return Vector3(box.min + box.size().cwiseProduct(u));
  };
  std::vector<std::pair<Vector3, Vector3>> segments;
  for (int k = 0; k < kNumInputs; ++k) segments.emplace_back(random_in_box(), random_in_box());
  TimeFirstHits(state, bvh, segments);
}

void BM_ClosestPoint(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  const std::vector<Vector3> points = NearSurfacePoints(bvh, 0.01 * bvh.mesh().size(), 3);
  int k = 0;
  for (auto _ : state) {
    const MeshClosestPoint closest = FindClosestPointOnMesh(bvh, points[k++ & (kNumInputs - 1)]);
    benchmark::DoNotOptimize(closest);
  }
  SetLabel(state, bvh);
}

void BM_SphereContacts(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  const double size = bvh.mesh().size();
  std::vector<Sphere> spheres;
  for (const Vector3& center : NearSurfacePoints(bvh, 0.01 * size, 4)) {
    spheres.push_back({center, 0.01 * size});
  }
  std::vector<SphereMeshContact> buffer(64);
  int k = 0;
  long long contacts = 0;
  for (auto _ : state) {
    const Sphere& sphere = spheres[k++ & (kNumInputs - 1)];
    const SphereMeshContacts result = FindSphereMeshContacts(bvh, sphere, buffer);
    contacts += result.num_touching;
    benchmark::DoNotOptimize(result);
    benchmark::DoNotOptimize(buffer.data());
  }
  SetLabel(state, bvh);
  state.counters["contacts"] = static_cast<double>(contacts) / state.iterations();
}

void BM_Inside(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  const std::vector<Vector3> points = NearSurfacePoints(bvh, 0.01 * bvh.mesh().size(), 5);
  int k = 0, inside = 0;
  for (auto _ : state) {
    const bool in = IsPointInsideMesh(bvh, points[k++ & (kNumInputs - 1)]);
    inside += in;
    benchmark::DoNotOptimize(in);
  }
  SetLabel(state, bvh);
  state.counters["inside_rate"] = static_cast<double>(inside) / state.iterations();
}

void MeshArgs(benchmark::internal::Benchmark* b) {
  for (int shape = 0; shape < 2; ++shape) {
    for (int size = 0; size < 3; ++size) b->Args({shape, size});
  }
}

BENCHMARK(BM_BvhBuild)->Apply(MeshArgs)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ShortSegment)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_CoherentSegment)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_LongSegment)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_ClosestPoint)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_SphereContacts)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_Inside)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);

}  // namespace
}  // namespace hapticd::geometry

BENCHMARK_MAIN();
