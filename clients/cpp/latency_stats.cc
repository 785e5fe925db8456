#include "clients/cpp/latency_stats.h"

#include <algorithm>
#include <cmath>

namespace hapticd::proxy {

double Quantile(std::span<const int64_t> sorted, double q) {
  // position q (n - 1) between ranks lower and lower + 1
  const double position = q * static_cast<double>(sorted.size() - 1);
  const std::size_t lower = static_cast<std::size_t>(std::floor(position));
  // q = 1 (or rounding just under it) lands on the last sample
  if (lower + 1 >= sorted.size()) return static_cast<double>(sorted.back());
  const double fraction = position - static_cast<double>(lower);
  const double a = static_cast<double>(sorted[lower]);
  const double b = static_cast<double>(sorted[lower + 1]);
  return a + fraction * (b - a);
}

LatencyStats::LatencyStats(std::size_t capacity) : samples_(capacity) {}

Percentiles LatencyStats::Summarize() {
  Percentiles result;
  if (count_ == 0) return result;
  const auto recorded = std::span<int64_t>(samples_.data(), count_);
  std::sort(recorded.begin(), recorded.end());
  result.count = count_;
  result.p50 = Quantile(recorded, 0.50);
  result.p90 = Quantile(recorded, 0.90);
  result.p99 = Quantile(recorded, 0.99);
  result.p999 = Quantile(recorded, 0.999);
  result.max = static_cast<double>(recorded.back());
  return result;
}

}  // namespace hapticd::proxy
