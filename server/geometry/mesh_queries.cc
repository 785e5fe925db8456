#include "server/geometry/mesh_queries.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "server/geometry/bvh_simd.h"
#include "server/geometry/exact_predicates.h"
#include "server/geometry/segment_triangle.h"
#include "server/geometry/work_meter.h"

namespace hapticd::geometry {
namespace {

using namespace bvh_simd;

// A gap shorter than this (relative to the coordinates) has no reliable direction.
constexpr double kTinyGap = 1e-12;

struct StackEntry {
  int node;
  double key;  // entry t of a segment, or squared distance of a point
};

// The segment p -> q, prepared for slab tests in double precision: the fallback for
// segments that float cannot carry (see FloatSegmentSlabs).
struct SegmentSlabs {
  using Key = double;
  Double2 origin[3];
  Double2 inv_dir[3];
  bool negative[3];  // direction sign bit: the near slab plane is the upper one

  SegmentSlabs(const Vector3& p, const Vector3& q) {
    for (int a = 0; a < 3; ++a) {
      const double d = q[a] - p[a];
      origin[a] = Splat(p[a]);
      inv_dir[a] = Splat(1 / d);
      negative[a] = std::signbit(d);
    }
  }

  // Whether a child entered at `key` (its entry t) is still before the end t_max.
  static bool Within(double key, double t_max) { return key <= t_max * kSlabSlack; }

  // Which children of `node` the segment touches for t in [0, t_max]: bit c for child
  // c, with its entry t in t_entry[c]. A zero direction component gives infinite slab
  // distances, or NaN where the origin lies on the slab plane; the selects
  // `x > acc ? x : acc` skip the NaN, which leaves that slab unbounded, as it should be.
  int IntersectChildren(const BvhNode& node, double t_max, double t_entry[kBvhWidth]) const {
    int mask = 0;
    for (int c = 0; c < kBvhWidth; c += 4) {
      Double2 near[2] = {Splat(0), Splat(0)};
      Double2 far[2] = {Splat(t_max), Splat(t_max)};
      for (int a = 0; a < 3; ++a) {
        Double2 near_plane[2], far_plane[2];
        Load((negative[a] ? node.hi[a] : node.lo[a]) + c, near_plane[0], near_plane[1]);
        Load((negative[a] ? node.lo[a] : node.hi[a]) + c, far_plane[0], far_plane[1]);
        for (int h = 0; h < 2; ++h) {
          const Double2 t0 = (near_plane[h] - origin[a]) * inv_dir[a];
          const Double2 t1 = (far_plane[h] - origin[a]) * inv_dir[a];
          near[h] = t0 > near[h] ? t0 : near[h];
          far[h] = t1 < far[h] ? t1 : far[h];
        }
      }
      for (int h = 0; h < 2; ++h) {
        const Mask2 touched = near[h] <= far[h] * kSlabSlack;
        t_entry[c + 2 * h] = near[h][0];
        t_entry[c + 2 * h + 1] = near[h][1];
        mask |= (touched[0] ? 1 << (c + 2 * h) : 0) | (touched[1] ? 2 << (c + 2 * h) : 0);
      }
    }
    return mask;
  }
};

// The segment p -> q, prepared for slab tests in float, four children per vector, with
// every rounding taken against missing a box (after Ize 2013, "Robust BVH ray
// traversal"):
//  - the origin is rounded to float and widened, o_lo <= p <= o_hi, and each slab plane
//    subtracts the one that moves its distance outwards (the near plane the origin
//    ahead of p, the far plane the one behind), so the float slab is never narrower
//    than the exact one, and its distances have the exact signs;
//  - what is left is relative: the subtraction, the product, 1 / d rounded to double
//    and then to float, and t_max rounded to float, each within 2^-24, so an entry t
//    is at most (1 + 3.01 2^-24) times its exact value and an exit t at least
//    (1 - 3.01 2^-24) times; comparing entry <= exit (1 + 2^-20) covers their ratio and
//    the rounding of that product with room to spare;
//  - a product that underflows has an absolute error below 2^-149, which kFloatFloor
//    covers.
// A zero direction component gives infinite slab distances, or NaN where the plane
// meets the rounded origin; the selects skip the NaN, which leaves that slab unbounded
// (conservative). Float carries this only for coordinates within +-1e30 and direction
// components 0 or of at least 1e-37 in magnitude (1 / d then a normal float); `usable`
// says so, and the traversal falls back to SegmentSlabs where it is false.
struct FloatSegmentSlabs {
  using Key = float;
  static constexpr float kFloatSlack = 1 + 1.0f / (1 << 20);
  static constexpr float kFloatFloor = 1e-30f;
  static constexpr double kMaxCoordinate = 1e30;
  static constexpr double kMinDirection = 1e-37;

