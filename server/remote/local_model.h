#pragma once

// The local model (Adachi et al. 1995; Mark et al. 1996): what the renderer sends a
// remote device of the scene near its avatar, so that the device renders its force at
// its own rate from geometry that is there, instead of from a force that arrives a
// round trip late.
//
// Theory of operation. The renderer cuts a model out of its snapshot: every object
// whose bounds come within the model's radius of its centre, primitives and hulls
// whole, a mesh as the patch of its triangles that may lie there (the whole mesh, a
// closed solid, when the patch is all of it), each with its material, and the
// kinematic ones with their velocity and their pose at the time of the cut. The radius
// covers where the device can get before a newer model reaches it (ModelRadius). The
// device builds a small scene of it (LocalRenderer) and renders with the same
// force::RenderSession the renderer runs; its kinematic objects move on by their
// velocity between models. A newer model replaces the scene under the session, which
// keeps its proxy (so the proxy stays outside what both models hold solid); where the
// two models disagree about the surface near the avatar (an object's pose corrected, an
// edit), the force is blended from the old to the new over kModelBlendS, so the hand
// is never jerked.

#include <cstdint>
#include <memory>
#include <vector>

#include "server/force/render_session.h"
#include "server/scene/scene_builder.h"

namespace hapticd::remote {

using geometry::Vector3;

// Bounds of a model, so that it fits what a device can take and build within a few ticks.
inline constexpr int kMaxModelObjects = 64;
inline constexpr int kMaxModelTriangles = 4096;
inline constexpr double kMaxModelRadiusM = 1.0;
// Beyond the reach the device's velocity gives: the avatar's own radius is added too.
inline constexpr double kModelMarginM = 0.005;
// How long a force jump between disagreeing models is blended over.
inline constexpr double kModelBlendS = 0.005;

struct LocalModel {
  uint64_t version = 0;        // 1, 2, ... in the order the renderer cut them
  double t_s = 0;              // renderer time of the cut: the kinematic poses are at it
  Vector3 center_W = Vector3::Zero();
  double radius = 0;           // the ball it covers; everything of the scene within it is in it
  scene::SceneSettings settings;  // the scene's (its tolerance); always the native backend
  std::vector<scene::ObjectSpec> objects;
  // Objects near the ball that it had no room for (past kMaxModelObjects, or a mesh
  // patch past kMaxModelTriangles): left out, so the ball was not covered.
  int left_out = 0;
};

// The radius a model needs: where a device moving at up to max_velocity (m/s) gets in
// round_trip_s plus the time until the next model (s), with the avatar's radius and
// the margin; at most kMaxModelRadiusM.
double ModelRadius(double max_velocity, double round_trip_s, double model_interval_s, double avatar_radius);

// Cuts the model of scene within radius of center_W. Allocates: off the real-time
// thread (or where the renderer may allocate).
LocalModel CutLocalModel(const scene::SceneSnapshot& scene, const Vector3& center_W, double radius,
                         uint64_t version, double t_s);

// A model built into the scene a device renders from: made by LocalRenderer::Prepare
// (allocates), taken by Adopt (does not), so a real-time device builds it on another
// thread.
struct PreparedModel {
  uint64_t version = 0;
  Vector3 center_W = Vector3::Zero();
  double radius = -1;
  scene::SceneBuilder builder;  // keeps the objects, to move the kinematic ones on
  std::shared_ptr<const scene::SceneSnapshot> scene;
  bool moving = false;  // some kinematic object has a velocity
};

// The device side: renders from the newest model it has.
class LocalRenderer {
 public:
  // The session as the device asked for it. Throws std::invalid_argument on bad settings.
  explicit LocalRenderer(const force::SessionSettings& settings);
  LocalRenderer(LocalRenderer&&) noexcept;
  ~LocalRenderer();

  void Reset(const Vector3& p_W);
  // Builds model's scene, its kinematic objects moved on from the cut to now_s (the
  // renderer's clock). Allocates: off the real-time thread.
  static std::unique_ptr<PreparedModel> Prepare(const LocalModel& model, double now_s);
  // Renders from model from the next tick on; a version no newer than the one held is
  // left with the caller (false). Allocates and frees nothing: the model it replaces is
  // kept until the tick after (to blend against), then waits in TakeRetired.
  bool Adopt(std::unique_ptr<PreparedModel>& model);
  // The model a tick has finished with, for the caller to free where it may (null if
  // none). Left untaken, it is freed by the next Adopt.
  std::unique_ptr<PreparedModel> TakeRetired() { return std::move(retired_); }
  // Prepare and Adopt at once (the simulator's device, which may allocate).
  bool Accept(const LocalModel& model, double now_s);
  // One tick from the newest model (free space before any), then its kinematic objects
  // move on by dt. Allocates nothing for a model without moving objects; with them it
  // builds the moved scene each tick (allocates: a real-time device loop holding one
  // breaks its rule; moving them in place is left to do).
  force::TickOutput Tick(const force::DeviceInput& input, double dt);

  uint64_t model_version() const { return version_; }
  // Whether the avatar of radius r at p_W lies within the model's ball.
  bool Covers(const Vector3& p_W) const;
  const force::RenderSession& session() const { return session_; }
  // Switches between models that disagreed near the avatar (each blended).
  int64_t blends() const { return blends_; }

 private:
  force::RenderSession session_;
  std::unique_ptr<PreparedModel> model_;
  std::unique_ptr<PreparedModel> previous_;  // until the first tick on model_
  std::unique_ptr<PreparedModel> retired_;   // previous_ after that tick
  uint64_t version_ = 0;
  Vector3 last_avatar_W_ = Vector3::Zero();
  Vector3 last_f_W_ = Vector3::Zero();
  Vector3 blend_offset_W_ = Vector3::Zero();  // decays to zero over kModelBlendS
  double blend_left_s_ = 0;
  int64_t blends_ = 0;
};

}  // namespace hapticd::remote
