#include "server/geometry/sphere_sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/bvh_simd.h"
#include "server/geometry/exact_predicates.h"
#include "server/geometry/segment_triangle.h"
#include "server/geometry/work_meter.h"

namespace hapticd::geometry {
namespace {

using namespace bvh_simd;

// The skin, as a fraction of the coordinates' magnitude (see CalcSphereSweepSkin).
constexpr double kSkin = 1e-9;
// Radii up to this fraction of the coordinates' magnitude are swept as points.
constexpr double kPointRadius = 1e-12;
// Boxes are grown by r plus this fraction of the coordinates' magnitude, far more than
// the rounding of lo - r and hi + r, so they hold everything within r of a triangle.
constexpr double kBoxSlack = 1e-12;
// A gap shorter than this fraction of the coordinates' magnitude has no reliable
// direction.
constexpr double kTinyGap = 1e-12;
// What the per-triangle kernels return for "no contact".
constexpr double kNoHit = -1;

// One sweep's constants, shared by every triangle it meets.
struct Sweep {
  Vector3 a, b, d;      // start, end, motion b - a
  double inverse_motion_squared;  // 1 / |d|^2, so that triangles are passed over without a division
  double radius;        // 0: swept as a point
  double block_radius;  // radius - skin: how close the centre must come to block
  double scale;         // r + max |a_i|, |b_i|: the magnitude of the coordinates
  double reach;         // radius + kBoxSlack scale: what lies farther is never touched
};

// The skin of a sweep of radius r whose coordinates are of magnitude scale; 0 for a
// radius swept as a point.
double SkinOf(double r, double scale) {
  return r > kPointRadius * scale ? std::min(0.5 * r, kSkin * scale) : 0;
}

// r + max |a_i|, |b_i|: the magnitude of a sweep's coordinates.
double ScaleOf(const Vector3& a, const Vector3& b, double r) {
  return r + std::max(a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff());
}

// Fills s, or returns false for input that misses at once (non-finite, r < 0, a == b).
bool MakeSweep(const Vector3& a, const Vector3& b, double r, Sweep& s) {
  if (!a.allFinite() || !b.allFinite() || !(r >= 0) || !std::isfinite(r) || a == b) return false;
  s.a = a;
  s.b = b;
  s.d = b - a;
  s.inverse_motion_squared = 1 / s.d.squaredNorm();
  s.scale = ScaleOf(a, b, r);
  // a radius lost in the rounding of the coordinates: a point
  s.radius = r > kPointRadius * s.scale ? r : 0;
  s.block_radius = s.radius - SkinOf(s.radius, s.scale);
  s.reach = s.radius + kBoxSlack * s.scale;
  return true;
}

// The right-handed normal (v1 - v0) x (v2 - v0) of a triangle, made unit; zero when it
// has no area. TriangleMesh's rule, so the bits are those of its face_normal().
Vector3 UnitOrZero(const Vector3& area_normal) {
  const double length = area_normal.norm();
  if (!(length > 0) || !std::isfinite(length)) return Vector3::Zero();
  return area_normal / length;
}

Vector3 AreaNormal(const Triangle& tri) { return (tri.v1 - tri.v0).cross(tri.v2 - tri.v0); }

// The first t in [0, 1] where |m + t w|^2 falls to rho^2, written
// A t^2 + 2 B t + C = 0 (A = |w|^2, B = m.w, C = |m|^2 - rho^2), for a centre that
// approaches (B < 0); kNoHit otherwise. The smaller root in the form
// C / (-B + sqrt(B^2 - AC)), which loses nothing to cancellation.
double EntryTime(double A, double B, double C) {
  if (!(B < 0)) return kNoHit;
  // inside already: the caller found the centre outside, so only by rounding; it enters
  // at once
  if (C <= 0) return 0;
  const double discriminant = B * B - A * C;
  // the centre's path stays outside (a NaN from overflow falls through to a NaN t: a miss)
  if (discriminant < 0) return kNoHit;
  const double t = C / (-B + std::sqrt(discriminant));
  return t <= 1 ? t : kNoHit;
}

// First entry of the centre into the cylinder of radius rho around edge p-q, where its
// closest point of the edge lies between p and q.
double EdgeEntryTime(const Vector3& p, const Vector3& q, const Vector3& a, const Vector3& d,
                     double rho) {
  // distances to the edge's line are |(x - p) x e| / |e|: all squared terms scale by |e|^2
  const Vector3 e = q - p;
  const Vector3 m = a - p;
  const Vector3 u = m.cross(e);
  const Vector3 w = d.cross(e);
  const double length_squared = e.squaredNorm();
  const double t =
      EntryTime(w.squaredNorm(), u.dot(w), u.squaredNorm() - rho * rho * length_squared);
  if (t == kNoHit) return kNoHit;
  // beyond an end: that corner's sphere decides
  const double along = (m + t * d).dot(e);
  return along >= 0 && along <= length_squared ? t : kNoHit;
}

// First entry of the centre into the sphere of radius rho around corner v.
double VertexEntryTime(const Vector3& v, const Vector3& a, const Vector3& d, double rho) {
  const Vector3 m = a - v;
  return EntryTime(d.squaredNorm(), m.dot(d), m.squaredNorm() - rho * rho);
}

// First entry of the centre into the face's slab (the plane offset by rho towards the
// centre), where the centre then projects into the closed triangle. n: unit normal.
double FaceEntryTime(const Triangle& tri, const Vector3& n, const Vector3& a, const Vector3& d,
                     double rho) {
  // a degenerate triangle has no face
  if (n.isZero()) return kNoHit;
  const double height = n.dot(a - tri.v0);
  const double gap = std::abs(height) - rho;
  const double approach = height >= 0 ? -n.dot(d) : n.dot(d);
  if (!(approach > 0)) return kNoHit;
  // within rho of the plane already: over the triangle only by rounding (the caller
  // found the centre farther), so it enters at once; beside it, the edges decide
  const double t = std::max(gap, 0.0) / approach;
  if (!(t <= 1)) return kNoHit;
  // inside every edge (n . (e x (c - p)) is unchanged by c's height above the plane);
  // a contact just outside is an edge cylinder's
  const Vector3 c = a + t * d;
  const bool inside = n.dot((tri.v1 - tri.v0).cross(c - tri.v0)) >= 0 &&
                      n.dot((tri.v2 - tri.v1).cross(c - tri.v1)) >= 0 &&
                      n.dot((tri.v0 - tri.v2).cross(c - tri.v2)) >= 0;
  return inside ? t : kNoHit;
}

// First t in [0, 1] where the centre, outside the closed rho-neighbourhood of tri at
// t = 0, enters it: the earliest of the face slab, the edge cylinders and the corner
// spheres (their union is the triangle swelled by rho; the slab's side walls lie
// inside the cylinders and the cylinders' end caps inside the spheres).
double FirstEntryTime(const Triangle& tri, const Vector3& n, const Vector3& a, const Vector3& d,
                      double rho) {
  double best = kNoHit;
  const auto keep = [&](double t) {
    if (t != kNoHit && (best == kNoHit || t < best)) best = t;
  };
  keep(FaceEntryTime(tri, n, a, d, rho));
  keep(EdgeEntryTime(tri.v0, tri.v1, a, d, rho));
  keep(EdgeEntryTime(tri.v1, tri.v2, a, d, rho));
  keep(EdgeEntryTime(tri.v2, tri.v0, a, d, rho));
  keep(VertexEntryTime(tri.v0, a, d, rho));
  keep(VertexEntryTime(tri.v1, a, d, rho));
  keep(VertexEntryTime(tri.v2, a, d, rho));
  return best;
}

// Unit direction from the triangle towards the centre c, whose closest point is
// `closest`: on a face the face normal turned to c's side, decided exactly (the front
// side when c is in the plane); on an edge or a corner the gap's direction, or the
// front side again when the gap is lost in rounding (c on the triangle's boundary).
// Zero for a degenerate triangle with c on it.
Vector3 ContactNormal(const Triangle& tri, const Vector3& n, const Vector3& c,
                      const ClosestPointOnTriangle& closest, double scale) {
  if (closest.feature == TriangleFeature::kFace && !n.isZero()) {
    return Orient3d(tri.v0, tri.v1, tri.v2, c) < 0 ? Vector3(-n) : n;
  }
  const Vector3 gap = c - closest.point;
  const double length = gap.norm();
  if (length > kTinyGap * scale) return gap / length;
  return n;
}

// Whether the motion takes a centre c, already within the blocking distance of the
// triangle, deeper in: d . ContactNormal < 0, decided exactly on a face.
bool MovesInto(const Triangle& tri, const Vector3& n, const Vector3& c,
               const ClosestPointOnTriangle& closest, const Sweep& s) {
  if (closest.feature == TriangleFeature::kFace && !n.isZero()) {
    // the side c is on (the front when in the plane) against the sign of d . N
    const int side = Orient3d(tri.v0, tri.v1, tri.v2, c) < 0 ? -1 : 1;
    return side * OrientLineEdge(tri.v0, s.d, tri.v1, tri.v2) < 0;
  }
  return s.d.dot(ContactNormal(tri, n, c, closest, s.scale)) < 0;
}

// The point sweep (r = 0): the exact segment test, with a start on the plane taken on
// the front side.
double PointSweepTime(const Triangle& tri, const Sweep& s) {
  // on the plane, and b not behind it: leaving the front side, or staying in the plane
  if (Orient3d(tri.v0, tri.v1, tri.v2, s.a) == 0 && Orient3d(tri.v0, tri.v1, tri.v2, s.b) >= 0) {
    return kNoHit;
  }
  const TriangleHit h = IntersectSegmentTriangleWatertight(s.a, s.b, tri);
  return h.hit ? h.t : kNoHit;
}

// The centre of a triangle's bounding sphere.
Vector3 CentroidOf(const Triangle& tri) { return (tri.v0 + tri.v1 + tri.v2) / 3; }

// The squared radius of the sphere about centroid that holds the triangle.
double BoundingRadiusSquaredOf(const Triangle& tri, const Vector3& centroid) {
  return std::max({(tri.v0 - centroid).squaredNorm(), (tri.v1 - centroid).squaredNorm(),
                   (tri.v2 - centroid).squaredNorm()});
}

// The radius of the sphere about centroid that holds the triangle.
double BoundingRadiusOf(const Triangle& tri, const Vector3& centroid) {
  return std::sqrt(BoundingRadiusSquaredOf(tri, centroid));
}

// Whether a sweep of radius > 0 passes farther than its reach from a triangle's bounding
// sphere: then it never comes within r. Cheap, and it drops most of the triangles near a
// resting sphere that the boxes and the plane test keep.
bool PassesFarFrom(const Vector3& centroid, double bounding_radius, const Sweep& s) {
  const Vector3 offset = s.a - centroid;
  const double nearest = std::clamp(-offset.dot(s.d) * s.inverse_motion_squared, 0.0, 1.0);
  const double bound = s.reach + bounding_radius;
  return (offset + nearest * s.d).squaredNorm() > bound * bound;
}

// The last step of the bound below, for both its forms: whether l - b > sqrt(s2), given
// excess = (l^2 - b^2 - s2) scale and its scale (l^2 known times scale, so no division).
bool ExceedsBeyondCircle(double excess, double bounding_radius_squared, double left, double scale) {
  return excess > 0 && excess * excess > 4 * bounding_radius_squared * left * scale * scale;
}

// Whether the segment a -> a + d stays farther than sqrt(limit_squared) from a triangle
// lying in the plane through centroid with unit normal n (zero: no area), within
// sqrt(bounding_radius_squared) of centroid, by a lower bound of the distance: at a point
// of height h over the plane whose projection lies l from the centroid, the distance is
// at least sqrt(h^2 + max(0, l - bounding radius)^2); over the segment, the least height
// (0 when it crosses the plane) and the least l bound it below. Squared throughout, so
// no square root (l - b > sqrt(s2) <=> X = l^2 - b^2 - s2 > 0 and X^2 > 4 b^2 s2); the
// rounding is a few ulps of the squares, far inside the callers' slack.
bool LowerDistanceExceeds(const Vector3& n, const Vector3& centroid, double bounding_radius_squared,
                          const Vector3& a, const Vector3& d, double limit_squared) {
  const Vector3 offset = a - centroid;
  const double height_a = n.dot(offset);
  const double climb = n.dot(d);
  const double height_b = height_a + climb;
  const double height = height_a * height_b <= 0 ? 0 : std::min(std::abs(height_a), std::abs(height_b));
  const double left = limit_squared - height * height;
  if (left < 0) return true;
  // in the plane: the start's and the motion's components along it; the motion's point
  // nearest the centroid's foot is at lateral + (toward / drift^2) drift where it lies
  // inside the motion, and there the bound is taken times drift^2 (no division)
  const Vector3 lateral = offset - height_a * n;
  const Vector3 drift = d - climb * n;
  const double drift_squared = drift.squaredNorm();
  const double toward = -lateral.dot(drift);
  double scale = 1;  // what excess is multiplied by
  double excess;
  // (a motion under 1e-75 m, far inside the callers' slack, counts as none: the
  // scale's square would underflow)
  if (!(toward > 0) || drift_squared < 1e-150) {
    excess = lateral.squaredNorm() - bounding_radius_squared - left;
  } else if (toward >= drift_squared) {
    excess = (lateral + drift).squaredNorm() - bounding_radius_squared - left;
  } else {
    scale = drift_squared;
    excess = drift_squared * (lateral.squaredNorm() - bounding_radius_squared - left) - toward * toward;
  }
  return ExceedsBeyondCircle(excess, bounding_radius_squared, left, scale);
}

// Whether a sweep of radius > 0 stays farther than its reach from a prepared triangle,
// by LowerDistanceExceeds: tighter than the bounding sphere where a sphere slides over a
// dense surface (there every triangle near the contact is about r from the centre, and
// only those under the path are within reach). Rounding is far inside the reach's
// slack.
bool PassesFarFrom(const PreparedTriangle& prepared, const Sweep& s) {
  return LowerDistanceExceeds(prepared.normal, prepared.centroid, prepared.bounding_radius * prepared.bounding_radius,
                              s.a, s.d, s.reach * s.reach);
}

// SweepTime for r > 0 on a triangle whose bounding sphere the sweep comes near.
double NearSweepTime(const Triangle& tri, const Vector3& centroid, double bounding_radius, const Sweep& s) {
  const Vector3 offset = s.a - centroid;
  // both ends farther than r from the plane, on one side: never within r (heights and
  // reach scaled by |N|, so no square root yet)
  const Vector3 area_normal = AreaNormal(tri);
  const double scale_squared = area_normal.squaredNorm();
  const double height_a = area_normal.dot(s.a - tri.v0);
  const double height_b = area_normal.dot(s.b - tri.v0);
  const double reach_squared = s.reach * s.reach * scale_squared;
  if (height_a * height_b > 0 && height_a * height_a > reach_squared &&
      height_b * height_b > reach_squared) {
    return kNoHit;
  }
  const Vector3 n = UnitOrZero(area_normal);
  // a start within r of the plane and of the bounding sphere needs its distance to the
  // triangle; from farther, D(0) > r is known
  const double near_bound = s.radius + bounding_radius;
  const bool starts_near = !(height_a * height_a > s.radius * s.radius * scale_squared) &&
                           offset.squaredNorm() <= near_bound * near_bound;
  ClosestPointOnTriangle start;
  double distance = 0;
  if (starts_near) {
    start = FindClosestPointOnTriangle(s.a, tri);
    distance = std::sqrt(start.distance_squared);
    // deeper than the skin already: blocks at once when the motion goes deeper still
    if (distance <= s.block_radius) return MovesInto(tri, n, s.a, start, s) ? 0 : kNoHit;
  }
  // the motion never takes the centre within the blocking distance: a graze at most
  const double t_block = FirstEntryTime(tri, n, s.a, s.d, s.block_radius);
  if (t_block == kNoHit) return kNoHit;
  // touching already, and going in by more than the skin
  if (starts_near && distance <= s.radius) return 0;
  // contact where D first reaches r (never after t_block, whatever the rounding)
  const double t_touch = FirstEntryTime(tri, n, s.a, s.d, s.radius);
  return t_touch == kNoHit ? t_block : std::min(t_touch, t_block);
}

// The t at which the sweep first blocks on tri (see the header's rules), or kNoHit.
double SweepTime(const Triangle& tri, const Sweep& s) {
  if (s.radius == 0) return PointSweepTime(tri, s);
  const Vector3 centroid = CentroidOf(tri);
  const double bounding_radius = BoundingRadiusOf(tri, centroid);
  if (PassesFarFrom(centroid, bounding_radius, s)) return kNoHit;
  return NearSweepTime(tri, centroid, bounding_radius, s);
}

// Which feature the line a-b crosses the triangle at, from the exact signs of the
// watertight test: a zero sign means the line meets that edge's line.
TriangleFeature CrossedFeature(const Triangle& tri, const Vector3& a, const Vector3& b) {
  const bool on_01 = Orient3d(a, b, tri.v0, tri.v1) == 0;
  const bool on_12 = Orient3d(a, b, tri.v1, tri.v2) == 0;
  const bool on_20 = Orient3d(a, b, tri.v2, tri.v0) == 0;
  if (on_20 && on_01) return TriangleFeature::kVertex0;
  if (on_01 && on_12) return TriangleFeature::kVertex1;
  if (on_12 && on_20) return TriangleFeature::kVertex2;
  if (on_01) return TriangleFeature::kEdge01;
  if (on_12) return TriangleFeature::kEdge12;
  if (on_20) return TriangleFeature::kEdge20;
  return TriangleFeature::kFace;
}

// The hit at time t on tri: where the centre is, what it touches, which way out.
SphereSweepHit MakeHit(const Triangle& tri, const Sweep& s, double t) {
  const Vector3 n = UnitOrZero(AreaNormal(tri));
  SphereSweepHit hit;
  hit.hit = true;
  hit.t = t;
  // the ends exactly: a + 1 (b - a) need not round to b
  const Vector3 c = t == 0 ? s.a : t == 1 ? s.b : Vector3(s.a + t * s.d);
  if (s.radius == 0) {
    hit.point = c;
    hit.feature = CrossedFeature(tri, s.a, s.b);
    hit.normal = Orient3d(tri.v0, tri.v1, tri.v2, s.a) < 0 ? Vector3(-n) : n;
    return hit;
  }
  const ClosestPointOnTriangle closest = FindClosestPointOnTriangle(c, tri);
  hit.point = closest.point;
  hit.feature = closest.feature;
  hit.normal = ContactNormal(tri, n, c, closest, s.scale);
  return hit;
}

// ---- BVH traversal: the segment a -> b against the node boxes grown by a margin,
// nearest first (the approach of mesh_queries.cc's FindFirstSegmentHit).

struct StackEntry {
  int node;
  double t;  // entry t of the segment into the grown box
};

// The segment, prepared for slab tests against boxes grown by margin on every side,
// and the ball around it (centred at its middle, half its length plus margin), which
// holds everything within margin of it: for a sweep shorter than the radius the ball
// is the tighter bound (a box grown by r is mostly corners that a sphere never reaches).
struct GrownSlabs {
  Double2 origin[3];
  Double2 inv_dir[3];
  bool negative[3];  // direction sign bit: the near slab plane is the upper one
  Double2 margin;
  Double2 middle[3];
  Double2 ball_squared;

