// Per-query time of SweepSphereMesh for the proxies: short sweeps (1 mm) of a finger
// proxy (r = 5 mm) and of a god-object (r = 0) near the surface of geodesic spheres of
// about 10k, 100k and 1M triangles, of radius 0.1 m (a hand-sized object: at 1M
// triangles the 5 mm sphere covers hundreds of them) and 1 m (a few). Queries cycle
// through 4096 inputs made beforehand with a fixed seed:
//   Approach  centre 0 to 2 mm beyond r from the surface, moving 1 mm in a random
//             direction (about an eighth hit)
//   Slide     centre resting r + 1 nm off a face (where the proxy solver leaves it),
//             moving 1 mm along that face: on a convex mesh it rises off the surface,
//             but the sweep must still examine every triangle near the path
//   CoherentSlide  the same, but each sweep starts where the last ended (put back to
//             r + 1 nm off the surface): a proxy's motion, so consecutive queries touch
//             the same part of the tree and it stays in the caches
//   Point     centre 0 to 2 mm off the surface, moving 1 mm in a random direction, r = 0
//             (the god-object; about an eighth hit)
// Arguments: /size (0: ~10k, 1: ~100k, 2: ~1M triangles) /object radius in cm (10, 100).

#include <benchmark/benchmark.h>

#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/bvh.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/sphere_sweep.h"

namespace hapticd::geometry {
namespace {

constexpr int kNumInputs = 4096;
constexpr double kProxyRadius = 0.005;
constexpr double kStep = 0.001;

// Meshes and BVHs are made once per (size, radius) and kept for the whole run.
const MeshBvh& CachedBvh(const benchmark::State& state) {
  static constexpr int kFrequency[3] = {22, 71, 224};
  static std::map<std::pair<int, int>, std::unique_ptr<MeshBvh>> cache;
  const int size = static_cast<int>(state.range(0)), radius_cm = static_cast<int>(state.range(1));
  auto& slot = cache[{size, radius_cm}];
  if (!slot) {
    slot = std::make_unique<MeshBvh>(
        std::make_shared<const TriangleMesh>(MakeIcosphere(kFrequency[size], 0.01 * radius_cm)));
  }
  return *slot;
}

Vector3 RandomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  return Vector3(normal(rng), normal(rng), normal(rng)).normalized();
}

// A random point of a random face, and that face's normal.
std::pair<Vector3, Vector3> RandomSurfacePoint(const MeshBvh& bvh, std::mt19937_64& rng) {
  std::uniform_int_distribution<int> pick(0, bvh.num_primitives() - 1);
  std::uniform_real_distribution<double> unit(0, 1);
  const int i = pick(rng);
  const Triangle& t = bvh.primitive(i);
  double u = unit(rng), v = unit(rng);
  if (u + v > 1) u = 1 - u, v = 1 - v;
  return {t.v0 + u * (t.v1 - t.v0) + v * (t.v2 - t.v0),
          bvh.mesh().face_normal(bvh.primitive_triangle(i))};
}

struct Sweep {
  Vector3 a, b;
};

// Random sweeps starting `radius` plus 0 to 2 mm off the surface.
std::vector<Sweep> ApproachSweeps(const MeshBvh& bvh, double radius) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<Sweep> sweeps;
  for (int k = 0; k < kNumInputs; ++k) {
    const auto [on, normal] = RandomSurfacePoint(bvh, rng);
    const Vector3 a = on + (radius + 0.002 * unit(rng)) * normal;
    sweeps.push_back({a, a + kStep * RandomDirection(rng)});
  }
  return sweeps;
}

std::vector<Sweep> SlideSweeps(const MeshBvh& bvh) {
  std::mt19937_64 rng(22);
  std::vector<Sweep> sweeps;
  for (int k = 0; k < kNumInputs; ++k) {
    const auto [on, normal] = RandomSurfacePoint(bvh, rng);
    const Vector3 a = on + (kProxyRadius + 1e-9) * normal;
    Vector3 along = RandomDirection(rng);
    along = (along - along.dot(normal) * normal).normalized();
    sweeps.push_back({a, a + kStep * along});
  }
  return sweeps;
}

// A walk of slides: each starts where the last ended, put back to r + 1 nm off the
// surface along the normal of the nearest face.
std::vector<Sweep> CoherentSlideSweeps(const MeshBvh& bvh) {
  std::mt19937_64 rng(23);
  std::vector<Sweep> sweeps;
  Vector3 end = RandomSurfacePoint(bvh, rng).first;
  for (int k = 0; k < kNumInputs; ++k) {
    const MeshClosestPoint on = FindClosestPointOnMesh(bvh, end);
    const Vector3 normal = bvh.mesh().face_normal(on.triangle);
    const Vector3 a = on.point + (kProxyRadius + 1e-9) * normal;
    Vector3 along = RandomDirection(rng);
    along = (along - along.dot(normal) * normal).normalized();
    end = a + kStep * along;
    sweeps.push_back({a, end});
  }
  return sweeps;
}

// Times SweepSphereMesh over the sweeps in turn.
void TimeSweeps(benchmark::State& state, const MeshBvh& bvh, const std::vector<Sweep>& sweeps,
                double r) {
  int k = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    const Sweep& s = sweeps[k++ & (kNumInputs - 1)];
    const SphereSweepHit hit = SweepSphereMesh(bvh, s.a, s.b, r);
    hits += hit.hit;
    benchmark::DoNotOptimize(hit);
  }
  state.SetLabel("icosphere " + std::to_string(bvh.mesh().num_triangles()) + " triangles, radius " +
                 std::to_string(state.range(1)) + " cm");
  state.counters["hit_rate"] = static_cast<double>(hits) / state.iterations();
}

void BM_SweepApproach(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  TimeSweeps(state, bvh, ApproachSweeps(bvh, kProxyRadius), kProxyRadius);
}

void BM_SweepSlide(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  TimeSweeps(state, bvh, SlideSweeps(bvh), kProxyRadius);
}

void BM_SweepCoherentSlide(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  TimeSweeps(state, bvh, CoherentSlideSweeps(bvh), kProxyRadius);
}

void BM_SweepPoint(benchmark::State& state) {
  const MeshBvh& bvh = CachedBvh(state);
  TimeSweeps(state, bvh, ApproachSweeps(bvh, 0), 0);
}

void MeshArgs(benchmark::internal::Benchmark* b) {
  for (int radius_cm : {10, 100}) {
    for (int size = 0; size < 3; ++size) b->Args({size, radius_cm});
  }
}

BENCHMARK(BM_SweepApproach)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_SweepSlide)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_SweepCoherentSlide)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_SweepPoint)->Apply(MeshArgs)->Unit(benchmark::kNanosecond);

}  // namespace
}  // namespace hapticd::geometry

BENCHMARK_MAIN();
