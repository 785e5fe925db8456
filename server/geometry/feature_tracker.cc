#include "server/geometry/feature_tracker.h"

#include <cmath>

namespace hapticd::geometry {

TrackedDistance FeatureTracker::Update(const Matrix3& R_WA, const Vector3& p_WA, const Matrix3& R_WB,
                                       const Vector3& p_WB) {
  const HullSupport a(*a_, R_WA, p_WA), b(*b_, R_WB, p_WB);
  TrackedDistance tracked;
  tracked.gjk = CalcGjkDistance(a, b, features_.size > 0 ? &features_ : nullptr);
  tracked.steps = tracked.gjk.support_visits + tracked.gjk.iterations;
  // keep the features for the next tick, unless the answer is not a number
  features_ = std::isfinite(tracked.gjk.distance) ? tracked.gjk.simplex : GjkSimplex{};
  return tracked;
}

TrackedDistance CalcHullDistanceCold(const ConvexHull& a, const Matrix3& R_WA, const Vector3& p_WA,
                                     const ConvexHull& b, const Matrix3& R_WB, const Vector3& p_WB) {
  TrackedDistance cold;
  cold.gjk = CalcGjkDistance(HullSupport(a, R_WA, p_WA), HullSupport(b, R_WB, p_WB));
  cold.steps = cold.gjk.support_visits + cold.gjk.iterations;
  return cold;
}

}  // namespace hapticd::geometry