  GrownSlabs(const Vector3& p, const Vector3& q, double grow) : margin(Splat(grow)) {
    for (int a = 0; a < 3; ++a) {
      const double d = q[a] - p[a];
      origin[a] = Splat(p[a]);
      inv_dir[a] = Splat(1 / d);
      negative[a] = std::signbit(d);
      middle[a] = Splat(0.5 * (p[a] + q[a]));
    }
    const double ball = 0.5 * (q - p).norm() + grow;
    ball_squared = Splat(ball * ball);
  }
};

// Which grown children of `node` the segment touches for t in [0, t_max], and whose
// (ungrown) box meets the ball: bit c for child c, its entry t in t_entry[c]. Empty
// slots (lo = +inf, hi = -inf) stay empty when grown. A zero direction component gives
// infinite slab distances, or NaN where the origin lies on a slab plane; the selects
// `x > acc ? x : acc` skip the NaN, which leaves that slab unbounded, as it should be.
inline int IntersectChildren(const BvhNode& node, const GrownSlabs& s, double t_max,
                             double t_entry[kBvhWidth]) {
  int mask = 0;
  for (int c = 0; c < kBvhWidth; c += 4) {
    Double2 near[2] = {Splat(0), Splat(0)};
    Double2 far[2] = {Splat(t_max), Splat(t_max)};
    Double2 gap_squared[2] = {Splat(0), Splat(0)};
    for (int a = 0; a < 3; ++a) {
      Double2 lo[2], hi[2];
      Load(node.lo[a] + c, lo[0], lo[1]);
      Load(node.hi[a] + c, hi[0], hi[1]);
      for (int h = 0; h < 2; ++h) {
        const Double2 below = lo[h] - s.middle[a];
        const Double2 above = s.middle[a] - hi[h];
        Double2 gap = below > above ? below : above;
        gap = gap > 0 ? gap : Splat(0);
        gap_squared[h] += gap * gap;
        const Double2 low = lo[h] - s.margin;
        const Double2 high = hi[h] + s.margin;
        const Double2 near_plane = s.negative[a] ? high : low;
        const Double2 far_plane = s.negative[a] ? low : high;
        const Double2 t0 = (near_plane - s.origin[a]) * s.inv_dir[a];
        const Double2 t1 = (far_plane - s.origin[a]) * s.inv_dir[a];
        near[h] = t0 > near[h] ? t0 : near[h];
        far[h] = t1 < far[h] ? t1 : far[h];
      }
    }
    for (int h = 0; h < 2; ++h) {
      const Mask2 touched = (near[h] <= far[h] * kSlabSlack) & (gap_squared[h] <= s.ball_squared);
      t_entry[c + 2 * h] = near[h][0];
      t_entry[c + 2 * h + 1] = near[h][1];
      mask |= (touched[0] ? 1 << (c + 2 * h) : 0) | (touched[1] ? 2 << (c + 2 * h) : 0);
    }
  }
  return mask;
}

// Walks the BVH front to back along a -> b with boxes grown by margin, passing over the
// children whose discs lie farther than margin from the whole segment. visit(first,
// count) tests a leaf's primitives and returns the new t_max (the segment is cut at a
// hit), or a negative value to stop.
template <typename LeafVisitor>
void TraverseGrownSegment(const MeshBvh& bvh, const Vector3& a, const Vector3& b, double margin,
                          LeafVisitor visit) {
  const GrownSlabs slabs(a, b, margin);
  const FloatDiscsWithin discs(a, b - a, margin);
  const std::vector<BvhNode>& nodes = bvh.nodes();
  StackEntry stack[(kBvhWidth - 1) * kMaxBvhDepth];
  int top = 0;
  double t_max = 1;
  const auto within = [&](double t) { return t <= t_max * kSlabSlack; };
  int current = 0;
  while (true) {
    if (!WorkMeter::Charge(1)) return;
    const BvhNode& node = nodes[current];
    double t_entry[kBvhWidth];
    int mask = IntersectChildren(node, slabs, t_max, t_entry);
    if (mask != 0) mask &= discs.ChildrenWithin(bvh.discs()[current]);
    // the touched children by entry t (insertion sort of at most kBvhWidth)
    int order[kBvhWidth];
    int num = 0;
    for (int c = 0; c < kBvhWidth; ++c) {
      if (!(mask >> c & 1)) continue;
      int k = num++;
      for (; k > 0 && t_entry[order[k - 1]] > t_entry[c]; --k) order[k] = order[k - 1];
      order[k] = c;
    }
    // leaves first, in order (each may cut the segment); then the nearest internal
    // child still reached goes on, the others are stacked farthest first
    int internal[kBvhWidth];
    int num_internal = 0;
    for (int k = 0; k < num; ++k) {
      const int c = order[k];
      if (!within(t_entry[c])) break;
      if (!node.is_leaf(c)) {
        Prefetch(nodes[node.child[c]]);
        Prefetch(bvh.discs()[node.child[c]]);
        internal[num_internal++] = c;
      } else if (node.count[c] > 0) {
        if (!WorkMeter::Charge(node.count[c])) return;
        t_max = visit(node.first_primitive(c), node.count[c]);
        if (t_max < 0) return;
      }
    }
    int next = -1;
    for (int k = num_internal - 1; k >= 0; --k) {
      const int c = internal[k];
      if (!within(t_entry[c])) continue;
      if (next >= 0) stack[top++] = {node.child[next], t_entry[next]};
      next = c;
    }
    if (next >= 0) {
      current = node.child[next];
      continue;
    }
    // pop the next subtree the (possibly shortened) segment still reaches
    do {
      if (top == 0) return;
      --top;
    } while (!within(stack[top].t));
    current = stack[top].node;
  }
}

}  // namespace

double CalcSphereSweepSkin(const Vector3& a, const Vector3& b, double r) {
  if (!a.allFinite() || !b.allFinite() || !(r >= 0) || !std::isfinite(r)) return 0;
  return SkinOf(r, ScaleOf(a, b, r));
}

double CalcSphereSweepReach(const Vector3& a, const Vector3& b, double r) {
  Sweep s;
  return MakeSweep(a, b, r, s) ? s.reach : 0;
}

SphereSweepHit SweepSphereTriangle(const Triangle& tri, const Vector3& a, const Vector3& b,
                                   double r) {
  Sweep s;
  if (!MakeSweep(a, b, r, s) || !tri.v0.allFinite() || !tri.v1.allFinite() ||
      !tri.v2.allFinite()) {
    return {};
  }
  const double t = SweepTime(tri, s);
  if (t == kNoHit) return {};
  return MakeHit(tri, s, t);
}

SphereSweepHit SweepSphereMesh(const MeshBvh& bvh, const Vector3& a, const Vector3& b, double r) {
  Sweep s;
  if (!MakeSweep(a, b, r, s)) return {};
  // the boxes, and the segment's own box, grown by r and a little more
  const Aabb reach = Aabb{a.cwiseMin(b), a.cwiseMax(b)}.Inflated(s.reach);
  int best = -1;  // leaf-order index of the first hit so far
  double best_t = 0;
  TraverseGrownSegment(bvh, a, b, s.reach, [&](int first, int count) {
    for (int i = first; i < first + count; ++i) {
      const Triangle& tri = bvh.primitive(i);
      // boxes apart (exact comparisons): no contact
      if (!AabbsOverlap(reach, Aabb::OfTriangle(tri))) continue;
      const double t = SweepTime(tri, s);
      if (t != kNoHit && (best < 0 || t < best_t)) {
        best = i;
        best_t = t;
      }
    }
    // a hit at the start cannot be beaten: stop
    if (best < 0) return 1.0;
    return best_t == 0 ? -1.0 : best_t;
  });
  if (best < 0) return {};
  const int triangle = bvh.primitive_triangle(best);
  SphereSweepHit hit = MakeHit(bvh.primitive(best), s, best_t);
  hit.triangle = triangle;
  return hit;
}

namespace {

// Fills prepared from the parts already made of triangle (GatherMeshTriangles makes them
// before it decides to keep it, and writes the kept ones straight to its output).
void Prepare(const Triangle& triangle, int index, const Vector3& centroid, double bounding_radius_squared,
             const Vector3& normal, PreparedTriangle& prepared) {
  prepared.triangle = triangle;
  prepared.box = Aabb::OfTriangle(triangle);
  prepared.centroid = centroid;
  prepared.bounding_radius = std::sqrt(bounding_radius_squared);
  prepared.normal = normal;
  prepared.index = index;
}

}  // namespace

PreparedTriangle PrepareTriangle(const Triangle& triangle, int index) {
  const Vector3 centroid = CentroidOf(triangle);
  PreparedTriangle prepared;
  Prepare(triangle, index, centroid, BoundingRadiusSquaredOf(triangle, centroid), UnitOrZero(AreaNormal(triangle)),
          prepared);
  return prepared;
}

bool LiesFartherThan(const PreparedTriangle& triangle, const Vector3& p, double limit) {
  // LowerDistanceExceeds for a segment of no length, with the same arithmetic (its
  // height at both ends is the one height, and its drift zero)
  const Vector3 offset = p - triangle.centroid;
  const double height = triangle.normal.dot(offset);
  const double left = limit * limit - height * height;
  if (left < 0) return true;
  const double bounding_radius_squared = triangle.bounding_radius * triangle.bounding_radius;
  const double excess = (offset - height * triangle.normal).squaredNorm() - bounding_radius_squared - left;
  return ExceedsBeyondCircle(excess, bounding_radius_squared, left, 1);
}

int GatherMeshTriangles(const MeshBvh& bvh, const Capsule& region, std::span<PreparedTriangle> out) {
  const Vector3& a = region.p0;
  const Vector3 d = region.p1 - region.p0;
  if (!a.allFinite() || !d.allFinite() || !(region.radius >= 0) || !std::isfinite(region.radius)) return 0;
  // the BVH is walked with the segment's own box (a box farther than the radius from it
  // is farther from the segment); each triangle whose box passes is then kept by its
  // distance bound from the segment itself, with a hair of slack for rounding
  const Aabb segment_box{a.cwiseMin(region.p1), a.cwiseMax(region.p1)};
  const double scale = region.radius + std::max(a.cwiseAbs().maxCoeff(), region.p1.cwiseAbs().maxCoeff());
  const double keep = region.radius + kBoxSlack * scale;
  const double r2 = keep * keep;
  const Double2 q_lo[3] = {Splat(segment_box.min.x()), Splat(segment_box.min.y()), Splat(segment_box.min.z())};
  const Double2 q_hi[3] = {Splat(segment_box.max.x()), Splat(segment_box.max.y()), Splat(segment_box.max.z())};
  const FloatBoxWithin float_box(segment_box, keep);
  const FloatDiscsWithin float_discs(a, d, keep);
  const TriangleMesh& mesh = bvh.mesh();
  const std::vector<BvhNode>& nodes = bvh.nodes();
  const std::vector<BvhDiscs>& discs = bvh.discs();
  // every child box within the radius of the segment's box is opened (no order: all
  // of them are wanted), tested in float where it can be
  int stack[(kBvhWidth - 1) * kMaxBvhDepth + 1];
  int top = 0;
  stack[top++] = 0;
  int found = 0;
  const int capacity = static_cast<int>(out.size());
  while (top > 0) {
    if (!WorkMeter::Charge(1)) return found;
    const int node_index = stack[--top];
    const BvhNode& node = nodes[node_index];
    int within = 0;
    if (float_box.usable) {
      within = float_box.ChildrenWithin(node);
      // then the discs, which pass over much of what the boxes keep near a surface
      if (within != 0) within &= float_discs.ChildrenWithin(discs[node_index]);
    } else {
      double d2[kBvhWidth];
      ChildDistancesSquared(node, q_lo, q_hi, d2);
      for (int k = 0; k < kBvhWidth; ++k) within |= (d2[k] <= r2) << k;
    }
    for (int k = 0; k < kBvhWidth; ++k) {
      if (!(within >> k & 1)) continue;
      if (!node.is_leaf(k)) {
        Prefetch(nodes[node.child[k]]);
        Prefetch(discs[node.child[k]]);
        stack[top++] = node.child[k];
        continue;
      }
      if (!WorkMeter::Charge(node.count[k])) return found;
      for (int i = node.first_primitive(k); i < node.first_primitive(k) + node.count[k]; ++i) {
        const Triangle& tri = bvh.primitive(i);
        // a leaf of one triangle: its box was the test just passed
        if (node.count[k] > 1 && CalcAabbAabbDistanceSquared(Aabb::OfTriangle(tri), segment_box) > r2) continue;
        // the bound first, the rest of the preparation only for the triangles kept
        const Vector3 centroid = CentroidOf(tri);
        const double bounding_radius_squared = BoundingRadiusSquaredOf(tri, centroid);
        // the mesh's face normal: UnitOrZero(AreaNormal(tri)), made with the mesh
        const int index = bvh.primitive_triangle(i);
        const Vector3& normal = mesh.face_normal(index);
        // (a leaf of one triangle with a disc has just passed this bound, in float)
        const bool disc_tested = float_box.usable && node.count[k] == 1 && std::isfinite(discs[node_index].radius[k]);
        if (!disc_tested && LowerDistanceExceeds(normal, centroid, bounding_radius_squared, a, d, r2)) continue;
        // full: say so, and stop
        if (found == capacity) return capacity + 1;
        Prepare(tri, index, centroid, bounding_radius_squared, normal, out[found++]);
      }
    }
  }
  return found;
}

SphereSweepHit SweepSphereTriangles(std::span<const PreparedTriangle> triangles, const Vector3& a,
                                    const Vector3& b, double r) {
  Sweep s;
  if (!MakeSweep(a, b, r, s)) return {};
  // SweepSphereMesh's leaf test on each triangle: its exact box reject, the bounding
  // sphere's, then the sweep; with the tighter plane-and-circle bound before the sphere
  if (!WorkMeter::Charge((static_cast<int64_t>(triangles.size()) + 7) / 8)) return {};
  const Aabb reach = Aabb{a.cwiseMin(b), a.cwiseMax(b)}.Inflated(s.reach);
  int best = -1;
  double best_t = 0;
  for (int i = 0; i < static_cast<int>(triangles.size()); ++i) {
    const PreparedTriangle& prepared = triangles[i];
    if (!AabbsOverlap(reach, prepared.box)) continue;
    // the tighter bound first: where a sphere slides over a dense surface the bounding
    // spheres of nearly every gathered triangle come within reach, and it passes over
    // all but a few (finger proxy on 1.3M triangles: 81 -> 6 a sweep)
    if (s.radius > 0 && (PassesFarFrom(prepared, s) ||
                         PassesFarFrom(prepared.centroid, prepared.bounding_radius, s))) {
      continue;
    }
    if (!WorkMeter::Charge(1)) return {};
    const double t = s.radius == 0 ? PointSweepTime(prepared.triangle, s)
                                   : NearSweepTime(prepared.triangle, prepared.centroid,
                                                   prepared.bounding_radius, s);
    if (t == kNoHit || (best >= 0 && !(t < best_t))) continue;
    best = i;
    best_t = t;
    // a hit at the start cannot be beaten
    if (t == 0) break;
  }
  if (best < 0) return {};
  SphereSweepHit hit = MakeHit(triangles[best].triangle, s, best_t);
  hit.triangle = triangles[best].index;
  return hit;
}

}  // namespace hapticd::geometry
