#pragma once
// The device end of a local-model session (hapticd.v1.REMOTE_MODE_LOCAL_MODEL): the force
// is rendered here, at the loop's rate, from the newest local model of the scene the
// server sent (remote/local_model.h), not from the commands' force, which arrives a round
// trip late.
//
// Theory of operation. The loop's thread hands every model fragment the link reads to
// Offer, which gathers them in a preallocated assembler (net/model_codec.h). A completed
// model's bytes are copied to a builder thread, which decodes the model and builds its
// scene (both allocate) and leaves it ready; the loop's next Tick adopts it, and the
// model it replaced goes back to the builder to be freed. The loop's thread only ever
// try-locks the exchange: when the builder holds it, the hand-over waits a tick. So a
// tick allocates, frees and blocks on nothing.
//
// Moving kinematic objects (as the server's control thread moves them for its realtime
// thread): while the newest model has one with a velocity, the builder wakes every
// motion period P, moves the objects of its own copy of the model (remote::
// KinematicMotion) to the time half a period ahead, builds that scene and leaves it in
// the exchange; the loop's next Tick swaps it in (remote::LocalRenderer::Move: the same
// model version, not blended) and hands the scene it replaced back to be freed.
//
//   builder:  wake at w ── move to w + P/2 ── build ── moved ─┐      (every P)
//   loop:     tick ─ try-lock: adopt ready, swap in moved, ◄──┘ give back the old ─ render
//
// Pose lag: a scene built at w is for w + P/2 and is rendered until the next one, built
// at w + P, reaches the loop; so a tick at t renders the poses of a time within
// [t - P/2 - b, t + P/2], b being how long after its due wake the builder's next scene
// reaches the loop (wake-up latency and build time, plus a tick when the try-lock
// fails; tens of microseconds on an idle core). A kinematic object moving at v is off by at most
// v (P/2 + b) from where it is at the tick; never ahead by more than v P/2.
//
// Clock: a model's cut time is on the server's session clock (0 when the session
// opened); the device takes its own time since OpenSession returned for it, late by the
// control reply's one-way delay, which is what kinematic objects are moved on by.
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "clients/cpp/device_driver.h"
#include "clients/cpp/realtime_link.h"
#include "server/net/model_codec.h"
#include "server/remote/local_model.h"

namespace hapticd::proxy {

// What a local-model device has seen so far.
struct LocalModelCounters {
  uint64_t fragments = 0;   // model fragments offered
  uint64_t completed = 0;   // models whose fragments were all gathered
  uint64_t adopted = 0;     // models rendered from
  uint64_t rejected = 0;    // completed models that did not decode (the last good one stays)
  uint64_t blends = 0;      // model changes blended
  uint64_t moved = 0;       // scenes with the kinematic objects moved on, swapped in
  uint64_t version = 0;     // the model rendered from now (0: none yet)

  LocalModelCounters& operator+=(const LocalModelCounters& other);
};

class LocalModelDevice final : public FragmentSink {
 public:
  // The session as the device opened it (the same settings the server reads from the
  // OpenSession request; its device rate is the loop's, and the motion period P is one
  // period of it), the handle at start_W, the session opened at session_start_ns
  // (CLOCK_MONOTONIC). Starts the builder thread.
  LocalModelDevice(const force::SessionSettings& settings, const Vector3& start_W, int64_t session_start_ns);
  ~LocalModelDevice() override;
  LocalModelDevice(const LocalModelDevice&) = delete;
  LocalModelDevice& operator=(const LocalModelDevice&) = delete;

  // Loop thread: a fragment the link read.
  void Offer(const net::ModelFragmentView& fragment) override;
  // Loop thread: one tick of the device's own rendering; reading is the handle now,
  // f_held_W the force rendered since the previous tick.
  force::TickOutput Tick(const DeviceReading& reading, const Vector3& f_held_W, double dt);

  // For the next state: the newest model held and the proxy on it.
  uint64_t model_version() const { return renderer_.model_version(); }
  const Vector3& avatar_W() const { return avatar_W_; }
  // Loop thread: the session time (s) the kinematic poses the last tick rendered are at.
  double scene_t_s() const { return renderer_.scene_t_s(); }
  // After the run (locks).
  LocalModelCounters counters();

 private:
  // A scene with the kinematic objects moved on, and the session time they are at.
  struct MovedScene {
    std::shared_ptr<const scene::SceneSnapshot> scene;
    double t_s = 0;
  };

  // The builder thread: decode and build what the loop handed over, move the kinematic
  // objects on, free what the loop gave back.
  void Build();
  // Loop thread: try to hand the completed model over; false when the builder held the lock.
  bool HandOver();

  remote::LocalRenderer renderer_;
  net::ModelAssembler assembler_;
  int64_t session_start_ns_;
  int64_t motion_period_ns_;
  Vector3 avatar_W_;
  bool handover_pending_ = false;  // a completed model not yet handed over
  std::unique_ptr<remote::PreparedModel> retiring_;  // waiting for the lock to go back
  LocalModelCounters counters_;  // the loop thread's (rejected: the builder's, below)

  std::mutex mutex_;  // guards the fields below
  std::condition_variable wake_;
  std::vector<uint8_t> inbox_;  // kMaxModelBytes, sized once
  std::size_t inbox_size_ = 0;  // 0: empty
  std::unique_ptr<remote::PreparedModel> ready_;
  std::vector<std::unique_ptr<remote::PreparedModel>> retired_;  // capacity kRetiredCapacity
  MovedScene moved_;  // the newest moved scene, not yet swapped in
  std::shared_ptr<const scene::SceneSnapshot> moved_back_;  // a scene swapped out, to free
  uint64_t rejected_ = 0;
  bool stop_ = false;
  std::thread builder_;
};

}  // namespace hapticd::proxy
