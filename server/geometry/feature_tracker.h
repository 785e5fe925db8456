#pragma once

// Closest-feature tracking with temporal coherence (after Lin & Canny 1991, "A fast
// algorithm for incremental distance calculation"): two convex hulls move rigidly a
// little each tick, so the closest features of the last tick are the best guess for
// this one. Here the features are the final GJK simplex's vertex pairs (they span the
// closest feature pair: vertex, edge or face on each side). Each tick restarts GJK from
// them, re-evaluated at the new poses, and every support search hill-climbs from the
// last support vertex; after a small motion that is a few vertex visits and one or two
// iterations, where a cold query climbs from an arbitrary vertex and rebuilds the
// simplex. The answer is the same as a cold query's: GJK's termination does not depend
// on where it starts.

#include "server/geometry/convex_hull.h"
#include "server/geometry/gjk.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct TrackedDistance {
  // Distance, normal (from a towards b), witness points in the world frame, and
  // intersect when the hulls touch or overlap (distance 0; no depth).
  GjkResult gjk;
  // Work done: support-vertex visits plus GJK iterations.
  int steps = 0;
};

// Tracks one pair of hulls. The hulls are in their body frames and must outlive the
// tracker. Not thread-safe; no allocation per tick.
class FeatureTracker {
 public:
  FeatureTracker(const ConvexHull& a, const ConvexHull& b) : a_(&a), b_(&b) {}

  // Distance at the poses X_WA = (R_WA, p_WA) and X_WB, warm-started from the previous
  // call's features. Rotations must be orthonormal. Non-finite poses give unspecified
  // values (and the next call starts cold).
  TrackedDistance Update(const Matrix3& R_WA, const Vector3& p_WA, const Matrix3& R_WB, const Vector3& p_WB);

  // Forgets the features: the next Update starts cold.
  void Reset() { features_ = GjkSimplex{}; }

  // The tracked features: simplex vertex pairs (indices into each hull's vertices).
  const GjkSimplex& features() const { return features_; }

 private:
  const ConvexHull* a_;
  const ConvexHull* b_;
  GjkSimplex features_;
};

// The same query without coherence (no features, searches start at vertex 0): the
// reference the tracker is measured against.
TrackedDistance CalcHullDistanceCold(const ConvexHull& a, const Matrix3& R_WA, const Vector3& p_WA,
                                     const ConvexHull& b, const Matrix3& R_WB, const Vector3& p_WB);

}  // namespace hapticd::geometry
