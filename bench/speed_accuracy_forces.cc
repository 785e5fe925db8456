#include "bench/speed_accuracy_forces.h"

#include <chrono>
#include <cstdio>
#include <string>

#include "server/force/render_session.h"

namespace hapticd::bench {
namespace {

constexpr double kTickSeconds = 0.001;
// How far off the surface the avatar starts, m.
constexpr double kStartGap = 0.005;
// A force that still changes by more than this (N) on the last settle tick is reported.
constexpr double kSettledChange = 1e-9;

struct Avatar {
  std::string query;
  force::AvatarType type;
  force::ForceMethod method;
  double radius;
};

force::SessionSettings MakeSettings(const Avatar& avatar) {
  force::SessionSettings settings;
  settings.avatar.type = avatar.type;
  settings.avatar.method = avatar.method;
  settings.avatar.radius = avatar.radius;
  // far above k d (a few N), so saturation never hides an error (the torus's hull
  // asks for tens of N)
  settings.device.max_force = 1000;
  return settings;
}

// The device position that holds the avatar `depth` into the surface at site i, and
// where the avatar starts, both along the analytic normal.
struct SitePose {
  Vector3 device;
  Vector3 start;
};
SitePose PoseAt(const QueryInputs& in, int i, double avatar_radius) {
  const Vector3& x = in.site_point[i];
  const Vector3& n = in.site_normal[i];
  return {x + (avatar_radius - in.site_depth[i]) * n, x + (avatar_radius + kStartGap) * n};
}

// Resets the session at site i and ticks it settle_ticks times; returns the last output.
force::TickOutput Settle(force::RenderSession& session, const scene::SceneSnapshot& scene,
                         const SitePose& pose, int settle_ticks, Vector3* previous_force) {
  session.Reset(pose.start);
  force::DeviceInput input;
  input.p_WD = pose.device;
  force::TickOutput out;
  for (int tick = 0; tick < settle_ticks; ++tick) {
    *previous_force = out.f_W;
    out = session.Tick(scene, input, kTickSeconds);
  }
  return out;
}

ResultRow MeasureAvatar(const scene::SceneSnapshot& scene, const QueryInputs& in,
                        const ForceOptions& options, const TimingOptions& timing,
                        const ResultRow& identity, const Avatar& avatar) {
  // a budget no tick here reaches (the hulls' forces take milliseconds), so that every
  // tick is rendered and measured whole
  force::RenderSession session(MakeSettings(avatar), int64_t{1} << 40);
  const int sites = static_cast<int>(in.site_point.size());
  // errors after settling
  std::vector<double> errors(sites);
  int unsettled = 0;
  const auto begin = std::chrono::steady_clock::now();
  for (int i = 0; i < sites; ++i) {
    Vector3 previous = Vector3::Zero();
    const force::TickOutput out =
        Settle(session, scene, PoseAt(in, i, avatar.radius), options.settle_ticks, &previous);
    const Vector3 ideal = options.stiffness * in.site_depth[i] * in.site_normal[i];
    errors[i] = (out.f_W - ideal).norm();
    if ((out.f_W - previous).norm() > kSettledChange) ++unsettled;
  }
  // steady-state ticks, timed per site (reset and settling are not timed); a slow
  // representation is timed on fewer sites
  const double settle_s = SecondsSince(begin);
  const double pass_s = settle_s * (options.settle_ticks + options.timed_ticks) / options.settle_ticks;
  const int timed_sites = TimedBatchSize(sites, pass_s, timing, /*min_items=*/8);
  std::vector<double> per_tick_ns;
  double spent_s = 0;
  while (static_cast<int>(per_tick_ns.size()) < timing.max_reps &&
         (static_cast<int>(per_tick_ns.size()) < timing.min_reps || spent_s < timing.budget_s)) {
    double seconds = 0;
    for (int i = 0; i < timed_sites; ++i) {
      const SitePose pose = PoseAt(in, i, avatar.radius);
      Vector3 previous;
      Settle(session, scene, pose, options.settle_ticks, &previous);
      force::DeviceInput input;
      input.p_WD = pose.device;
      const auto begin = std::chrono::steady_clock::now();
      for (int tick = 0; tick < options.timed_ticks; ++tick) {
        const force::TickOutput out = session.Tick(scene, input, kTickSeconds);
        asm volatile("" : : "g"(&out) : "memory");
      }
      const auto end = std::chrono::steady_clock::now();
      seconds += std::chrono::duration<double>(end - begin).count();
    }
    spent_s += seconds;
    per_tick_ns.push_back(1e9 * seconds / (timed_sites * options.timed_ticks));
  }
  const BatchTiming t = MedianTiming(std::move(per_tick_ns));
  ResultRow row = identity;
  row.query = avatar.query;
  row.queries = timed_sites * options.timed_ticks;
  row.reps = t.reps;
  row.time_ns = t.median_ns;
  row.time_ns_min = t.min_ns;
  row.error_unit = std::string("N");
  row.error = SummarizeErrors(std::move(errors));
  if (unsettled > 0) {
    row.note = std::to_string(unsettled) + " of " + std::to_string(sites) + " sites still moving after " +
               std::to_string(options.settle_ticks) + " ticks";
  }
  return row;
}

}  // namespace

std::vector<ResultRow> MeasureForces(const scene::SceneSnapshot& scene, const QueryInputs& inputs,
                                     const ForceOptions& options, const TimingOptions& timing,
                                     const ResultRow& identity) {
  const Avatar point{"force_point", force::AvatarType::kPoint, force::ForceMethod::kGodObject, 0};
  const Avatar sphere{"force_sphere", force::AvatarType::kSphere, force::ForceMethod::kFingerProxy,
                      options.avatar_radius};
  return {MeasureAvatar(scene, inputs, options, timing, identity, point),
          MeasureAvatar(scene, inputs, options, timing, identity, sphere)};
}

}  // namespace hapticd::bench