  Float4 near_origin[3];
  Float4 far_origin[3];
  Float4 inv_dir[3];
  int near_row[3];  // row of the node's bounds (lo[a] = a, hi[a] = 3 + a) of the near plane
  int far_row[3];
  bool usable = true;

  FloatSegmentSlabs(const Vector3& p, const Vector3& q) {
    for (int a = 0; a < 3; ++a) {
      const double d = q[a] - p[a];
      if (!(std::abs(p[a]) <= kMaxCoordinate && std::abs(q[a]) <= kMaxCoordinate) ||
          (d != 0 && !(std::abs(d) >= kMinDirection))) {
        usable = false;
        return;
      }
      const bool negative = std::signbit(d);
      // p rounded to float, then widened by at least an ulp each way (|o| 2^-23 is one
      // ulp or more, FLT_MIN more than a subnormal's), each sum rounding to no less
      const float o = static_cast<float>(p[a]);
      const float widen = std::abs(o) * (1.0f / (1 << 23)) + std::numeric_limits<float>::min();
      const float o_lo = o - widen;
      const float o_hi = o + widen;
      near_origin[a] = SplatFloat(negative ? o_lo : o_hi);
      far_origin[a] = SplatFloat(negative ? o_hi : o_lo);
      inv_dir[a] = SplatFloat(static_cast<float>(1 / d));
      near_row[a] = negative ? 3 + a : a;
      far_row[a] = negative ? a : 3 + a;
    }
  }

  static bool Within(double key, double t_max) {
    return key <= t_max * static_cast<double>(kFloatSlack) + static_cast<double>(kFloatFloor);
  }

