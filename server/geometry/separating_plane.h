#pragma once

// Separating plane of two convex point sets by linear programming (the CS277
// collision lecture's test for convex polyhedra): find n, c with n.a < c for every
// point a of A and n.b > c for every point b of B, or show there is none.
//
// The LP, in the unknowns (n, c, delta), after moving the points into [-1, 1]^3:
//   maximize delta  subject to  n.a - c + delta <= 0   (each a),
//                               c - n.b + delta <= 0   (each b),
//                               |n_k| <= 1, |c| <= 4, -1 <= delta <= 4.
// It is always feasible (n = 0, c = 0, delta = -1); the sets are strictly separable
// exactly when the optimum delta is positive. Solved by Seidel's randomized incremental
// algorithm (Seidel 1991): expected O(d! m) for m points in d = 5 unknowns, with the
// variable bounds kept as bounds through the recursion so every subproblem is bounded.

#include <cstdint>
#include <span>

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct SeparatingPlane {
  // True when a plane strictly separates the sets (so their hulls are disjoint).
  // Touching or overlapping hulls have none.
  bool found = false;
  // Unit, from a towards b: normal.x < offset on a, > offset on b, when found.
  Vector3 normal = Vector3::UnitX();
  double offset = 0;
  // Least distance of a point to the plane when found (the plane lies midway between
  // the two sets' extents along normal); <= 0 otherwise.
  double margin = 0;
  // Constraints that the LP found violated (each costs a recursion): the work done.
  int violations = 0;
};

// Separating plane of the hulls of points_a and points_b (one frame). seed drives the
// random constraint order (the answer does not depend on it, the time may). Gaps below
// about 1e-12 of the sets' extent read as touching. Preconditions: non-empty, finite;
// otherwise found = false. Allocates (the LP's constraint rows).
SeparatingPlane FindSeparatingPlane(std::span<const Vector3> points_a, std::span<const Vector3> points_b,
                                    std::uint64_t seed);

}  // namespace hapticd::geometry
