#include "server/sim/simulator.h"

#include <gtest/gtest.h>
#include <rapidjson/document.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "server/sim/scenario_parser.h"
#include "server/sim/sim_output.h"

namespace hapticd::sim {
namespace {

// A point pressed into a box (top face at z = 0.01) by a hand that wants to be 5 mm
// inside it; no friction, no damping anywhere unless a test sets it.
constexpr std::string_view kPress = R"({
  "rate_hz": 1000,
  "duration_s": 1.0,
  "scene": {"objects": [
    {"name": "box", "shape": {"type": "box", "half_extents": [0.05, 0.05, 0.01]},
     "position": [0, 0, 0], "material": {"stiffness": 1500}}
  ]},
  "avatar": {"type": "point", "method": "god_object"},
  "device": {"mode": "impedance", "mass": 0.05, "damping": 0, "max_force": 20, "start": [0.001, 0.002, 0.03]},
  "hand": {"mass": 0.3, "stiffness": 300, "damping": 0, "path": [[0, 0.001, 0.002, 0.005]]}
})";

struct SimRun {
  SimSummary summary;
  std::vector<TraceRow> rows;
};

SimRun Simulate(std::vector<std::string> overrides = {}, std::string_view json = kPress) {
  Simulator simulator(ParseScenario(json, ".", overrides));
  SimRun run;
  run.summary = simulator.Run([&](const TraceRow& row) { run.rows.push_back(row); });
  return run;
}

// The same run, bit for bit: the trace as the CSV writes it.
std::vector<std::string> TraceText(const SimRun& run) {
  std::vector<std::string> lines;
  for (const TraceRow& row : run.rows) lines.push_back(FormatTraceRow(row));
  return lines;
}

// Sum over ticks of f_k . (x_k+1 - x_k) from the trace, x_ticks being the final position.
double EnergyFromTrace(const SimRun& run, double sign = 1) {
  double energy = 0;
  for (size_t k = 0; k < run.rows.size(); ++k) {
    const Vector3& next = k + 1 < run.rows.size() ? run.rows[k + 1].p_device_W : run.summary.final_device_W;
    energy += sign * run.rows[k].f_W.dot(next - run.rows[k].p_device_W);
  }
  return energy;
}

// Index of the first row with a non-zero force, or -1.
int FirstForceTick(const SimRun& run) {
  for (size_t k = 0; k < run.rows.size(); ++k) {
    if (run.rows[k].f_W != Vector3::Zero()) return static_cast<int>(k);
  }
  return -1;
}

TEST(Simulator, TraceHasOneRowPerTickAtTickTimes) {
  const SimRun run = Simulate();
  ASSERT_EQ(run.summary.ticks, 1000);
  ASSERT_EQ(run.rows.size(), 1000u);
  for (int k = 0; k < 1000; ++k) EXPECT_EQ(run.rows[k].t, k / 1000.0);
  EXPECT_EQ(run.rows[0].p_device_W, Vector3(0.001, 0.002, 0.03));
  EXPECT_EQ(run.rows[0].v_device_W, Vector3::Zero());
  // the hand pulled the device onto the box: there was contact and force
  EXPECT_GT(run.summary.contact_ticks, 0);
  EXPECT_GT(run.summary.max_force_n, 1);
}

// With no damping anywhere, the work the held force did is the change of the hand-device
// body's mechanical energy; and energy_j is exactly the sum the trace gives.
TEST(Simulator, EnergyIsTheWorkOfTheHeldForce) {
  for (const char* method : {"god_object", "penalty"}) {
    const SimRun run = Simulate({std::string("avatar.method=") + method});
    EXPECT_EQ(run.summary.energy_j, EnergyFromTrace(run)) << method;
    const double m = 0.35;
    const Vector3 p(0.001, 0.002, 0.005);
    auto mechanical = [&](const Vector3& x, const Vector3& v) {
      return 0.5 * m * v.squaredNorm() + 0.5 * 300 * (x - p).squaredNorm();
    };
    const TraceRow& first = run.rows.front();
    // the final velocity: rerun one tick longer and read its last row
    const SimRun longer = Simulate({std::string("avatar.method=") + method, "duration_s=1.001"});
    ASSERT_EQ(longer.rows[1000].p_device_W, run.summary.final_device_W);
    const double change = mechanical(run.summary.final_device_W, longer.rows[1000].v_device_W) -
                          mechanical(first.p_device_W, first.v_device_W);
    EXPECT_NEAR(run.summary.energy_j, change, 1e-9) << method;
    EXPECT_GT(std::abs(run.summary.energy_j), 1e-4) << method;  // the wall did work
  }
}

