// The impairment model against what was asked, on many datagrams with fixed seeds: the
// delay and its jitter bounds and moments, independent and bursty loss (rate and burst
// lengths against the chain's own formulas), reordering, duplication, the rate cap, a
// delay trace, and the same fates from the same seed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "server/netem/impairment.h"

namespace hapticd::netem {
namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int kCount = 200'000;

// Datagrams 1 ms apart, 100 bytes each; their fates.
std::vector<Fate> Fates(const ImpairmentSpec& spec, uint64_t seed, int count = kCount) {
  Impairment impairment(spec, seed);
  std::vector<Fate> fates;
  for (int i = 0; i < count; ++i) fates.push_back(impairment.Decide(i * kMs, 100));
  return fates;
}

// A binomial count's bound: 5 standard deviations.
double Slack(double p, int n) { return 5 * std::sqrt(p * (1 - p) * n) + 1; }

TEST(Impairment, NoneRelaysEveryDatagramAtOnce) {
  const auto fates = Fates({}, 1, 1000);
  for (int i = 0; i < 1000; ++i) {
    EXPECT_EQ(fates[i].copies, 1);
    EXPECT_EQ(fates[i].release_ns, i * kMs);
  }
}

TEST(Impairment, UniformJitterStaysWithinItsBoundsWithItsMoments) {
  ImpairmentSpec spec;
  spec.delay_ms = 20;
  spec.jitter_ms = 5;
  const auto fates = Fates(spec, 2);
  double sum = 0, sum2 = 0;
  for (int i = 0; i < kCount; ++i) {
    const double d = static_cast<double>(fates[i].release_ns - i * kMs) / kMs;
    ASSERT_GE(d, 15.0);
    ASSERT_LE(d, 25.0);
    sum += d, sum2 += d * d;
  }
  const double mean = sum / kCount, variance = sum2 / kCount - mean * mean;
  EXPECT_NEAR(mean, 20, 0.03);
  EXPECT_NEAR(variance, 25.0 / 3, 0.1);  // (2 J)^2 / 12
}

TEST(Impairment, NormalJitterHasItsDeviationAndIsCutAtFourOfThem) {
  ImpairmentSpec spec;
  spec.delay_ms = 50;
  spec.jitter_ms = 4;
  spec.jitter_distribution = JitterDistribution::kNormal;
  const auto fates = Fates(spec, 3);
  double sum = 0, sum2 = 0;
  int within_one = 0;
  for (int i = 0; i < kCount; ++i) {
    const double d = static_cast<double>(fates[i].release_ns - i * kMs) / kMs;
    ASSERT_GE(d, 50 - 16.0);
    ASSERT_LE(d, 50 + 16.0);
    sum += d, sum2 += d * d;
    within_one += std::abs(d - 50) <= 4;
  }
  const double mean = sum / kCount;
  EXPECT_NEAR(mean, 50, 0.05);
  EXPECT_NEAR(std::sqrt(sum2 / kCount - mean * mean), 4, 0.05);
  EXPECT_NEAR(within_one, 0.6827 * kCount, Slack(0.6827, kCount));
}

TEST(Impairment, DelayNeverGoesBelowZero) {
  ImpairmentSpec spec;
  spec.delay_ms = 1;
  spec.jitter_ms = 10;
  const auto fates = Fates(spec, 4, 20'000);
  int at_zero = 0;
  for (int i = 0; i < 20'000; ++i) {
    ASSERT_GE(fates[i].release_ns, i * kMs);
    at_zero += fates[i].release_ns == i * kMs;
  }
  EXPECT_NEAR(at_zero, 0.45 * 20'000, Slack(0.45, 20'000));  // P(1 + U(-10, 10) <= 0)
}

TEST(Impairment, IndependentLossHasItsRate) {
  ImpairmentSpec spec;
  spec.loss = 0.1;
  const auto fates = Fates(spec, 5);
  const auto lost = std::count_if(fates.begin(), fates.end(), [](const Fate& f) { return f.copies == 0; });
  EXPECT_NEAR(lost, 0.1 * kCount, Slack(0.1, kCount));
}

// The chain's stationary loss and its mean burst length (bad-state runs, each datagram in
// the bad state lost): pi_bad = p / (p + r), runs of mean 1 / r.
TEST(Impairment, GilbertElliottLossHasItsRateAndBurstLength) {
  ImpairmentSpec spec;
  spec.bursty = true;
  spec.burst = {.p = 0.02, .r = 0.25, .loss_good = 0.0, .loss_bad = 1.0};
  const auto fates = Fates(spec, 6);
  int lost = 0, runs = 0;
  for (int i = 0; i < kCount; ++i) {
    const bool l = fates[i].copies == 0;
    lost += l;
    runs += l && (i == 0 || fates[i - 1].copies != 0);
  }
  const double pi_bad = 0.02 / 0.27;
  EXPECT_NEAR(lost, pi_bad * kCount, 0.05 * pi_bad * kCount);
  EXPECT_NEAR(static_cast<double>(lost) / runs, 1 / 0.25, 0.15);
  // independent loss of the same rate would make runs of 1 / (1 - pi_bad), about 1.08
}

TEST(Impairment, ReorderingSkipsTheDelayForItsShare) {
  ImpairmentSpec spec;
  spec.delay_ms = 10;
  spec.reorder = 0.25;
  const auto fates = Fates(spec, 7);
  int reordered = 0;
  for (int i = 0; i < kCount; ++i) {
    const int64_t delay = fates[i].release_ns - i * kMs;
    ASSERT_TRUE(delay == 0 || delay == 10 * kMs);
    ASSERT_EQ(fates[i].reordered, delay == 0);
    reordered += fates[i].reordered;
  }
  EXPECT_NEAR(reordered, 0.25 * kCount, Slack(0.25, kCount));
}

TEST(Impairment, DuplicationSendsASecondCopyForItsShare) {
  ImpairmentSpec spec;
  spec.duplicate = 0.05;
  const auto fates = Fates(spec, 8);
  const auto twice = std::count_if(fates.begin(), fates.end(), [](const Fate& f) { return f.copies == 2; });
  EXPECT_NEAR(twice, 0.05 * kCount, Slack(0.05, kCount));
}

TEST(Impairment, ARateCapSpacesTheDatagramsAndKeepsTheirOrder) {
  ImpairmentSpec spec;
  spec.delay_ms = 5;
  spec.jitter_ms = 4;
  spec.rate_bytes_per_s = 50'000;  // 100 bytes: 2 ms each, twice the arrival spacing
  Impairment impairment(spec, 9);
  int64_t last = INT64_MIN;
  for (int i = 0; i < 1000; ++i) {
    const Fate fate = impairment.Decide(i * kMs, 100);
    if (i > 0) {
      EXPECT_GE(fate.release_ns - last, 2 * kMs) << i;
    }
    last = fate.release_ns;
  }
  // the queue builds: the last leaves about 2 s after the first arrival
  EXPECT_NEAR(static_cast<double>(last) / kMs, 2000, 10);
}

TEST(Impairment, ADelayTraceIsReplayedInOrderAndCycled) {
  ImpairmentSpec spec;
  spec.delay_ms = 99;  // replaced
  spec.jitter_ms = 50;
  spec.delay_trace_ms = {3, 0, 12.5};
  const auto fates = Fates(spec, 10, 7);
  const double want[] = {3, 0, 12.5, 3, 0, 12.5, 3};
  for (int i = 0; i < 7; ++i) EXPECT_EQ(fates[i].release_ns - i * kMs, static_cast<int64_t>(want[i] * kMs)) << i;
}

TEST(Impairment, TheSameSeedGivesTheSameFatesAndAnotherSeedOthers) {
  ImpairmentSpec spec;
  spec.delay_ms = 20;
  spec.jitter_ms = 10;
  spec.loss = 0.1;
  spec.duplicate = 0.1;
  spec.reorder = 0.1;
  const auto a = Fates(spec, 11, 10'000), b = Fates(spec, 11, 10'000), c = Fates(spec, 12, 10'000);
  int differ = 0;
  for (int i = 0; i < 10'000; ++i) {
    ASSERT_EQ(a[i].copies, b[i].copies);
    ASSERT_EQ(a[i].release_ns, b[i].release_ns);
    differ += a[i].release_ns != c[i].release_ns || a[i].copies != c[i].copies;
  }
  EXPECT_GT(differ, 9000);
}

TEST(Impairment, StreamsOfFlowsAndDirectionsDiffer) {
  EXPECT_NE(StreamSeed(1, 0, 0), StreamSeed(1, 0, 1));
  EXPECT_NE(StreamSeed(1, 0, 1), StreamSeed(1, 1, 0));
  EXPECT_NE(StreamSeed(1, 0, 0), StreamSeed(2, 0, 0));
  EXPECT_EQ(StreamSeed(7, 3, 1), StreamSeed(7, 3, 1));
}

}  // namespace
}  // namespace hapticd::netem
