#include "server/force/render_session.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "server/force/admittance_avatar.h"
#include "server/force/control.h"
#include "server/force/penalty_avatar.h"
#include "server/force/proxy_avatar.h"
#include "server/geometry/work_meter.h"

namespace hapticd::force {
namespace {

// Positions beyond this (m) are absurd for a desktop device or an arm's workspace.
constexpr double kMaxPosition = 100;
// Input faster than this many times the declared maximum velocity is absurd.
constexpr double kVelocityMargin = 10;
// A sensed force beyond this many times the device's maximum force is absurd.
constexpr double kForceMargin = 100;
// The passivity controller's damping is capped so that it alone stays below the force
// limit at 1 cm/s.
constexpr double kPassivityDampingPerNewton = 100;

bool IsFinite(const DeviceInput& in) {
  return in.p_WD.allFinite() && in.v_WD.allFinite() && in.f_held_W.allFinite() &&
         in.f_sensed_W.allFinite();
}

bool IsAbsurd(const DeviceInput& in, const DeviceSettings& device) {
  return in.p_WD.norm() > kMaxPosition ||
         in.v_WD.norm() > kVelocityMargin * device.max_velocity ||
         in.f_sensed_W.norm() > kForceMargin * device.max_force ||
         in.f_held_W.norm() > kForceMargin * device.max_force;
}

// A penalty session asks one query a tick: nothing to gather for.
NeighbourhoodCapacity CapacityFor(const SessionSettings& s, const NeighbourhoodCapacity& asked) {
  const bool penalty = s.device.mode == DeviceMode::kImpedance && s.avatar.method == ForceMethod::kPenalty;
  return penalty ? NeighbourhoodCapacity{0, 0} : asked;
}

}  // namespace

struct RenderSession::State {
  State(const SessionSettings& s, const NeighbourhoodCapacity& capacity)
      : near(capacity.objects, capacity.triangles),
        proxy(s.avatar.radius, s.avatar.force_shading),
        admittance(s.avatar.radius, s.admittance, s.device.max_velocity),
        passivity(s.control.passivity, kPassivityDampingPerNewton * s.device.max_force),
        limiter(s.device.max_force, s.device.max_force_rate),
        watchdog(s.control.watchdog_timeout_s, s.control.watchdog_ramp_s) {}

