#include "server/net/ray_batch.h"

#include <cmath>
#include <limits>
#include <vector>

#include <fmt/format.h>

#include "server/embree/embree_segment_queries.h"
#include "server/force/shape_queries.h"
#include "server/net/proto_convert.h"
#include "server/net/request_error.h"

namespace hapticd::net {
namespace {

using geometry::Vector3;

// The most segments one request may hold (its frame is bounded anyway).
constexpr int kMaxSegments = 1'000'000;

// The best hit so far of one segment, in W.
struct BatchHit {
  double t = std::numeric_limits<double>::infinity();  // along origin -> end, in [0, 1]
  int object = -1;
  Vector3 point_W = Vector3::Zero();
  Vector3 normal_W = Vector3::Zero();
};

// The segments of a mesh on the Embree backend, in packets, in the mesh's frame.
void TraceMesh(const scene::SceneObject& object, const embree::EmbreeMesh& mesh, int index,
               const std::vector<Vector3>& a_W, const std::vector<Vector3>& b_W, std::vector<BatchHit>& best) {
  const std::size_t n = a_W.size();
  std::vector<Vector3> a_B(n), b_B(n);
  for (std::size_t i = 0; i < n; ++i) {
    a_B[i] = object.X_WB.ToBody(a_W[i]);
    b_B[i] = object.X_WB.ToBody(b_W[i]);
  }
  std::vector<geometry::SegmentMeshHit> hits(n);
  embree::FindFirstSegmentHits(mesh, a_B, b_B, hits);
  const geometry::TriangleMesh& triangles = mesh.mesh();
  for (std::size_t i = 0; i < n; ++i) {
    if (!hits[i].hit || hits[i].t >= best[i].t) continue;
    // a segment touching the surface where it starts hits by the closed-set rule; a ray
    // does only when it goes into the solid: the point sweep decides, as for one ray
    if (hits[i].t == 0) {
      const force::ShapeSweep sweep = force::SweepSphereShape(object.shape, a_B[i], b_B[i], 0);
      if (sweep.hit && sweep.t < best[i].t) {
        best[i] = {sweep.t, index, object.X_WB.ToWorld(sweep.point_B), object.X_WB.DirectionToWorld(sweep.normal_B)};
      }
      continue;
    }
    const Vector3 point_B = a_B[i] + hits[i].t * (b_B[i] - a_B[i]);
    // the face normal, turned towards the segment's origin
    Vector3 normal_B = triangles.face_normal(hits[i].triangle);
    if (normal_B.dot(a_B[i] - point_B) < 0) normal_B = -normal_B;
    best[i] = {hits[i].t, index, object.X_WB.ToWorld(point_B), object.X_WB.DirectionToWorld(normal_B)};
  }
}

// The segments against any other object, one exact point sweep each.
void SweepObject(const scene::SceneObject& object, int index, const std::vector<Vector3>& a_W,
                 const std::vector<Vector3>& b_W, std::vector<BatchHit>& best) {
  for (std::size_t i = 0; i < a_W.size(); ++i) {
    const force::ShapeSweep sweep =
        force::SweepSphereShape(object.shape, object.X_WB.ToBody(a_W[i]), object.X_WB.ToBody(b_W[i]), 0);
    if (!sweep.hit || sweep.t >= best[i].t) continue;
    best[i] = {sweep.t, index, object.X_WB.ToWorld(sweep.point_B), object.X_WB.DirectionToWorld(sweep.normal_B)};
  }
}

}  // namespace

v1::RayHits CastRayBatch(const scene::SceneSnapshot& scene, const v1::RayCastBatch& batch) {
  // the segments, checked
  const auto& origins = batch.origins();
  const auto& directions = batch.directions();
  if (origins.size() % 3 != 0 || origins.size() != directions.size()) {
    throw BadRequest(fmt::format("ray_cast_batch has {} origin and {} direction values; it needs x, y, z "
                                 "of each, as many of one as of the other",
                                 origins.size(), directions.size()));
  }
  const int n = origins.size() / 3;
  if (n > kMaxSegments) {
    throw BadRequest(fmt::format("ray_cast_batch has {} segments; at most {} are served", n, kMaxSegments));
  }
  const double length = RequirePositive(batch.max_distance(), "ray_cast_batch.max_distance");
  std::vector<Vector3> a_W(n), b_W(n);
  for (int i = 0; i < n; ++i) {
    const Vector3 origin(origins[3 * i], origins[3 * i + 1], origins[3 * i + 2]);
    const Vector3 direction(directions[3 * i], directions[3 * i + 1], directions[3 * i + 2]);
    if (!origin.allFinite() || !direction.allFinite() || !(direction.norm() > 0)) {
      throw BadRequest(fmt::format("ray_cast_batch segment {} has origin [{}, {}, {}] and direction [{}, {}, {}]; "
                                   "both must be finite and the direction non-zero",
                                   i, origin.x(), origin.y(), origin.z(), direction.x(), direction.y(),
                                   direction.z()));
    }
    a_W[i] = origin;
    b_W[i] = origin + direction.normalized() * length;
  }

  // the objects the segments' box meets, in scene order, keeping each segment's
  // earliest hit
  geometry::Aabb reach;
  for (int i = 0; i < n; ++i) {
    reach.Extend(a_W[i]);
    reach.Extend(b_W[i]);
  }
  std::vector<BatchHit> best(n);
  for (const int index : scene.ObjectsNear(reach)) {
    const scene::SceneObject& object = scene.object(index);
    const auto* mesh = std::get_if<scene::MeshShape>(&object.shape);
    if (mesh != nullptr && mesh->embree) {
      TraceMesh(object, *mesh->embree, index, a_W, b_W, best);
    } else {
      SweepObject(object, index, a_W, b_W, best);
    }
  }

  v1::RayHits hits;
  for (const BatchHit& hit : best) {
    const bool found = hit.object >= 0;
    hits.add_hit(found);
    hits.add_distance(found ? hit.t * length : 0);
    for (int k = 0; k < 3; ++k) hits.add_points(hit.point_W[k]);
    for (int k = 0; k < 3; ++k) hits.add_normals(hit.normal_W[k]);
    hits.add_objects(found ? scene.object(hit.object).name : "");
  }
  return hits;
}

}  // namespace hapticd::net
