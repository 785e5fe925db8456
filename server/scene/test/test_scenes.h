#pragma once

// Scenes for the tests, built through the scene's own builder (as a client would).

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/mesh_generators.h"
#include "server/scene/scene_builder.h"

namespace hapticd::scene::testing {




inline Material MakeMaterial(double stiffness, double damping = 0, double static_friction = 0,
                                    double dynamic_friction = 0) {
  Material material;
  material.stiffness = stiffness;
  material.damping = damping;
  material.static_friction = static_friction;
  material.dynamic_friction = dynamic_friction;
  return material;
}

inline ObjectSpec MakeObject(std::string name, ShapeSpec shape, const Vector3& position,
                             const Material& material) {
  ObjectSpec spec;
  spec.name = std::move(name);
  spec.shape = std::move(shape);
  spec.X_WB.translation = position;
  spec.material = material;
  return spec;
}

// A mesh spec from a generated mesh, pinned so that it stays a mesh.
inline MeshSpec MeshOf(const geometry::TriangleMesh& mesh) {
  MeshSpec spec;
  spec.vertices = mesh.vertices();
  spec.triangles = mesh.triangles();
  spec.pin = Representation::kMesh;
  return spec;
}

inline std::shared_ptr<const SceneSnapshot> BuildScene(const std::vector<ObjectSpec>& specs,
                                                              uint64_t version = 1) {
  SceneBuilder builder;
  for (const ObjectSpec& spec : specs) builder.Add(spec);
  return builder.Build(version);
}

}  // namespace hapticd::scene::testing
