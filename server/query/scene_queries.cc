#include "server/query/scene_queries.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>
#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/work_meter.h"
#include "server/query/neighbourhood.h"

namespace hapticd::query {
namespace {

// Each query's rule is written once, over the objects some walk offers (Objects:
// for_each(box, visit) calls visit(i, mesh) for objects i whose bounds overlap box, mesh
// the triangles a Neighbourhood gathered of it): the snapshot's broad phase, or a
// Neighbourhood's gathered objects.

const GatheredMesh kNoTriangles;

// Offers the snapshot's objects near box, with no gathered triangles.
struct SceneObjects {
  const scene::SceneSnapshot& scene;
  template <typename Visit>
  void operator()(const geometry::Aabb& box, Visit visit) const {
    scene.ForEachObjectNear(box, [&](int i) { return visit(i, kNoTriangles); });
  }
};

// Offers a Neighbourhood's gathered objects near box.
struct GatheredObjects {
  const Neighbourhood& near;
  template <typename Visit>
  void operator()(const geometry::Aabb& box, Visit visit) const {
    near.ForEachObjectNear(box, visit);
  }
};

// A probe of object i (asked for a sphere of radius r) as a contact in W.
SceneContact ContactInWorld(const scene::SceneObject& object, int i, const ShapeProbe& probe, double r) {
  return {i, r - probe.signed_distance, object.X_WB.ToWorld(probe.point_B),
          object.X_WB.DirectionToWorld(probe.normal_B), probe.triangle};
}

// A hit of object i's sweep as a hit in W.
SceneSweep SweepInWorld(const scene::SceneObject& object, int i, const ShapeSweep& sweep) {
  return {true, i, sweep.t, object.X_WB.ToWorld(sweep.point_B), object.X_WB.DirectionToWorld(sweep.normal_B),
          sweep.triangle};
}

template <typename Objects>
SceneContact FindDeepestContactAmong(const scene::SceneSnapshot& scene, const Objects& objects, const Vector3& c_W,
                                     double r, double max_gap) {
  SceneContact deepest;
  if (!c_W.allFinite() || !(r >= 0) || !(max_gap >= 0)) return deepest;
  const double reach = r + max_gap;
  const geometry::Aabb near{c_W - Vector3::Constant(reach), c_W + Vector3::Constant(reach)};
  objects(near, [&](int i, const GatheredMesh&) {
    if (!geometry::WorkMeter::Charge(1)) return false;
    const scene::SceneObject& object = scene.object(i);
    // skip objects whose box is out of reach
    if (geometry::CalcPointAabbDistanceSquared(c_W, object.bounds_W) > reach * reach) return true;
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(c_W), reach);
    if (!probe.found) return true;
    const double depth = r - probe.signed_distance;
    if (depth < -max_gap) return true;
    // the deepest; of equally deep ones, the first in the scene
    if (deepest.object >= 0 && (depth < deepest.depth || (depth == deepest.depth && i > deepest.object))) {
      return true;
    }
    deepest = ContactInWorld(object, i, probe, r);
    return true;
  });
  return deepest;
}

template <typename Objects>
SceneContact FindKinematicContactAmong(const scene::SceneSnapshot& scene, const Objects& objects, const Vector3& c_W,
                                       double reach) {
  SceneContact carrier;
  if (!c_W.allFinite() || !(reach >= 0)) return carrier;
  objects({c_W - Vector3::Constant(reach), c_W + Vector3::Constant(reach)}, [&](int i, const GatheredMesh&) {
    if (!geometry::WorkMeter::Charge(1)) return false;
    const scene::SceneObject& object = scene.object(i);
    if (object.motion != scene::Motion::kKinematic || (carrier.object >= 0 && i > carrier.object)) return true;
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(c_W), reach);
    if (!probe.found || probe.signed_distance > reach) return true;
    carrier = ContactInWorld(object, i, probe, reach);
    return true;
  });
  return carrier;
}

