#pragma once

// Constrained motion of a proxy (a point, or a sphere of radius r) towards a goal
// through a scene: the core of the god-object (Zilles & Salisbury 1995) and finger
// proxy (Ruspini, Kolarov & Khatib 1997) methods, and of the admittance avatar.
//
// Theory of operation. The proxy never enters an object. Each pass sweeps it from where
// it is towards the nearest point to the goal that satisfies the constraint planes met
// so far (min |x - goal|^2 subject to n_i . x >= d_i; the answer rests on at most
// three planes: a face, an edge where two meet, a corner where three meet). When the sweep touches a surface the
// proxy stops there and the surface's tangent plane joins the constraints; when it does
// not, the proxy has arrived. On a curved surface of radius R a tangential step s lets
// the proxy float s^2 / (2 R) off the surface (0.4 micrometres for 0.2 mm on a 5 cm
// ball); the next tick's first sweep puts it back.

#include <array>

#include "server/geometry/half_spaces.h"
#include "server/query/neighbourhood.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::force {

using geometry::Vector3;

// A constraint on the proxy's centre x: normal . x >= offset, where offset keeps the
// proxy a skin's width (1e-9 m) off the surface it touches at point_W (triangle for
// meshes), so that sliding along it never counts as running into it.
struct ProxyPlane {
  Vector3 normal = Vector3::UnitZ();
  double offset = 0;
  Vector3 point_W = Vector3::Zero();
  int object = -1;
  int triangle = -1;
};

// Planes a proxy may meet in one tick; the nearest point to the goal rests on at most
// three of them (a corner), the others are satisfied on the way
// (geometry::NearestPointInHalfSpaces).
constexpr int kMaxProxyPlanes = geometry::kMaxHalfSpaces;

struct ProxyMove {
  Vector3 position = Vector3::Zero();  // where the proxy ended
  std::array<ProxyPlane, kMaxProxyPlanes> planes;  // constraints met on the way
  int num_planes = 0;
  // more constraints than kMaxProxyPlanes, passes ran out, or a surface stopped the proxy
  // again where the constraints already allowed it (a query inconsistent with itself)
  bool overflow = false;
};

// Moves a proxy of radius r >= 0 from start (outside every object) towards goal, asking
// near's scene queries (what a tick gathered around the proxy; the answers are the
// scene's). Allocation-free; non-finite input leaves the proxy at start.
ProxyMove MoveProxy(const query::Neighbourhood& near, const Vector3& start, const Vector3& goal, double r);
// The same, asking every query of the whole scene (the direct path: the oracle of the
// gathered one).
ProxyMove MoveProxy(const scene::SceneSnapshot& scene, const Vector3& start, const Vector3& goal,
                    double r);

// Where a proxy of radius r at x must start this tick of dt seconds: carried along by
// a kinematic object it rests on (the object's point velocity times dt), then pushed out
// of any object that moved into it (along the deepest contact's normal). Static scenes
// that did not change since the last tick (scene_changed false) skip the push-out: a
// proxy that stayed outside is still outside. Asks near's queries. Allocation-free.
Vector3 CarryProxy(const query::Neighbourhood& near, const Vector3& x, double r, double dt, bool scene_changed);
// The same, asking the whole scene.
Vector3 CarryProxy(const scene::SceneSnapshot& scene, const Vector3& x, double r, double dt,
                   bool scene_changed);

// Gathers near, for a tick of a proxy of radius r >= 0 at x that is expected to move by
// about expected_motion (m) this tick, in the region that holds the proxy along that
// motion with some room: within r plus 0.1 of the motion's length plus 20 micrometres of
// the segment from x to x + expected_motion (a proxy at rest still slides a little, and
// its step turns and grows from tick to tick). Only the cost depends on the guess: a
// query reaching farther asks the scene. Triangles are gathered for a sphere only
// (gathered_mesh.h). Real-time safe.
void GatherAlong(const scene::SceneSnapshot& scene, query::Neighbourhood& near, const Vector3& x, double r,
                 const Vector3& expected_motion);

}  // namespace hapticd::force
