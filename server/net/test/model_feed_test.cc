// The server's side of a local-model session over a real loopback socket: the feed cuts
// a model about the device's proxy, the realtime channel sends it in fragments with the
// commands until the device says it holds it, and a scene edit brings a newer one.
#include "server/net/model_feed.h"

#include <optional>

#include <gtest/gtest.h>

#include "server/net/model_codec.h"
#include "server/net/test/net_harness.h"

namespace hapticd::net {
namespace {

using testing::DeviceSocket;
using testing::Harness;

constexpr int kDeadlineMs = 5000;

v1::Request OpenRequest(v1::DeviceType type, v1::RemoteMode mode, double max_velocity = 0.5) {
  v1::Request request;
  v1::OpenSession* open = request.mutable_open_session();
  open->set_device_type(type);
  open->set_degrees_of_freedom(3);
  open->set_max_force(50);
  open->set_max_velocity(max_velocity);
  open->set_rate_hz(1000);
  open->set_remote_mode(mode);
  open->mutable_start()->set_z(0.08);  // 3 cm above the test box's top (z = 0.05)
  return request;
}

struct Session {
  uint32_t id = 0;
  SessionKey key{};
};

Session Open(Harness& harness, v1::RemoteMode mode, double max_velocity = 0.5) {
  const v1::Reply reply = harness.Call(OpenRequest(v1::DEVICE_TYPE_IMPEDANCE, mode, max_velocity));
  EXPECT_TRUE(reply.has_session_opened()) << reply.DebugString();
  Session session;
  session.id = reply.session_opened().session_id();
  std::copy(reply.session_opened().session_key().begin(), reply.session_opened().session_key().end(),
            session.key.begin());
  return session;
}

class ModelFeedTest : public ::testing::Test {
 protected:
  void SetUp() override { harness_.realtime.Start(); }

  // Sends a state holding model_version and returns the fragment its command carried
  // (count 0: none), copied into fragment_bytes_.
  std::optional<ModelFragmentView> Exchange(DeviceSocket& device, const Session& session, uint64_t model_version) {
    DeviceStateSample state;
    state.session_id = session.id;
    state.sequence = ++sequence_;
    state.p_WD = p_W_;
    state.avatar_W = avatar_W_;
    state.model_version = model_version;
    std::array<uint8_t, kMaxStateSize> buffer;
    device.SendRaw({buffer.data(), EncodeState(state, session.key, buffer)});
    for (;;) {
      const auto bytes = device.Receive(kDeadlineMs);
      if (!bytes) return std::nullopt;
      EXPECT_LE(bytes->size(), kMaxCommandSize);
      EXPECT_TRUE(CheckTag(*bytes, session.key));
      DeviceCommandSample command;
      EXPECT_EQ(ParseCommand(*bytes, command), DatagramError::kNone);
      if (command.sequence != state.sequence) continue;  // a watchdog command
      fragment_bytes_.assign(command.model.data.begin(), command.model.data.end());
      ModelFragmentView fragment = command.model;
      fragment.data = fragment_bytes_;
      return fragment;
    }
  }

  // Exchanges states until the assembler completes a model (at most 200 states).
  std::optional<remote::LocalModel> Gather(DeviceSocket& device, const Session& session, uint64_t held) {
    for (int i = 0; i < 200; ++i) {
      const auto fragment = Exchange(device, session, held);
      if (!fragment) return std::nullopt;
      if (fragment->count != 0 && assembler_.Offer(*fragment)) return DecodeLocalModel(assembler_.bytes());
    }
    return std::nullopt;
  }

