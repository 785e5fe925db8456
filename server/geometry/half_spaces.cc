#include "server/geometry/half_spaces.h"

#include <bit>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace hapticd::geometry {
namespace {

// Point nearest goal on the given planes (all active): x = goal + N lambda with
// N^T x = offsets. False when the planes are dependent (det N^T N <= 1e-12: a parallel
// pair, three through one line) or one of them would pull the point towards its inside
// (lambda < 0: that plane is not active). Solved through a QR factorisation of N with
// column pivoting (N P = Q R), not the normal equations: N^T N squares N's condition,
// and the facets of a fine mesh meet at angles small enough that the point it gave fell
// outside its own planes by more than kHalfSpaceFeasibility.
template <int kCount>
bool ProjectOntoActive(const Vector3& goal, const HalfSpace* const* active, Vector3* x) {
  using Normals = Eigen::Matrix<double, 3, kCount>;
  using Coefficients = Eigen::Matrix<double, kCount, 1>;
  Normals normals;
  Coefficients shortfalls;  // offset_i - normal_i . goal
  for (int i = 0; i < kCount; ++i) {
    normals.col(i) = active[i]->normal;
    shortfalls[i] = active[i]->offset - active[i]->normal.dot(goal);
  }
  const Eigen::ColPivHouseholderQR<Normals> qr(normals);
  const Eigen::Matrix<double, kCount, kCount> r = qr.matrixR().template topLeftCorner<kCount, kCount>();
  if (!(r.diagonal().prod() * r.diagonal().prod() > 1e-12)) return false;
  const auto upper = r.template triangularView<Eigen::Upper>();
  // the step x - goal = Q [y; 0] with R^T y = P^T shortfalls; lambda = P R^-1 y
  const Coefficients y = upper.transpose().solve(qr.colsPermutation().transpose() * shortfalls);
  const Coefficients lambda = qr.colsPermutation() * upper.solve(y);
  if (!((lambda.array() >= 0).all())) return false;
  Vector3 step = Vector3::Zero();
  step.template head<kCount>() = y;
  *x = goal + qr.householderQ() * step;
  return true;
}

// The subset's planes (bit i: plane i active) projected onto.
bool ProjectOntoSubset(const Vector3& goal, std::span<const HalfSpace> half_spaces, int subset, Vector3* x) {
  const HalfSpace* active[3];
  int count = 0;
  for (int i = 0; i < static_cast<int>(half_spaces.size()); ++i) {
    if (subset & (1 << i)) active[count++] = &half_spaces[i];
  }
  switch (count) {
    case 1: return ProjectOntoActive<1>(goal, active, x);
    case 2: return ProjectOntoActive<2>(goal, active, x);
    case 3: return ProjectOntoActive<3>(goal, active, x);
    default: return false;
  }
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
