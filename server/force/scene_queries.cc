#include "server/force/scene_queries.h"

#include <cmath>

#include "server/geometry/work_meter.h"

namespace hapticd::force {
namespace {

// Squared distance from p to a box (0 inside); infinite extents work.
double DistanceSquaredToBox(const geometry::Aabb& box, const Vector3& p) {
  const Vector3 outside = (box.min - p).cwiseMax(p - box.max).cwiseMax(0.0);
  return outside.squaredNorm();
}

}  // namespace

SceneContact FindDeepestContact(const scene::SceneSnapshot& scene, const Vector3& c_W, double r,
                                double max_gap) {
  SceneContact deepest;
  if (!c_W.allFinite() || !(r >= 0) || !(max_gap >= 0)) return deepest;
  const double reach = r + max_gap;
  const geometry::Aabb near{c_W - Vector3::Constant(reach), c_W + Vector3::Constant(reach)};
  scene.ForEachObjectNear(near, [&](int i) {
    if (!geometry::WorkMeter::Charge(1)) return false;
    const scene::SceneObject& object = scene.object(i);
    // skip objects whose box is out of reach
    if (DistanceSquaredToBox(object.bounds_W, c_W) > reach * reach) return true;
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(c_W), reach);
    if (!probe.found) return true;
    const double depth = r - probe.signed_distance;
    if (depth < -max_gap) return true;
    // the deepest; of equally deep ones, the first in the scene
    if (deepest.object >= 0 && (depth < deepest.depth || (depth == deepest.depth && i > deepest.object))) {
      return true;
    }
    deepest.object = i;
    deepest.depth = depth;
    deepest.point_W = object.X_WB.ToWorld(probe.point_B);
    deepest.normal_W = object.X_WB.DirectionToWorld(probe.normal_B);
    deepest.triangle = probe.triangle;
    return true;
  });
  return deepest;
}

SceneSweep SweepSphereScene(const scene::SceneSnapshot& scene, const Vector3& a_W,
                            const Vector3& b_W, double r) {
  SceneSweep first;
  if (!a_W.allFinite() || !b_W.allFinite() || !(r >= 0) || a_W == b_W) return first;
  // the box swept by the sphere, to skip objects it cannot reach
  geometry::Aabb swept{a_W.cwiseMin(b_W) - Vector3::Constant(r), a_W.cwiseMax(b_W) + Vector3::Constant(r)};
  scene.ForEachObjectNear(swept, [&](int i) {
    if (!geometry::WorkMeter::Charge(1)) return false;
    const scene::SceneObject& object = scene.object(i);
    const ShapeSweep sweep =
        SweepSphereShape(object.shape, object.X_WB.ToBody(a_W), object.X_WB.ToBody(b_W), r);
    // the first contact; of simultaneous ones, the first object in the scene
    if (!sweep.hit || (first.hit && (sweep.t > first.t || (sweep.t == first.t && i > first.object)))) {
      return true;
    }
    first.hit = true;
    first.object = i;
    first.t = sweep.t;
    first.point_W = object.X_WB.ToWorld(sweep.point_B);
    first.normal_W = object.X_WB.DirectionToWorld(sweep.normal_B);
    first.triangle = sweep.triangle;
    return true;
  });
  return first;
}

Vector3 CalcSceneShadingNormal(const scene::SceneSnapshot& scene, int object, int triangle,
                               const Vector3& point_W, const Vector3& normal_W) {
  const scene::SceneObject& touched = scene.object(object);
  return touched.X_WB.DirectionToWorld(
      CalcShadingNormal(touched.shape, triangle, touched.X_WB.ToBody(point_W),
                        touched.X_WB.DirectionToBody(normal_W)));
}

}  // namespace hapticd::force
