#include "server/sim/channel.h"

#include <algorithm>

namespace hapticd::sim {
namespace {

// Slack, in ticks, for delays that are a whole number of ticks up to rounding
// (0.005 s * 1000 Hz = 5.000000000000001).
constexpr double kTickSlack = 1e-9;
// Latencies are capped here, so that tick + latency cannot overflow.
constexpr double kMaxLatencyTicks = 1e15;

}  // namespace

DeliveryDrawer::DeliveryDrawer(const ChannelSpec& channel, double rate_hz, uint32_t stream)
    : channel_(channel), rate_hz_(rate_hz) {
  std::seed_seq seeds{static_cast<uint32_t>(channel.seed), static_cast<uint32_t>(channel.seed >> 32), stream};
  random_.seed(seeds);
}

double DeliveryDrawer::DrawUniform() { return static_cast<double>(random_() >> 11) * 0x1.0p-53; }

Delivery DeliveryDrawer::Draw() {
  // both draws for every message, lost or not
  const double loss_draw = DrawUniform();
  const double jitter_draw = DrawUniform();
  Delivery delivery;
  delivery.lost = loss_draw < channel_.loss;
  const double delay_s = channel_.delay_s + channel_.jitter_s * jitter_draw;
  // a delay beyond kMaxLatencyTicks never arrives within any run (kMaxTicks is far less)
  const double ticks = std::ceil(delay_s * rate_hz_ - kTickSlack);
  delivery.latency_ticks = static_cast<int64_t>(std::clamp(ticks, 0.0, kMaxLatencyTicks));
  return delivery;
}

}  // namespace hapticd::sim
