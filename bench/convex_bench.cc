// Convex-convex queries on hulls of about 20 and 200 points (random points in a ball;
// the hulls keep roughly 15 and 100 of them as vertices). Inputs are made beforehand
// with a fixed seed and queries cycle through them:
//   HullBuild       Quickhull of one point set
//   GjkCold         distance of two posed hulls along a smooth motion (1 ms ticks,
//                   millimetre and milliradian steps), searches from scratch each tick
//   GjkTracked      the same motion through FeatureTracker (warm simplex and hints)
//   Penetration     depth of two overlapping hulls (exact candidate axes)
//   SeparatingPlane Seidel's LP on the two point sets, half of them separable
//   CollideConvex   the conformance query from point sets (hulls included)
// Argument: points per set. Counters: steps = support-vertex visits + GJK iterations.

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "server/geometry/convex_convex.h"
#include "server/geometry/convex_hull.h"
#include "server/geometry/feature_tracker.h"
#include "server/geometry/penetration.h"
#include "server/geometry/separating_plane.h"

namespace hapticd::geometry {
namespace {

constexpr int kNumInputs = 64;
constexpr int kNumTicks = 4096;

std::vector<Vector3> RandomBall(std::mt19937_64& rng, int n, double radius, const Vector3& center) {
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vector3> points;
  for (int i = 0; i < n; ++i) {
    points.push_back(center + radius * std::cbrt(u(rng)) * Vector3(g(rng), g(rng), g(rng)).normalized());
  }
  return points;
}

// Pairs of point sets; offset sets b's centre distance from a's (radius 1 each).
struct Pairs {
  std::vector<std::vector<Vector3>> a, b;
  std::vector<ConvexHull> hull_a, hull_b;
};
Pairs MakePairs(int n, double min_offset, double max_offset, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  Pairs p;
  for (int i = 0; i < kNumInputs; ++i) {
    const Vector3 dir = Vector3(g(rng), g(rng), g(rng)).normalized();
    p.a.push_back(RandomBall(rng, n, 1, Vector3::Zero()));
    p.b.push_back(RandomBall(rng, n, 1, (min_offset + (max_offset - min_offset) * u(rng)) * dir));
    p.hull_a.push_back(BuildConvexHull(p.a.back()));
    p.hull_b.push_back(BuildConvexHull(p.b.back()));
  }
  return p;
}

// Poses of two bodies along smooth sinusoidal paths, 1 ms apart.
struct Tick {
  Matrix3 R_WA, R_WB;
  Vector3 p_WA, p_WB;
};
std::vector<Tick> MakeMotion(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const Vector3 freq(1 + 2 * u(rng), 1 + 2 * u(rng), 1 + 2 * u(rng)), phase(6 * u(rng), 6 * u(rng), 6 * u(rng));
  const Vector3 spin(1 + u(rng), 1 + u(rng), 1 + u(rng));
  std::vector<Tick> ticks;
  for (int k = 0; k < kNumTicks; ++k) {
    const double t = 1e-3 * k;
    Tick tick;
    tick.R_WA = Eigen::AngleAxisd(spin.x() * t, Vector3::UnitZ()).toRotationMatrix();
    tick.R_WB = (Eigen::AngleAxisd(spin.y() * t, Vector3::UnitY()) * Eigen::AngleAxisd(spin.z() * t, Vector3::UnitX()))
                    .toRotationMatrix();
    tick.p_WA = 0.3 * (freq * t + phase).array().sin().matrix();
    tick.p_WB = Vector3(2.6, 0, 0) + 0.3 * (freq.reverse() * t).array().cos().matrix();
    ticks.push_back(tick);
  }
  return ticks;
}

void BM_HullBuild(benchmark::State& state) {
  const Pairs p = MakePairs(static_cast<int>(state.range(0)), 0, 0, 1);
  int i = 0;
  for (auto _ : state) {
    ConvexHull h = BuildConvexHull(p.a[i++ % kNumInputs]);
    benchmark::DoNotOptimize(h);
  }
  state.counters["vertices"] = p.hull_a[0].num_vertices();
}

void BM_GjkCold(benchmark::State& state) {
  const Pairs p = MakePairs(static_cast<int>(state.range(0)), 0, 0, 2);
  const std::vector<Tick> motion = MakeMotion(3);
  long steps = 0, queries = 0;
  int k = 0;
  for (auto _ : state) {
    const Tick& t = motion[k++ % kNumTicks];
    const TrackedDistance d = CalcHullDistanceCold(p.hull_a[0], t.R_WA, t.p_WA, p.hull_b[0], t.R_WB, t.p_WB);
    benchmark::DoNotOptimize(d);
    steps += d.steps, ++queries;
  }
  state.counters["steps"] = static_cast<double>(steps) / queries;
}

void BM_GjkTracked(benchmark::State& state) {
  const Pairs p = MakePairs(static_cast<int>(state.range(0)), 0, 0, 2);
  const std::vector<Tick> motion = MakeMotion(3);
  FeatureTracker tracker(p.hull_a[0], p.hull_b[0]);
  long steps = 0, queries = 0;
  int k = 0;
  for (auto _ : state) {
    const Tick& t = motion[k++ % kNumTicks];
    const TrackedDistance d = tracker.Update(t.R_WA, t.p_WA, t.R_WB, t.p_WB);
    benchmark::DoNotOptimize(d);
    steps += d.steps, ++queries;
  }
  state.counters["steps"] = static_cast<double>(steps) / queries;
}

void BM_Penetration(benchmark::State& state) {
  const Pairs p = MakePairs(static_cast<int>(state.range(0)), 0.2, 1.2, 4);
  int i = 0;
  for (auto _ : state) {
    const PenetrationResult r = CalcPenetration(p.hull_a[i % kNumInputs], p.hull_b[i % kNumInputs]);
    benchmark::DoNotOptimize(r);
    ++i;
  }
}

void BM_SeparatingPlane(benchmark::State& state) {
  const Pairs p = MakePairs(static_cast<int>(state.range(0)), 1.5, 2.5, 5);
  int i = 0;
  for (auto _ : state) {
    const SeparatingPlane s = FindSeparatingPlane(p.a[i % kNumInputs], p.b[i % kNumInputs], i);
    benchmark::DoNotOptimize(s);
    ++i;
  }
}

void BM_CollideConvex(benchmark::State& state) {
  const Pairs p = MakePairs(static_cast<int>(state.range(0)), 1.0, 3.0, 6);
  int i = 0;
  for (auto _ : state) {
    const ConvexConvexResult r = CollideConvex(p.a[i % kNumInputs], p.b[i % kNumInputs]);
    benchmark::DoNotOptimize(r);
    ++i;
  }
}

BENCHMARK(BM_HullBuild)->Arg(20)->Arg(200);
BENCHMARK(BM_GjkCold)->Arg(20)->Arg(200);
BENCHMARK(BM_GjkTracked)->Arg(20)->Arg(200);
BENCHMARK(BM_Penetration)->Arg(20)->Arg(200);
BENCHMARK(BM_SeparatingPlane)->Arg(20)->Arg(200);
BENCHMARK(BM_CollideConvex)->Arg(20)->Arg(200);

}  // namespace
}  // namespace hapticd::geometry

BENCHMARK_MAIN();
