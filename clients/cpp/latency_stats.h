#pragma once
// Percentiles of latencies recorded in a real-time loop.
//
// The samples go into a buffer allocated once, at construction, for the whole run:
// Record is a store and an increment, so the loop never allocates. A full buffer drops
// further samples and counts them (size the buffer for the run: ticks x sessions).
// Summarize sorts the buffer in place, after the loop.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace hapticd::proxy {

// Order statistics of a set of samples, in the samples' unit (ns for the loop's).
// All zero when there are no samples.
struct Percentiles {
  std::size_t count = 0;
  double p50 = 0;
  double p90 = 0;
  double p99 = 0;
  double p999 = 0;
  double max = 0;
};

// The q-quantile (q in [0, 1]) of sorted (ascending, non-empty) samples, interpolated
// linearly between the two nearest ranks: the value at position q * (n - 1), as numpy's
// default percentile computes it.
double Quantile(std::span<const int64_t> sorted, double q);

class LatencyStats {
 public:
  // Room for capacity samples.
  explicit LatencyStats(std::size_t capacity);

  // Adds one sample; counts it as dropped when the buffer is full. Real-time safe.
  void Record(int64_t value) {
    if (count_ < samples_.size()) {
      samples_[count_++] = value;
    } else {
      ++dropped_;
    }
  }

  std::size_t count() const { return count_; }
  std::size_t dropped() const { return dropped_; }
  std::span<const int64_t> samples() const { return {samples_.data(), count_}; }

  // The percentiles of the samples recorded so far (sorts them; not real-time).
  Percentiles Summarize();

  // Forgets every sample, keeping the buffer.
  void Clear() {
    count_ = 0;
    dropped_ = 0;
  }

 private:
  std::vector<int64_t> samples_;
  std::size_t count_ = 0;
  std::size_t dropped_ = 0;
};

}  // namespace hapticd::proxy
