// The histogram's quantiles against the sorted samples: never below the true value, at
// most 1/128 above it; exact below 128 ns and at the maximum.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "server/netem/delay_histogram.h"

namespace hapticd::netem {
namespace {

TEST(DelayHistogram, QuantilesAreWithinOneBucketAboveTheSortedSamples) {
  std::mt19937_64 random(1);
  std::lognormal_distribution<double> delay(std::log(2e6), 1.5);  // ns, a long tail
  DelayHistogram histogram;
  std::vector<int64_t> samples;
  for (int i = 0; i < 100'000; ++i) {
    const auto v = static_cast<int64_t>(delay(random));
    samples.push_back(v);
    histogram.Record(v);
  }
  std::sort(samples.begin(), samples.end());
  EXPECT_EQ(histogram.count(), 100'000);
  EXPECT_EQ(histogram.max(), samples.back());
  for (const double q : {0.001, 0.1, 0.5, 0.9, 0.99, 0.999, 0.9999}) {
    const int64_t want = samples[static_cast<size_t>(std::ceil(q * samples.size())) - 1];
    const int64_t got = histogram.Quantile(q);
    EXPECT_GE(got, want) << q;
    EXPECT_LE(static_cast<double>(got), static_cast<double>(want) * (1 + 1.0 / 128) + 1) << q;
  }
  EXPECT_EQ(histogram.Quantile(1), samples.back());
}

TEST(DelayHistogram, SmallValuesAreExactAndNegativeOnesCountAsZero) {
  DelayHistogram histogram;
  EXPECT_EQ(histogram.Quantile(0.5), 0);  // empty
  for (int v = 0; v < 128; ++v) histogram.Record(v);
  histogram.Record(-5);
  EXPECT_EQ(histogram.Quantile(0.5), 63);
  EXPECT_EQ(histogram.Quantile(1.0 / 129), 0);
  EXPECT_EQ(histogram.max(), 127);
}

TEST(DelayHistogram, HoldsTheWholeRange) {
  DelayHistogram histogram;
  histogram.Record(INT64_MAX);
  histogram.Record(1);
  EXPECT_EQ(histogram.Quantile(1), INT64_MAX);
  EXPECT_EQ(histogram.Quantile(0.5), 1);
}

}  // namespace
}  // namespace hapticd::netem
