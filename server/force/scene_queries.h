#pragma once

// The shape queries of shape_queries.h over a whole scene snapshot, in the world frame
// W: every object whose bounds can matter is asked, and the answers are combined.

#include "server/force/shape_queries.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::force {

struct SceneContact {
  int object = -1;               // index in the snapshot; -1: nothing found
  double depth = 0;              // how far a sphere of the given radius at c_W is inside
                                 // the object (radius - signed distance of c_W), m;
                                 // negative when it is apart
  Vector3 point_W = Vector3::Zero();    // nearest surface point of that object
  Vector3 normal_W = Vector3::UnitZ();  // unit outward normal there
  int triangle = -1;
};

// The object that a sphere of radius r >= 0 at c_W penetrates deepest (largest depth),
// among objects within max_gap (>= 0, m) of touching it; of equally deep ones, the
// first in the scene. Only the objects near c_W are visited (the snapshot's broad
// phase). Real-time safe.
SceneContact FindDeepestContact(const scene::SceneSnapshot& scene, const Vector3& c_W, double r,
                                double max_gap);

struct SceneSweep {
  bool hit = false;
  int object = -1;
  double t = 0;  // centre at contact = a_W + t (b_W - a_W)
  Vector3 point_W = Vector3::Zero();
  Vector3 normal_W = Vector3::UnitZ();
  int triangle = -1;
};

// Earliest first contact over all objects of a sphere of radius r >= 0 swept a_W -> b_W
// (SweepSphereShape's rule for surfaces touched at the start); of simultaneous ones,
// the first object in the scene. Only the objects the sweep's box meets are visited.
// Real-time safe.
SceneSweep SweepSphereScene(const scene::SceneSnapshot& scene, const Vector3& a_W,
                            const Vector3& b_W, double r);

// CalcShadingNormal for a contact with object at point_W (unit normal_W), in W.
Vector3 CalcSceneShadingNormal(const scene::SceneSnapshot& scene, int object, int triangle,
                               const Vector3& point_W, const Vector3& normal_W);

}  // namespace hapticd::force