  query::Neighbourhood near;  // gathered by the avatar each tick
  ProxyAvatar proxy;
  AdmittanceAvatar admittance;
  PassivityController passivity;
  ForceLimiter limiter;
  Watchdog watchdog;
  DeviceInput last_good;
  bool has_good = false;
  // this tick's watchdog scale and force before it (what Render leaves), the last
  // force that did not overrun (the safe one an overrun repeats), whether the last
  // tick overran
  double scale = 1;
  Vector3 f_unscaled_W = Vector3::Zero();
  Vector3 safe_f_W = Vector3::Zero();
  bool overran = false;
};

RenderSession::RenderSession(const SessionSettings& settings, int64_t work_budget,
                             const NeighbourhoodCapacity& neighbourhood)
    : settings_(settings), work_budget_(work_budget), work_credit_(work_budget) {
  if (const auto error = ValidateSessionSettings(settings)) throw std::invalid_argument(*error);
  if (work_budget <= 0) {
    throw std::invalid_argument("the tick work budget is " + std::to_string(work_budget) + "; it must be positive");
  }
  state_ = std::make_unique<State>(settings, CapacityFor(settings, neighbourhood));
}

RenderSession::~RenderSession() = default;
RenderSession::RenderSession(RenderSession&&) noexcept = default;
RenderSession& RenderSession::operator=(RenderSession&&) noexcept = default;

void RenderSession::Reset(const Vector3& p_W) {
  State& s = *state_;
  s.proxy.Reset(p_W);
  s.admittance.Reset(p_W);
  s.passivity.Reset(p_W);
  s.limiter.Reset();
  s.watchdog.Reset();
  s.last_good = DeviceInput{};
  s.last_good.p_WD = p_W;
  s.has_good = true;
  s.scale = 1;
  s.f_unscaled_W = s.safe_f_W = Vector3::Zero();
  s.overran = false;
  work_credit_ = work_budget_;
}

const query::Neighbourhood& RenderSession::neighbourhood() const { return state_->near; }

double RenderSession::observed_energy() const { return state_->passivity.observed_energy(); }

TickOutput RenderSession::Tick(const scene::SceneSnapshot& scene, const DeviceInput& input,
                               double dt) {
  State& s = *state_;
  // what an overrun restores: what this tick's (incomplete) answers would change
  const ProxyAvatar proxy_before = s.proxy;
  const AdmittanceAvatar admittance_before = s.admittance;
  const ForceLimiter limiter_before = s.limiter;
  const SessionCounters counters_before = counters_;
  work_credit_ = std::min(work_budget_, work_credit_ + std::max<int64_t>(1, work_budget_ / 4));
  const geometry::WorkMeter meter(work_credit_);
  TickOutput out = Render(scene, input, dt);
  last_tick_work_ = meter.used();
  work_credit_ -= last_tick_work_;
  s.overran = meter.exhausted();
  if (!s.overran) {
    s.safe_f_W = s.f_unscaled_W;
    return out;
  }
  s.proxy = proxy_before;
  s.admittance = admittance_before;
  s.limiter = limiter_before;
  counters_.force_saturations = counters_before.force_saturations;
  counters_.passivity_activations = counters_before.passivity_activations;
  counters_.constraint_overflows = counters_before.constraint_overflows;
  ++counters_.tick_overruns;
  const bool admittance = settings_.device.mode == DeviceMode::kAdmittance;
  TickOutput safe;
  safe.overrun = true;
  safe.f_W = s.scale * s.safe_f_W;
  safe.f_unscaled_W = s.safe_f_W;
  safe.avatar_W = admittance ? admittance_before.position() : proxy_before.proxy();
  safe.p_command_W = admittance ? admittance_before.position() : out.p_command_W;
  return safe;
}

TickOutput RenderSession::Render(const scene::SceneSnapshot& scene, const DeviceInput& input, double dt) {
  State& s = *state_;
  ++counters_.ticks;
  if (!(dt > 0) || !std::isfinite(dt)) dt = 1 / settings_.device.rate_hz;

  // sanity checks: a bad sample is counted and treated as a missing one
  bool fresh = input.fresh;
  if (fresh && !IsFinite(input)) {
    ++counters_.nonfinite_inputs;
    fresh = false;
  } else if (fresh && IsAbsurd(input, settings_.device)) {
    ++counters_.absurd_inputs;
    fresh = false;
  }
  if (fresh) {
    s.last_good = input;
    s.has_good = true;
    s.passivity.Observe(input.p_WD, input.f_held_W);
  }
  const unsigned long long trips_before = s.watchdog.trips();
  // a tick after an overrun counts as silence: a stream of overruns ramps down like one
  const double scale = s.watchdog.Step(fresh && !s.overran, dt);
  counters_.watchdog_trips += s.watchdog.trips() - trips_before;
  s.scale = scale;

  TickOutput out;
  if (!s.has_good) return out;
  const DeviceInput& in = s.last_good;

  // admittance: force in, pose out (a silent device's force fades with the watchdog)
  if (settings_.device.mode == DeviceMode::kAdmittance) {
    const AvatarForce avatar = s.admittance.Step(scene, s.near, scale * in.f_sensed_W, dt);
    counters_.constraint_overflows += avatar.overflow;
    s.f_unscaled_W = in.f_sensed_W;
    out.f_W = avatar.f_W;
    out.p_command_W = avatar.avatar_W;
    out.avatar_W = avatar.avatar_W;
    out.contact = avatar.contact;
    out.touched_object = avatar.object;
    return out;
  }

  // impedance: collision detection and force response
  const AvatarSettings& a = settings_.avatar;
  const AvatarForce avatar =
      a.method == ForceMethod::kPenalty
          ? CalcPenaltyForce(scene, in.p_WD, in.v_WD, a.radius, a.force_shading)
          : s.proxy.Step(scene, s.near, in.p_WD, in.v_WD, dt);
  counters_.constraint_overflows += avatar.overflow;

  // control: passivity, then the device's limits, then the watchdog's ramp
  Vector3 f = s.passivity.Apply(avatar.f_W, in.v_WD, dt);
  counters_.passivity_activations += s.passivity.active();
  f = s.limiter.Apply(f, dt);
  counters_.force_saturations += s.limiter.saturated();
  s.f_unscaled_W = f;
  out.f_W = scale * f;
  out.f_unscaled_W = f;
  out.p_command_W = in.p_WD;
  out.avatar_W = avatar.avatar_W;
  out.contact = avatar.contact;
  out.touched_object = avatar.object;
  if (avatar.object >= 0 && avatar.object < scene.num_objects()) {
    out.v_surface_W = scene.object(avatar.object).CalcPointVelocity(avatar.avatar_W);
  }
  return out;
}

}  // namespace hapticd::force