// Released in free space, the hand-device body follows the closed-form response of a
// mass-spring-damper, whatever the renderer (it renders nothing).
TEST(Simulator, FreeSpaceIsTheMassSpringDamper) {
  const SimRun run = Simulate({"scene.objects=[]", "hand.damping=5", "device.damping=0.5"});
  const Vector3 p(0.001, 0.002, 0.005);
  const Vector3 amplitude = Vector3(0.001, 0.002, 0.03) - p;
  const double m = 0.35;
  const double a = 5.5 / (2 * m);
  const double wd = std::sqrt(300 / m - a * a);
  ASSERT_EQ(run.rows.size(), 1000u);  // 1 s at 1 kHz: the loop below checks every tick
  for (const TraceRow& row : run.rows) {
    const double decay = std::exp(-a * row.t);
    const Vector3 x = p + decay * (std::cos(wd * row.t) + a / wd * std::sin(wd * row.t)) * amplitude;
    ASSERT_LT((row.p_device_W - x).norm(), 1e-11) << row.t;
    ASSERT_EQ(row.f_W, Vector3::Zero()) << row.t;
  }
  EXPECT_EQ(run.summary.energy_j, 0);
  EXPECT_EQ(run.summary.max_penetration_m, 0);
}

// Until the first force reaches the device the runs are identical, so a delay of D ticks
// each way moves the first force by exactly 2 D ticks.
TEST(Simulator, ChannelDelayShiftsTheFirstForceByTheRoundTrip) {
  const int undelayed = FirstForceTick(Simulate());
  ASSERT_GT(undelayed, 0);
  for (const int delay_ms : {1, 3, 7}) {
    const SimRun run = Simulate({"channel.delay_ms=" + std::to_string(delay_ms)});
    EXPECT_EQ(FirstForceTick(run), undelayed + 2 * delay_ms) << delay_ms;
    EXPECT_EQ(run.summary.ticks_without_input, delay_ms);
    EXPECT_EQ(run.summary.packets_lost_up + run.summary.packets_lost_down, 0u);
  }
}

TEST(Simulator, SameSeedSameRunOtherSeedOtherRun) {
  const std::vector<std::string> lossy = {"channel={\"delay_ms\": 2, \"jitter_ms\": 3, \"loss\": 0.2, \"seed\": 11}",
                                          "device.position_resolution=1e-5"};
  const SimRun a = Simulate(lossy);
  const SimRun b = Simulate(lossy);
  EXPECT_EQ(TraceText(a), TraceText(b));
  EXPECT_EQ(FormatSummaryJson(a.summary), FormatSummaryJson(b.summary));
  EXPECT_GT(a.summary.packets_lost_up, 100u);
  EXPECT_GT(a.summary.packets_lost_down, 100u);
  std::vector<std::string> other = lossy;
  other.push_back("channel.seed=12");
  EXPECT_NE(TraceText(Simulate(other)), TraceText(a));
}

// The device point's deepest penetration, against an independent box depth of the
// trace's positions (the box is axis-aligned at the origin).
TEST(Simulator, MaxPenetrationIsTheDeepestSample) {
  const SimRun run = Simulate({"avatar.method=penalty"});
  const Vector3 half(0.05, 0.05, 0.01);
  double deepest = 0;
  auto depth = [&](const Vector3& x) { return std::max(0.0, (half - x.cwiseAbs()).minCoeff()); };
  for (const TraceRow& row : run.rows) deepest = std::max(deepest, depth(row.p_device_W));
  deepest = std::max(deepest, depth(run.summary.final_device_W));
  EXPECT_GT(deepest, 1e-4);
  EXPECT_NEAR(run.summary.max_penetration_m, deepest, 1e-15);
  EXPECT_EQ(run.summary.max_avatar_penetration_m, run.summary.max_penetration_m);  // a point avatar
}

// The passivity observer sees the same work as energy_j, one tick late (the last tick's
// work is never reported to it), when the channel and sensor are exact.
TEST(Simulator, ObserverSeesTheHeldForcesWork) {
  const SimRun run = Simulate();
  const TraceRow& last = run.rows.back();
  const double last_work = last.f_W.dot(run.summary.final_device_W - last.p_device_W);
  EXPECT_NEAR(run.summary.observed_energy_j, run.summary.energy_j - last_work, 1e-12);
}

