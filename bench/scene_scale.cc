// How a tick scales with the scene (issue 12's scale aims): per-tick percentiles of a
// point god-object and a 5 mm finger proxy sliding pressed into a box, in a scene of 10
// objects and in one of 10,000 (spheres, boxes, capsules and small meshes, 2 to 10 cm,
// in a 4 m cube; 1% of them, and at least one, kinematic and moved every millisecond
// on a thread of their own, as the server's control thread does), ticked at 1 kHz on
// the latest snapshot, measured in the same run, each avatar gathering its neighbourhood once a tick (query::Neighbourhood)
// and asking the whole scene every query (the direct path), taking turns; and what moving 100 kinematic objects costs: SceneBuilder::AdvanceKinematic
// (the broad phase's incremental update included) and the Build of the snapshot that
// publishes it.
//
//   scene_scale [--ticks N]   -> Markdown tables on stdout

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "server/force/render_session.h"
#include "server/geometry/mesh_generators.h"
#include "server/scene/scene_builder.h"

namespace {

using hapticd::geometry::Vector3;
using namespace hapticd;
using Clock = std::chrono::steady_clock;

double Micros(Clock::time_point begin, Clock::time_point end) {
  return std::chrono::duration<double, std::micro>(end - begin).count();
}

struct Percentiles {
  double p50, p99, p999, max;
};

Percentiles Of(std::vector<double> samples) {
  std::sort(samples.begin(), samples.end());
  const auto at = [&](double q) { return samples[std::min<size_t>(samples.size() - 1, q * samples.size())]; };
  return {at(0.5), at(0.99), at(0.999), samples.back()};
}

// The box the device presses (10 cm, top at z = 0.05) and n - 1 others around it,
// none within 20 cm of it.
scene::SceneBuilder MakeScene(int n, int kinematic) {
  scene::SceneSettings settings;
  settings.budgets.max_objects = n;
  scene::SceneBuilder builder(settings);
  scene::ObjectSpec box;
  box.name = "pressed";
  box.shape = scene::BoxShape{Vector3::Constant(0.05)};
  box.material.stiffness = 2000;
  builder.Add(box);
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> coordinate(-2, 2), size(0.01, 0.05);
  const geometry::TriangleMesh ball = geometry::MakeIcosphere(3, 1.0);
  for (int i = 1; i < n; ++i) {
    scene::ObjectSpec spec;
    spec.name = std::string("o").append(std::to_string(i));
    spec.material.stiffness = 1000;
    do {
      spec.X_WB.translation = Vector3(coordinate(random), coordinate(random), coordinate(random));
    } while (spec.X_WB.translation.norm() < 0.2);
    const double s = size(random);
    switch (i % 4) {
      case 0: spec.shape = scene::SphereShape{s}; break;
      case 1: spec.shape = scene::BoxShape{Vector3(s, 0.6 * s, 0.3 * s)}; break;
      case 2: spec.shape = scene::CapsuleShape{0.4 * s, s}; break;
      default: {
        scene::MeshSpec mesh;
        for (const Vector3& v : ball.vertices()) mesh.vertices.push_back(s * v);
        mesh.triangles = ball.triangles();
        mesh.pin = scene::Representation::kMesh;
        spec.shape = mesh;
      }
    }
    if (i <= kinematic) {
      spec.motion = scene::Motion::kKinematic;
      spec.v_WB = Vector3(0.1, 0.05, 0);
      spec.w_WB = Vector3(0, 0, 1);
    }
    builder.Add(spec);
  }
  return builder;
}

// A scene whose kinematic objects move every millisecond on a thread of their own, as
// the server's control thread moves them (server/app/server.cc), each move published as
// a new snapshot; a tick takes the latest, as the realtime thread does.
class MovingScene {
 public:
  MovingScene(int n, int kinematic)
      : builder_(MakeScene(n, kinematic)), latest_(builder_.Build(1)), mover_([this] { Move(); }) {}
  ~MovingScene() {
    stop_ = true;
    mover_.join();
  }
  std::shared_ptr<const scene::SceneSnapshot> Latest() {
    const std::lock_guard lock(mutex_);
    return latest_;
  }

 private:
  void Move() {
    auto next = Clock::now();
    for (uint64_t version = 2; !stop_; ++version) {
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
      builder_.AdvanceKinematic(1e-3);
      std::shared_ptr<const scene::SceneSnapshot> snapshot = builder_.Build(version);
      const std::lock_guard lock(mutex_);
      latest_.swap(snapshot);
    }
  }

  scene::SceneBuilder builder_;
  std::mutex mutex_;
  std::shared_ptr<const scene::SceneSnapshot> latest_;
  std::atomic<bool> stop_{false};
  std::thread mover_;
};

// A session sliding on the box's top, ticked in blocks so that two can take turns in one
// run, every tick timed on its own.
class Slider {
 public:
  Slider(force::ForceMethod method, double radius, const force::NeighbourhoodCapacity& capacity)
      : session_(Settings(method, radius), int64_t{1} << 40, capacity), radius_(radius) {
    session_.Reset(Vector3(0, 0, 0.08));
  }