  int IntersectChildren(const BvhNode& node, double t_max, float t_entry[kBvhWidth]) const {
    static_assert(kBvhWidth == 4, "one vector of four children per node");
    const float* rows = &node.lo[0][0];  // lo[0..2] then hi[0..2], four children each
    Float4 near = SplatFloat(0);
    Float4 far = SplatFloat(static_cast<float>(t_max));
    for (int a = 0; a < 3; ++a) {
      const Float4 t0 = (LoadFloat4(rows + 4 * near_row[a]) - near_origin[a]) * inv_dir[a];
      const Float4 t1 = (LoadFloat4(rows + 4 * far_row[a]) - far_origin[a]) * inv_dir[a];
      near = t0 > near ? t0 : near;
      far = t1 < far ? t1 : far;
    }
    const Mask4 touched = near <= far * kFloatSlack + kFloatFloor;
    std::memcpy(t_entry, &near, sizeof(near));
    return (touched[0] & 1) | (touched[1] & 2) | (touched[2] & 4) | (touched[3] & 8);
  }
};

// What VisitChildren returns instead of a node to go on with.
constexpr int kPop = -1;   // take the next node from the stack
constexpr int kStop = -2;  // a leaf visitor ended the traversal

// The children of a node whose key (entry t or squared distance) passes, nearest
// first: leaves are handed to visit_leaf as they come (which may tighten the bound),
// then the traversal goes on into the nearest internal child still within the bound and
// stacks the others, farthest first. Returns that child's node, kPop or kStop.
template <typename Key, typename WithinBound, typename LeafVisitor>
inline int VisitChildren(const std::vector<BvhNode>& nodes, const BvhNode& node,
                         const Key key[kBvhWidth], int mask, StackEntry* stack, int& top,
                         WithinBound within, LeafVisitor visit_leaf) {
  // none or one child: nothing to order or stack
  if ((mask & (mask - 1)) == 0) {
    if (mask == 0) return kPop;
    const int c = std::countr_zero(static_cast<unsigned>(mask));
    if (!within(key[c])) return kPop;
    if (!node.is_leaf(c)) return node.child[c];
    if (node.count[c] > 0 && !visit_leaf(node.first_primitive(c), node.count[c])) return kStop;
    return kPop;
  }
  // order the touched children by key (insertion sort of at most kBvhWidth)
  int order[kBvhWidth];
  int num = 0;
  for (int c = 0; c < kBvhWidth; ++c) {
    if (!(mask >> c & 1)) continue;
    int k = num++;
    for (; k > 0 && key[order[k - 1]] > key[c]; --k) order[k] = order[k - 1];
    order[k] = c;
  }
  int internal[kBvhWidth];
  int num_internal = 0;
  for (int k = 0; k < num; ++k) {
    const int c = order[k];
    if (!within(key[c])) break;
    if (node.is_leaf(c)) {
      if (node.count[c] > 0 && !visit_leaf(node.first_primitive(c), node.count[c])) return kStop;
    } else {
      Prefetch(nodes[node.child[c]]);
      internal[num_internal++] = c;
    }
  }
  int next = -1;
  for (int k = num_internal - 1; k >= 0; --k) {
    const int c = internal[k];
    if (!within(key[c])) continue;
    if (next >= 0) stack[top++] = {node.child[next], key[next]};
    next = c;
  }
  return next >= 0 ? node.child[next] : kPop;
}

// Walks the BVH front to back along the segment prepared in `slabs` (SegmentSlabs or
// FloatSegmentSlabs). visit(first, count) tests a leaf's primitives and returns the new
// t_max (the segment is cut at a hit), or a negative value to stop.
template <typename Slabs, typename LeafVisitor>
void TraverseSegmentSlabs(const MeshBvh& bvh, const Slabs& slabs, LeafVisitor visit) {
  const std::vector<BvhNode>& nodes = bvh.nodes();
  StackEntry stack[(kBvhWidth - 1) * kMaxBvhDepth];
  int top = 0;
  double t_max = 1;
  auto within = [&](double t) { return Slabs::Within(t, t_max); };
  auto visit_leaf = [&](int first, int count) {
    if (!WorkMeter::Charge(count)) return false;
    t_max = visit(first, count);
    return t_max >= 0;
  };
  int current = 0;
  while (true) {
    if (!WorkMeter::Charge(1)) return;
    const BvhNode& node = nodes[current];
    typename Slabs::Key t_entry[kBvhWidth];
    const int mask = slabs.IntersectChildren(node, t_max, t_entry);
    current = VisitChildren(nodes, node, t_entry, mask, stack, top, within, visit_leaf);
    if (current == kStop) return;
    if (current != kPop) continue;
    // pop the next subtree the (possibly shortened) segment still reaches
    do {
      if (top == 0) return;
      --top;
    } while (!within(stack[top].key));
    current = stack[top].node;
  }
}

// Walks the BVH front to back along p -> q: in float where float carries the segment,
// else in double. visit as above.
template <typename LeafVisitor>
void TraverseSegment(const MeshBvh& bvh, const Vector3& p, const Vector3& q, LeafVisitor visit) {
  const FloatSegmentSlabs float_slabs(p, q);
  if (float_slabs.usable) {
    TraverseSegmentSlabs(bvh, float_slabs, visit);
  } else {
    TraverseSegmentSlabs(bvh, SegmentSlabs(p, q), visit);
  }
}

// Walks every leaf whose box lies within sqrt(*bound_d2) of p, nearest first.
// visit(first, count) may lower *bound_d2 to prune the rest.
template <typename LeafVisitor>
void TraverseNearest(const MeshBvh& bvh, const Vector3& p, const double* bound_d2,
                     LeafVisitor visit) {
  const std::vector<BvhNode>& nodes = bvh.nodes();
  const Double2 p2[3] = {Splat(p.x()), Splat(p.y()), Splat(p.z())};
  StackEntry stack[(kBvhWidth - 1) * kMaxBvhDepth];
  int top = 0;
  auto within = [&](double d2) { return d2 <= *bound_d2; };
  auto visit_leaf = [&](int first, int count) {
    if (!WorkMeter::Charge(count)) return false;
    visit(first, count);
    return true;
  };
  int current = 0;
  while (true) {
    if (!WorkMeter::Charge(1)) return;
    const BvhNode& node = nodes[current];
    double d2[kBvhWidth];
    ChildDistancesSquared(node, p2, d2);
    const int all = (1 << kBvhWidth) - 1;
    current = VisitChildren(nodes, node, d2, all, stack, top, within, visit_leaf);
    if (current == kStop) return;
    if (current != kPop) continue;
    do {
      if (top == 0) return;
      --top;
    } while (!within(stack[top].key));
    current = stack[top].node;
  }
}

// Squared distance from p to the box around t: a lower bound of the distance to t that
// costs a fraction of the exact closest point.
inline double BoxDistanceSquared(const Vector3& p, const Triangle& t) {
  const Vector3 lo = t.v0.cwiseMin(t.v1).cwiseMin(t.v2);
  const Vector3 hi = t.v0.cwiseMax(t.v1).cwiseMax(t.v2);
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).squaredNorm();
}

// Original index of a triangle that holds p exactly, or -1.
int FindTriangleHoldingPoint(const MeshBvh& bvh, const Vector3& p) {
  int found = -1;
  const double zero = 0;
  TraverseNearest(bvh, p, &zero, [&](int first, int count) {
    for (int i = first; i < first + count && found < 0; ++i) {
      const Triangle& t = bvh.primitive(i);
      if (Aabb::OfTriangle(t).Contains(p) && IsPointOnTriangle(p, t)) {
        found = bvh.primitive_triangle(i);
      }
    }
  });
  return found;
}

// Unit normal of a sphere contact, from the triangle towards the centre. On a face it is
// the face normal, turned to the centre's side (exact, and defined when the centre is
// on the face: then the face normal itself). On an edge or vertex it is the direction
// of the gap, or the feature's pseudo-normal when the gap is too small to have one.
Vector3 ContactNormal(const TriangleMesh& mesh, int triangle, const ClosestPointOnTriangle& c,
                      const Vector3& center, double distance) {
  if (c.feature == TriangleFeature::kFace) {
    const Triangle t = mesh.triangle(triangle);
    const bool behind = Orient3d(t.v0, t.v1, t.v2, center) < 0;
    return behind ? Vector3(-mesh.face_normal(triangle)) : mesh.face_normal(triangle);
  }
  const Vector3 gap = center - c.point;
  if (distance > kTinyGap * (center.cwiseAbs().maxCoeff() + distance)) return gap / distance;
  return mesh.FeatureNormal(triangle, c.feature);
}

}  // namespace

