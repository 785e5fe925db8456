// Per-tick time of RenderSession::Tick (collision detection, force response and
// control), as percentiles over many ticks: point and sphere avatars, every method,
// against primitives and against meshes of about 10k, 100k and 1.3M triangles.
//
// The device slides around the object's equator pressed 1 mm in, at 0.2 m/s, so every
// tick is in contact (the expensive case). One thread; every tick is timed on its own
// with the steady clock (about 20 ns of overhead, included), and its work units counted
// (geometry::WorkMeter: what --tick-work-budget bounds). The proxy methods run twice,
// taking turns in the same run: gathering a neighbourhood once a tick (as the server does)
// and asking the whole scene each query (the direct path, as before issue 12).
//
// The baseline: a fixed arithmetic loop as long as the first session's median tick,
// timed the same way in the same blocks. It does no memory work at all, so its tail is
// what this machine alone adds at that duration (interrupts, preemption, the
// hypervisor): on a shared 2-core machine a 25 us loop's p99.9 is far above its p50.
// After the table, a probe of those interruptions: how often and how long (see
// ProbeInterruptions).
//
//   render_tick_percentiles [--ticks N] [--quick] [--triangles N] [--method NAME] [--gathered-only]
//     -> a Markdown table on stdout (--triangles, --method: only that object (0 for the
//        primitives) or method; --gathered-only: no direct sessions; for profiling)

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <memory>
#include <random>
#include <utility>
#include <string>
#include <tuple>
#include <vector>

#include "server/force/render_session.h"
#include "server/geometry/mesh_generators.h"
#include "server/scene/scene_builder.h"

namespace {

using hapticd::geometry::Vector3;
using namespace hapticd;

constexpr double kRadius = 0.05;       // every object's size: a 10 cm ball
constexpr double kPress = 0.001;       // depth the device is held inside, m
constexpr double kSpeed = 0.2;         // m/s along the surface
constexpr double kAvatarRadius = 0.005;

struct Target {
  std::string name;
  scene::ObjectSpec spec;
  int triangles = 0;
};

scene::ObjectSpec Spec(std::string name, scene::ShapeSpec shape) {
  scene::ObjectSpec spec;
  spec.name = std::move(name);
  spec.shape = std::move(shape);
  spec.material.stiffness = 2000;
  return spec;
}

scene::MeshSpec PinnedMesh(const geometry::TriangleMesh& mesh) {
  scene::MeshSpec spec;
  spec.vertices = mesh.vertices();
  spec.triangles = mesh.triangles();
  spec.pin = scene::Representation::kMesh;
  return spec;
}

std::vector<Target> MakeTargets(bool quick) {
  std::vector<Target> targets;
  targets.push_back({"sphere", Spec("sphere", scene::SphereShape{kRadius}), 0});
  targets.push_back({"box", Spec("box", scene::BoxShape{Vector3::Constant(kRadius)}), 0});
  targets.push_back({"capsule", Spec("capsule", scene::CapsuleShape{kRadius, 0.05}), 0});
  // the hull of 200 points on the sphere
  std::mt19937_64 random(7);
  std::normal_distribution<double> normal;
  scene::ConvexSpec hull;
  for (int i = 0; i < 200; ++i) {
    hull.points.push_back(kRadius * Vector3(normal(random), normal(random), normal(random)).normalized());
  }
  targets.push_back({"convex (200 points)", Spec("convex", hull), 0});
  // icospheres: 20 f^2 triangles
  for (int frequency : quick ? std::vector<int>{22} : std::vector<int>{22, 71, 256}) {
    const geometry::TriangleMesh mesh = geometry::MakeIcosphere(frequency, kRadius);
    targets.push_back({"mesh", Spec("mesh", PinnedMesh(mesh)), mesh.num_triangles()});
  }
  return targets;
}

struct Method {
  const char* name;
  force::ForceMethod method;
  double radius;
};

struct Percentiles {
  double p50, p99, p999, max;
  int64_t work_p999, work_max;  // work units per tick (geometry::WorkMeter)
  int triangles_p50, triangles_max;  // triangles gathered per tick
  double local;                      // share of the queries answered by the neighbourhood
  double loop_p50 = 0, loop_p999 = 0;  // the baseline loop's, in the same blocks
};

// The baseline loop: a chain of dependent multiply-adds (no memory traffic), its length
// set so that its median matches a given duration.
class BaselineLoop {
 public:
  void Calibrate(double target_us) {
    iterations_ = 1000;
    std::vector<double> times;
    for (int k = 0; k < 201; ++k) times.push_back(TimeOnce());
    std::nth_element(times.begin(), times.begin() + 100, times.end());
    iterations_ = std::max<int64_t>(1, static_cast<int64_t>(iterations_ * target_us / times[100]));
  }
  void Run(int count) {
    for (int k = 0; k < count; ++k) samples_.push_back(TimeOnce());
  }
  std::pair<double, double> P50AndP999() {
    std::sort(samples_.begin(), samples_.end());
    const auto at = [&](double q) { return samples_[std::min<size_t>(samples_.size() - 1, q * samples_.size())]; };
    return {at(0.5), at(0.999)};
  }

