#pragma once

// Percentiles of delays without keeping the samples and without dropping the tail: a
// log-linear histogram (HdrHistogram's layout with 7 bits of sub-buckets). Values below
// 128 ns are counted exactly; above, each bucket spans under 1/128 of its values, so a
// percentile read back is at most 0.8% above the true one. The largest value is kept
// exactly. Fixed memory (64 KB), no allocation after construction.

#include <array>
#include <cstdint>

namespace hapticd::netem {

class DelayHistogram {
 public:
  // Counts one value (ns; negative counts as 0).
  void Record(int64_t ns);

  int64_t count() const { return count_; }
  int64_t max() const { return max_; }
  // The q-quantile (q in [0, 1]): the upper end of the bucket holding the value of rank
  // ceil(q count) (the largest value for q = 1); 0 when empty.
  int64_t Quantile(double q) const;

 private:
  static constexpr int kSubBits = 7;
  static constexpr int kSub = 1 << kSubBits;
  static int IndexOf(uint64_t v);
  static uint64_t UpperEndOf(int index);

  std::array<int64_t, 64 * kSub> counts_{};
  int64_t count_ = 0;
  int64_t max_ = 0;
};

}  // namespace hapticd::netem
