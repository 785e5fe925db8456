// The scenario parser (sim::ParseScenario with `--set` overrides) and a short run of
// what it accepts through the simulator (hapticd-sim's path).
//
// Input: a scenario's JSON, optionally followed by a NUL byte and override lines
// ("key.path=value", one per line). Checks on an accepted scenario: the documented
// ranges of scenario.h (rate and duration > 0, ticks = round(duration_s * rate_hz) in
// [1, kMaxTicks], hand path times strictly increasing, channel loss in [0, 1], ...);
// then the simulator, capped at kTicks ticks, either refuses the scene with a
// ScenarioError or runs them, with a finite summary whose impedance force never exceeds
// device.max_force (the saturation FORMAT.md promises). Any other exception escapes and
// is reported as a crash. Mesh files are read relative to bench/scenarios.

#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "server/fuzz/fuzz_check.h"
#include "server/sim/scenario_parser.h"
#include "server/sim/simulator.h"

namespace hapticd::fuzz {
namespace {

using sim::Scenario;

// Enough ticks to reach contact code in most seeds, few enough for thousands of runs a second.
constexpr int64_t kTicks = 32;

void CheckScenario(const Scenario& s) {
  FUZZ_CHECK(std::isfinite(s.rate_hz) && s.rate_hz > 0, "rate_hz is %g", s.rate_hz);
  FUZZ_CHECK(std::isfinite(s.duration_s) && s.duration_s > 0, "duration_s is %g", s.duration_s);
  FUZZ_CHECK(s.ticks >= 1 && s.ticks <= sim::kMaxTicks && s.ticks == std::llround(s.duration_s * s.rate_hz),
             "%lld ticks for %g s at %g Hz", static_cast<long long>(s.ticks), s.duration_s, s.rate_hz);
  FUZZ_CHECK(std::isfinite(s.scene_settings.tolerance) && s.scene_settings.tolerance > 0, "scene.tolerance is %g",
             s.scene_settings.tolerance);
  FUZZ_CHECK(std::isfinite(s.device.mass) && s.device.mass > 0, "device.mass is %g", s.device.mass);
  FUZZ_CHECK(s.device.damping >= 0 && s.device.position_resolution >= 0 && s.device.start_W.allFinite(),
             "device.damping %g, position_resolution %g", s.device.damping, s.device.position_resolution);
  FUZZ_CHECK(std::isfinite(s.session.device.max_force) && s.session.device.max_force > 0, "device.max_force is %g",
             s.session.device.max_force);
  FUZZ_CHECK(s.hand.mass >= 0 && s.hand.stiffness >= 0 && s.hand.damping >= 0, "hand mass %g stiffness %g damping %g",
             s.hand.mass, s.hand.stiffness, s.hand.damping);
  FUZZ_CHECK(!s.hand.path.empty(), "an empty hand.path");
  for (std::size_t i = 0; i < s.hand.path.size(); ++i) {
    FUZZ_CHECK(std::isfinite(s.hand.path[i].t) && s.hand.path[i].p_W.allFinite(), "hand.path[%zu] is not finite", i);
    if (i > 0) FUZZ_CHECK(s.hand.path[i].t > s.hand.path[i - 1].t, "hand.path[%zu] does not move on in time", i);
  }
  FUZZ_CHECK(s.channel.delay_s >= 0 && s.channel.jitter_s >= 0 && std::isfinite(s.channel.delay_s) &&
                 std::isfinite(s.channel.jitter_s),
             "channel delay %g jitter %g", s.channel.delay_s, s.channel.jitter_s);
  FUZZ_CHECK(s.channel.loss >= 0 && s.channel.loss <= 1, "channel.loss is %g", s.channel.loss);
  for (const auto& object : s.objects) {
    FUZZ_CHECK(!object.name.empty(), "an object without a name");
    FUZZ_CHECK(object.X_WB.translation.allFinite() && object.X_WB.rotation.allFinite(),
               "objects[%s] has a non-finite pose", object.name.c_str());
  }
}

void CheckSummary(const Scenario& s, const sim::SimSummary& summary) {
  FUZZ_CHECK(summary.ticks == s.ticks, "ran %lld of %lld ticks", static_cast<long long>(summary.ticks),
             static_cast<long long>(s.ticks));
  FUZZ_CHECK(std::isfinite(summary.max_force_n) && summary.max_force_n >= 0, "max_force_n is %g", summary.max_force_n);
  if (s.session.device.mode == force::DeviceMode::kImpedance) {
    FUZZ_CHECK(summary.max_force_n <= s.session.device.max_force * (1 + 1e-12),
               "an impedance force of %g N over max_force %g N", summary.max_force_n, s.session.device.max_force);
  }
  FUZZ_CHECK(!std::isnan(summary.max_penetration_m) && summary.max_penetration_m >= 0, "max_penetration_m is %g",
             summary.max_penetration_m);
  FUZZ_CHECK(summary.contact_ticks >= 0 && summary.contact_ticks <= summary.ticks, "%lld contact ticks of %lld",
             static_cast<long long>(summary.contact_ticks), static_cast<long long>(summary.ticks));
}

}  // namespace
}  // namespace hapticd::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace hapticd;
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  // JSON, then NUL, then override lines
  const std::size_t nul = input.find('\0');
  const std::string_view json = input.substr(0, nul);
  std::vector<std::string> overrides;
  if (nul != std::string_view::npos) {
    std::string_view rest = input.substr(nul + 1);
    while (!rest.empty()) {
      const std::size_t end = std::min(rest.find('\n'), rest.size());
      overrides.emplace_back(rest.substr(0, end));
      rest.remove_prefix(std::min(end + 1, rest.size()));
    }
  }

  sim::Scenario scenario;
  try {
    scenario = sim::ParseScenario(json, HAPTICD_FUZZ_SCENARIO_DIR, overrides);
  } catch (const sim::ScenarioError&) {
    return 0;
  }
  fuzz::CheckScenario(scenario);

  scenario.ticks = std::min(scenario.ticks, fuzz::kTicks);
  const sim::Scenario checked = scenario;
  try {
    sim::Simulator simulator(std::move(scenario));
    fuzz::CheckSummary(checked, simulator.Run());
  } catch (const sim::ScenarioError&) {
    // the scene builder or the render session refused it, by name
  }
  return 0;
}