 private:
  double TimeOnce() {
    const auto begin = std::chrono::steady_clock::now();
    double x = value_;
    // kept between the clock readings: neither hoisted above nor sunk below them
    asm volatile("" : "+x"(x) : : "memory");
    for (int64_t i = 0; i < iterations_; ++i) x = x * 0.999999 + 1e-9;
    asm volatile("" : "+x"(x) : : "memory");
    value_ = x;
    const auto end = std::chrono::steady_clock::now();
    return std::chrono::duration<double, std::micro>(end - begin).count();
  }
  int64_t iterations_ = 1;
  double value_ = 1;
  std::vector<double> samples_;
};

// The machine's own interruptions: a thread that does nothing but read the steady clock
// sees each one as a gap between two readings (a reading costs about 20 ns, so a gap of
// 2 us or more is time taken from it: a timer or device interrupt, the hypervisor,
// another thread). Their rate says how often a tick of a given length meets one: a tick
// of T us is interrupted in about rate * T of its runs, so where that exceeds 0.1% the
// tick's p99.9 holds an interruption, whatever the tick itself does.
struct Interruptions {
  static constexpr double kAtLeastUs[] = {2, 10, 20, 40, 80};
  double seconds = 0;
  double per_second[std::size(kAtLeastUs)] = {};  // gaps of at least kAtLeastUs[i]
  double max_us = 0;
};

Interruptions ProbeInterruptions(double seconds) {
  Interruptions result;
  int64_t counts[std::size(Interruptions::kAtLeastUs)] = {};
  const auto begin = std::chrono::steady_clock::now();
  auto last = begin;
  for (;;) {
    const auto now = std::chrono::steady_clock::now();
    const double gap = std::chrono::duration<double, std::micro>(now - last).count();
    for (size_t i = 0; i < std::size(counts) && gap >= Interruptions::kAtLeastUs[i]; ++i) ++counts[i];
    result.max_us = std::max(result.max_us, gap);
    last = now;
    if (now - begin >= std::chrono::duration<double>(seconds)) break;
  }
  result.seconds = std::chrono::duration<double>(last - begin).count();
  for (size_t i = 0; i < std::size(counts); ++i) result.per_second[i] = static_cast<double>(counts[i]) / result.seconds;
  return result;
}

// One session sliding around the object, ticked in blocks (so that two sessions can
// take turns in one run) and timed tick by tick.
class Slider {
 public:
  Slider(const scene::SceneSnapshot& scene, const Method& m, const force::NeighbourhoodCapacity& capacity)
      : scene_(scene), session_(Settings(m), int64_t{1} << 40, capacity), orbit_(kRadius + m.radius - kPress) {
    // a budget no tick here reaches, so that every tick is measured whole
    session_.Reset(Vector3(orbit_ + 0.01, 0, 0));
  }

