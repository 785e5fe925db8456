// The renderer's side of a session's channel as hapticd and hapticd-sim both run it:
// when a silent tick renders a prediction, what it predicts, the input's steps and what
// the port observes of them, when a deadband session's command goes down, and that none
// of it allocates.
#include "server/remote/renderer_channel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "server/net/test/count_allocations.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::remote {
namespace {

using scene::testing::MakeMaterial;
using scene::testing::MakeObject;

constexpr int64_t kPeriodNs = 1'000'000;
constexpr double kDt = 0.001;
constexpr double kStiffness = 2000;

// A box whose top face is the plane z = 0.
std::shared_ptr<const scene::SceneSnapshot> BoxScene() {
  scene::SceneBuilder builder;
  builder.Add(MakeObject("box", scene::BoxShape{Vector3(0.05, 0.05, 0.05)}, {0, 0, -0.05}, MakeMaterial(kStiffness)));
  return builder.Build(1);
}

// The spring's answer at the input's depth, as a session's tick gives it.
force::TickOutput Spring(const Vector3& p_W) {
  force::TickOutput output;
  output.f_W = Vector3(0, 0, std::max(0.0, -p_W.z()) * kStiffness);
  output.f_unscaled_W = output.f_W;
  output.touched_object = p_W.z() < 0 ? 0 : -1;
  output.avatar_W = Vector3(p_W.x(), p_W.y(), std::max(0.0, p_W.z()));
  output.contact = p_W.z() < 0;
  return output;
}

DeadbandSettings Deadband(double weber, double keepalive_s) {
  DeadbandSettings settings;
  settings.weber = weber;
  settings.keepalive_s = keepalive_s;
  return settings;
}

TEST(RendererChannelTest, SilentTicksPredictWithinTheKeepaliveAndAPeriod) {
  RendererChannel channel(false, Deadband(0.1, 0.01));
  channel.Reset(Vector3::Zero());
  // nothing to predict on before the first state
  EXPECT_FALSE(channel.Predicts(5 * kPeriodNs, kPeriodNs));
  channel.ReceiveState(100 * kPeriodNs, Vector3(0, 0, 0.01), Vector3(0, 0, -0.1), 0);
  EXPECT_TRUE(channel.Predicts(101 * kPeriodNs, kPeriodNs));
  EXPECT_TRUE(channel.Predicts(111 * kPeriodNs, kPeriodNs));  // 10 ms and a period
  EXPECT_FALSE(channel.Predicts(111 * kPeriodNs + 1, kPeriodNs));
  // the last state moved on at its velocity
  EXPECT_NEAR(channel.Predict(105 * kPeriodNs).z(), 0.01 - 0.1 * 0.005, 1e-15);
  EXPECT_EQ(channel.state_v_W(), Vector3(0, 0, -0.1));
  // without a deadband a silent tick never predicts
  RendererChannel plain(false, DeadbandSettings{});
  plain.Reset(Vector3::Zero());
  plain.ReceiveState(0, Vector3::Zero(), Vector3::Zero(), 0);
  EXPECT_FALSE(plain.Predicts(kPeriodNs, kPeriodNs));
  // without a keep-alive (the simulator's channel) it predicts until the next state,
  // however long, and nothing overflows
  RendererChannel quiet(false, Deadband(0.1, std::numeric_limits<double>::infinity()));
  quiet.Reset(Vector3::Zero());
  quiet.ReceiveState(kPeriodNs, Vector3::Zero(), Vector3::Zero(), 0);
  EXPECT_TRUE(quiet.Predicts(int64_t{1} << 62, kPeriodNs));
}

TEST(RendererChannelTest, AnswersGoDownWhenFirstKeepaliveOldOrOutOfBand) {
  RendererChannel channel(false, Deadband(0.1, 0.01));
  channel.Reset(Vector3::Zero());
  EXPECT_TRUE(channel.AnswerDue(0, false));  // the first
  channel.RecordCommand(Vector3(0, 0, 2), 0);
  EXPECT_FALSE(channel.AnswerDue(5 * kPeriodNs, false));
  EXPECT_TRUE(channel.AnswerDue(10 * kPeriodNs, false));  // a keep-alive old
  EXPECT_TRUE(channel.AnswerDue(5 * kPeriodNs, true));
  // the band about the last force sent: 10% of 2 N plus the 0.02 N floor
  EXPECT_FALSE(channel.ForceOutOfBand(Vector3(0, 0, 2.21)));
  EXPECT_TRUE(channel.ForceOutOfBand(Vector3(0, 0, 2.23)));
  EXPECT_EQ(channel.f_sent_W(), Vector3(0, 0, 2));
  // no keep-alive: only the first and what leaves the band
  RendererChannel quiet(false, Deadband(0.1, std::numeric_limits<double>::infinity()));
  quiet.Reset(Vector3::Zero());
  quiet.RecordCommand(Vector3(0, 0, 2), 0);
  EXPECT_FALSE(quiet.AnswerDue(int64_t{1} << 62, false));
}

TEST(RendererChannelTest, TheInputStepsThroughThePortAndAStepRefusedIsTakenBack) {
  const auto scene = BoxScene();
  RendererChannel channel(true, DeadbandSettings{});
  channel.Reset(Vector3(0, 0, 0.002));
  force::DeviceInput input;
  // nothing came in: the input stops short of the surface, its velocity the step's
  Vector3 step = channel.StepInput(*scene, Vector3(0, 0, -0.001), 0, kDt, input);
  EXPECT_EQ(input.p_WD, channel.end().input_W());
  EXPECT_EQ(input.v_WD, step / kDt);
  EXPECT_GE(input.p_WD.z(), 0);
  EXPECT_NEAR(channel.drift_m(), input.p_WD.z() + 0.001, 1e-15);
  channel.ObserveTick(Spring(input.p_WD), step, false);
  EXPECT_LE(channel.end().energy().out, 0);
  // a step the session refused moved nothing
  channel.ReceiveState(0, Vector3(0, 0, -0.001), Vector3::Zero(), 1);
  const Vector3 before = channel.end().input_W();
  step = channel.StepInput(*scene, Vector3(0, 0, -0.001), 0, kDt, input);
  ASSERT_LT(step.z(), 0);
  channel.ObserveTick(Spring(before), step, true);
  EXPECT_EQ(channel.end().input_W(), before);
  EXPECT_EQ(channel.end().energy().out, 0);
  // a non-finite target goes to the session as it is, no step
  const Vector3 nan = Vector3::Constant(std::nan(""));
  EXPECT_EQ(channel.StepInput(*scene, nan, 0, kDt, input), Vector3::Zero());
  EXPECT_FALSE(input.p_WD.allFinite());
  EXPECT_EQ(channel.end().input_W(), before);
}

TEST(RendererChannelTest, ItsTicksAllocateNothing) {
  const auto scene = BoxScene();
  RendererChannel channel(true, Deadband(0.1, std::numeric_limits<double>::infinity()));
  channel.Reset(Vector3(0, 0, 0.002));
  force::DeviceInput input;
  const long before = hapticd::testing::AllocationCount();
  for (int k = 0; k < 200; ++k) {
    const int64_t now_ns = k * kPeriodNs;
    if (k % 7 == 0) channel.ReceiveState(now_ns, Vector3(0, 0, 0.002 - 2e-5 * k), Vector3(0, 0, -0.02), 1e-3 * k);
    if (!channel.Predicts(now_ns, kPeriodNs) && k % 7 != 0) continue;
    const Vector3 step = channel.StepInput(*scene, channel.Predict(now_ns), 0, kDt, input);
    const force::TickOutput output = Spring(input.p_WD);
    channel.ObserveTick(output, step, false);
    if (channel.AnswerDue(now_ns, channel.ForceOutOfBand(output.f_W))) channel.RecordCommand(output.f_W, now_ns);
  }
  EXPECT_EQ(hapticd::testing::AllocationCount() - before, 0);
}

}  // namespace
}  // namespace hapticd::remote
