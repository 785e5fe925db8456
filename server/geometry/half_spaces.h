#pragma once

// The point of an intersection of half-spaces nearest a goal: Ruspini's sub-goal for a
// proxy held by the constraint planes it met (force/proxy_solver.h).
//
// min |x - goal|^2 subject to normal_i . x >= offset_i. In three dimensions the answer
// rests on at most three planes (a face, an edge where two meet, a corner where three
// meet), so every subset of at most three planes is tried as the active set and the
// nearest point that satisfies them all is kept; dependent subsets (parallel planes,
// three through one line) are skipped.
//
// Degenerate answers: a goal that satisfies every plane (none given included) is the
// answer; so is a goal with no point on at most three of the planes that satisfies them
// all (planes that leave nothing between them). A non-finite goal or plane gives the
// goal. Violations up to kHalfSpaceFeasibility count as satisfied.

#include <span>

#include "server/geometry/types.h"

namespace hapticd::geometry {

// normal . x >= offset, normal of unit length.
struct HalfSpace {
  Vector3 normal = Vector3::UnitZ();
  double offset = 0;
};

// The most half-spaces one call takes: every subset of them is tried (2^8 at most).
constexpr int kMaxHalfSpaces = 8;
// A point this far outside a half-space (m) still satisfies it.
constexpr double kHalfSpaceFeasibility = 1e-12;

// Whether x satisfies every half-space, within kHalfSpaceFeasibility.
bool SatisfiesHalfSpaces(const Vector3& x, std::span<const HalfSpace> half_spaces);

// The point nearest goal that satisfies every half-space (see the header's comment).
// More than kMaxHalfSpaces half-spaces: the goal is returned. Allocation-free.
Vector3 NearestPointInHalfSpaces(const Vector3& goal, std::span<const HalfSpace> half_spaces);

}  // namespace hapticd::geometry
