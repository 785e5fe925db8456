#include "server/net/model_feed.h"

#include <algorithm>
#include <cstring>

#include "server/net/model_codec.h"
#include "server/net/realtime_channel.h"
#include "server/remote/local_model.h"

namespace hapticd::net {

ModelFeed::ModelFeed(SessionTable& sessions, scene::SnapshotPublisher& publisher)
    : sessions_(sessions), publisher_(publisher), feeds_(sessions.capacity()) {}

bool ModelFeed::Pass(int64_t now_ns) {
  const std::shared_ptr<const scene::SceneSnapshot> scene = publisher_.current();
  const int used = sessions_.used_slots();
  bool served = false;
  for (int i = 0; i < used; ++i) {
    SessionSlot& slot = sessions_.slot(i);
    const SlotState state = slot.state.load(std::memory_order_acquire);
    if (!IsLive(state) || !slot.local_model) continue;
    Serve(slot, feeds_[i], now_ns, *scene);
    served = true;
  }
  return served;
}

void ModelFeed::Serve(SessionSlot& slot, Feed& feed, int64_t now_ns, const scene::SceneSnapshot& scene) {
  if (feed.session_id != slot.id) feed = Feed{slot.id};
  const SessionTelemetrySample telemetry = slot.published.Read();
  const double now_s = static_cast<double>(now_ns - slot.opened_ns) * 1e-9;

  // what the device holds: a model's round trip, and the waits between them
  if (telemetry.model_version > feed.acked) {
    if (telemetry.model_version == feed.version) {
      feed.round_trip_s = std::max(feed.round_trip_s, static_cast<double>(now_ns - feed.cut_ns) * 1e-9);
    }
    if (feed.acked != 0) feed.longest_gap_s = std::max(feed.longest_gap_s, static_cast<double>(now_ns - feed.acked_ns) * 1e-9);
    feed.acked = telemetry.model_version;
    feed.acked_ns = now_ns;
  }

  // about the device's proxy (before its first state: where the session started), out
  // to where the device point can get
  const bool heard = telemetry.states_received > 0;
  const Vector3 avatar_W = heard ? telemetry.device_avatar_W : slot.start_W;
  const Vector3 device_W = heard ? telemetry.p_WD : slot.start_W;
  const force::SessionSettings& settings = slot.render->settings();
  const double round_trip_s = feed.round_trip_s < 0 ? kInitialRoundTripS : feed.round_trip_s;
  const double reach =
      remote::ModelRadius(settings.device.max_velocity, round_trip_s,
                          std::max(static_cast<double>(kPassNs) * 1e-9, feed.longest_gap_s), settings.avatar.radius) +
      (device_W - avatar_W).norm();
  const bool scene_changed = feed.version != 0 && scene.version() != feed.scene_version;
  // uncovered, and a newer ball about the avatar would cover more of it: once the reach
  // passes what the largest ball holds, a cut about the same point is the same model
  // (without this, at a long round trip, one per round trip while the hand rests)
  const double radius = std::min(kRadiusSlack * reach, remote::kMaxModelRadiusM);
  const double moved = (avatar_W - feed.center_W).norm();
  const bool uncovered = moved + reach > feed.radius && moved + radius - feed.radius > kMinGainM;
  const bool in_flight = feed.version > feed.acked && static_cast<double>(now_ns - feed.cut_ns) * 1e-9 < kResendS;
  if (feed.version != 0 && (in_flight || !(uncovered || scene_changed))) return;

  const remote::LocalModel model = remote::CutLocalModel(scene, avatar_W, radius, feed.version + 1, now_s);
  const std::string encoded = EncodeLocalModel(model);
  EncodedModel& out = slot.models->back();
  out.session_id = slot.id;
  out.version = model.version;
  out.size = encoded.size();
  std::memcpy(out.bytes.data(), encoded.data(), encoded.size());
  slot.models->Publish();
  models_cut_.fetch_add(1, std::memory_order_relaxed);
  feed.version = model.version;
  feed.center_W = avatar_W;
  feed.radius = radius;
  feed.cut_ns = now_ns;
  feed.scene_version = scene.version();
}

}  // namespace hapticd::net