  // count ticks; measured ones are kept
  void Run(int count, bool measured) {
    const double omega = kSpeed / orbit_;
    for (int k = 0; k < count; ++k, ++tick_) {
      const double t = 0.001 * tick_;
      force::DeviceInput input;
      // slightly tilted equator, so the path crosses mesh edges at every angle
      input.p_WD = orbit_ * Vector3(std::cos(omega * t), std::sin(omega * t) * 0.96, std::sin(omega * t) * 0.28);
      input.v_WD = kSpeed * Vector3(-std::sin(omega * t), std::cos(omega * t) * 0.96, std::cos(omega * t) * 0.28);
      const auto begin = std::chrono::steady_clock::now();
      const force::TickOutput out = session_.Tick(scene_, input, 0.001);
      const auto end = std::chrono::steady_clock::now();
      asm volatile("" : : "g"(&out) : "memory");
      if (!measured) continue;
      samples_.push_back(std::chrono::duration<double, std::micro>(end - begin).count());
      work_.push_back(session_.last_tick_work());
      triangles_.push_back(session_.neighbourhood().num_triangles());
    }
    if (!measured) local_before_ = session_.neighbourhood().local_answers(), scene_before_ = session_.neighbourhood().scene_answers();
  }

  // the median of count ticks, none kept (to calibrate the baseline)
  double MedianOf(int count) {
    std::vector<double> times;
    for (int k = 0; k < count; ++k) {
      const auto begin = std::chrono::steady_clock::now();
      Run(1, false);
      times.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - begin).count());
    }
    std::nth_element(times.begin(), times.begin() + count / 2, times.end());
    return times[count / 2];
  }

  Percentiles Result() {
    std::sort(samples_.begin(), samples_.end());
    std::sort(work_.begin(), work_.end());
    std::sort(triangles_.begin(), triangles_.end());
    const auto index = [&](double q) { return std::min<size_t>(samples_.size() - 1, q * samples_.size()); };
    const double local = static_cast<double>(session_.neighbourhood().local_answers() - local_before_);
    const double asked = local + static_cast<double>(session_.neighbourhood().scene_answers() - scene_before_);
    return {samples_[index(0.5)],   samples_[index(0.99)], samples_[index(0.999)], samples_.back(),
            work_[index(0.999)],    work_.back(),          triangles_[index(0.5)], triangles_.back(),
            asked > 0 ? local / asked : 0};
  }

 private:
  static force::SessionSettings Settings(const Method& m) {
    force::SessionSettings settings;
    settings.avatar.type = m.radius > 0 ? force::AvatarType::kSphere : force::AvatarType::kPoint;
    settings.avatar.radius = m.radius;
    settings.avatar.method = m.method;
    settings.device.max_force = 100;
    return settings;
  }

  const scene::SceneSnapshot& scene_;
  force::RenderSession session_;
  double orbit_;
  int tick_ = 0;
  std::vector<double> samples_;
  std::vector<int64_t> work_;
  std::vector<int> triangles_;
  int64_t local_before_ = 0, scene_before_ = 0;
};

// A session that gathers its neighbourhood (as the server's do) and one that asks the
// whole scene every query (the direct path), taking turns in blocks of a thousand ticks
// so that the machine's load falls on both alike, and the baseline loop as long as the
// first one's median in the same blocks. Penalty never gathers: one session.
std::pair<Percentiles, Percentiles> Measure(const scene::SceneSnapshot& scene, const Method& m, int ticks,
                                            bool gathered_only) {
  constexpr int kBlock = 1000;
  Slider gathered(scene, m, {});
  Slider direct(scene, m, {0, 0});
  const bool both = m.method != force::ForceMethod::kPenalty && !gathered_only;
  gathered.Run(ticks / 10, false);
  if (both) direct.Run(ticks / 10, false);
  BaselineLoop baseline;
  baseline.Calibrate(gathered.MedianOf(501));
  for (int done = 0; done < ticks; done += kBlock) {
    gathered.Run(std::min(kBlock, ticks - done), true);
    if (both) direct.Run(std::min(kBlock, ticks - done), true);
    baseline.Run(std::min(kBlock, ticks - done));
  }
  Percentiles first = gathered.Result();
  std::tie(first.loop_p50, first.loop_p999) = baseline.P50AndP999();
  return {first, both ? direct.Result() : Percentiles{}};
}

}  // namespace

