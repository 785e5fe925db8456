#include "server/net/point_batches.h"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "server/net/proto_convert.h"
#include "server/net/request_error.h"
#include "server/query/scene_queries.h"

namespace hapticd::net {
namespace {

using geometry::Vector3;

// The points of a flat x0 y0 z0 x1 ... array, each finite; RequestError naming field
// (and the point by its index) otherwise.
std::vector<Vector3> ReadPoints(const google::protobuf::RepeatedField<double>& values, const std::string& field) {
  if (values.size() % 3 != 0) {
    throw BadRequest(fmt::format("{} has {} values; it needs x, y, z of each point", field, values.size()));
  }
  const int n = values.size() / 3;
  if (n > kMaxBatchPoints) {
    throw BadRequest(fmt::format("{} has {} points; at most {} are served in one request", field, n,
                                 kMaxBatchPoints));
  }
  std::vector<Vector3> points(n);
  for (int i = 0; i < n; ++i) {
    points[i] = Vector3(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
    if (!points[i].allFinite()) {
      throw BadRequest(fmt::format("{}[{}] is [{}, {}, {}]; every point must be finite", field, i, points[i].x(),
                                   points[i].y(), points[i].z()));
    }
  }
  return points;
}

// Writes n vectors into a repeated double field as x0 y0 z0 x1 ... at once.
template <typename Get>
void WriteVectors(int n, Get get, google::protobuf::RepeatedField<double>* out) {
  out->Resize(3 * n, 0.0);
  double* data = out->mutable_data();
  for (int i = 0; i < n; ++i) {
    const Vector3 v = get(i);
    data[3 * i] = v.x();
    data[3 * i + 1] = v.y();
    data[3 * i + 2] = v.z();
  }
}

// Names each object index that occurs in objects (-1 left out), ascending.
void WriteObjectNames(const scene::SceneSnapshot& scene, const google::protobuf::RepeatedField<int32_t>& objects,
                      v1::ObjectNames* out) {
  std::vector<char> named(scene.num_objects(), 0);
  for (const int32_t i : objects) {
    if (i >= 0) named[i] = 1;
  }
  for (int i = 0; i < scene.num_objects(); ++i) {
    if (!named[i]) continue;
    out->add_indices(i);
    out->add_names(scene.object(i).name);
  }
}

}  // namespace

v1::ClosestPoints FindClosestPointBatch(const scene::SceneSnapshot& scene, const v1::ClosestPointBatch& batch) {
  const std::vector<Vector3> p_W = ReadPoints(batch.points(), "closest_point_batch.points");
  const double max_distance = RequirePositive(batch.max_distance(), "closest_point_batch.max_distance");
  const int n = static_cast<int>(p_W.size());
  std::vector<query::SceneContact> nearest(n);
  query::FindClosestPoints(scene, p_W, max_distance, nearest);

  // the answers, column by column
  v1::ClosestPoints out;
  out.set_scene_version(scene.version());
  out.mutable_found()->Resize(n, false);
  out.mutable_signed_distance()->Resize(n, 0.0);
  out.mutable_objects()->Resize(n, -1);
  for (int i = 0; i < n; ++i) {
    const bool found = nearest[i].object >= 0;
    out.set_found(i, found);
    out.set_signed_distance(i, found ? -nearest[i].depth : std::numeric_limits<double>::infinity());
    out.set_objects(i, nearest[i].object);
  }
  WriteVectors(
      n, [&](int i) { return nearest[i].object >= 0 ? nearest[i].point_W : Vector3::Zero(); }, out.mutable_points());
  WriteVectors(
      n, [&](int i) { return nearest[i].object >= 0 ? nearest[i].normal_W : Vector3::Zero(); },
      out.mutable_normals());
  WriteObjectNames(scene, out.objects(), out.mutable_object_names());
  return out;
}

v1::ContactsBatch FindBatchContacts(const scene::SceneSnapshot& scene, const v1::FindContactsBatch& batch) {
  const std::vector<Vector3> c_W = ReadPoints(batch.centers(), "find_contacts_batch.centers");
  const int n = static_cast<int>(c_W.size());
  // one radius for all, or one per centre; each finite and >= 0
  const auto& radii = batch.radii();
  if (radii.size() != 1 && radii.size() != n) {
    throw BadRequest(fmt::format("find_contacts_batch.radii has {} values for {} centers; it needs one for "
                                 "every center or one per center",
                                 radii.size(), n));
  }
  for (int i = 0; i < radii.size(); ++i) {
    if (!(std::isfinite(radii[i]) && radii[i] >= 0)) {
      throw BadRequest(
          fmt::format("find_contacts_batch.radii[{}] is {}; it must be a finite number >= 0", i, radii[i]));
    }
  }
  std::vector<query::SceneContact> contacts;
  std::vector<int> counts(n, 0);
  if (!query::FindObjectContactsBatch(scene, c_W, {radii.data(), static_cast<std::size_t>(radii.size())},
                                      kMaxBatchContacts, contacts, counts)) {
    throw RequestError(v1::Error::CODE_RESOURCE_EXHAUSTED,
                       fmt::format("find_contacts_batch finds more than {} contacts for its {} centers, the most "
                                   "one reply holds; ask fewer centers or a smaller radius",
                                   kMaxBatchContacts, n));
  }

  // the contacts laid end to end, column by column
  v1::ContactsBatch out;
  out.set_scene_version(scene.version());
  out.mutable_counts()->Reserve(n);
  for (const int count : counts) out.add_counts(count);
  const int m = static_cast<int>(contacts.size());
  out.mutable_objects()->Resize(m, -1);
  out.mutable_depths()->Resize(m, 0.0);
  for (int k = 0; k < m; ++k) {
    out.set_objects(k, contacts[k].object);
    out.set_depths(k, contacts[k].depth);
  }
  WriteVectors(m, [&](int k) { return contacts[k].point_W; }, out.mutable_points());
  WriteVectors(m, [&](int k) { return contacts[k].normal_W; }, out.mutable_normals());
  WriteObjectNames(scene, out.objects(), out.mutable_object_names());
  return out;
}

}  // namespace hapticd::net