  Harness harness_;
  ModelFeed feed_{harness_.sessions, harness_.publisher};
  ModelAssembler assembler_;
  std::vector<uint8_t> fragment_bytes_;
  uint64_t sequence_ = 0;
  Vector3 p_W_ = Vector3(0, 0, 0.08);       // where Exchange's states put the device
  Vector3 avatar_W_ = Vector3(0, 0, 0.08);  // and its own proxy
};

TEST_F(ModelFeedTest, ALocalModelSessionGetsTheSceneNearItInFragmentsUntilItHoldsIt) {
  const Session session = Open(harness_, v1::REMOTE_MODE_LOCAL_MODEL);
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  // before the feed's first pass: no model to send
  const auto before = Exchange(device, session, 0);
  ASSERT_TRUE(before);
  EXPECT_EQ(before->count, 0u);

  EXPECT_TRUE(feed_.Pass(MonotonicNowNs()));
  EXPECT_EQ(feed_.models_cut(), 1u);
  const auto model = Gather(device, session, 0);
  ASSERT_TRUE(model);
  EXPECT_EQ(model->version, 1u);
  EXPECT_EQ(model->center_W, Vector3(0, 0, 0.08));
  // 0.5 m/s over the first round trip's guess (0.2 s) and more: the box, 3 cm away, is
  // in it; the floor 1 m below is not
  EXPECT_GT(model->radius, 0.1);
  ASSERT_EQ(model->objects.size(), 1u);
  EXPECT_EQ(model->objects[0].name, "box");
  EXPECT_EQ(model->objects[0].material.stiffness, 1000);

  // held: no more fragments, and no new cut while nothing changed
  const auto held = Exchange(device, session, 1);
  ASSERT_TRUE(held);
  EXPECT_EQ(held->count, 0u);
  EXPECT_TRUE(feed_.Pass(MonotonicNowNs()));
  EXPECT_EQ(feed_.models_cut(), 1u);
  const SessionTelemetrySample telemetry =
      harness_.sessions.slot(harness_.sessions.FindById(session.id)).published.Read();
  EXPECT_EQ(telemetry.model_version, 1u);
  EXPECT_GE(telemetry.model_fragments_sent, 1u);
  EXPECT_EQ(telemetry.device_avatar_W, Vector3(0, 0, 0.08));
}

TEST_F(ModelFeedTest, ASceneEditBringsANewerModel) {
  const Session session = Open(harness_, v1::REMOTE_MODE_LOCAL_MODEL);
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  ASSERT_TRUE(Exchange(device, session, 0));
  feed_.Pass(MonotonicNowNs());
  ASSERT_TRUE(Gather(device, session, 0));
  ASSERT_TRUE(Exchange(device, session, 1));

  v1::Request add;
  v1::Object* ball = add.mutable_add_object()->mutable_object();
  ball->set_name("ball");
  ball->mutable_shape()->mutable_sphere()->set_radius(0.01);
  ball->mutable_pose()->mutable_position()->set_x(0.015);
  ball->mutable_pose()->mutable_position()->set_z(0.08);
  ball->mutable_material()->set_stiffness(700);
  ASSERT_FALSE(harness_.Call(add).has_error());
  feed_.Pass(MonotonicNowNs());
  EXPECT_EQ(feed_.models_cut(), 2u);
  const auto model = Gather(device, session, 1);
  ASSERT_TRUE(model);
  EXPECT_EQ(model->version, 2u);
  // the round trip is measured now (loopback: a few ms), so the ball is smaller: the
  // box 3 cm away is out of reach, the new ball 5 mm away in it
  EXPECT_LT(model->radius, 0.03);
  EXPECT_GE(model->radius, ModelFeed::kRadiusSlack * remote::kModelMarginM);
  ASSERT_EQ(model->objects.size(), 1u);
  EXPECT_EQ(model->objects[0].name, "ball");
}

// A device fast enough that its reach over the round trip passes the largest ball (1 m):
// a newer cut about the same point would be the same model, so none is cut while the
// hand rests (on a long round trip the feed used to send one per round trip), and one
// is as soon as the avatar has travelled.
TEST_F(ModelFeedTest, AReachPastTheLargestBallRecutsOnlyAsTheAvatarTravels) {
  const Session session = Open(harness_, v1::REMOTE_MODE_LOCAL_MODEL, 5);
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  // the device 0.5 mm past its proxy (pressing a surface), as the proxy reports
  p_W_ = Vector3(0, 0, 0.0795);
  ASSERT_TRUE(Exchange(device, session, 0));
  const int64_t t0 = MonotonicNowNs();
  feed_.Pass(t0);
  const auto model = Gather(device, session, 0);
  ASSERT_TRUE(model);
  EXPECT_EQ(model->radius, remote::kMaxModelRadiusM);  // 5 m/s x 0.2 s: capped
  // held, the round trip measured 0.3 s later (a long one): the hand has not moved
  ASSERT_TRUE(Exchange(device, session, 1));
  feed_.Pass(t0 + 300'000'000);
  feed_.Pass(t0 + 600'000'000);
  EXPECT_EQ(feed_.models_cut(), 1u);
  // the proxy 10 cm further: a ball about it covers more
  avatar_W_ = Vector3(0.1, 0, 0.08);
  p_W_ = avatar_W_;
  ASSERT_TRUE(Exchange(device, session, 1));
  feed_.Pass(t0 + 900'000'000);
  EXPECT_EQ(feed_.models_cut(), 2u);
}

TEST_F(ModelFeedTest, ADirectSessionGetsNoModel) {
  const Session session = Open(harness_, v1::REMOTE_MODE_DIRECT);
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  EXPECT_FALSE(feed_.Pass(MonotonicNowNs()));
  EXPECT_EQ(feed_.models_cut(), 0u);
  for (int i = 0; i < 5; ++i) {
    const auto fragment = Exchange(device, session, 0);
    ASSERT_TRUE(fragment);
    EXPECT_EQ(fragment->count, 0u);
  }
}

TEST_F(ModelFeedTest, AnAdmittanceDeviceCannotAskForALocalModel) {
  const v1::Reply reply = harness_.Call(OpenRequest(v1::DEVICE_TYPE_ADMITTANCE, v1::REMOTE_MODE_LOCAL_MODEL));
  ASSERT_TRUE(reply.has_error());
  EXPECT_EQ(reply.error().code(), v1::Error::CODE_BAD_REQUEST);
  EXPECT_NE(reply.error().message().find("open_session.remote_mode is local_model for an admittance device"),
            std::string::npos)
      << reply.error().message();
}

}  // namespace
}  // namespace hapticd::net