template <typename Objects>
SceneSweep SweepSphereSceneAmong(const scene::SceneSnapshot& scene, const Objects& objects, const Vector3& a_W,
                                 const Vector3& b_W, double r) {
  SceneSweep first;
  if (!a_W.allFinite() || !b_W.allFinite() || !(r >= 0) || a_W == b_W) return first;
  // the box swept by the sphere, to skip objects it cannot reach
  geometry::Aabb swept{a_W.cwiseMin(b_W) - Vector3::Constant(r), a_W.cwiseMax(b_W) + Vector3::Constant(r)};
  objects(swept, [&](int i, const GatheredMesh& mesh) {
    if (!geometry::WorkMeter::Charge(1)) return false;
    const scene::SceneObject& object = scene.object(i);
    const Vector3 a_B = object.X_WB.ToBody(a_W);
    const Vector3 b_B = object.X_WB.ToBody(b_W);
    const ShapeSweep sweep =
        mesh.gathered() ? SweepSphereShape(object.shape, a_B, b_B, r, mesh) : SweepSphereShape(object.shape, a_B, b_B, r);
    // the first contact; of simultaneous ones, the first object in the scene
    if (!sweep.hit || (first.hit && (sweep.t > first.t || (sweep.t == first.t && i > first.object)))) {
      return true;
    }
    first = SweepInWorld(object, i, sweep);
    return true;
  });
  return first;
}

// Appends each object a sphere of radius r at c_W touches (FindObjectContacts's rule)
// to out, in scene order; near is scratch for the objects' indices.
void AppendObjectContacts(const scene::SceneSnapshot& scene, const Vector3& c_W, double r, std::vector<int>& near,
                          std::vector<SceneContact>& out) {
  if (!c_W.allFinite() || !(r >= 0)) return;
  near.clear();
  scene.ForEachObjectNear({c_W - Vector3::Constant(r), c_W + Vector3::Constant(r)}, [&](int i) {
    near.push_back(i);
    return true;
  });
  std::sort(near.begin(), near.end());
  for (const int i : near) {
    const scene::SceneObject& object = scene.object(i);
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(c_W), r);
    if (!probe.found || probe.signed_distance > r) continue;
    out.push_back(ContactInWorld(object, i, probe, r));
  }
}

// A candidate of FindNearestSurface: an object, whether it is a mesh (a dear probe),
// and a lower bound on its signed distance from the point: the distance to its box from
// outside the box; from inside, minus the distance to the box's boundary (no solid
// inside the box reaches deeper). Ordered primitives first, then by bound, then by
// object.
struct NearCandidate {
  bool mesh;
  double bound;
  int object;
  bool operator<(const NearCandidate& other) const {
    return std::tie(mesh, bound, object) < std::tie(other.mesh, other.bound, other.object);
  }
};

// FindDeepestContact(scene, p_W, 0, max_gap), nearest first: the same objects are
// candidates, but probed cheapest and nearest first, each only as far as the nearest
// surface found so far, and not at all when its bound (NearCandidate) is above that:
// such an object cannot be nearer, nor as near and earlier in the scene (an object
// whose bound equals it is still probed). The primitives and hulls go first, then the
// meshes in the order of their bounds, so that the cheap probes tighten the reach of
// the dear ones and a point near a few objects probes only those, and not far,
// whatever else lies within max_gap. order is scratch.
SceneContact FindNearestSurface(const scene::SceneSnapshot& scene, const Vector3& p_W, double max_gap,
                                std::vector<NearCandidate>& order) {
  SceneContact nearest;
  if (!p_W.allFinite() || !(max_gap >= 0)) return nearest;
  order.clear();
  scene.ForEachObjectNear({p_W - Vector3::Constant(max_gap), p_W + Vector3::Constant(max_gap)}, [&](int i) {
    const scene::SceneObject& object = scene.object(i);
    // FindDeepestContactAmong's candidates: boxes within reach
    const double outside_sq = geometry::CalcPointAabbDistanceSquared(p_W, object.bounds_W);
    if (outside_sq > max_gap * max_gap) return true;
    const double bound = outside_sq > 0 ? std::sqrt(outside_sq)
                                        : -(p_W - object.bounds_W.min).cwiseMin(object.bounds_W.max - p_W).minCoeff();
    order.push_back({scene::TypeOf(object.shape) == scene::ShapeType::kMesh, bound, i});
    return true;
  });
  // a handful as a rule: an insertion sort
  for (std::size_t k = 1; k < order.size(); ++k) {
    const NearCandidate held = order[k];
    std::size_t j = k;
    for (; j > 0 && held < order[j - 1]; --j) order[j] = order[j - 1];
    order[j] = held;
  }
  for (const NearCandidate& candidate : order) {
    if (nearest.object >= 0 && candidate.bound > -nearest.depth) {
      // the meshes are in the order of their bounds: none after this one can be nearer
      if (candidate.mesh) break;
      continue;
    }
    // only a surface as near as the nearest so far can matter: a probe looks no farther
    // (a probe's answer does not depend on its reach once it finds the surface within
    // it; a point deeper inside a solid is found by the inside test whatever the reach)
    const double reach = nearest.object >= 0 ? std::min(max_gap, std::abs(nearest.depth)) : max_gap;
    const int i = candidate.object;
    const scene::SceneObject& object = scene.object(i);
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(p_W), reach);
    if (!probe.found || -probe.signed_distance < -max_gap) continue;
    // the deepest (nearest); of equally deep ones, the first in the scene
    const double depth = -probe.signed_distance;
    if (nearest.object >= 0 && (depth < nearest.depth || (depth == nearest.depth && i > nearest.object))) continue;
    nearest = ContactInWorld(object, i, probe, 0);
  }
  return nearest;
}

}  // namespace

