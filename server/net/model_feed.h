#pragma once
// Cuts each local-model session's local models (remote/local_model.h) off the realtime
// thread and hands them to it encoded (model_mailbox.h), which sends them in fragments
// with the session's commands. Its passes run on the control thread (a timer of the
// server's), which owns the slots' lifecycle: a slot cannot be refilled under a pass.
//
// Theory of operation. Every kPassNs a pass reads each local-model session's
// published telemetry: where the device and its own proxy are, and the newest model the
// device says it holds. It cuts a model about the device's proxy when the session has
// none, when the scene changed, or when the ball of the last one no longer holds where
// the device can get before a newer one reaches it (ModelRadius: its declared maximum
// velocity times the round trip of the models so far, plus the longest wait between
// them), and gives the new ball room to spare (kRadiusSlack) so that a moving hand does
// not need one every pass; it cuts again only where the new ball would reach at least
// kMinGainM further about the avatar (past the largest ball, 1 m, a reach recuts only as
// the avatar travels). While a model is on its way (not yet held) no newer one is
// cut unless it is overdue (kResendS): a model of many fragments must get through
// whole. So a scene that keeps changing (a kinematic object moving) sends one model
// per round trip, each with the poses and velocities of its cut.
#include <atomic>
#include <cstdint>
#include <vector>

#include "server/net/session_table.h"
#include "server/scene/snapshot_publisher.h"

namespace hapticd::net {

class ModelFeed {
 public:
  static constexpr int64_t kPassNs = 2'000'000;
  static constexpr double kRadiusSlack = 1.5;
  static constexpr double kResendS = 1.0;
  static constexpr double kMinGainM = 1e-3;
  // Before a model's round trip is measured.
  static constexpr double kInitialRoundTripS = 0.2;

  ModelFeed(SessionTable& sessions, scene::SnapshotPublisher& publisher);
  ModelFeed(const ModelFeed&) = delete;
  ModelFeed& operator=(const ModelFeed&) = delete;

  // One pass at now_ns, on the control thread; whether any local-model session lives
  // (without one the server passes less often).
  bool Pass(int64_t now_ns);
  uint64_t models_cut() const { return models_cut_.load(std::memory_order_relaxed); }

 private:
  // What the thread knows of one slot's session.
  struct Feed {
    uint32_t session_id = 0;
    uint64_t version = 0;  // the last cut
    Vector3 center_W = Vector3::Zero();
    double radius = 0;
    int64_t cut_ns = 0;
    uint64_t scene_version = 0;
    uint64_t acked = 0;       // the newest the device holds
    int64_t acked_ns = 0;     // when that was first seen
    double round_trip_s = -1;  // the longest from a cut to its ack; < 0: none yet
    double longest_gap_s = 0;  // the longest between two acks
  };
  void Serve(SessionSlot& slot, Feed& feed, int64_t now_ns, const scene::SceneSnapshot& scene);

  SessionTable& sessions_;
  scene::SnapshotPublisher& publisher_;
  std::vector<Feed> feeds_;
  std::atomic<uint64_t> models_cut_{0};
};

}  // namespace hapticd::net