bool IsPointOnTriangle(const Vector3& p, const Triangle& t) {
  if (Orient3d(t.v0, t.v1, t.v2, p) != 0) return false;
  for (int drop = 0; drop < 3; ++drop) {
    const int i = (drop + 1) % 3, j = (drop + 2) % 3;
    const Vector2 a(t.v0[i], t.v0[j]), b(t.v1[i], t.v1[j]), c(t.v2[i], t.v2[j]), x(p[i], p[j]);
    const int orientation = Orient2d(a, b, c);
    // this projection flattens the triangle to a segment: try the next axis
    if (orientation == 0) continue;
    return Orient2d(a, b, x) * orientation >= 0 && Orient2d(b, c, x) * orientation >= 0 &&
           Orient2d(c, a, x) * orientation >= 0;
  }
  return false;
}

bool IsOutsideOfClosestFeature(const TriangleMesh& mesh, const Vector3& p, const MeshClosestPoint& closest) {
  // on a face, exactly
  if (closest.feature == TriangleFeature::kFace) {
    const Triangle t = mesh.triangle(closest.triangle);
    return Orient3d(t.v0, t.v1, t.v2, p) > 0;
  }
  return (p - closest.point).dot(mesh.FeatureNormal(closest.triangle, closest.feature)) > 0;
}

SegmentMeshHit FindFirstSegmentHit(const MeshBvh& bvh, const Vector3& p, const Vector3& q) {
  SegmentMeshHit best;
  // non-finite input, or the precondition p != q broken: a miss
  if (!p.allFinite() || !q.allFinite() || p == q) return best;
  // the leaves' boxes are the triangles' own (mostly one a leaf), so each is tested at once
  TraverseSegment(bvh, p, q, [&](int first, int count) {
    for (int i = first; i < first + count; ++i) {
      const TriangleHit h = IntersectSegmentTriangleWatertight(p, q, bvh.primitive(i));
      if (h.hit && (!best.hit || h.t < best.t)) {
        best = {true, h.t, bvh.primitive_triangle(i), h.u, h.v};
      }
    }
    return best.hit ? best.t : 1.0;
  });
  return best;
}

bool SegmentHitsMesh(const MeshBvh& bvh, const Vector3& p, const Vector3& q) {
  bool hit = false;
  if (!p.allFinite() || !q.allFinite() || p == q) return hit;
  TraverseSegment(bvh, p, q, [&](int first, int count) {
    for (int i = first; i < first + count && !hit; ++i) {
      hit = IntersectSegmentTriangleWatertight(p, q, bvh.primitive(i)).hit;
    }
    return hit ? -1.0 : 1.0;
  });
  return hit;
}

