#pragma once

// Oriented box versus oriented box: the separating axis test of Gottschalk, Lin and
// Manocha ("OBBTree", SIGGRAPH 1996) over 15 axes, after Drake's BoxesOverlap.

#include "server/geometry/types.h"

namespace hapticd::geometry {

// The absolute tolerance of BoxesOverlap, relative to the scale of the pair: an axis
// separates only when the projected gap exceeds kBoxesOverlapTolerance * (|t|_1 +
// sum of all six half extents), t the vector between the centres.
inline constexpr double kBoxesOverlapTolerance = 1e-12;

// True when the closed boxes a and b (same frame) share a point, within a small
// inclusive tolerance (above): boxes that touch report contact, also when their axes
// are rotated and the touching configuration is only exact up to rounding. Boxes
// apart by more than about 1e-12 of their size report no contact. Nearly parallel
// edges (whose cross product vanishes) never separate by rounding noise. Preconditions:
// orthonormal rotations, half_extents >= 0. A NaN or infinity anywhere in either box
// (centre, rotation or half extents) gives false: no contact.
bool BoxesOverlap(const Box& a, const Box& b);

}  // namespace hapticd::geometry
