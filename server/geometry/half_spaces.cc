#include "server/geometry/half_spaces.h"

#include <bit>
#include <limits>

namespace hapticd::geometry {
namespace {

// Point nearest goal on the given planes (all active): x = goal + N lambda with
// N^T x = offsets (N: the unit normals as columns). False when the planes are dependent
// (det N^T N <= 1e-12: a parallel pair, three through one line) or one of them would
// pull the point towards its inside (lambda < 0: that plane is not active). Solved in
// closed form from N itself (an orthogonalised pair; Cramer's rule for three), not from
// the normal equations: N^T N squares N's condition, and the facets of a fine mesh meet
// at angles small enough that the point it gave fell outside its own planes by more
// than kHalfSpaceFeasibility.
bool ProjectOntoActive(const Vector3& goal, const HalfSpace* const* active, int count, Vector3* x) {
  // shortfall_i = offset_i - n_i . goal: how far the goal is to be moved along n_i
  const auto shortfall = [&](int i) { return active[i]->offset - active[i]->normal.dot(goal); };
  if (count == 1) {
    const double s = shortfall(0);
    if (!(s >= 0)) return false;
    *x = goal + s * active[0]->normal;
    return true;
  }
  const Vector3& n1 = active[0]->normal;
  const Vector3& n2 = active[1]->normal;
  if (count == 2) {
    // n2 = c n1 + u with u orthogonal to n1; the step is s1 n1 + y u / |u|
    const double c = n1.dot(n2);
    const Vector3 u = n2 - c * n1;
    const double u2 = u.squaredNorm();
    if (!(u2 > 1e-12)) return false;
    const double s1 = shortfall(0), s2 = shortfall(1);
    // lambda_2 = (s2 - c s1) / |u|^2, lambda_1 = (s1 - c s2) / |u|^2
    if (!(s2 - c * s1 >= 0) || !(s1 - c * s2 >= 0)) return false;
    *x = goal + s1 * n1 + ((s2 - c * s1) / u2) * u;
    return true;
  }
  const Vector3& n3 = active[2]->normal;
  const Vector3 c23 = n2.cross(n3), c31 = n3.cross(n1), c12 = n1.cross(n2);
  const double det = n1.dot(c23);
  if (!(det * det > 1e-12)) return false;
  // N^-1 has rows c23, c31, c12 over det: step = N^-T s, lambda = N^-1 step
  const Vector3 step = (shortfall(0) * c23 + shortfall(1) * c31 + shortfall(2) * c12) / det;
  if (!(c23.dot(step) / det >= 0) || !(c31.dot(step) / det >= 0) || !(c12.dot(step) / det >= 0)) return false;
  *x = goal + step;
  return true;
}

// The subset's planes (bit i: plane i active) projected onto.
bool ProjectOntoSubset(const Vector3& goal, std::span<const HalfSpace> half_spaces, int subset, Vector3* x) {
  const HalfSpace* active[3];
  int count = 0;
  for (int i = 0; i < static_cast<int>(half_spaces.size()); ++i) {
    if (subset & (1 << i)) active[count++] = &half_spaces[i];
  }
  return count >= 1 && count <= 3 && ProjectOntoActive(goal, active, count, x);
}

}  // namespace

bool SatisfiesHalfSpaces(const Vector3& x, std::span<const HalfSpace> half_spaces) {
  for (const HalfSpace& h : half_spaces) {
    if (!(h.normal.dot(x) >= h.offset - kHalfSpaceFeasibility)) return false;
  }
  return true;
}

Vector3 NearestPointInHalfSpaces(const Vector3& goal, std::span<const HalfSpace> half_spaces) {
  const int count = static_cast<int>(half_spaces.size());
  if (count > kMaxHalfSpaces || !goal.allFinite()) return goal;
  if (SatisfiesHalfSpaces(goal, half_spaces)) return goal;
  Vector3 best = goal;
  double best_distance = std::numeric_limits<double>::infinity();
  for (int subset = 1; subset < (1 << count); ++subset) {
    if (std::popcount(static_cast<unsigned>(subset)) > 3) continue;
    Vector3 x;
    if (!ProjectOntoSubset(goal, half_spaces, subset, &x)) continue;
    if (!SatisfiesHalfSpaces(x, half_spaces)) continue;
    const double distance = (x - goal).squaredNorm();
    if (distance < best_distance) best_distance = distance, best = x;
  }
  return best;
}

}  // namespace hapticd::geometry
