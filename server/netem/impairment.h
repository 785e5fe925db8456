#pragma once

// What the impairment relay (hapticd-netem) does to each datagram of one direction of one
// flow: netem's model, in user space (this machine's kernel has no netem qdisc).
//
// Theory of operation. Decide(arrival, bytes) draws the datagram's fate from the
// direction's own seeded stream, in this order:
//   1. loss: independent with probability `loss`, or a Gilbert-Elliott chain (a good and
//      a bad state, each with its own loss probability; the state moves once a datagram);
//   2. delay: `delay` plus jitter (uniform in [-jitter, +jitter], or normal with standard
//      deviation `jitter` cut at 4 of them), never below zero; or, with a delay trace,
//      the trace's next one-way delay (cycled), which replaces delay and jitter;
//   3. reordering: with probability `reorder` the datagram skips the delay (netem's
//      reorder: sent at once, so it overtakes the ones held back);
//   4. rate: with a cap, the datagram leaves no earlier than the one before it has been
//      sent at that rate (bytes / rate after it), as netem's rate does: a rate keeps
//      the order;
//   5. duplication: with probability `duplicate` a second copy leaves with the first.
// Jitter reorders datagrams whose release times cross, as netem's time-sorted queue
// does. The same seed and the same sequence of datagrams give the same fates: the
// stream is std::mt19937_64 (fixed by the standard) and the draws are made here from its
// bits, not by the library's distributions (whose algorithms are not).

#include <cstdint>
#include <random>
#include <vector>

namespace hapticd::netem {

enum class JitterDistribution { kUniform, kNormal };

// Gilbert-Elliott loss (netem's "loss gemodel p r 1-h 1-k"): p = P(good -> bad), r =
// P(bad -> good) per datagram; a datagram is lost with loss_good in the good state and
// loss_bad in the bad one. Mean burst (bad-state run) length 1 / r.
struct GilbertElliott {
  double p = 0;
  double r = 1;
  double loss_good = 0;
  double loss_bad = 1;
};

// One direction's impairment. Times in milliseconds, probabilities in [0, 1].
struct ImpairmentSpec {
  double delay_ms = 0;
  double jitter_ms = 0;
  JitterDistribution jitter_distribution = JitterDistribution::kUniform;
  double loss = 0;                  // independent loss (ignored with a burst model)
  bool bursty = false;              // Gilbert-Elliott instead of independent loss
  GilbertElliott burst;
  double reorder = 0;
  double duplicate = 0;
  double rate_bytes_per_s = 0;      // 0: no cap
  std::vector<double> delay_trace_ms;  // non-empty: per-datagram delays, cycled
};

// The fate of one datagram: how many copies leave (0: lost), and when (ns, on the clock
// of the arrival time given).
struct Fate {
  int copies = 0;
  int64_t release_ns = 0;
  bool reordered = false;  // skipped the delay
};

class Impairment {
 public:
  Impairment(const ImpairmentSpec& spec, uint64_t seed);

  // The fate of the next datagram, of bytes bytes, arrived at arrival_ns.
  Fate Decide(int64_t arrival_ns, std::size_t bytes);

  // Whether the Gilbert-Elliott chain is in its bad state (for tests).
  bool in_bad_state() const { return bad_; }

 private:
  double Uniform01();  // [0, 1), 53 bits
  double StandardNormal();
  int64_t DelayNs();

  ImpairmentSpec spec_;
  std::mt19937_64 random_;
  bool bad_ = false;
  std::size_t trace_next_ = 0;
  int64_t last_release_ns_ = INT64_MIN;  // for the rate cap
};

// The stream of one direction of one flow: flows numbered in order of arrival, direction
// 0 (device to server) or 1 (server to device), from the relay's seed.
uint64_t StreamSeed(uint64_t seed, int flow, int direction);

}  // namespace hapticd::netem