  // count ticks at 1 kHz, each on the scene's latest snapshot
  void Run(MovingScene& scene, int count, bool measured) {
    auto next = Clock::now();
    for (int k = 0; k < count; ++k, ++tick_) {
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
      const std::shared_ptr<const scene::SceneSnapshot> snapshot = scene.Latest();
      const double t = 1e-3 * tick_;
      force::DeviceInput input;
      // a circle of 3 cm on the box's top, pressed 1 mm in
      input.p_WD = Vector3(0.03 * std::cos(5 * t), 0.03 * std::sin(5 * t), 0.05 + radius_ - 0.001);
      input.v_WD = 0.15 * Vector3(-std::sin(5 * t), std::cos(5 * t), 0);
      const auto begin = Clock::now();
      const force::TickOutput out = session_.Tick(*snapshot, input, 1e-3);
      const auto end = Clock::now();
      asm volatile("" : : "g"(&out) : "memory");
      if (measured) samples_.push_back(Micros(begin, end));
    }
  }
  const std::vector<double>& samples() const { return samples_; }

 private:
  static force::SessionSettings Settings(force::ForceMethod method, double radius) {
    force::SessionSettings settings;
    settings.avatar.type = radius > 0 ? force::AvatarType::kSphere : force::AvatarType::kPoint;
    settings.avatar.radius = radius;
    settings.avatar.method = method;
    return settings;
  }

  force::RenderSession session_;
  double radius_;
  int tick_ = 0;
  std::vector<double> samples_;
};

// One avatar in the scenes of 10 and 10,000 objects, gathering its neighbourhood once a
// tick (as the server's sessions do) and asking the whole scene every query (the direct
// path, as before): the four take turns in blocks of a thousand ticks (a second each),
// so that a burst of other work on the machine lands on all of them alike.
struct Runs {
  Percentiles gathered, direct;
};
std::vector<Runs> MeasureTicks(std::vector<std::unique_ptr<MovingScene>>& scenes, force::ForceMethod method,
                               double radius, int ticks) {
  std::vector<std::pair<Slider, Slider>> sliders;
  sliders.reserve(scenes.size());
  for (size_t k = 0; k < scenes.size(); ++k) {
    sliders.emplace_back(std::piecewise_construct, std::forward_as_tuple(method, radius, force::NeighbourhoodCapacity{}),
                         std::forward_as_tuple(method, radius, force::NeighbourhoodCapacity{0, 0}));
  }
  for (size_t k = 0; k < scenes.size(); ++k) {
    sliders[k].first.Run(*scenes[k], ticks / 10, false);
    sliders[k].second.Run(*scenes[k], ticks / 10, false);
  }
  for (int done = 0; done < ticks; done += 1000) {
    for (size_t k = 0; k < scenes.size(); ++k) {
      sliders[k].first.Run(*scenes[k], std::min(1000, ticks - done), true);
      sliders[k].second.Run(*scenes[k], std::min(1000, ticks - done), true);
    }
  }
  std::vector<Runs> runs;
  for (const auto& [gathered, direct] : sliders) runs.push_back({Of(gathered.samples()), Of(direct.samples())});
  return runs;
}

}  // namespace

int main(int argc, char** argv) {
  int ticks = 5000;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--ticks") && i + 1 < argc) {
      ticks = std::max(1000, std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: %s [--ticks N]\n", argv[0]);
      return 2;
    }
  }
  struct Avatar {
    const char* name;
    force::ForceMethod method;
    double radius;
  };
  const Avatar avatars[] = {{"point god-object", force::ForceMethod::kGodObject, 0},
                            {"5 mm sphere finger proxy", force::ForceMethod::kFingerProxy, 0.005}};
  std::printf(
      "| objects | avatar | queries | p50 µs | p99 µs | p99.9 µs | max µs |\n|---:|---|---|---:|---:|---:|---:|\n");
  const int sizes[] = {10, 10000};
  std::vector<std::unique_ptr<MovingScene>> scenes;
  for (const int n : sizes) scenes.push_back(std::make_unique<MovingScene>(n, std::max(1, n / 100)));
  for (const Avatar& a : avatars) {
    const std::vector<Runs> runs = MeasureTicks(scenes, a.method, a.radius, ticks);
    for (size_t k = 0; k < runs.size(); ++k) {
      for (const auto& [queries, p] :
           {std::pair{"gathered once a tick", runs[k].gathered}, {"direct (before)", runs[k].direct}}) {
        std::printf("| %d | %s | %s | %.2f | %.2f | %.2f | %.1f |\n", sizes[k], a.name, queries, p.p50, p.p99,
                    p.p999, p.max);
      }
    }
    std::fflush(stdout);
  }
  scenes.clear();
  // the moves: 100 kinematic objects among 10,000, advanced by 1 ms, then published
  scene::SceneBuilder builder = MakeScene(10000, 100);
  std::vector<double> advance, build;
  for (int i = 0; i < 2000; ++i) {
    const auto begin = Clock::now();
    builder.AdvanceKinematic(1e-3);
    const auto moved = Clock::now();
    const auto snapshot = builder.Build(2 + i);
    const auto built = Clock::now();
    asm volatile("" : : "g"(snapshot.get()) : "memory");
    advance.push_back(Micros(begin, moved));
    build.push_back(Micros(moved, built));
  }
  const Percentiles a = Of(advance), b = Of(build);
  std::printf("\n| 100 kinematic moves among 10,000 objects | p50 µs | p99 µs | max µs |\n|---|---:|---:|---:|\n");
  std::printf("| AdvanceKinematic (poses, bounds, broad phase) | %.1f | %.1f | %.1f |\n", a.p50, a.p99, a.max);
  std::printf("| Build (the snapshot that publishes them) | %.1f | %.1f | %.1f |\n", b.p50, b.p99, b.max);
  return 0;
}
