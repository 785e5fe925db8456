#pragma once
// Invariants of what the scene's validation boundary accepts (scene_builder.h), shared by
// the targets whose input ends up as scene objects: every built object has a finite
// pose with an orthonormal rotation, a usable material, bounds that are not NaN (finite
// but for a plane), and a mesh's representation a non-NaN error bound.

#include <cmath>
#include <string>
#include <variant>

#include "server/fuzz/fuzz_check.h"
#include "server/scene/material.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::fuzz {

inline void CheckSceneObject(const scene::SceneObject& object) {
  const char* name = object.name.c_str();
  FUZZ_CHECK(!object.name.empty(), "an object without a name");
  FUZZ_CHECK(object.X_WB.translation.allFinite() && object.X_WB.rotation.allFinite(),
             "objects[%s] has a non-finite pose", name);
  const double orthonormality =
      (object.X_WB.rotation.transpose() * object.X_WB.rotation - geometry::Matrix3::Identity()).norm();
  FUZZ_CHECK(orthonormality <= 1e-5 && object.X_WB.rotation.determinant() > 0,
             "objects[%s] has a rotation %g from orthonormal (det %g)", name, orthonormality,
             object.X_WB.rotation.determinant());
  const auto problem = scene::ValidateMaterial(object.material, "material");
  FUZZ_CHECK(!problem, "objects[%s]: %s", name, problem ? problem->c_str() : "");
  FUZZ_CHECK(object.v_WB.allFinite() && object.w_WB.allFinite(), "objects[%s] has a non-finite velocity", name);
  FUZZ_CHECK(!object.bounds_W.min.hasNaN() && !object.bounds_W.max.hasNaN() && !object.bounds_W.empty(),
             "objects[%s] has bounds [%g %g %g] - [%g %g %g]", name, object.bounds_W.min.x(), object.bounds_W.min.y(),
             object.bounds_W.min.z(), object.bounds_W.max.x(), object.bounds_W.max.y(), object.bounds_W.max.z());
  if (!std::holds_alternative<scene::PlaneShape>(object.shape)) {
    FUZZ_CHECK(object.bounds_W.min.allFinite() && object.bounds_W.max.allFinite(),
               "objects[%s] (not a plane) has infinite bounds", name);
  }
  if (object.representation.chosen != scene::Representation::kAuto) {
    FUZZ_CHECK(object.representation.error_bound >= 0, "objects[%s] has a representation error bound of %g", name,
               object.representation.error_bound);
  }
  if (const auto* mesh = std::get_if<scene::MeshShape>(&object.shape)) {
    FUZZ_CHECK(mesh->bvh != nullptr, "objects[%s] is a mesh without a BVH", name);
    FUZZ_CHECK(!mesh->bvh->mesh().nondegenerate_triangles().empty(), "objects[%s] is a mesh of no area", name);
  }
}

inline void CheckSnapshot(const scene::SceneSnapshot& snapshot) {
  for (int i = 0; i < snapshot.num_objects(); ++i) {
    const scene::SceneObject& object = snapshot.object(i);
    CheckSceneObject(object);
    FUZZ_CHECK(snapshot.FindObject(object.name) == i, "objects[%s] is object %d but found at %d",
               object.name.c_str(), i, snapshot.FindObject(object.name));
  }
}

}  // namespace hapticd::fuzz
