// The device end of a local-model session: fragments in, the model built on its own
// thread, the force rendered as the server would render it from the whole scene, bad
// models refused without losing the good one, moving objects moved on by the builder,
// and no allocation on the loop's side.
#include "clients/cpp/local_model_device.h"

#include <algorithm>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "clients/cpp/tick_schedule.h"
#include "server/net/test/count_allocations.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::proxy {
namespace {

using scene::testing::MakeMaterial;
using scene::testing::MakeObject;

constexpr double kDt = 0.001;
constexpr double kStiffness = 5000;
// The god-object rests on the scene's tolerance above the face (1 um: 5 mN here).
constexpr double kSkinN = 1e-2;

// A box whose top face is z = top, and a sphere beside it.
std::shared_ptr<const scene::SceneSnapshot> BoxScene(double top, uint64_t version) {
  scene::SceneBuilder builder;
  builder.Add(MakeObject("box", scene::BoxShape{Vector3(0.05, 0.05, 0.05)}, {0, 0, top - 0.05},
                         MakeMaterial(kStiffness)));
  builder.Add(MakeObject("ball", scene::SphereShape{0.02}, {0.08, 0, top}, MakeMaterial(2000)));
  return builder.Build(version);
}

// Offers model's fragments to device, in an order shuffled by seed.
void OfferModel(LocalModelDevice& device, const remote::LocalModel& model, unsigned seed) {
  const std::string bytes = net::EncodeLocalModel(model);
  const std::span<const uint8_t> encoded(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  std::vector<uint32_t> order(net::FragmentCount(bytes.size()));
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  std::mt19937 random(seed);
  std::shuffle(order.begin(), order.end(), random);
  for (const uint32_t index : order) device.Offer(net::Fragment(encoded, model.version, index));
}

DeviceReading At(const Vector3& p_W) {
  DeviceReading reading;
  reading.p_W = p_W;
  return reading;
}

// Ticks at p_W until the device renders from version (up to 2 s of wall time: the
// builder is a thread); the last tick's output.
force::TickOutput TickUntilVersion(LocalModelDevice& device, const Vector3& p_W, uint64_t version) {
  force::TickOutput output;
  const int64_t give_up = MonotonicNowNs() + 2'000'000'000;
  do {
    output = device.Tick(At(p_W), Vector3::Zero(), kDt);
    SleepUntilNs(MonotonicNowNs() + 1'000'000);
  } while (device.model_version() < version && MonotonicNowNs() < give_up);
  EXPECT_EQ(device.model_version(), version);
  return output;
}

TEST(LocalModelDevice, RendersAsTheServerWouldFromTheWholeScene) {
  const auto scene = BoxScene(0.1, 4);
  const Vector3 start(0, 0, 0.12);
  const force::SessionSettings settings;  // god-object point, as the server's default
  LocalModelDevice device(settings, start, MonotonicNowNs());
  OfferModel(device, remote::CutLocalModel(*scene, start, 0.1, 1, 0), 3);
  TickUntilVersion(device, start, 1);

  // the server's own session on the whole scene, fed the same path: the same forces
  force::RenderSession server(settings);
  server.Reset(start);
  force::DeviceInput input;
  input.p_WD = start;
  server.Tick(*scene, input, kDt);
  for (int k = 0; k <= 300; ++k) {
    // down through the top face, then sideways along it towards the ball
    const Vector3 p = k < 150 ? Vector3(0, 0, 0.12 - 0.0002 * k) : Vector3(0.0002 * (k - 150), 0, 0.09);
    input.p_WD = p;
    const force::TickOutput expected = server.Tick(*scene, input, kDt);
    const force::TickOutput got = device.Tick(At(p), Vector3::Zero(), kDt);
    ASSERT_NEAR((got.f_W - expected.f_W).norm(), 0, 1e-12) << k;
    ASSERT_NEAR((got.avatar_W - expected.avatar_W).norm(), 0, 1e-12) << k;
    EXPECT_EQ(device.avatar_W(), got.avatar_W);
  }
  const LocalModelCounters counters = device.counters();
  EXPECT_EQ(counters.completed, 1u);
  EXPECT_EQ(counters.adopted, 1u);
  EXPECT_EQ(counters.rejected, 0u);
}

TEST(LocalModelDevice, AModelThatDoesNotDecodeIsRefusedAndTheLastGoodOneStays) {
  const Vector3 start(0, 0, 0.12);
  LocalModelDevice device(force::SessionSettings{}, start, MonotonicNowNs());
  OfferModel(device, remote::CutLocalModel(*BoxScene(0.1, 1), start, 0.1, 1, 0), 1);
  TickUntilVersion(device, start, 1);
  // version 2: whole, but not a model
  const std::array<uint8_t, 7> garbage{0xff, 0xff, 0xff, 0xff, 0x0f, 0x01, 0x02};
  device.Offer({2, 0, 1, garbage});
  const int64_t give_up = MonotonicNowNs() + 2'000'000'000;
  while (device.counters().rejected == 0 && MonotonicNowNs() < give_up) {
    device.Tick(At(start), Vector3::Zero(), kDt);
    SleepUntilNs(MonotonicNowNs() + 1'000'000);
  }
  EXPECT_EQ(device.counters().rejected, 1u);
  EXPECT_EQ(device.model_version(), 1u);
  // pressing 1 mm in: the box of model 1 pushes back k * d
  Vector3 p = start;
  force::TickOutput output;
  for (; p.z() > 0.099; p.z() -= 0.0005) output = device.Tick(At(p), Vector3::Zero(), kDt);
  output = device.Tick(At(Vector3(0, 0, 0.099)), Vector3::Zero(), kDt);
  EXPECT_NEAR(output.f_W.z(), kStiffness * 0.001, kSkinN);
}

TEST(LocalModelDevice, ANewerModelIsBlendedInAndAnOlderIgnored) {
  const Vector3 start(0, 0, 0.12);
  LocalModelDevice device(force::SessionSettings{}, start, MonotonicNowNs());
  OfferModel(device, remote::CutLocalModel(*BoxScene(0.1, 1), start, 0.1, 2, 0), 2);
  TickUntilVersion(device, start, 2);
  Vector3 p = start;
  for (; p.z() > 0.099; p.z() -= 0.0005) device.Tick(At(p), Vector3::Zero(), kDt);
  const Vector3 pressed(0, 0, 0.099);
  EXPECT_NEAR(device.Tick(At(pressed), Vector3::Zero(), kDt).f_W.z(), 5.0, kSkinN);
  // an older version is ignored whole
  OfferModel(device, remote::CutLocalModel(*BoxScene(0.2, 1), start, 0.1, 1, 0), 5);
  // the box corrected 1 mm up: the force moves from 5 N to 10 N over kModelBlendS
  OfferModel(device, remote::CutLocalModel(*BoxScene(0.101, 2), start, 0.1, 3, 0), 4);
  const force::TickOutput first = TickUntilVersion(device, pressed, 3);
  EXPECT_LT(first.f_W.z(), 10.0);
  force::TickOutput output;
  for (int k = 0; k < 10; ++k) output = device.Tick(At(pressed), Vector3::Zero(), kDt);
  EXPECT_NEAR(output.f_W.z(), 10.0, kSkinN);
  EXPECT_EQ(device.counters().blends, 1u);
  EXPECT_EQ(device.counters().adopted, 2u);
}

TEST(LocalModelDevice, ATickAndAFragmentAllocateNothing) {
  const Vector3 start(0, 0, 0.12);
  LocalModelDevice device(force::SessionSettings{}, start, MonotonicNowNs());
  const remote::LocalModel model = remote::CutLocalModel(*BoxScene(0.1, 1), start, 0.1, 1, 0);
  OfferModel(device, model, 6);
  TickUntilVersion(device, start, 1);
  // the builder is idle now: whatever allocates is the loop's side
  const std::string bytes = net::EncodeLocalModel(model);
  const std::span<const uint8_t> encoded(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  const net::ModelFragmentView duplicate = net::Fragment(encoded, 1, 0);
  const long before = hapticd::testing::AllocationCount();
  Vector3 p = start;
  for (int k = 0; k < 100; ++k, p.z() -= 0.0003) {
    device.Offer(duplicate);
    device.Tick(At(p), Vector3::Zero(), kDt);
  }
  EXPECT_EQ(hapticd::testing::AllocationCount(), before);
}

// A plate rising at a known velocity under a held handle, the loop ticking at its 1 kHz
// (1 ms sleeps) while the builder thread moves the plate on: after the model is adopted,
// the loop's thread allocates and frees nothing; each tick renders the plate where its
// velocity puts it at the scene's time (the force is k times the depth of the top, to
// the 1 um skin); that time is never more than half a period ahead of the tick and
// follows it (a plate that did not move would fall 0.3 s behind).
TEST(LocalModelDevice, AMovingPlateMovesOnWithoutTheLoopAllocating) {
  constexpr double kRise = 0.01;  // m/s
  constexpr double kPlateStiffness = 1000;
  constexpr double kHalfPeriodS = 0.0005;  // of the session's 1 kHz
  scene::SceneBuilder builder;
  scene::ObjectSpec plate = MakeObject("plate", scene::BoxShape{Vector3(0.05, 0.05, 0.005)}, {0, 0, -0.005},
                                       MakeMaterial(kPlateStiffness));
  plate.motion = scene::Motion::kKinematic;
  plate.v_WB = Vector3(0, 0, kRise);  // its top at kRise t (session time t)
  builder.Add(plate);
  const Vector3 p(0, 0, 0.0002);  // the top reaches it at 20 ms
  const int64_t session_start_ns = MonotonicNowNs();
  const auto session_s = [&] { return static_cast<double>(MonotonicNowNs() - session_start_ns) * 1e-9; };
  LocalModelDevice device(force::SessionSettings{}, p, session_start_ns);
  OfferModel(device, remote::CutLocalModel(*builder.Build(1), Vector3::Zero(), 0.2, 1, 0), 8);
  TickUntilVersion(device, p, 1);
  for (int k = 0; k < 20; ++k) {
    device.Tick(At(p), Vector3::Zero(), kDt);
    SleepUntilNs(MonotonicNowNs() + 1'000'000);
  }

  constexpr int kTicks = 300;
  std::vector<double> f_z(kTicks), scene_t(kTicks), tick_start(kTicks), tick_end(kTicks);
  const long allocated_before = hapticd::testing::ThreadAllocationCount();
  const long freed_before = hapticd::testing::ThreadFreeCount();
  for (int k = 0; k < kTicks; ++k) {
    tick_start[k] = session_s();
    f_z[k] = device.Tick(At(p), Vector3::Zero(), kDt).f_W.z();
    tick_end[k] = session_s();
    scene_t[k] = device.scene_t_s();
    SleepUntilNs(MonotonicNowNs() + 1'000'000);
  }
  EXPECT_EQ(hapticd::testing::ThreadAllocationCount() - allocated_before, 0);
  EXPECT_EQ(hapticd::testing::ThreadFreeCount() - freed_before, 0);

  std::vector<double> lags;
  for (int k = 0; k < kTicks; ++k) {
    const double depth = kRise * scene_t[k] - p.z();
    // in contact, below the 10 N the force is saturated to
    if (depth > 1e-5 && kPlateStiffness * depth < 9) {
      EXPECT_NEAR(f_z[k], kPlateStiffness * depth, kPlateStiffness * 2e-6) << k;
    }
    EXPECT_LE(scene_t[k], tick_end[k] + kHalfPeriodS + 1e-9) << k;
    lags.push_back(tick_start[k] - scene_t[k]);
  }
  EXPECT_GT(f_z.back(), 1.0);  // 1 mm into the plate at least (0.3 s)
  std::sort(lags.begin(), lags.end());
  // a bound for a loaded machine (the lag is P/2 plus the builder's lateness, tens of
  // microseconds when idle)
  EXPECT_LT(lags.back(), 0.1) << "median " << lags[kTicks / 2];
  const LocalModelCounters counters = device.counters();
  EXPECT_GT(counters.moved, 0u);
  EXPECT_EQ(counters.version, 1u);
  EXPECT_EQ(counters.adopted, 1u);
  EXPECT_EQ(counters.blends, 0u);
}

}  // namespace
}  // namespace hapticd::proxy
