// Broad phase: one simulation step of n moving boxes, for n = 1k and 10k, in the
// dynamic AABB tree, against brute force for 1k.
//
// Scene: boxes with half extents 0.1..0.5 m in a cube sized so that they fill about
// 8% of it (side 14 m for 1k, 30 m for 10k). Motion: 32 frames made beforehand with a
// fixed seed; from one frame to the next every box moves up to 2 cm per axis and 3%
// of them jump to a random place. The benchmark plays the frames forwards and
// backwards, so each step is such a motion. Tree margin 0.1 m; Move gets the motion as
// its displacement hint, except for the jumps.
//   Step         every box Move()s to the next frame, then FindOverlappingPairs
//   UpdateOnly   the Move()s alone
//   PairsOnly    FindOverlappingPairs alone on a fixed tree
//   BruteForce   copy the boxes, then test all n (n - 1) / 2 pairs

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "server/geometry/broad_phase.h"

namespace hapticd::geometry {
namespace {

constexpr int kFrames = 32;
constexpr double kMargin = 0.1;

struct Scene {
  std::vector<std::vector<Aabb>> frames;  // frames[f][object]
};

Scene MakeScene(int n) {
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<double> half(0.1, 0.5);
  std::uniform_real_distribution<double> jitter(-0.02, 0.02);
  std::uniform_real_distribution<double> unit(0, 1);
  // Mean box volume (2 * 0.3)^3; side chosen for an 8% filling.
  const double side = std::cbrt(n * 0.216 / 0.08);
  std::uniform_real_distribution<double> coord(0, side);
  Scene scene;
  scene.frames.resize(kFrames);
  for (int i = 0; i < n; ++i) {
    const Vector3 h(half(rng), half(rng), half(rng));
    const Vector3 c(coord(rng), coord(rng), coord(rng));
    scene.frames[0].push_back({c - h, c + h});
  }
  for (int f = 1; f < kFrames; ++f) {
    scene.frames[f] = scene.frames[f - 1];
    for (Aabb& box : scene.frames[f]) {
      Vector3 d(jitter(rng), jitter(rng), jitter(rng));
      if (unit(rng) < 0.03) d = Vector3(coord(rng), coord(rng), coord(rng)) - box.center();
      box.min += d;
      box.max += d;
    }
  }
  return scene;
}

// Frame index of step k when playing forwards then backwards: 0, 1, .., 31, 30, .., 1.
int FrameOfStep(int64_t k) {
  const int period = 2 * kFrames - 2;
  const int phase = static_cast<int>(k % period);
  return phase < kFrames ? phase : period - phase;
}

// Moves every box to its place in `to`. The displacement hint is the motion for the
// small continuous moves, zero for the jumps (a teleport says nothing about the next
// motion; as a hint it would stretch the fat box across the scene).
void MoveAll(DynamicAabbTree& tree, const std::vector<int>& ids, const std::vector<Aabb>& from,
             const std::vector<Aabb>& to, int64_t* reinserted) {
  for (size_t i = 0; i < ids.size(); ++i) {
    const Vector3 d = to[i].center() - from[i].center();
    const bool small = d.cwiseAbs().maxCoeff() <= kMargin;
    *reinserted += tree.Move(ids[i], to[i], small ? d : Vector3::Zero());
  }
}

DynamicAabbTree MakeTree(const Scene& scene, std::vector<int>* ids) {
  const int n = static_cast<int>(scene.frames[0].size());
  DynamicAabbTree tree(n, kMargin);
  for (const Aabb& box : scene.frames[0]) ids->push_back(tree.Insert(box));
  return tree;
}

void BM_TreeStep(benchmark::State& state) {
  const Scene scene = MakeScene(static_cast<int>(state.range(0)));
  std::vector<int> ids;
  DynamicAabbTree tree = MakeTree(scene, &ids);
  std::vector<ProxyPair> pairs;
  pairs.reserve(16 * ids.size());
  int64_t step = 0;
  int64_t reinserted = 0;
  int64_t pair_count = 0;
  for (auto _ : state) {
    const std::vector<Aabb>& from = scene.frames[FrameOfStep(step)];
    const std::vector<Aabb>& to = scene.frames[FrameOfStep(step + 1)];
    MoveAll(tree, ids, from, to, &reinserted);
    tree.FindOverlappingPairs(&pairs);
    benchmark::DoNotOptimize(pairs.data());
    pair_count += static_cast<int64_t>(pairs.size());
    ++step;
  }
  state.counters["pairs"] = static_cast<double>(pair_count) / state.iterations();
  state.counters["reinserted"] = static_cast<double>(reinserted) / state.iterations();
  state.counters["height"] = tree.height();
}
BENCHMARK(BM_TreeStep)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

void BM_TreeUpdateOnly(benchmark::State& state) {
  const Scene scene = MakeScene(static_cast<int>(state.range(0)));
  std::vector<int> ids;
  DynamicAabbTree tree = MakeTree(scene, &ids);
  int64_t step = 0;
  int64_t reinserted = 0;
  for (auto _ : state) {
    MoveAll(tree, ids, scene.frames[FrameOfStep(step)], scene.frames[FrameOfStep(step + 1)],
            &reinserted);
    benchmark::ClobberMemory();
    ++step;
  }
  state.counters["reinserted"] = static_cast<double>(reinserted) / state.iterations();
}
BENCHMARK(BM_TreeUpdateOnly)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

void BM_TreePairsOnly(benchmark::State& state) {
  const Scene scene = MakeScene(static_cast<int>(state.range(0)));
  std::vector<int> ids;
  const DynamicAabbTree tree = MakeTree(scene, &ids);
  std::vector<ProxyPair> pairs;
  pairs.reserve(16 * ids.size());
  for (auto _ : state) {
    tree.FindOverlappingPairs(&pairs);
    benchmark::DoNotOptimize(pairs.data());
  }
  state.counters["pairs"] = static_cast<double>(pairs.size());
}
BENCHMARK(BM_TreePairsOnly)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The O(n^2) baseline: same motion, every pair tested.
void BM_BruteForceStep(benchmark::State& state) {
  const Scene scene = MakeScene(static_cast<int>(state.range(0)));
  const int n = static_cast<int>(state.range(0));
  std::vector<Aabb> boxes = scene.frames[0];
  std::vector<ProxyPair> pairs;
  pairs.reserve(16 * n);
  int64_t step = 0;
  int64_t pair_count = 0;
  for (auto _ : state) {
    const std::vector<Aabb>& to = scene.frames[FrameOfStep(step + 1)];
    for (int i = 0; i < n; ++i) boxes[i] = to[i];
    pairs.clear();
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        if (AabbsOverlap(boxes[i], boxes[j])) pairs.push_back({i, j});
      }
    }
    benchmark::DoNotOptimize(pairs.data());
    pair_count += static_cast<int64_t>(pairs.size());
    ++step;
  }
  state.counters["pairs"] = static_cast<double>(pair_count) / state.iterations();
}
BENCHMARK(BM_BruteForceStep)->Arg(1000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace hapticd::geometry

BENCHMARK_MAIN();