int main(int argc, char** argv) {
  int ticks = 50000;
  bool quick = false;
  int only_triangles = -1;           // keep only the target with this many triangles (0: primitives)
  const char* only_method = nullptr;  // keep only this method
  bool gathered_only = false;         // no direct sessions (for profiling the gathered one)
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--ticks") && i + 1 < argc) {
      ticks = std::max(1000, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--quick")) {
      quick = true;
    } else if (!std::strcmp(argv[i], "--triangles") && i + 1 < argc) {
      only_triangles = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--gathered-only")) {
      gathered_only = true;
    } else if (!std::strcmp(argv[i], "--method") && i + 1 < argc) {
      only_method = argv[++i];
    } else {
      std::fprintf(stderr, "usage: %s [--ticks N] [--quick] [--triangles N] [--method NAME] [--gathered-only]\n", argv[0]);
      return 2;
    }
  }
  const Method methods[] = {
      {"point penalty", force::ForceMethod::kPenalty, 0},
      {"point god-object", force::ForceMethod::kGodObject, 0},
      {"sphere penalty", force::ForceMethod::kPenalty, kAvatarRadius},
      {"sphere finger proxy", force::ForceMethod::kFingerProxy, kAvatarRadius},
  };
  std::printf(
      "| object | triangles | avatar and method | queries | p50 µs | p99 µs | p99.9 µs | max µs | work p99.9 | work max "
      "| gathered triangles p50 / max | answered by the neighbourhood | baseline loop p50 / p99.9 µs |\n");
  std::printf("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  const auto row = [](const Target& target, const Method& m, const char* queries, const Percentiles& p,
                      bool gathers) {
    std::printf("| %s | %s | %s | %s | %.2f | %.2f | %.2f | %.1f | %lld | %lld |", target.name.c_str(),
                target.triangles ? std::to_string(target.triangles).c_str() : "-", m.name, queries, p.p50, p.p99,
                p.p999, p.max, static_cast<long long>(p.work_p999), static_cast<long long>(p.work_max));
    if (gathers) {
      std::printf(" %d / %d | %.1f%% |", p.triangles_p50, p.triangles_max, 100 * p.local);
    } else {
      std::printf(" - | - |");
    }
    if (p.loop_p50 > 0) {
      std::printf(" %.2f / %.2f |\n", p.loop_p50, p.loop_p999);
    } else {
      std::printf(" - |\n");
    }
    std::fflush(stdout);
  };
  for (const Target& target : MakeTargets(quick)) {
    if (only_triangles >= 0 && target.triangles != only_triangles) continue;
    scene::SceneBuilder builder;
    builder.Add(target.spec);
    const auto scene = builder.Build(1);
    for (const Method& m : methods) {
      if (only_method != nullptr && std::strcmp(only_method, m.name)) continue;
      const auto [gathered, direct] = Measure(*scene, m, ticks, gathered_only);
      if (m.method == force::ForceMethod::kPenalty) {
        row(target, m, "one per tick", gathered, false);
        continue;
      }
      row(target, m, "gathered once a tick", gathered, true);
      if (!gathered_only) row(target, m, "direct (before)", direct, false);
    }
  }
  // the machine's interruptions, after the ticks (the same machine, moments apart)
  const Interruptions probe = ProbeInterruptions(quick ? 1 : 5);
  std::printf("\nInterruptions seen by a thread that only reads the steady clock, over %.0f s: gaps between two "
              "readings of at least", probe.seconds);
  for (size_t i = 0; i < std::size(Interruptions::kAtLeastUs); ++i) {
    std::printf("%s %.0f µs: %.0f a second", i ? ";" : "", Interruptions::kAtLeastUs[i], probe.per_second[i]);
  }
  std::printf(" (longest %.0f µs). A tick of T µs meets a gap of at least G µs in about T x (G's rate) / 10^6 of its "
              "runs; where that share exceeds 0.1%%, the tick's p99.9 is at least T + G whatever the tick does, and more "
              "where the interruption evicts the tick's memory and the tick must fetch it again (the baseline loop has "
              "none to fetch).\n",
              probe.max_us);
  return 0;
}
