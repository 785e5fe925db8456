// Mesh validation: a mesh as a client sends it (vertices, index triples, a pinned
// representation, a backend) through SceneBuilder::Add (geometry::TriangleMesh's checks,
// the representation choice, hull and BVH), then the queries a tick makes on it.
//
// The input is decoded with FuzzedDataProvider into a few header choices, up to 48
// vertices (on a coarse grid, so that coincident, collinear and duplicate ones are
// common; slightly off it; or any 8 bytes, NaN and infinities included) and up to 96
// triangles (indices from -1 to one past the last vertex). Checks: a refusal is a
// SceneError naming the object; an accepted object passes CheckSceneObject
// (scene_checks.h) and keeps a pinned representation; the nearest-surface query and a
// sweep towards its centre answer with finite points, unit normals, and t in [0, 1].

#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "server/query/scene_queries.h"
#include "server/fuzz/scene_checks.h"
#include "server/scene/scene_builder.h"

namespace hapticd::fuzz {
namespace {

using geometry::Vector3;

constexpr int kMaxVertices = 48;
constexpr int kMaxTriangles = 96;

double ConsumeCoordinate(FuzzedDataProvider& input) {
  switch (input.ConsumeIntegralInRange(0, 3)) {
    case 0:
    case 1: return 0.25 * input.ConsumeIntegralInRange(-4, 4);
    case 2: return 0.25 * input.ConsumeIntegralInRange(-4, 4) + 1e-9 * input.ConsumeIntegralInRange(-8, 8);
    default: {
      const uint64_t bits = input.ConsumeIntegral<uint64_t>();
      double x;
      std::memcpy(&x, &bits, sizeof x);
      return x;
    }
  }
}

scene::ObjectSpec ConsumeMeshObject(FuzzedDataProvider& input) {
  scene::ObjectSpec spec;
  spec.name = "mesh";
  spec.material.stiffness = 1000;
  scene::MeshSpec mesh;
  mesh.pin = static_cast<scene::Representation>(
      input.ConsumeIntegralInRange(0, static_cast<int>(scene::Representation::kCount) - 1));
  if (input.ConsumeIntegralInRange(0, 3) == 0) spec.ray_backend = scene::RayBackend::kEmbree;
  spec.X_WB.translation = {ConsumeCoordinate(input), 0, 0};
  const int num_vertices = input.ConsumeIntegralInRange(0, kMaxVertices);
  for (int i = 0; i < num_vertices; ++i) {
    const double x = ConsumeCoordinate(input);
    const double y = ConsumeCoordinate(input);
    mesh.vertices.emplace_back(x, y, ConsumeCoordinate(input));
  }
  const int num_triangles = input.ConsumeIntegralInRange(0, kMaxTriangles);
  for (int t = 0; t < num_triangles && input.remaining_bytes() > 0; ++t) {
    std::array<int, 3> triangle;
    for (int& index : triangle) index = input.ConsumeIntegralInRange(-1, num_vertices);
    mesh.triangles.push_back(triangle);
  }
  spec.shape = std::move(mesh);
  return spec;
}

bool IsUnit(const Vector3& n) { return std::abs(n.norm() - 1) <= 1e-6; }

// The nearest-surface query and a sweep, as a tick asks them, from a few places.
void CheckQueries(const scene::SceneSnapshot& snapshot) {
  const scene::SceneObject& object = snapshot.object(0);
  const Vector3 center = object.bounds_W.center();
  const Vector3 corner = object.bounds_W.max;
  const double size = object.bounds_W.size().norm();
  for (const Vector3& p_W : {center, corner, Vector3(center + Vector3(0.01, 0.02, 0.03) * size)}) {
    if (!p_W.allFinite()) continue;
    const query::SceneContact contact = query::FindDeepestContact(snapshot, p_W, 0, size);
    if (contact.object < 0) continue;
    FUZZ_CHECK(contact.object == 0, "a contact with object %d of 1", contact.object);
    FUZZ_CHECK(std::isfinite(contact.depth) && contact.point_W.allFinite() &&
                   IsUnit(contact.normal_W),
               "a contact of depth %g at [%g %g %g] with a normal of length %g", contact.depth, contact.point_W.x(),
               contact.point_W.y(), contact.point_W.z(), contact.normal_W.norm());
  }
  const Vector3 outside = corner + Vector3::Constant(0.5 * size + 0.1);
  if (!outside.allFinite() || !center.allFinite()) return;
  for (const double r : {0.0, 0.01 * size}) {
    const query::SceneSweep sweep = query::SweepSphereScene(snapshot, outside, center, r);
    if (!sweep.hit) continue;
    FUZZ_CHECK(sweep.object == 0 && sweep.t >= 0 && sweep.t <= 1 && sweep.point_W.allFinite() &&
                   IsUnit(sweep.normal_W),
               "a sweep (r %g) hit object %d at t %g with a normal of length %g", r, sweep.object, sweep.t,
               sweep.normal_W.norm());
  }
}

}  // namespace
}  // namespace hapticd::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace hapticd;
  FuzzedDataProvider input(data, size);
  const scene::ObjectSpec spec = fuzz::ConsumeMeshObject(input);
  const auto pin = std::get<scene::MeshSpec>(spec.shape).pin;
  scene::SceneBuilder builder;
  try {
    builder.Add(spec);
  } catch (const scene::SceneError& error) {
    FUZZ_CHECK(std::string(error.what()).starts_with("objects[mesh]"), "a SceneError that does not name the object: %s",
               error.what());
    return 0;
  }
  const auto snapshot = builder.Build(1);
  FUZZ_CHECK(snapshot->num_objects() == 1, "one object added, %d in the snapshot", snapshot->num_objects());
  const scene::SceneObject& object = snapshot->object(0);
  fuzz::CheckSceneObject(object);
  if (pin != scene::Representation::kAuto) {
    FUZZ_CHECK(object.representation.chosen == pin, "pinned %d, represented as %d", static_cast<int>(pin),
               static_cast<int>(object.representation.chosen));
  }
  fuzz::CheckQueries(*snapshot);
  return 0;
}