// Admittance: the handle reaches each pose command one tick later (ideal tracking), and
// energy_j counts the force on the hand, -f_hand, over the displacement.
TEST(Simulator, AdmittanceTracksThePoseCommand) {
  const SimRun run = Simulate({"device.mode=admittance", "device.virtual_mass=0.5", "device.virtual_damping=10"});
  ASSERT_EQ(run.rows.size(), 1000u);  // 1 s at 1 kHz: the loops below check every tick
  for (size_t k = 0; k + 1 < run.rows.size(); ++k) {
    ASSERT_EQ(run.rows[k + 1].p_device_W, run.rows[k].avatar_W) << k;
    ASSERT_EQ(run.rows[k + 1].v_device_W, (run.rows[k + 1].p_device_W - run.rows[k].p_device_W) / (1 / 1000.0)) << k;
  }
  // the hand force: its spring towards the path (no hand damping here)
  const Vector3 p(0.001, 0.002, 0.005);
  for (const TraceRow& row : run.rows) ASSERT_EQ(row.f_W, 300 * (p - row.p_device_W)) << row.t;
  EXPECT_EQ(run.summary.energy_j, EnergyFromTrace(run, -1));
  EXPECT_GT(run.summary.contact_ticks, 0);
}

// A kinematic box moving up into a device held still above it: the box comes to the
// device, so there is contact, which the same box held still never makes.
TEST(Simulator, KinematicObjectsMove) {
  const std::vector<std::string> held = {"hand.path=[[0, 0, 0, 0.02]]", "device.start=[0, 0, 0.02]",
                                         "hand.stiffness=3000"};
  EXPECT_EQ(Simulate(held).summary.contact_ticks, 0);
  std::vector<std::string> moving = held;
  moving.push_back("scene.objects.0.motion={\"velocity\": [0, 0, 0.02]}");
  const SimRun run = Simulate(moving);
  EXPECT_GT(run.summary.contact_ticks, 0);
  // the top face reaches the device's height z = 0.02 after 0.5 s
  EXPECT_EQ(FirstForceTick(run) >= 490 && FirstForceTick(run) <= 510, true) << FirstForceTick(run);
  EXPECT_GT(run.summary.final_device_W.z(), 0.02 + 1e-3);  // pushed up
}

// Every example in bench/scenarios loads and runs to a finite summary, twice the same.
TEST(Simulator, ExampleScenariosRun) {
  const std::filesystem::path dir = std::filesystem::path(__FILE__).parent_path() / "../../../bench/scenarios";
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    auto summary = [&] { return Simulator(LoadScenario(entry.path())).Run(); };
    const SimSummary first = summary();
    EXPECT_GT(first.ticks, 0) << entry.path();
    EXPECT_TRUE(std::isfinite(first.energy_j) && std::isfinite(first.max_force_n)) << entry.path();
    EXPECT_TRUE(first.final_device_W.allFinite()) << entry.path();
    EXPECT_EQ(FormatSummaryJson(first), FormatSummaryJson(summary())) << entry.path();
  }
  EXPECT_GE(count, 11);  // the 11 examples of README.md, and any others
}

TEST(SimOutput, SummaryIsOneJsonLineWithTheFormatsFieldsFirst) {
  SimSummary summary;
  summary.ticks = 3;
  summary.max_force_n = 1.5;
  summary.energy_j = -0.1;
  summary.final_device_W = Vector3(std::numeric_limits<double>::quiet_NaN(), 0, 1);
  const std::string line = FormatSummaryJson(summary);
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_EQ(line.rfind("{\"ticks\":3,\"max_force_n\":1.5,\"max_penetration_m\":0.0,\"energy_j\":-0.1,", 0), 0u) << line;
  rapidjson::Document document;
  document.Parse(line.c_str());
  ASSERT_FALSE(document.HasParseError()) << line;
  EXPECT_TRUE(document["final_device"][0].IsNull());
  for (const char* key : {"max_avatar_penetration_m", "contact_ticks", "final_avatar", "observed_energy_j",
                          "nonfinite_inputs", "watchdog_trips", "passivity_activations", "force_saturations",
                          "packets_lost_up", "packets_lost_down"}) {
    EXPECT_TRUE(document.HasMember(key)) << key;
  }
}

TEST(SimOutput, TraceRowsRoundTrip) {
  EXPECT_EQ(std::string(kTraceHeader),
            "t,dev_x,dev_y,dev_z,dev_vx,dev_vy,dev_vz,avatar_x,avatar_y,avatar_z,f_x,f_y,f_z,contact");
  TraceRow row;
  row.t = 0.001;
  row.p_device_W = Vector3(0.1, 1.0 / 3.0, -2e-17);
  row.f_W = Vector3(0, 0, 7.5);
  row.contact = true;
  EXPECT_EQ(FormatTraceRow(row), "0.001,0.1,0.3333333333333333,-2e-17,0,0,0,0,0,0,0,0,7.5,1");
}

}  // namespace
}  // namespace hapticd::sim