MeshClosestPoint FindClosestPointOnMesh(const MeshBvh& bvh, const Vector3& p,
                                        double max_distance) {
  MeshClosestPoint best;
  if (!p.allFinite() || !(max_distance >= 0)) return best;
  double best_d2 = max_distance * max_distance;
  TraverseNearest(bvh, p, &best_d2, [&](int first, int count) {
    for (int i = first; i < first + count; ++i) {
      if (BoxDistanceSquared(p, bvh.primitive(i)) > best_d2) continue;
      const ClosestPointOnTriangle c = FindClosestPointOnTriangle(p, bvh.primitive(i));
      // within the radius at first, then strictly closer
      if (c.distance_squared < best_d2 || (!best.found && c.distance_squared <= best_d2)) {
        best_d2 = c.distance_squared;
        best = {true, bvh.primitive_triangle(i), c.feature, c.point, c.u, c.v, 0};
      }
    }
  });
  if (best.found) best.distance = std::sqrt(best_d2);
  return best;
}

SphereMeshContacts FindSphereMeshContacts(const MeshBvh& bvh, const Sphere& sphere,
                                          std::span<SphereMeshContact> out) {
  SphereMeshContacts result;
  const Vector3& center = sphere.center;
  if (!center.allFinite() || !(sphere.radius >= 0) || !std::isfinite(sphere.radius)) {
    return result;
  }
  const double r2 = sphere.radius * sphere.radius;
  const TriangleMesh& mesh = bvh.mesh();
  TraverseNearest(bvh, center, &r2, [&](int first, int count) {
    for (int i = first; i < first + count; ++i) {
      if (BoxDistanceSquared(center, bvh.primitive(i)) > r2) continue;
      const ClosestPointOnTriangle c = FindClosestPointOnTriangle(center, bvh.primitive(i));
      if (!(c.distance_squared <= r2)) continue;
      ++result.num_touching;
      SphereMeshContact contact;
      contact.triangle = bvh.primitive_triangle(i);
      contact.point = c.point;
      contact.feature = c.feature;
      const double distance = std::sqrt(c.distance_squared);
      contact.depth = std::max(0.0, sphere.radius - distance);
      contact.normal = ContactNormal(mesh, contact.triangle, c, center, distance);
      // buffer full: replace the shallowest kept contact if this one is deeper
      if (result.count < static_cast<int>(out.size())) {
        out[result.count++] = contact;
        continue;
      }
      result.truncated = true;
      if (out.empty()) continue;
      auto shallowest = std::min_element(
          out.begin(), out.end(),
          [](const SphereMeshContact& x, const SphereMeshContact& y) { return x.depth < y.depth; });
      if (shallowest->depth < contact.depth) *shallowest = contact;
    }
  });
  return result;
}

MeshSignedDistance CalcSignedDistanceToMesh(const MeshBvh& bvh, const Vector3& p) {
  MeshSignedDistance result;
  result.closest = FindClosestPointOnMesh(bvh, p);
  if (!result.closest.found) return result;
  MeshClosestPoint& closest = result.closest;
  const TriangleMesh& mesh = bvh.mesh();

  // on the surface: exactly zero, or found exactly when rounding leaves a tiny gap
  const double magnitude = mesh.size() + p.cwiseAbs().maxCoeff();
  if (closest.distance == 0) {
    result.inside = true;
    return result;
  }
  if (closest.distance <= kOnSurfaceTolerance * magnitude) {
    const int holder = FindTriangleHoldingPoint(bvh, p);
    if (holder >= 0) {
      const ClosestPointOnTriangle on = FindClosestPointOnTriangle(p, mesh.triangle(holder));
      closest = {true, holder, on.feature, p, on.u, on.v, 0};
      result.inside = true;
      return result;
    }
  }

  // the side of the closest feature's pseudo-normal
  bool outside = IsOutsideOfClosestFeature(mesh, p, closest);
  // a closed mesh wound inwards: its outside is the other side
  if (mesh.signed_volume() < 0) outside = !outside;
  result.inside = !outside;
  result.signed_distance = outside ? closest.distance : -closest.distance;
  return result;
}

bool IsPointInsideMesh(const MeshBvh& bvh, const Vector3& p) {
  return CalcSignedDistanceToMesh(bvh, p).inside;
}

}  // namespace hapticd::geometry
