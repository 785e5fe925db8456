#include "server/embree/embree_device.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "server/embree/embree_mesh.h"
#include "server/embree/embree_triangle_scene.h"
#include "server/geometry/mesh_generators.h"

namespace hapticd::embree {
namespace {

TEST(EmbreeDeviceTest, StartsWithoutErrors) {
  const EmbreeDevice device;
  EXPECT_NE(device.handle(), nullptr);
  EXPECT_EQ(device.error_count(), 0);
  EXPECT_EQ(device.TakeError().code, RTC_ERROR_NONE);
  EXPECT_NO_THROW(device.ThrowIfError("nothing"));
}

// The report names the kernels Embree picks: capped at SSE2 (every x86-64 has it) it is
// SSE2 with 4-wide packets only; uncapped it is one of the compiled targets, and the
// native widths follow it (16 only with AVX-512 kernels, 8 with AVX ones).
TEST(EmbreeDeviceTest, ReportNamesTheKernelsEmbreePicks) {
  const EmbreeIsaReport capped = ReportEmbreeIsa("max_isa=sse2");
  EXPECT_EQ(capped.kernels, "SSE2");
  EXPECT_EQ(capped.native_packet_widths, std::vector<int>({4}));
  EXPECT_EQ(capped.version.substr(0, 2), "3.");

  const EmbreeIsaReport best = ReportEmbreeIsa();
  ASSERT_FALSE(best.compiled.empty());
  EXPECT_NE(std::find(best.compiled.begin(), best.compiled.end(), best.kernels), best.compiled.end())
      << best.kernels;
  const auto& widths = best.native_packet_widths;
  const bool has16 = std::find(widths.begin(), widths.end(), 16) != widths.end();
  const bool has8 = std::find(widths.begin(), widths.end(), 8) != widths.end();
  EXPECT_EQ(has16, best.kernels == "AVX512") << best.kernels;
  EXPECT_EQ(has8, best.kernels.starts_with("AVX")) << best.kernels;
  // a device made the ordinary way traces the same widths
  EXPECT_EQ(EmbreeDevice().native_packet_widths(), widths);
  // the capture put std::cout back
  EXPECT_NE(std::cout.rdbuf(), nullptr);
}

TEST(EmbreeDeviceTest, MalformedConfigThrowsWithTheConfig) {
  try {
    const EmbreeDevice device("threads=abc");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("threads=abc"), std::string::npos) << e.what();
  }
}

// A buffer of the wrong format: Embree calls the error callback, the device records it,
// and committing the broken geometry afterwards neither crashes nor hides the error.
TEST(EmbreeDeviceTest, CallbackRecordsABadBufferAndThrowIfErrorReportsIt) {
  const EmbreeDevice device;
  RTCGeometry geometry = rtcNewGeometry(device.handle(), RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_UINT3,
                          3 * sizeof(unsigned), 3);
  rtcCommitGeometry(geometry);
  EXPECT_EQ(device.error_count(), 1);
  const DeviceError error = device.TakeError();
  EXPECT_EQ(error.code, RTC_ERROR_INVALID_OPERATION);
  EXPECT_NE(error.message.find("vertex buffer format"), std::string::npos) << error.message;
  // taken: cleared, still counted
  EXPECT_EQ(device.TakeError().code, RTC_ERROR_NONE);
  EXPECT_EQ(device.error_count(), 1);

  // the next bad call comes back as an exception naming the operation and the message
  rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_FLOAT3,
                          3 * sizeof(float), 1);
  try {
    device.ThrowIfError("setting the index buffer");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("RTC_ERROR_INVALID_OPERATION in setting the index buffer"),
              std::string::npos) << what;
    EXPECT_NE(what.find("index buffer format"), std::string::npos) << what;
  }
  EXPECT_EQ(device.error_count(), 2);
  rtcReleaseGeometry(geometry);
}

TEST(EmbreeDeviceTest, ErrorCodesHaveNames) {
  EXPECT_EQ(ErrorCodeName(RTC_ERROR_NONE), "RTC_ERROR_NONE");
  EXPECT_EQ(ErrorCodeName(RTC_ERROR_OUT_OF_MEMORY), "RTC_ERROR_OUT_OF_MEMORY");
  EXPECT_EQ(ErrorCodeName(static_cast<RTCError>(99)), "RTC_ERROR_(unrecognised)");
}

TEST(EmbreeDeviceTest, ScenesRejectNullArguments) {
  auto device = std::make_shared<const EmbreeDevice>();
  auto mesh = std::make_shared<const geometry::TriangleMesh>(geometry::MakeIcosphere(2, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(mesh);
  EXPECT_THROW(EmbreeMesh(nullptr, bvh), std::invalid_argument);
  EXPECT_THROW(EmbreeMesh(device, nullptr), std::invalid_argument);
  EXPECT_THROW(EmbreeTriangleScene(nullptr, mesh), std::invalid_argument);
  EXPECT_THROW(EmbreeTriangleScene(device, nullptr), std::invalid_argument);
}

// Coordinates float cannot carry with the guard's margin are refused, by value.
TEST(EmbreeDeviceTest, MeshBeyondFloatRangeIsRefusedByMagnitude) {
  auto device = std::make_shared<const EmbreeDevice>();
  auto huge = std::make_shared<const geometry::TriangleMesh>(geometry::MakeIcosphere(2, 1e31));
  try {
    const EmbreeMesh mesh(device, std::make_shared<const geometry::MeshBvh>(huge));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("magnitude 3e+31"), std::string::npos) << e.what();
  }
  auto tiny = std::make_shared<const geometry::TriangleMesh>(geometry::MakeIcosphere(2, 1e-12));
  EXPECT_THROW(EmbreeMesh(device, std::make_shared<const geometry::MeshBvh>(tiny)),
               std::invalid_argument);
  EXPECT_EQ(device->error_count(), 0);
}

// The guard and trust bound follow the mesh's reach: 8 (max |coordinate| + size), and
// 2^-18 of that.
TEST(EmbreeDeviceTest, GuardFollowsTheMeshReach) {
  auto device = std::make_shared<const EmbreeDevice>();
  auto mesh = std::make_shared<const geometry::TriangleMesh>(geometry::MakeBoxMesh({0.5, 1, 0.25}));
  const EmbreeMesh embree(device, std::make_shared<const geometry::MeshBvh>(mesh));
  EXPECT_EQ(embree.trust_bound(), 8 * (1.0 + 2.0));
  EXPECT_EQ(embree.guard(), 24.0 / (1 << 18));
  EXPECT_TRUE(embree.IsTrustedSegment({20, 0, 0}, {16, 0, 0}));
  EXPECT_FALSE(embree.IsTrustedSegment({20, 0, 0}, {15, 0, 0}));
  EXPECT_FALSE(embree.IsTrustedSegment({0, 0, 0}, {0, NAN, 0}));
  EXPECT_TRUE(embree.IsTrustedPoint({0, -24, 0}));
  EXPECT_FALSE(embree.IsTrustedPoint({0, -24.5, 0}));
}

}  // namespace
}  // namespace hapticd::embree
