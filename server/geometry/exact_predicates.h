#pragma once

// Exact geometric predicates: the sign of a small determinant, correct for every
// finite double input. A fast floating-point evaluation is tried first and kept when
// its error bound proves the sign (Shewchuk 1997, "Adaptive precision floating-point
// arithmetic and fast robust geometric predicates"); otherwise the determinant is
// evaluated exactly with floating-point expansions. The fallback is rare and
// allocation-free.
//
// Why exact: touching counts as contact, and a segment aimed through a shared mesh
// edge must hit one of its triangles. Both need signs that are right at zero and that
// flip exactly when two arguments are swapped.
//
// Precondition: finite inputs whose products neither overflow nor underflow (roughly
// |x| within 1e-100..1e100). Non-finite input gives an unspecified sign, never a crash.

#include "server/geometry/types.h"

namespace hapticd::geometry {

// Sign (-1, 0, +1) of ((b - a) x (c - a)) . (d - a): positive when d lies on the side
// of plane abc that the right-handed normal of the triangle (a, b, c) points to, zero
// when the four points are coplanar. Swapping any two arguments flips the sign.
int Orient3d(const Vector3& a, const Vector3& b, const Vector3& c, const Vector3& d);

// Sign of (b - a) x (c - a) in the plane: positive when a, b, c turn counter-clockwise,
// zero when collinear.
int Orient2d(const Vector2& a, const Vector2& b, const Vector2& c);

// Sign of dir . ((a - o) x (b - o)): which way the line through o along dir passes the
// directed edge a -> b. Exact for the given dir (no o + dir is ever formed), so a ray
// and a segment share one predicate. Swapping a and b flips the sign.
int OrientLineEdge(const Vector3& o, const Vector3& dir, const Vector3& a, const Vector3& b);

// Sign of (u x v) . w for vectors given directly.
int TripleProductSign(const Vector3& u, const Vector3& v, const Vector3& w);

// True when a, b, c are collinear or coincide (the triangle has exactly zero area).
bool IsDegenerateTriangle(const Vector3& a, const Vector3& b, const Vector3& c);

}  // namespace hapticd::geometry
