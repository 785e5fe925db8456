#pragma once

// An immutable Embree scene over one triangle mesh, for queries whose answers equal
// the native exact ones (server/geometry/mesh_queries.h), computed through Embree's
// BVH.
//
// Theory of operation. Embree decides in single precision: a segment aimed exactly
// through a vertex or an edge of a closed mesh slips between its triangles a few times
// in a thousand (embree_leak_rate_main.cc measures it), and a segment nearly in a
// triangle's plane can cross it somewhere else entirely once rounded to float. No test
// on Embree's float answer can tell such a miss from a true one, so Embree is not
// asked to decide anything. Instead each triangle enters the scene as an Embree user
// primitive whose box is the triangle's box grown by guard() on every side:
//
//   segment p->q (double) --float--> ray: org = p, dir = q - p, t in [0, 1]
//        Embree's BVH traversal (BVH8 with AVX), float boxes grown by guard()
//   every primitive whose grown box the ray enters -> callback: the exact watertight
//        test (IntersectSegmentTriangleWatertight) on the double segment and triangle
//   the best exact hit so far cuts the ray at t rounded up to float
//
// The guard is 2^-18 of trust_bound() (64 float ulps). For a segment with
// |p|_inf + |q - p|_inf <= trust_bound(), the float ray passes within 1 ulp of that
// bound of every point of the double segment, and Embree's slab arithmetic errs by a
// few more; so every triangle the segment touches has a grown box the ray enters with
// margin, and reaches the exact test. The answer is then the minimum over the same
// exact tests the native query makes: the same hit, t, u and v (where two triangles
// hold the first point at exactly the same t, either may be reported, as natively).
// A segment beyond the trust bound is answered by the native BVH instead.
//
// Built and committed in the constructor (setup work, off the real-time thread); after
// that every query is const, thread-safe and allocation-free.

#include <embree3/rtcore.h>

#include <memory>

#include "server/embree/embree_device.h"
#include "server/geometry/bvh.h"
#include "server/geometry/types.h"

namespace hapticd::embree {

class EmbreeMesh {
 public:
  // Builds the scene over bvh's primitives (its non-degenerate triangles, in its leaf
  // order); shares ownership of the device and the BVH. Throws std::invalid_argument on
  // a null argument or a mesh whose magnitude (largest |coordinate| plus size) is
  // outside [1e-9, 1e30] (float cannot cover it), and std::runtime_error with Embree's
  // message when Embree fails to build.
  EmbreeMesh(std::shared_ptr<const EmbreeDevice> device,
             std::shared_ptr<const geometry::MeshBvh> bvh);
  ~EmbreeMesh();
  // Embree holds a pointer to this object: neither copied nor moved.
  EmbreeMesh(const EmbreeMesh&) = delete;
  EmbreeMesh& operator=(const EmbreeMesh&) = delete;

  RTCScene scene() const { return scene_; }
  const EmbreeDevice& device() const { return *device_; }
  const geometry::MeshBvh& bvh() const { return *bvh_; }
  const geometry::TriangleMesh& mesh() const { return bvh_->mesh(); }

  // Embree primitive i is the BVH's primitive i: its double triangle and its original
  // mesh index. Precondition: i < bvh().num_primitives().
  const geometry::Triangle& primitive(unsigned i) const { return bvh_->primitive(static_cast<int>(i)); }
  int primitive_triangle(unsigned i) const { return bvh_->primitive_triangle(static_cast<int>(i)); }

  // Queries whose coordinates stay within this bound (m) go through Embree:
  // 8 (largest |coordinate| of the mesh's box + its size).
  double trust_bound() const { return trust_bound_; }
  // How far each primitive's box is grown (m): trust_bound() * 2^-18.
  double guard() const { return guard_; }

  // True when the segment p->q is answered through Embree: finite, and
  // |p|_inf + |q - p|_inf <= trust_bound().
  bool IsTrustedSegment(const geometry::Vector3& p, const geometry::Vector3& q) const;
  // True when a point query at p is answered through Embree: finite, |p|_inf <=
  // trust_bound().
  bool IsTrustedPoint(const geometry::Vector3& p) const;

 private:
  static void Bounds(const RTCBoundsFunctionArguments* args);

  std::shared_ptr<const EmbreeDevice> device_;
  std::shared_ptr<const geometry::MeshBvh> bvh_;
  double trust_bound_ = 0;
  double guard_ = 0;
  RTCScene scene_ = nullptr;
};

// The float nearest x in the given direction: RoundDown(x) <= x <= RoundUp(x) (overflow
// gives an infinity of the right sign). For bounds handed to Embree.
float RoundDown(double x);
float RoundUp(double x);

}  // namespace hapticd::embree
