#pragma once

// Random inputs shared by the geometry tests, drawn from the caller's generator so
// every test keeps its own fixed seed.

#include <cmath>
#include <random>
#include <vector>

#include "server/geometry/types.h"

namespace hapticd::geometry {

// A rotation uniformly distributed over SO(3) (a normalised Gaussian quaternion).
inline Matrix3 RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return q.normalized().toRotationMatrix();
}

// n points uniformly distributed in the ball of the given radius and centre.
inline std::vector<Vector3> RandomBall(std::mt19937_64& rng, int n, double radius,
                                       const Vector3& center = Vector3::Zero()) {
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vector3> points;
  for (int i = 0; i < n; ++i) {
    const Vector3 direction = Vector3(g(rng), g(rng), g(rng)).normalized();
    points.push_back(center + radius * std::cbrt(u(rng)) * direction);
  }
  return points;
}

}  // namespace hapticd::geometry
