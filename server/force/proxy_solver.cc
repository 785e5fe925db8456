#include "server/force/proxy_solver.h"

#include <array>
#include <cmath>
#include <span>

namespace hapticd::force {
namespace {

// Sweeps per tick: each one that stops adds a plane, so this also bounds the planes
// met (kMaxProxyPlanes); three pin a corner, the rest are met on the way there.
constexpr int kMaxPasses = 8;
// The proxy stops this far short of a surface (m), so rounding never leaves it inside.
constexpr double kSkin = 1e-9;
// Moves shorter than this (m) are arrivals.
constexpr double kArrived = 1e-12;
// A proxy this close to a kinematic object (m) rests on it and is carried along.
constexpr double kRestingGap = 1e-6;
// Push-outs per tick: one per object the proxy can be wedged between.
constexpr int kMaxPushes = 3;
// What a neighbourhood holds beyond the sphere around the expected motion (the segment
// from the proxy to where it would go on as it went): this share of the motion's
// length, and this much more (m).
constexpr double kGatherMotionMargin = 0.1;
constexpr double kGatherMargin = 2e-5;

// A plane already among the constraints: meeting it again means the sweep and the
// constraints disagree, and another pass would only repeat itself.
bool IsKnown(const ProxyMove& move, const Vector3& normal, double offset) {
  for (int i = 0; i < move.num_planes; ++i) {
    if (move.planes[i].normal.dot(normal) > 1 - 1e-12 &&
        std::abs(move.planes[i].offset - offset) <= geometry::kHalfSpaceFeasibility) {
      return true;
    }
  }
  return false;
}

}  // namespace

void GatherAlong(const scene::SceneSnapshot& scene, query::Neighbourhood& near, const Vector3& x, double r,
                 const Vector3& expected_motion) {
  near.Gather(scene, x, x + expected_motion, r + kGatherMotionMargin * expected_motion.norm() + kGatherMargin, r > 0);
}

Vector3 CarryProxy(const query::Neighbourhood& near, const Vector3& x, double r, double dt, bool scene_changed) {
  const scene::SceneSnapshot& scene = near.scene();
  if (!x.allFinite()) return x;
  Vector3 carried = x;
  // a proxy resting on (within a micrometre of) a kinematic object moves with it: the
  // first such object in the scene, among those near it
  const bool any_kinematic = !scene.kinematic_objects().empty();
  if (any_kinematic) {
    const query::SceneContact carrier = query::FindKinematicContact(near, x, r + kRestingGap);
    if (carrier.object >= 0) carried += dt * scene.object(carrier.object).CalcPointVelocity(carrier.point_W);
  }
  // an object that moved into the proxy (or appeared around it) pushes it out, however
  // little: a point's sweep that starts inside a solid is not stopped by the face it is
  // behind (primitives allow 1e-10 m, meshes nothing), so a proxy left even a skin's
  // width inside (an object that moved a little more than the carry) would drop through
  if (!any_kinematic && !scene_changed) return carried;
  for (int push = 0; push < kMaxPushes; ++push) {
    const query::SceneContact inside = query::FindDeepestContact(near, carried, r, 0);
    if (inside.object < 0 || inside.depth <= 0) break;
    carried += (inside.depth + kSkin) * inside.normal_W;
  }
  return carried;
}

Vector3 CarryProxy(const scene::SceneSnapshot& scene, const Vector3& x, double r, double dt,
                   bool scene_changed) {
  return CarryProxy(query::Neighbourhood(scene), x, r, dt, scene_changed);
}

ProxyMove MoveProxy(const scene::SceneSnapshot& scene, const Vector3& start, const Vector3& goal,
                    double r) {
  return MoveProxy(query::Neighbourhood(scene), start, goal, r);
}

ProxyMove MoveProxy(const query::Neighbourhood& near, const Vector3& start, const Vector3& goal, double r) {
  ProxyMove move;
  move.position = start;
  if (!start.allFinite() || !goal.allFinite() || !(r >= 0)) return move;
  // the planes met, as the constraints the sub-goal must satisfy
  std::array<geometry::HalfSpace, kMaxProxyPlanes> constraints;
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    const Vector3 target =
        geometry::NearestPointInHalfSpaces(goal, std::span(constraints.data(), move.num_planes));
    const Vector3 motion = target - move.position;
    if (motion.norm() <= kArrived) return move;
    const query::SceneSweep sweep = query::SweepSphereScene(near, move.position, target, r);
    if (!sweep.hit) {
      move.position = target;
      return move;
    }
    // stop on the surface, a skin's width off it
    move.position += sweep.t * motion + kSkin * sweep.normal_W;
    const double offset = sweep.normal_W.dot(sweep.point_W) + r + kSkin;
    if (move.num_planes == kMaxProxyPlanes || IsKnown(move, sweep.normal_W, offset)) {
      move.overflow = true;
      return move;
    }
    constraints[move.num_planes] = {sweep.normal_W, offset};
    move.planes[move.num_planes++] = {sweep.normal_W, offset, sweep.point_W, sweep.object, sweep.triangle};
  }
  move.overflow = true;
  return move;
}

}  // namespace hapticd::force