SceneContact FindDeepestContact(const scene::SceneSnapshot& scene, const Vector3& c_W, double r,
                                double max_gap) {
  return FindDeepestContactAmong(scene, SceneObjects{scene}, c_W, r, max_gap);
}

SceneContact FindKinematicContact(const scene::SceneSnapshot& scene, const Vector3& c_W, double reach) {
  return FindKinematicContactAmong(scene, SceneObjects{scene}, c_W, reach);
}

SceneSweep SweepSphereScene(const scene::SceneSnapshot& scene, const Vector3& a_W,
                            const Vector3& b_W, double r) {
  return SweepSphereSceneAmong(scene, SceneObjects{scene}, a_W, b_W, r);
}

// The neighbourhood's answers: from the gathered objects when the query reaches no
// farther than they were gathered, else from the scene.

SceneContact FindDeepestContact(const Neighbourhood& near, const Vector3& c_W, double r, double max_gap) {
  if (near.CountAnswer(near.Holds(c_W, r + max_gap))) {
    return FindDeepestContactAmong(near.scene(), GatheredObjects{near}, c_W, r, max_gap);
  }
  return FindDeepestContact(near.scene(), c_W, r, max_gap);
}

SceneContact FindKinematicContact(const Neighbourhood& near, const Vector3& c_W, double reach) {
  if (near.CountAnswer(near.Holds(c_W, reach))) {
    return FindKinematicContactAmong(near.scene(), GatheredObjects{near}, c_W, reach);
  }
  return FindKinematicContact(near.scene(), c_W, reach);
}

SceneSweep SweepSphereScene(const Neighbourhood& near, const Vector3& a_W, const Vector3& b_W, double r) {
  // the objects left out cannot be touched while the sphere stays within the gathered
  // ball: up to the first contact among the gathered ones, or the whole way
  if (near.Holds(a_W, r)) {
    const SceneSweep first = SweepSphereSceneAmong(near.scene(), GatheredObjects{near}, a_W, b_W, r);
    const Vector3 last = first.hit ? Vector3(a_W + first.t * (b_W - a_W)) : b_W;
    if (near.CountAnswer(near.Holds(last, r))) return first;
  } else {
    near.CountAnswer(false);
  }
  return SweepSphereScene(near.scene(), a_W, b_W, r);
}

void CastSegments(const scene::SceneSnapshot& scene, std::span<const Vector3> a_W, std::span<const Vector3> b_W,
                  std::span<SceneSweep> out) {
  const std::size_t n = std::min({a_W.size(), b_W.size(), out.size()});
  geometry::Aabb reach;
  for (std::size_t i = 0; i < n; ++i) {
    out[i] = {};
    reach.Extend(a_W[i]);
    reach.Extend(b_W[i]);
  }
  std::vector<Vector3> a_B(n), b_B(n);
  std::vector<ShapeSweep> sweeps(n);
  // scene order, so that of simultaneous hits the first object's stays
  for (const int index : scene.ObjectsNear(reach)) {
    const scene::SceneObject& object = scene.object(index);
    for (std::size_t i = 0; i < n; ++i) {
      a_B[i] = object.X_WB.ToBody(a_W[i]);
      b_B[i] = object.X_WB.ToBody(b_W[i]);
    }
    SweepPointsShape(object.shape, a_B, b_B, sweeps);
    for (std::size_t i = 0; i < n; ++i) {
      const ShapeSweep& sweep = sweeps[i];
      if (!sweep.hit || (out[i].hit && sweep.t >= out[i].t)) continue;
      out[i] = SweepInWorld(object, index, sweep);
    }
  }
}

