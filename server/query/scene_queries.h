#pragma once

// Every question asked of a scene snapshot, in the world frame W: the shape queries of
// shape_queries.h asked of the objects whose bounds can matter (the snapshot's broad
// phase finds them, so a query's cost grows with the objects near it) and combined.
// The force code, the control service, the ray batch and the conformance runner all ask
// here; none of them walks the objects or picks a backend itself.

#include <span>
#include <vector>

#include "server/query/shape_queries.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::query {

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

// The first kinematic object in the scene among those a sphere of radius reach >= 0 at
// c_W touches (what a proxy resting on it is carried by), with its nearest point (depth =
// reach - signed distance); object -1 when none. Real-time safe.
SceneContact FindKinematicContact(const scene::SceneSnapshot& scene, const Vector3& c_W, double reach);

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

// The first crossing of each segment a_W[i] -> b_W[i] (a point's sweep: SweepSphereScene
// with r = 0), for the first min(sizes) segments; of simultaneous ones, the first object
// in the scene. Meshes trace all segments together on their backend. Stops early once
// the thread's work meter is spent (the answers are then incomplete). Allocates: for the
// control thread.
void CastSegments(const scene::SceneSnapshot& scene, std::span<const Vector3> a_W, std::span<const Vector3> b_W,
                  std::span<SceneSweep> out);

// Each object a sphere of radius r >= 0 at c_W touches (signed distance <= r), with its
// nearest surface point: depth = r - signed distance, in scene order. Allocates: for the
// control thread.
std::vector<SceneContact> FindObjectContacts(const scene::SceneSnapshot& scene, const Vector3& c_W, double r);

// The batch forms of the two queries above, one snapshot for all points (the control
// channel's ClosestPointBatch and FindContactsBatch).
//
// out[i] = FindDeepestContact(scene, p_W[i], 0, max_distance) for the first min(sizes)
// points: each point's nearest surface point within max_distance (>= 0, m), depth =
// -signed distance; object -1 where none lies within reach or p_W[i] is not finite.
// The same answers, found nearest first: the objects near a point are probed in the
// order of a bound on their signed distance (from their boxes) until none left can be
// nearer, so a large max_distance costs little more than a small one. Stops early once
// the thread's work meter is spent. Allocates: for the control thread.
void FindClosestPoints(const scene::SceneSnapshot& scene, std::span<const Vector3> p_W, double max_distance,
                       std::span<SceneContact> out);

// FindObjectContacts for each sphere i (centre c_W[i], radius r[i], or r[0] for every
// centre when r holds one value; each >= 0) in turn: appends its contacts to out (after
// what out held) and sets counts[i] to their number, for the first min(c_W.size(),
// counts.size(), r.size() unless 1) centres. Returns false, with out and counts partly
// filled, as soon as out holds more than max_contacts; stops early (returning true)
// once the thread's work meter is spent. Allocates: for the control thread.
bool FindObjectContactsBatch(const scene::SceneSnapshot& scene, std::span<const Vector3> c_W,
                             std::span<const double> r, std::size_t max_contacts, std::vector<SceneContact>& out,
                             std::span<int> counts);

// One piece of surface near a point: a whole primitive, plane or hull, or one triangle
// of a mesh, with its object (whose material, motion and velocity say how it feels).
struct SceneFeature {
  int object = -1;
  int triangle = -1;                    // a mesh's triangle; -1: the whole shape
  double distance = 0;                  // from the point (< 0: inside a solid), m
  Vector3 point_W = Vector3::Zero();    // its point nearest the point
  Vector3 normal_W = Vector3::UnitZ();  // unit, from the surface towards the point
};

// What FindFeaturesWithin found: at most capacity features, kept without allocating
// (the buffers are made once, off the real-time thread).
class FeatureSet {
 public:
  explicit FeatureSet(int capacity);
  // The features found, sorted by object, then triangle.
  std::span<const SceneFeature> features() const { return {features_.data(), static_cast<size_t>(count_)}; }
  int capacity() const { return static_cast<int>(features_.size()); }
  // More features lay within the radius than capacity: the nearest capacity were kept
  // (ties by object, then triangle).
  bool truncated() const { return truncated_; }

 private:
  friend void FindFeaturesWithin(const scene::SceneSnapshot& scene, const Vector3& c_W, double radius,
                                 FeatureSet& out);
  std::vector<SceneFeature> features_;
  std::vector<geometry::SphereMeshContact> scratch_;
  int count_ = 0;
  bool truncated_ = false;
};

// Every piece of surface within radius (finite, >= 0) of c_W, over all objects
// (FindShapeFeatures per object). Replaces what out held. Native and Embree meshes give
// the same set. Real-time safe.
void FindFeaturesWithin(const scene::SceneSnapshot& scene, const Vector3& c_W, double radius, FeatureSet& out);

// CalcShadingNormal for a contact with object at point_W (unit normal_W), in W.
Vector3 CalcSceneShadingNormal(const scene::SceneSnapshot& scene, int object, int triangle,
                               const Vector3& point_W, const Vector3& normal_W);

}  // namespace hapticd::query
