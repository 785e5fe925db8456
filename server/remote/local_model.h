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
// velocity between models (ModelMotion: each tick moves them, or, on a real-time device,
// another thread builds the moved scene and the tick swaps it in, KinematicMotion). A
// newer model replaces the scene under the session, which keeps its proxy (so the proxy
// stays outside what both models hold solid); where the two models disagree about the
// surface near the avatar (an object's pose corrected, an edit), the force is blended
// from the old to the new over kModelBlendS, so the hand is never jerked.

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
  std::shared_ptr<const scene::SceneSnapshot> scene;  // its version is the model's
  double t_s = 0;       // renderer time the scene's kinematic poses are at
  bool moving = false;  // some kinematic object has a velocity
};

// Who moves a model's kinematic objects on between models.
enum class ModelMotion {
  // Each Tick moves them by its dt and builds the moved scene (allocates): for a device
  // that may allocate (the simulator's, the Python binding's).
  kByTick,
  // The caller moves them off the real-time thread (KinematicMotion) and hands each
  // moved scene to Move; a Tick allocates nothing.
  kByCaller,
};

// The device side: renders from the newest model it has.
class LocalRenderer {
 public:
  // The session as the device asked for it. Throws std::invalid_argument on bad settings.
  explicit LocalRenderer(const force::SessionSettings& settings, ModelMotion motion = ModelMotion::kByTick);
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
  // Renders from scene from the next tick on: the model held, its kinematic objects
  // moved to t_s (renderer time) off the real-time thread (KinematicMotion::SceneAt).
  // The same model, not a new one: neither blended nor counted as a version. A scene of
  // another version than the model held (or none) is left with the caller (false); on
  // true, scene holds the one it replaced, for the caller to free where it may.
  // Allocates and frees nothing.
  bool Move(std::shared_ptr<const scene::SceneSnapshot>& scene, double t_s);
  // One tick from the newest model (free space before any). With ModelMotion::kByTick,
  // its kinematic objects then move on by dt: a model with moving objects builds the
  // moved scene (allocates). With kByCaller, a tick allocates nothing.
  force::TickOutput Tick(const force::DeviceInput& input, double dt);

  uint64_t model_version() const { return version_; }
  // The renderer time the next tick's kinematic poses are at (0 before any model).
  double scene_t_s() const { return model_ ? model_->t_s : 0; }
  // Whether the avatar of radius r at p_W lies within the model's ball.
  bool Covers(const Vector3& p_W) const;
  const force::RenderSession& session() const { return session_; }
  // Switches between models that disagreed near the avatar (each blended).
  int64_t blends() const { return blends_; }

 private:
  force::RenderSession session_;
  ModelMotion motion_;
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

// The kinematic objects of the model a real-time device renders from, moved on off its
// real-time thread (for LocalRenderer with ModelMotion::kByCaller): it keeps its own
// copy of the model's objects (the geometry is shared) and builds the scene for the time
// its caller asks, which LocalRenderer::Move swaps in. Allocates: all of it belongs off
// the real-time thread. The snapshots it builds share objects with the model's, so the
// thread that calls it must be the only one to copy or free them (the device's builder).
class KinematicMotion {
 public:
  // Follows prepared's model from now on, from the poses its scene holds (at prepared.t_s).
  void Follow(const PreparedModel& prepared);
  // The model followed (0: none yet).
  uint64_t version() const { return version_; }
  // Whether the model followed has a kinematic object with a velocity: else every scene
  // would be the one the model already holds.
  bool moving() const { return moving_; }
  // The renderer time the poses are at now.
  double t_s() const { return t_s_; }
  // The followed model's scene (its version) with the kinematic objects moved on to t_s
  // (renderer time; one before the last asked for moves nothing). Null before any model.
  std::shared_ptr<const scene::SceneSnapshot> SceneAt(double t_s);

 private:
  scene::SceneBuilder builder_;
  uint64_t version_ = 0;
  double t_s_ = 0;
  bool moving_ = false;
};

}  // namespace hapticd::remote
