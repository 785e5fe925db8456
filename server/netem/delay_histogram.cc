#include "server/netem/delay_histogram.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace hapticd::netem {

// Values below kSub: their own bucket. Above: bucket (e - kSubBits + 1) * kSub + the
// kSubBits bits below the leading one, where e is the leading one's position.
int DelayHistogram::IndexOf(uint64_t v) {
  if (v < kSub) return static_cast<int>(v);
  const int e = 63 - std::countl_zero(v);
  const int shift = e - kSubBits;
  return (shift + 1) * kSub + static_cast<int>((v >> shift) & (kSub - 1));
}

uint64_t DelayHistogram::UpperEndOf(int index) {
  if (index < kSub) return static_cast<uint64_t>(index);
  const int shift = index / kSub - 1;
  const uint64_t mantissa = static_cast<uint64_t>(kSub + index % kSub);
  return ((mantissa + 1) << shift) - 1;
}

void DelayHistogram::Record(int64_t ns) {
  const uint64_t v = ns > 0 ? static_cast<uint64_t>(ns) : 0;
  ++counts_[IndexOf(v)];
  ++count_;
  max_ = std::max<int64_t>(max_, static_cast<int64_t>(v));
}

int64_t DelayHistogram::Quantile(double q) const {
  if (count_ == 0) return 0;
  if (q >= 1) return max_;
  const int64_t rank = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(q * static_cast<double>(count_))));
  int64_t seen = 0;
  for (int i = 0; i < static_cast<int>(counts_.size()); ++i) {
    seen += counts_[i];
    if (seen >= rank) return std::min<int64_t>(static_cast<int64_t>(UpperEndOf(i)), max_);
  }
  return max_;
}

}  // namespace hapticd::netem
