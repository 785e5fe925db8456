#pragma once

// Plain Embree: a mesh's triangles as an Embree triangle geometry in float, answered by
// Embree's own intersector with no confirmation. Not exact: a segment aimed through a
// vertex or an edge can slip between triangles, and one ending near a surface can be
// decided either way. It exists to measure Embree's own speed and leak rate beside
// EmbreeMesh's (embree_leak_rate_main.cc, the bench), never for a proxy.

#include <embree3/rtcore.h>

#include <memory>
#include <vector>

#include "server/embree/embree_device.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/triangle_mesh.h"

namespace hapticd::embree {

struct TriangleSceneOptions {
  // RTC_SCENE_FLAG_ROBUST: Embree's watertight-leaning triangle test and conservative
  // traversal, at some speed.
  bool robust = true;
  RTCBuildQuality quality = RTC_BUILD_QUALITY_HIGH;
};

class EmbreeTriangleScene {
 public:
  // Builds and commits the scene over the mesh's non-degenerate triangles, vertices
  // rounded to the nearest float. Throws std::invalid_argument on a null argument and
  // std::runtime_error with Embree's message when Embree fails to build.
  EmbreeTriangleScene(std::shared_ptr<const EmbreeDevice> device,
                      std::shared_ptr<const geometry::TriangleMesh> mesh,
                      const TriangleSceneOptions& options = {});
  ~EmbreeTriangleScene();
  EmbreeTriangleScene(const EmbreeTriangleScene&) = delete;
  EmbreeTriangleScene& operator=(const EmbreeTriangleScene&) = delete;

  RTCScene scene() const { return scene_; }
  const geometry::TriangleMesh& mesh() const { return *mesh_; }
  bool robust() const { return robust_; }
  // Original mesh index of Embree primitive i (i < the number of non-degenerate
  // triangles).
  int primitive_triangle(unsigned i) const { return mesh_->nondegenerate_triangles()[i]; }

 private:
  std::shared_ptr<const EmbreeDevice> device_;
  std::shared_ptr<const geometry::TriangleMesh> mesh_;
  bool robust_ = true;
  RTCScene scene_ = nullptr;
};

// Embree's own first hit along p -> q (rtcIntersect1 on the float ray org = p,
// dir = q - p, t in [0, 1]): t, u and v as Embree computes them, the triangle by its
// original index. Non-finite input or p == q misses. Thread-safe, allocation-free.
geometry::SegmentMeshHit CastSegmentUnconfirmed(const EmbreeTriangleScene& scene,
                                                const geometry::Vector3& p,
                                                const geometry::Vector3& q);

}  // namespace hapticd::embree
