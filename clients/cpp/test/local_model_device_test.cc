// The device end of a local-model session: fragments in, the model built on its own
// thread, the force rendered as the server would render it from the whole scene, bad
// models refused without losing the good one, and no allocation on the loop's side.
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

}  // namespace
}  // namespace hapticd::proxy
