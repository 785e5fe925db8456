#include "server/netem/impairment.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hapticd::netem {
namespace {

int64_t MillisToNanos(double ms) { return static_cast<int64_t>(std::llround(ms * 1e6)); }

}  // namespace

Impairment::Impairment(const ImpairmentSpec& spec, uint64_t seed) : spec_(spec), random_(seed) {}

double Impairment::Uniform01() { return static_cast<double>(random_() >> 11) * 0x1.0p-53; }

double Impairment::StandardNormal() {
  // Box-Muller, one of the pair; 1 - u keeps the logarithm finite
  const double u = 1.0 - Uniform01();
  const double v = Uniform01();
  return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * std::numbers::pi * v);
}

int64_t Impairment::DelayNs() {
  if (!spec_.delay_trace_ms.empty()) {
    const double ms = spec_.delay_trace_ms[trace_next_];
    trace_next_ = (trace_next_ + 1) % spec_.delay_trace_ms.size();
    return MillisToNanos(std::max(0.0, ms));
  }
  double ms = spec_.delay_ms;
  if (spec_.jitter_ms > 0) {
    if (spec_.jitter_distribution == JitterDistribution::kUniform) {
      ms += spec_.jitter_ms * (2.0 * Uniform01() - 1.0);
    } else {
      ms += spec_.jitter_ms * std::clamp(StandardNormal(), -4.0, 4.0);
    }
  }
  return MillisToNanos(std::max(0.0, ms));
}

Fate Impairment::Decide(int64_t arrival_ns, std::size_t bytes) {
  Fate fate;
  // every draw is made for every datagram, lost or not, so that one parameter's change
  // leaves the other draws' sequence alone
  const double loss_draw = Uniform01();
  bool lost;
  if (spec_.bursty) {
    lost = loss_draw < (bad_ ? spec_.burst.loss_bad : spec_.burst.loss_good);
    const double move = Uniform01();
    bad_ = bad_ ? !(move < spec_.burst.r) : move < spec_.burst.p;
  } else {
    lost = loss_draw < spec_.loss;
  }
  const int64_t delay = DelayNs();
  const bool reordered = Uniform01() < spec_.reorder;
  const bool duplicated = Uniform01() < spec_.duplicate;
  if (lost) return fate;
  fate.reordered = reordered;
  int64_t release = arrival_ns + (reordered ? 0 : delay);
  if (spec_.rate_bytes_per_s > 0) {
    release = std::max(release, last_release_ns_) +
              static_cast<int64_t>(std::llround(1e9 * static_cast<double>(bytes) / spec_.rate_bytes_per_s));
    last_release_ns_ = release;
  }
  fate.release_ns = release;
  fate.copies = duplicated ? 2 : 1;
  return fate;
}

uint64_t StreamSeed(uint64_t seed, int flow, int direction) {
  // SplitMix64's finalizer over the three: nearby seeds and flows give unrelated streams
  uint64_t z = seed + 0x9E3779B97F4A7C15ull * (2 * static_cast<uint64_t>(flow) + static_cast<uint64_t>(direction) + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace hapticd::netem
