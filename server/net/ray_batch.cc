#include "server/net/ray_batch.h"

#include <vector>

#include <fmt/format.h>

#include "server/net/proto_convert.h"
#include "server/query/scene_queries.h"
#include "server/net/request_error.h"

namespace hapticd::net {

using geometry::Vector3;

v1::RayHits CastRayBatch(const scene::SceneSnapshot& scene, const v1::RayCastBatch& batch) {
  // the segments, checked: one origin per direction, or one origin for them all
  const auto& origins = batch.origins();
  const auto& directions = batch.directions();
  const bool one_origin = origins.size() == 3;
  if (directions.size() % 3 != 0 || (!one_origin && origins.size() != directions.size())) {
    throw BadRequest(fmt::format("ray_cast_batch has {} origin and {} direction values; it needs x, y, z "
                                 "of each, and one origin for every direction or one per direction",
                                 origins.size(), directions.size()));
  }
  const int n = directions.size() / 3;
  if (n > kMaxRaySegments) {
    throw BadRequest(fmt::format("ray_cast_batch has {} segments; at most {} are served", n, kMaxRaySegments));
  }
  const double length = RequirePositive(batch.max_distance(), "ray_cast_batch.max_distance");
  std::vector<Vector3> a_W(n), b_W(n);
  for (int i = 0; i < n; ++i) {
    const int o = one_origin ? 0 : 3 * i;
    const Vector3 origin(origins[o], origins[o + 1], origins[o + 2]);
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

  std::vector<query::SceneSweep> best(n);
  query::CastSegments(scene, a_W, b_W, best);

  v1::RayHits hits;
  for (const query::SceneSweep& hit : best) {
    hits.add_hit(hit.hit);
    hits.add_distance(hit.hit ? hit.t * length : 0);
    const Vector3 point = hit.hit ? hit.point_W : Vector3::Zero();
    const Vector3 normal = hit.hit ? hit.normal_W : Vector3::Zero();
    for (int k = 0; k < 3; ++k) hits.add_points(point[k]);
    for (int k = 0; k < 3; ++k) hits.add_normals(normal[k]);
    hits.add_objects(hit.hit ? scene.object(hit.object).name : "");
  }
  return hits;
}

}  // namespace hapticd::net
