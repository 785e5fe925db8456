#include "server/app/default_scene.h"

#include <cmath>
#include <numbers>

namespace hapticd::app {
namespace {

using geometry::Vector3;

constexpr double kStiffness = 2000;  // N/m

// A closed torus about the z axis: rings x sides quads, two triangles each, counter-
// clockwise seen from outside.
scene::MeshSpec MakeTorus(double major_radius, double minor_radius, int rings, int sides) {
  scene::MeshSpec mesh;
  for (int i = 0; i < rings; ++i) {
    const double u = 2 * std::numbers::pi * i / rings;
    for (int j = 0; j < sides; ++j) {
      const double v = 2 * std::numbers::pi * j / sides;
      const double r = major_radius + minor_radius * std::cos(v);
      mesh.vertices.emplace_back(r * std::cos(u), r * std::sin(u), minor_radius * std::sin(v));
    }
  }
  auto index = [&](int i, int j) { return (i % rings) * sides + (j % sides); };
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < sides; ++j) {
      const int a = index(i, j), b = index(i + 1, j), c = index(i + 1, j + 1), d = index(i, j + 1);
      mesh.triangles.push_back({a, b, c});
      mesh.triangles.push_back({a, c, d});
    }
  }
  return mesh;
}

scene::ObjectSpec Place(std::string name, scene::ShapeSpec shape, const Vector3& p_WB) {
  scene::ObjectSpec spec;
  spec.name = std::move(name);
  spec.shape = std::move(shape);
  spec.X_WB.translation = p_WB;
  spec.material.stiffness = kStiffness;
  return spec;
}

}  // namespace

std::vector<scene::ObjectSpec> MakeDefaultScene() {
  std::vector<scene::ObjectSpec> objects;
  objects.push_back(Place("floor", scene::PlaneShape{}, Vector3::Zero()));
  objects.push_back(Place("box", scene::BoxShape{Vector3(0.05, 0.05, 0.05)}, {0.15, 0, 0.05}));
  objects.push_back(Place("ball", scene::SphereShape{0.05}, {-0.15, 0, 0.05}));
  objects.push_back(Place("pillar", scene::CapsuleShape{0.02, 0.05}, {0, 0.15, 0.07}));
  objects.push_back(Place("ring", MakeTorus(0.04, 0.012, 48, 24), {0, -0.15, 0.012}));
  return objects;
}

}  // namespace hapticd::app
