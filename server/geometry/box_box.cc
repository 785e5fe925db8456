#include "server/geometry/box_box.h"

#include <cmath>

namespace hapticd::geometry {
namespace {

bool IsFinite(const Box& box) {
  return box.center.allFinite() && box.rotation.allFinite() && box.half_extents.allFinite();
}

}  // namespace

// Theory. Two convex polyhedra are disjoint iff some axis separates their
// projections; for two boxes it suffices to try the 3 face normals of each and the 9
// cross products of an edge direction of a with one of b. Everything is expressed in
// a's frame A: R = R_WA^T R_WB holds b's axes as columns, t = R_WA^T (c_b - c_a). On
// axis L the projection of a box has radius sum_k h_k |L . axis_k| and the centres
// are |t . L| apart; L separates when |t . L| > r_a + r_b.
//
// The tolerance. Touching is contact, and a touching pair of rotated boxes is only
// touching up to rounding: its centres and rotations carry relative errors of a few
// ulps, which move each projection by a few ulps of |t| + sum of half extents. Every
// term above is a sum of such products, so one absolute slack,
// tol = kBoxesOverlapTolerance * (|t|_1 + sum h_a + sum h_b), covers all 15 axes with
// a margin of about 10^3 over the worst rounding. The same slack stands in for the
// classic "add epsilon to |R|" of Gottschalk's code: for nearly parallel edges the
// cross axis has nearly zero length, |t . L| and r_a + r_b are both rounding noise,
// and the absolute slack stops that noise from separating the boxes. The cost is
// that a gap smaller than tol (1e-12 of the scale) reads as contact; a cross axis
// whose edges meet at an angle theta separates only beyond a gap of about
// tol / sin(theta).
bool BoxesOverlap(const Box& a, const Box& b) {
  // Non-finite input: no contact (a NaN would otherwise pass every separation test).
  if (!IsFinite(a) || !IsFinite(b)) return false;
  const Vector3& ha = a.half_extents;
  const Vector3& hb = b.half_extents;
  const Matrix3 R = a.rotation.transpose() * b.rotation;
  const Vector3 t = a.rotation.transpose() * (b.center - a.center);
  const Matrix3 abs_R = R.cwiseAbs();
  const double tol = kBoxesOverlapTolerance * (t.cwiseAbs().sum() + ha.sum() + hb.sum());

  // a's face normals A_i.
  for (int i = 0; i < 3; ++i) {
    const double rb = hb.dot(abs_R.row(i));
    if (std::abs(t[i]) > ha[i] + rb + tol) return false;
  }
  // b's face normals B_j.
  for (int j = 0; j < 3; ++j) {
    const double ra = ha.dot(abs_R.col(j));
    if (std::abs(t.dot(R.col(j))) > ra + hb[j] + tol) return false;
  }
  // The nine edge-edge axes A_i x B_j, expanded in a's frame.
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3;
    const int i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3;
      const int j2 = (j + 2) % 3;
      const double ra = ha[i1] * abs_R(i2, j) + ha[i2] * abs_R(i1, j);
      const double rb = hb[j1] * abs_R(i, j2) + hb[j2] * abs_R(i, j1);
      const double dist = t[i2] * R(i1, j) - t[i1] * R(i2, j);
      if (std::abs(dist) > ra + rb + tol) return false;
    }
  }
  // No axis separates: the boxes overlap or touch.
  return true;
}

}  // namespace hapticd::geometry
