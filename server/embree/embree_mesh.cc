#include "server/embree/embree_mesh.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "server/embree/segment_callbacks.h"

namespace hapticd::embree {
namespace {

using geometry::Vector3;

// Magnitudes float covers with room to spare: below, Embree's clamping of tiny ray
// directions (to 1e-18) would no longer be negligible against the guard; above, float
// overflows.
constexpr double kMinMagnitude = 1e-9;
constexpr double kMaxMagnitude = 1e30;

// The trust bound in units of the mesh's reach, and the guard in units of the bound
// (2^-18: 64 float ulps; rounding the segment to float costs 1, Embree's slab
// arithmetic a few more; on embree_leak_rate's segments 2^-24 already leaks nothing,
// and no guard at all leaks 2.5%).
constexpr double kTrustFactor = 8;
constexpr double kGuardFactor = 1.0 / (1 << 18);

double MaxAbs(const Vector3& v) { return v.cwiseAbs().maxCoeff(); }

}  // namespace

float RoundDown(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

float RoundUp(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

EmbreeMesh::EmbreeMesh(std::shared_ptr<const EmbreeDevice> device,
                       std::shared_ptr<const geometry::MeshBvh> bvh)
    : device_(std::move(device)), bvh_(std::move(bvh)) {
  if (device_ == nullptr) throw std::invalid_argument("EmbreeMesh: the device is null");
  if (bvh_ == nullptr) throw std::invalid_argument("EmbreeMesh: the BVH is null");

  // the trust bound and the guard, from the mesh's reach
  const geometry::Aabb& bounds = mesh().bounds();
  const double magnitude = std::max(MaxAbs(bounds.min), MaxAbs(bounds.max)) + mesh().size();
  if (!(magnitude >= kMinMagnitude && magnitude <= kMaxMagnitude)) {
    std::ostringstream message;
    message << "Cannot build an Embree scene for a mesh of magnitude " << magnitude
            << " (largest |coordinate| plus size); float covers [" << kMinMagnitude << ", "
            << kMaxMagnitude << "]";
    throw std::invalid_argument(message.str());
  }
  trust_bound_ = kTrustFactor * magnitude;
  guard_ = kGuardFactor * trust_bound_;

  RTCDevice handle = device_->handle();
  // errors left from earlier calls are not this build's
  device_->TakeError();
  scene_ = rtcNewScene(handle);
  try {
    // Build quality HIGH: the scene never changes and is built off the real-time
    // thread, so build time is spent for the best traversal. No scene flags: ROBUST
    // selects Embree's robust triangle and traversal kernels, but Embree 3.13 has none
    // for user geometry (the flag would change nothing here); the guard is what makes
    // the traversal conservative. DYNAMIC and COMPACT would trade traversal speed for
    // updates and memory this scene does not need.
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_NONE);

    // one user primitive per BVH primitive, decided by the exact callbacks
    RTCGeometry geometry = rtcNewGeometry(handle, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geometry, static_cast<unsigned>(bvh_->num_primitives()));
    rtcSetGeometryUserData(geometry, this);
    rtcSetGeometryBoundsFunction(geometry, &EmbreeMesh::Bounds, this);
    rtcSetGeometryIntersectFunction(geometry, &internal::IntersectCandidate);
    rtcSetGeometryOccludedFunction(geometry, &internal::OccludeCandidate);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    device_->ThrowIfError("building the EmbreeMesh geometry");

    rtcCommitScene(scene_);
    device_->ThrowIfError("rtcCommitScene (EmbreeMesh)");
  } catch (...) {
    rtcReleaseScene(scene_);
    throw;
  }
}

EmbreeMesh::~EmbreeMesh() { rtcReleaseScene(scene_); }

void EmbreeMesh::Bounds(const RTCBoundsFunctionArguments* args) {
  const auto& self = *static_cast<const EmbreeMesh*>(args->geometryUserPtr);
  const geometry::Aabb box = geometry::Aabb::OfTriangle(self.primitive(args->primID));
  // grown by the guard, rounded outwards to float
  RTCBounds& out = *args->bounds_o;
  out.lower_x = RoundDown(box.min.x() - self.guard_);
  out.lower_y = RoundDown(box.min.y() - self.guard_);
  out.lower_z = RoundDown(box.min.z() - self.guard_);
  out.upper_x = RoundUp(box.max.x() + self.guard_);
  out.upper_y = RoundUp(box.max.y() + self.guard_);
  out.upper_z = RoundUp(box.max.z() + self.guard_);
}

bool EmbreeMesh::IsTrustedSegment(const Vector3& p, const Vector3& q) const {
  if (!p.allFinite() || !q.allFinite()) return false;
  return MaxAbs(p) + MaxAbs(q - p) <= trust_bound_;
}

bool EmbreeMesh::IsTrustedPoint(const Vector3& p) const {
  return p.allFinite() && MaxAbs(p) <= trust_bound_;
}

}  // namespace hapticd::embree
