// Time per query of the primitive pair tests: sphere-sphere, sphere-box, AABB-AABB,
// OBB-OBB and capsule-box. Each cycles through 4096 input pairs made beforehand with a
// fixed seed: shapes of size 0.05..1 with centres in a cube of side 1.5, so that about
// half of the pairs touch (the counter `hit_rate` says how many).

#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/box_box.h"
#include "server/geometry/capsule_box.h"
#include "server/geometry/sphere_box.h"
#include "server/geometry/sphere_sphere.h"

namespace hapticd::geometry {
namespace {

constexpr int kNumInputs = 4096;

struct Generator {
  std::mt19937_64 rng{12345};
  std::uniform_real_distribution<double> coord{-0.75, 0.75};
  std::uniform_real_distribution<double> extent{0.05, 1.0};
  std::normal_distribution<double> normal;

  Vector3 Point() { return {coord(rng), coord(rng), coord(rng)}; }
  Matrix3 Rotation() {
    Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
    return q.normalized().toRotationMatrix();
  }
  Sphere MakeSphere() { return {Point(), extent(rng)}; }
  Box MakeBox() { return {Point(), Rotation(), {extent(rng), extent(rng), extent(rng)}}; }
  Aabb MakeAabb() {
    const Vector3 c = Point();
    const Vector3 h(extent(rng), extent(rng), extent(rng));
    return {c - h, c + h};
  }
  Capsule MakeCapsule() {
    const Vector3 c = Point();
    const Vector3 direction = Vector3(normal(rng), normal(rng), normal(rng)).normalized();
    const Vector3 half = 0.5 * extent(rng) * direction;
    return {c - half, c + half, 0.5 * extent(rng)};
  }
};

template <typename A, typename B>
struct Pairs {
  std::vector<A> a;
  std::vector<B> b;
};

template <typename A, typename B, typename MakeA, typename MakeB>
Pairs<A, B> MakePairs(MakeA make_a, MakeB make_b) {
  Generator gen;
  Pairs<A, B> pairs;
  for (int i = 0; i < kNumInputs; ++i) {
    pairs.a.push_back(make_a(gen));
    pairs.b.push_back(make_b(gen));
  }
  return pairs;
}

void BM_SphereSphere(benchmark::State& state) {
  const auto pairs = MakePairs<Sphere, Sphere>([](Generator& g) { return g.MakeSphere(); },
                                               [](Generator& g) { return g.MakeSphere(); });
  int i = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    const SphereSphereResult r = CollideSpheres(pairs.a[i], pairs.b[i]);
    benchmark::DoNotOptimize(r);
    hits += r.intersect;
    i = (i + 1) & (kNumInputs - 1);
  }
  state.counters["hit_rate"] = static_cast<double>(hits) / state.iterations();
}
BENCHMARK(BM_SphereSphere);

void BM_SphereBox(benchmark::State& state) {
  const auto pairs = MakePairs<Sphere, Box>([](Generator& g) { return g.MakeSphere(); },
                                            [](Generator& g) { return g.MakeBox(); });
  int i = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    const SphereBoxResult r = CollideSphereBox(pairs.a[i], pairs.b[i]);
    benchmark::DoNotOptimize(r);
    hits += r.intersect;
    i = (i + 1) & (kNumInputs - 1);
  }
  state.counters["hit_rate"] = static_cast<double>(hits) / state.iterations();
}
BENCHMARK(BM_SphereBox);

void BM_AabbAabb(benchmark::State& state) {
  const auto pairs = MakePairs<Aabb, Aabb>([](Generator& g) { return g.MakeAabb(); },
                                           [](Generator& g) { return g.MakeAabb(); });
  int i = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    const bool r = AabbsOverlap(pairs.a[i], pairs.b[i]);
    benchmark::DoNotOptimize(r);
    hits += r;
    i = (i + 1) & (kNumInputs - 1);
  }
  state.counters["hit_rate"] = static_cast<double>(hits) / state.iterations();
}
BENCHMARK(BM_AabbAabb);

void BM_ObbObb(benchmark::State& state) {
  const auto pairs = MakePairs<Box, Box>([](Generator& g) { return g.MakeBox(); },
                                         [](Generator& g) { return g.MakeBox(); });
  int i = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    const bool r = BoxesOverlap(pairs.a[i], pairs.b[i]);
    benchmark::DoNotOptimize(r);
    hits += r;
    i = (i + 1) & (kNumInputs - 1);
  }
  state.counters["hit_rate"] = static_cast<double>(hits) / state.iterations();
}
BENCHMARK(BM_ObbObb);

void BM_CapsuleBox(benchmark::State& state) {
  const auto pairs = MakePairs<Capsule, Box>([](Generator& g) { return g.MakeCapsule(); },
                                             [](Generator& g) { return g.MakeBox(); });
  int i = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    const CapsuleBoxResult r = CollideCapsuleBox(pairs.a[i], pairs.b[i]);
    benchmark::DoNotOptimize(r);
    hits += r.intersect;
    i = (i + 1) & (kNumInputs - 1);
  }
  state.counters["hit_rate"] = static_cast<double>(hits) / state.iterations();
}
BENCHMARK(BM_CapsuleBox);

// The segment-box closest points alone (no penetration depth).
void BM_SegmentBoxClosest(benchmark::State& state) {
  const auto pairs = MakePairs<Capsule, Box>([](Generator& g) { return g.MakeCapsule(); },
                                             [](Generator& g) { return g.MakeBox(); });
  int i = 0;
  for (auto _ : state) {
    const Capsule& c = pairs.a[i];
    const SegmentBoxClosestPoints r = FindClosestPointsSegmentBox(c.p0, c.p1, pairs.b[i]);
    benchmark::DoNotOptimize(r);
    i = (i + 1) & (kNumInputs - 1);
  }
}
BENCHMARK(BM_SegmentBoxClosest);

}  // namespace
}  // namespace hapticd::geometry

BENCHMARK_MAIN();
