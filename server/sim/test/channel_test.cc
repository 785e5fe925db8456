#include "server/sim/channel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace hapticd::sim {
namespace {

ChannelSpec Spec(double delay_s, double jitter_s, double loss, uint64_t seed = 1) {
  ChannelSpec spec;
  spec.delay_s = delay_s;
  spec.jitter_s = jitter_s;
  spec.loss = loss;
  spec.seed = seed;
  return spec;
}

// Sends the tick number every tick for ticks ticks (then runs on until everything has
// arrived); returns, per receiving tick, the message taken (-1 for none).
std::vector<int64_t> SendEveryTick(Channel<int64_t>& channel, int64_t ticks, int64_t drain = 1000) {
  std::vector<int64_t> taken;
  for (int64_t k = 0; k < ticks + drain; ++k) {
    if (k < ticks) channel.Send(k, k);
    const std::optional<int64_t> message = channel.Receive(k);
    taken.push_back(message.value_or(-1));
  }
  return taken;
}

TEST(Channel, ZeroDelayDeliversInTheSameTick) {
  Channel<int64_t> channel(Spec(0, 0, 0), 1000, 0);
  const std::vector<int64_t> taken = SendEveryTick(channel, 100, 0);
  for (int64_t k = 0; k < 100; ++k) EXPECT_EQ(taken[k], k);
  EXPECT_EQ(channel.lost(), 0u);
}

TEST(Channel, DelayIsExactInTicks) {
  // 5 ms at 1 kHz is 5 ticks; 2.5 ms rounds up to the next tick, 3; 7 ms at 500 Hz is 3.5 -> 4
  struct Case {
    double delay_s;
    double rate_hz;
    int64_t ticks;
  };
  for (const Case& c : {Case{0.005, 1000, 5}, Case{0.0025, 1000, 3}, Case{0.007, 500, 4}, Case{0.001, 1000, 1},
                        Case{0.003, 1000, 3}, Case{0.1, 1000, 100}}) {
    Channel<int64_t> channel(Spec(c.delay_s, 0, 0), c.rate_hz, 0);
    const std::vector<int64_t> taken = SendEveryTick(channel, 200);
    for (int64_t k = 0; k < c.ticks; ++k) EXPECT_EQ(taken[k], -1) << c.delay_s << " s, tick " << k;
    for (int64_t k = c.ticks; k < 200 + c.ticks; ++k) {
      EXPECT_EQ(taken[k], k - c.ticks) << c.delay_s << " s at " << c.rate_hz << " Hz, tick " << k;
    }
    EXPECT_EQ(taken[200 + c.ticks], -1);
  }
}

TEST(Channel, AnAstronomicalDelayNeverDelivers) {
  Channel<int64_t> channel(Spec(1e300, 1e300, 0), 1000, 0);
  for (int64_t message : SendEveryTick(channel, 100)) EXPECT_EQ(message, -1);
  EXPECT_EQ(channel.lost(), 0u);
  // past the horizon nothing arrives either: 3 ticks of delay, horizon at tick 10
  Channel<int64_t> short_run(Spec(0.003, 0, 0), 1000, 0, 10);
  const std::vector<int64_t> taken = SendEveryTick(short_run, 10, 5);
  EXPECT_EQ(taken[9], 6);
  for (int64_t k = 10; k < 15; ++k) EXPECT_EQ(taken[k], -1);
}

TEST(Channel, LossFractionIsWithinBinomialBounds) {
  constexpr int64_t kMessages = 100'000;
  for (const double loss : {0.01, 0.1, 0.5}) {
    for (const uint64_t seed : {1u, 2u, 99u}) {
      Channel<int64_t> channel(Spec(0, 0, loss, seed), 1000, 0);
      const std::vector<int64_t> taken = SendEveryTick(channel, kMessages, 0);
      int64_t received = 0;
      for (int64_t message : taken) received += message >= 0 ? 1 : 0;
      // a zero-delay channel delivers every message that is not lost, in its tick
      EXPECT_EQ(received + static_cast<int64_t>(channel.lost()), kMessages);
      const double mean = kMessages * loss;
      const double sigma = std::sqrt(kMessages * loss * (1 - loss));
      EXPECT_NEAR(static_cast<double>(channel.lost()), mean, 5 * sigma) << "loss " << loss << " seed " << seed;
    }
  }
  // the extremes are exact
  Channel<int64_t> none(Spec(0, 0, 0), 1000, 0);
  SendEveryTick(none, 1000, 0);
  EXPECT_EQ(none.lost(), 0u);
  Channel<int64_t> all(Spec(0, 0, 1), 1000, 0);
  const std::vector<int64_t> taken = SendEveryTick(all, 1000, 0);
  EXPECT_EQ(all.lost(), 1000u);
  for (int64_t message : taken) EXPECT_EQ(message, -1);
}

TEST(Channel, JitterStaysInItsRangeAndOldMessagesAreDropped) {
  // delay 2 ms, jitter up to 5 ms: latency 2..7 ticks, and messages overtake each other
  Channel<int64_t> channel(Spec(0.002, 0.005, 0), 1000, 0);
  const std::vector<int64_t> taken = SendEveryTick(channel, 10'000, 10);
  int64_t last = -1;
  std::vector<int> latency_count(8, 0);
  for (int64_t k = 0; k < static_cast<int64_t>(taken.size()); ++k) {
    if (taken[k] < 0) continue;
    // newest first: what the receiver takes only ever increases
    EXPECT_GT(taken[k], last);
    last = taken[k];
    const int64_t latency = k - taken[k];
    ASSERT_GE(latency, 2);
    ASSERT_LE(latency, 7);
    ++latency_count[latency];
  }
  // 3..6 ticks each hold a fifth of the jitter range: each must show up
  for (int latency = 3; latency <= 6; ++latency) EXPECT_GT(latency_count[latency], 0) << latency;
  // out of order arrivals happened and were counted as stale or superseded, not lost
  EXPECT_GT(channel.stale() + channel.superseded(), 0u);
  EXPECT_EQ(channel.lost(), 0u);
  EXPECT_EQ(last, 9'999);
}

TEST(Channel, SameSeedSameDeliveriesOtherSeedOrStreamOthers) {
  auto deliveries = [](uint64_t seed, uint32_t stream) {
    Channel<int64_t> channel(Spec(0.001, 0.004, 0.2, seed), 1000, stream);
    return SendEveryTick(channel, 2000);
  };
  EXPECT_EQ(deliveries(7, 0), deliveries(7, 0));
  EXPECT_NE(deliveries(7, 0), deliveries(8, 0));
  EXPECT_NE(deliveries(7, 0), deliveries(7, 1));
  // seeds that differ only in their high 32 bits differ too
  EXPECT_NE(deliveries(7, 0), deliveries(7 + (uint64_t{1} << 32), 0));
}

}  // namespace
}  // namespace hapticd::sim
