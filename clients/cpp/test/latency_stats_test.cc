#include "clients/cpp/latency_stats.h"

#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace hapticd::proxy {
namespace {

// Percentiles of samples as numpy.percentile computes them (values from numpy 1.x).
TEST(LatencyStats, MatchesNumpyOnAHandBuiltSet) {
  const std::vector<int64_t> values = {907, 12, 55, 3, 3, 480, 71, 1000000, 64, 250, 18};
  LatencyStats stats(values.size());
  for (const int64_t v : values) stats.Record(v);
  const Percentiles p = stats.Summarize();
  EXPECT_EQ(p.count, values.size());
  EXPECT_DOUBLE_EQ(p.p50, 64.0);
  EXPECT_DOUBLE_EQ(p.p90, 907.0);
  EXPECT_NEAR(p.p99, 900090.7, 1e-6);
  EXPECT_NEAR(p.p999, 990009.07, 1e-6);
  EXPECT_EQ(p.max, 1000000.0);
}

TEST(LatencyStats, OneToHundred) {
  LatencyStats stats(100);
  // recorded in descending order: Summarize sorts
  for (int64_t v = 100; v >= 1; --v) stats.Record(v);
  const Percentiles p = stats.Summarize();
  EXPECT_DOUBLE_EQ(p.p50, 50.5);
  EXPECT_NEAR(p.p90, 90.1, 1e-9);
  EXPECT_NEAR(p.p99, 99.01, 1e-9);
  EXPECT_NEAR(p.p999, 99.901, 1e-9);
  EXPECT_EQ(p.max, 100.0);
}

// Against an oracle on a sorted copy: at q = i / (n - 1) the quantile is exactly the
// i-th smallest sample, halfway between two ranks it is their mean, and it never
// decreases with q.
TEST(LatencyStats, QuantileAgreesWithSortedOracle) {
  std::mt19937_64 random(7);
  std::uniform_int_distribution<int64_t> latency_ns(1, 5'000'000);
  for (int trial = 0; trial < 50; ++trial) {
    const std::size_t n = 2 + random() % 500;
    std::vector<int64_t> sorted(n);
    for (int64_t& v : sorted) v = latency_ns(random);
    std::sort(sorted.begin(), sorted.end());
    const double last = static_cast<double>(n - 1);
    for (std::size_t i = 0; i < n; ++i) {
      // q (n - 1) may round to just under i: then a hair short of the i-th sample
      EXPECT_NEAR(Quantile(sorted, static_cast<double>(i) / last), static_cast<double>(sorted[i]), 1e-6);
    }
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const double mid = (static_cast<double>(i) + 0.5) / last;
      EXPECT_NEAR(Quantile(sorted, mid), (sorted[i] + sorted[i + 1]) / 2.0, 1e-6);
    }
    double previous = -1;
    for (double q = 0; q <= 1; q += 0.001) {
      const double value = Quantile(sorted, q);
      EXPECT_GE(value, previous);
      previous = value;
    }
  }
}

TEST(LatencyStats, OneSampleIsEveryPercentile) {
  LatencyStats stats(4);
  stats.Record(42);
  const Percentiles p = stats.Summarize();
  EXPECT_EQ(p.count, 1u);
  EXPECT_EQ(p.p50, 42);
  EXPECT_EQ(p.p999, 42);
  EXPECT_EQ(p.max, 42);
}

TEST(LatencyStats, EmptyIsAllZero) {
  LatencyStats stats(4);
  const Percentiles p = stats.Summarize();
  EXPECT_EQ(p.count, 0u);
  EXPECT_EQ(p.p50, 0);
  EXPECT_EQ(p.max, 0);
}

// A full buffer keeps its first samples and counts the rest as dropped.
TEST(LatencyStats, FullBufferDropsAndCounts) {
  LatencyStats stats(3);
  for (int64_t v : {5, 1, 3, 100, 200}) stats.Record(v);
  EXPECT_EQ(stats.count(), 3u);
  EXPECT_EQ(stats.dropped(), 2u);
  EXPECT_EQ(stats.Summarize().max, 5);
  stats.Clear();
  EXPECT_EQ(stats.count(), 0u);
  EXPECT_EQ(stats.dropped(), 0u);
}

}  // namespace
}  // namespace hapticd::proxy