std::vector<SceneContact> FindObjectContacts(const scene::SceneSnapshot& scene, const Vector3& c_W, double r) {
  std::vector<SceneContact> contacts;
  std::vector<int> near;
  AppendObjectContacts(scene, c_W, r, near, contacts);
  return contacts;
}

void FindClosestPoints(const scene::SceneSnapshot& scene, std::span<const Vector3> p_W, double max_distance,
                       std::span<SceneContact> out) {
  const std::size_t n = std::min(p_W.size(), out.size());
  std::vector<NearCandidate> order;
  // a spent work budget stops the batch: its answers are thrown away (WorkMeter)
  for (std::size_t i = 0; i < n && !geometry::WorkMeter::Exhausted(); ++i) {
    out[i] = FindNearestSurface(scene, p_W[i], max_distance, order);
  }
}

bool FindObjectContactsBatch(const scene::SceneSnapshot& scene, std::span<const Vector3> c_W,
                             std::span<const double> r, std::size_t max_contacts, std::vector<SceneContact>& out,
                             std::span<int> counts) {
  const std::size_t n = std::min({c_W.size(), counts.size(), r.size() == 1 ? c_W.size() : r.size()});
  std::vector<int> near;
  for (std::size_t i = 0; i < n && !geometry::WorkMeter::Exhausted(); ++i) {
    const std::size_t before = out.size();
    AppendObjectContacts(scene, c_W[i], r.size() == 1 ? r[0] : r[i], near, out);
    // refuse rather than answer past the bound
    if (out.size() > max_contacts) return false;
    counts[i] = static_cast<int>(out.size() - before);
  }
  return true;
}

FeatureSet::FeatureSet(int capacity) : features_(std::max(capacity, 0)), scratch_(std::max(capacity, 0)) {}

void FindFeaturesWithin(const scene::SceneSnapshot& scene, const Vector3& c_W, double radius, FeatureSet& out) {
  out.count_ = 0;
  out.truncated_ = false;
  if (!c_W.allFinite() || !(radius >= 0) || !std::isfinite(radius) || out.capacity() == 0) return;
  // nearest first; of equally near ones, the first object and triangle (the heap's
  // top is the one to drop first)
  const auto nearer = [](const SceneFeature& x, const SceneFeature& y) {
    return std::tie(x.distance, x.object, x.triangle) < std::tie(y.distance, y.object, y.triangle);
  };
  const auto begin = out.features_.begin();
  const geometry::Aabb near{c_W - Vector3::Constant(radius), c_W + Vector3::Constant(radius)};
  scene.ForEachObjectNear(near, [&](int i) {
    if (!geometry::WorkMeter::Charge(1)) return false;
    const scene::SceneObject& object = scene.object(i);
    if (geometry::CalcPointAabbDistanceSquared(c_W, object.bounds_W) > radius * radius) return true;
    const int found = FindShapeFeatures(object.shape, object.X_WB.ToBody(c_W), radius, out.scratch_);
    const int kept = std::min(found, static_cast<int>(out.scratch_.size()));
    if (found > kept) out.truncated_ = true;
    for (int k = 0; k < kept; ++k) {
      const geometry::SphereMeshContact& piece = out.scratch_[k];
      const SceneFeature feature{i, piece.triangle, radius - piece.depth, object.X_WB.ToWorld(piece.point),
                                 object.X_WB.DirectionToWorld(piece.normal)};
      if (out.count_ < out.capacity()) {
        out.features_[out.count_++] = feature;
        std::push_heap(begin, begin + out.count_, nearer);
        continue;
      }
      out.truncated_ = true;
      if (!nearer(feature, out.features_.front())) continue;
      std::pop_heap(begin, begin + out.count_, nearer);
      out.features_[out.count_ - 1] = feature;
      std::push_heap(begin, begin + out.count_, nearer);
    }
    return true;
  });
  std::sort(begin, begin + out.count_, [](const SceneFeature& x, const SceneFeature& y) {
    return std::tie(x.object, x.triangle) < std::tie(y.object, y.triangle);
  });
}

Vector3 CalcSceneShadingNormal(const scene::SceneSnapshot& scene, int object, int triangle,
                               const Vector3& point_W, const Vector3& normal_W) {
  const scene::SceneObject& touched = scene.object(object);
  return touched.X_WB.DirectionToWorld(
      CalcShadingNormal(touched.shape, triangle, touched.X_WB.ToBody(point_W),
                        touched.X_WB.DirectionToBody(normal_W)));
}

}  // namespace hapticd::query
