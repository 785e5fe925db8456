#pragma once

// What a render tick gathers of the scene around its avatar once, so that its several
// queries (the carry, the push-outs, each sweep of the proxy's passes) are asked of a
// few objects and triangles instead of the whole scene.
//
// Theory of operation. Gather(scene, a_W, b_W, radius) keeps, in scene order, every
// object whose bounds may lie within radius of the segment a_W -> b_W (the region: a
// ball when a_W == b_W), and for each mesh among them every triangle that may
// (geometry::GatherMeshTriangles, prepared for sweeping). Whatever was left out is then
// farther than radius from the segment. A proxy gathers along the path it expects to
// take: the region is a sausage, not the ball around it, so on a dense surface it holds
// far fewer triangles. Each query below is scene_queries.h's query of the same name with
// the same answer:
//  - asked of the gathered objects when everything it can reach lies within the region
//    (a sweep: up to its first contact), otherwise of the whole scene;
//  - on a gathered mesh, its nearest triangle and its sweep asked of the gathered
//    triangles where they decide them, otherwise of the mesh (gathered_mesh.h).
// Only which of several triangles touched at exactly the same t (or equally near) is
// named may differ from the whole scene's answer. The buffers are made once, with fixed
// capacity; more objects near c_W than they hold leave the neighbourhood empty (every
// query asks the scene), a mesh with more triangles there than are left has its queries
// asked of the whole mesh. Nothing here allocates after construction.
//
//        scene (broad phase, BVHs)
//            |  Gather, once a tick
//            v
//   objects + triangles within the region -------> FindKinematicContact, FindDeepestContact,
//            |  (a query reaching past radius)      SweepSphereScene (one per pass)
//            +----> asks the scene instead

#include <cstdint>
#include <vector>

#include "server/query/gathered_mesh.h"
#include "server/query/scene_queries.h"

namespace hapticd::query {

// Capacity of a session's neighbourhood: objects near the avatar, and mesh triangles
// (enough for a 5 mm sphere sliding on a mesh of 0.2 mm triangles).
inline constexpr int kDefaultNeighbourObjects = 256;
inline constexpr int kDefaultNeighbourTriangles = 2048;

class Neighbourhood {
 public:
  // Empty, on scene: every query asks scene (the direct path; no buffers, so no
  // allocation).
  explicit Neighbourhood(const scene::SceneSnapshot& scene);
  // Buffers for max_objects objects and max_triangles triangles (allocates: off the
  // real-time thread); empty until the first Gather. 0 and 0: never gathers.
  Neighbourhood(int max_objects, int max_triangles);
  Neighbourhood(const Neighbourhood&) = delete;
  Neighbourhood& operator=(const Neighbourhood&) = delete;

  // Gathers what of scene lies within radius (>= 0, finite) of the segment a_W -> b_W,
  // replacing what it held: the objects, and with triangles the meshes' triangles there
  // (worth it for a sphere's sweeps, which meet many of a mesh's BVH boxes; a point's
  // sweep is one cheap segment traversal). Non-finite input, or more objects there than
  // it holds, leaves it empty on scene. Charges the work meter one unit per object
  // visited (and the meshes' traversal units). Real-time safe.
  void Gather(const scene::SceneSnapshot& scene, const Vector3& a_W, const Vector3& b_W, double radius,
              bool triangles = true);
  // The same about one point: the ball of radius about c_W.
  void Gather(const scene::SceneSnapshot& scene, const Vector3& c_W, double radius, bool triangles = true) {
    Gather(scene, c_W, c_W, radius, triangles);
  }

  const scene::SceneSnapshot& scene() const { return *scene_; }
  // Whether it holds what lies within the region; false: every query asks the scene.
  bool gathered() const { return region_W_.radius >= 0; }
  // The segment and radius gathered about (radius < 0: nothing gathered).
  const geometry::Capsule& region_W() const { return region_W_; }
  int num_objects() const { return num_objects_; }
  int num_triangles() const { return num_triangles_; }

  // Queries answered from what was gathered, and asked of the scene instead, since
  // construction (for benchmarks and tests).
  int64_t local_answers() const { return local_answers_; }
  int64_t scene_answers() const { return scene_answers_; }

  // For the queries (scene_queries.cc): whether everything within reach of p_W lies
  // within the region (false when nothing is gathered).
  bool Holds(const Vector3& p_W, double reach) const {
    if (!gathered()) return false;
    return geometry::CalcPointSegmentDistance(p_W, region_W_.p0, region_W_.p1) + reach + kGatheredSlack <=
           region_W_.radius;
  }
  // Calls visit(i, mesh) for each gathered object i whose bounds overlap box (closed;
  // objects without finite bounds always), in scene order, until a visit returns false;
  // mesh: the triangles gathered of it (none gathered, or not a mesh: !mesh.gathered()).
  template <typename Visit>
  void ForEachObjectNear(const geometry::Aabb& box, Visit visit) const {
    for (int k = 0; k < num_objects_; ++k) {
      const Object& object = objects_[k];
      if (object.bounded && !geometry::AabbsOverlap(scene_->object(object.index).bounds_W, box)) continue;
      if (!visit(object.index, object.mesh)) return;
    }
  }
  // Counts a query answered here (local) or asked of the scene; returns local.
  bool CountAnswer(bool local) const {
    ++(local ? local_answers_ : scene_answers_);
    return local;
  }

 private:
  struct Object {
    int index = -1;        // in the snapshot
    bool bounded = true;   // finite bounds (the broad phase's test applies)
    GatheredMesh mesh;     // a mesh's triangles (none gathered: asked of the whole mesh)
  };

  const scene::SceneSnapshot* scene_ = nullptr;
  geometry::Capsule region_W_{Vector3::Zero(), Vector3::Zero(), -1};
  std::vector<Object> objects_;
  int num_objects_ = 0;
  std::vector<geometry::PreparedTriangle> triangles_;
  int num_triangles_ = 0;
  scene::NearCache near_cache_;  // the broad phase's memory of where it gathered
  mutable int64_t local_answers_ = 0;
  mutable int64_t scene_answers_ = 0;
};

// scene_queries.h's FindDeepestContact, asked of near. Real-time safe.
SceneContact FindDeepestContact(const Neighbourhood& near, const Vector3& c_W, double r, double max_gap);

// scene_queries.h's FindKinematicContact, asked of near. Real-time safe.
SceneContact FindKinematicContact(const Neighbourhood& near, const Vector3& c_W, double reach);

// scene_queries.h's SweepSphereScene, asked of near. Real-time safe.
SceneSweep SweepSphereScene(const Neighbourhood& near, const Vector3& a_W, const Vector3& b_W, double r);

}  // namespace hapticd::query
