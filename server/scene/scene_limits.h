#pragma once

// What a scene may hold. Two kinds of bound, both checked by the scene builder (its
// SceneError names the field or the budget):
//  - SceneLimits, fixed: the range of every length and coefficient, chosen so that any
//    value that passes keeps the queries' and the tick's arithmetic finite and exact
//    enough. A device works within 100 m of the origin (render_session.cc), so nothing
//    beyond these is ever reached; at 1e4 m a double still resolves 2e-12 m.
//  - SceneBudgets, per deployment (hapticd's options): how much work and memory one
//    scene may take, so that one client's upload cannot stall or bloat the server.

#include <cstddef>

namespace hapticd::scene {

struct SceneLimits {
  static constexpr double kMaxCoordinate = 1e4;  // m: positions, vertices, hull points
  static constexpr double kMaxSize = 1e3;        // m: radii, half extents, half lengths
  static constexpr double kMaxStiffness = 1e7;   // N/m
  static constexpr double kMaxDamping = 1e5;     // N·s/m
  static constexpr double kMaxFriction = 10;     // friction coefficients
  static constexpr double kMaxSpeed = 100;       // m/s, a kinematic object's
  static constexpr double kMaxAngularSpeed = 1e3;  // rad/s
};

struct SceneBudgets {
  std::size_t max_objects = 1024;
  std::size_t max_triangles_per_mesh = 2'000'000;  // as given, degenerate ones included
  std::size_t max_triangles = 4'000'000;           // over all the scene's meshes
  std::size_t max_points_per_convex = 100'000;
  std::size_t max_name_bytes = 128;
};

}  // namespace hapticd::scene
