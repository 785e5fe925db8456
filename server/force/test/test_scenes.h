#pragma once

// Scenes for the force tests, built through the scene's own builder (as a client would).

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/mesh_generators.h"
#include "server/scene/scene_builder.h"

namespace hapticd::force::testing {

using scene::ObjectSpec;
using scene::Pose;

inline scene::Material MakeMaterial(double stiffness, double damping = 0, double static_friction = 0,
                                    double dynamic_friction = 0) {
  scene::Material material;
  material.stiffness = stiffness;
  material.damping = damping;
  material.static_friction = static_friction;
  material.dynamic_friction = dynamic_friction;
  return material;
}

inline ObjectSpec MakeObject(std::string name, scene::ShapeSpec shape, const Vector3& position,
                             const scene::Material& material) {
  ObjectSpec spec;
  spec.name = std::move(name);
  spec.shape = std::move(shape);
  spec.X_WB.translation = position;
  spec.material = material;
  return spec;
}

// A mesh spec from a generated mesh, pinned so that it stays a mesh.
inline scene::MeshSpec MeshOf(const geometry::TriangleMesh& mesh) {
  scene::MeshSpec spec;
  spec.vertices = mesh.vertices();
  spec.triangles = mesh.triangles();
  spec.pin = scene::Representation::kMesh;
  return spec;
}

inline std::shared_ptr<const scene::SceneSnapshot> BuildScene(const std::vector<ObjectSpec>& specs,
                                                              uint64_t version = 1) {
  scene::SceneBuilder builder;
  for (const ObjectSpec& spec : specs) builder.Add(spec);
  return builder.Build(version);
}

}  // namespace hapticd::force::testing
