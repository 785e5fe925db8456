// Per-tick time of RenderSession::Tick (collision detection, force response and
// control), as percentiles over many ticks: point and sphere avatars, every method,
// against primitives and against meshes of about 10k, 100k and 1M triangles.
//
// The device slides around the object's equator pressed 1 mm in, at 0.2 m/s, so every
// tick is in contact (the expensive case). One thread; every tick is timed on its own
// with the steady clock (about 20 ns of overhead, included), and its work units counted
// (geometry::WorkMeter: what --tick-work-budget bounds).
//
//   render_tick_percentiles [--ticks N] [--quick]   -> a Markdown table on stdout

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <string>
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
  for (int frequency : quick ? std::vector<int>{22} : std::vector<int>{22, 71, 224}) {
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
};

Percentiles Measure(const scene::SceneSnapshot& scene, const Method& m, int ticks) {
  force::SessionSettings settings;
  settings.avatar.type = m.radius > 0 ? force::AvatarType::kSphere : force::AvatarType::kPoint;
  settings.avatar.radius = m.radius;
  settings.avatar.method = m.method;
  settings.device.max_force = 100;
  // a budget no tick here reaches, so that every tick is measured whole
  force::RenderSession session(settings, int64_t{1} << 40);
  const double orbit = kRadius + m.radius - kPress;
  const double omega = kSpeed / orbit;
  session.Reset(Vector3(orbit + 0.01, 0, 0));
  std::vector<double> samples(ticks);
  std::vector<int64_t> work(ticks);
  const int warmup = ticks / 10;
  for (int tick = -warmup; tick < ticks; ++tick) {
    const double t = 0.001 * (tick + warmup);
    force::DeviceInput input;
    // slightly tilted equator, so the path crosses mesh edges at every angle
    input.p_WD = orbit * Vector3(std::cos(omega * t), std::sin(omega * t) * 0.96, std::sin(omega * t) * 0.28);
    input.v_WD = kSpeed * Vector3(-std::sin(omega * t), std::cos(omega * t) * 0.96, std::cos(omega * t) * 0.28);
    const auto begin = std::chrono::steady_clock::now();
    const force::TickOutput out = session.Tick(scene, input, 0.001);
    const auto end = std::chrono::steady_clock::now();
    asm volatile("" : : "g"(&out) : "memory");
    if (tick >= 0) {
      samples[tick] = std::chrono::duration<double, std::micro>(end - begin).count();
      work[tick] = session.last_tick_work();
    }
  }
  std::sort(samples.begin(), samples.end());
  std::sort(work.begin(), work.end());
  const auto index = [&](double q) { return std::min<size_t>(samples.size() - 1, q * samples.size()); };
  return {samples[index(0.5)], samples[index(0.99)], samples[index(0.999)], samples.back(), work[index(0.999)],
          work.back()};
}

}  // namespace

int main(int argc, char** argv) {
  int ticks = 50000;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--ticks") && i + 1 < argc) {
      ticks = std::max(1000, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--quick")) {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: %s [--ticks N] [--quick]\n", argv[0]);
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
      "| object | triangles | avatar and method | p50 µs | p99 µs | p99.9 µs | max µs | work p99.9 | work max |\n");
  std::printf("|---|---:|---|---:|---:|---:|---:|---:|---:|\n");
  for (const Target& target : MakeTargets(quick)) {
    scene::SceneBuilder builder;
    builder.Add(target.spec);
    const auto scene = builder.Build(1);
    for (const Method& m : methods) {
      const Percentiles p = Measure(*scene, m, ticks);
      std::printf("| %s | %s | %s | %.2f | %.2f | %.2f | %.1f | %lld | %lld |\n", target.name.c_str(),
                  target.triangles ? std::to_string(target.triangles).c_str() : "-", m.name, p.p50,
                  p.p99, p.p999, p.max, static_cast<long long>(p.work_p999), static_cast<long long>(p.work_max));
      std::fflush(stdout);
    }
  }
  return 0;
}
