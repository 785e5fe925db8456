// The scene read back (GetScene): every shape's parameters, the mesh an object was given
// as with its frame, a kinematic object's velocities as the client set them, mesh data
// only on request and within its bound, and a digest that follows the shape.
#include "server/net/scene_description.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "server/geometry/mesh_generators.h"
#include "server/net/request_error.h"
#include "server/net/test/net_harness.h"
#include "server/scene/scene_builder.h"

namespace hapticd::net {
namespace {

using geometry::Vector3;

const std::vector<Vector3> kTetra = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
const std::vector<std::array<int, 3>> kTetraTriangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

scene::ObjectSpec Named(std::string name, scene::ShapeSpec shape) {
  scene::ObjectSpec spec;
  spec.name = std::move(name);
  spec.shape = std::move(shape);
  return spec;
}

scene::MeshSpec MeshOf(std::vector<Vector3> vertices, std::vector<std::array<int, 3>> triangles,
                       scene::Representation pin) {
  scene::MeshSpec mesh;
  mesh.vertices = std::move(vertices);
  mesh.triangles = std::move(triangles);
  mesh.pin = pin;
  return mesh;
}

Vector3 Read(const v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

// R_WB of a pose message.
geometry::Matrix3 RotationOf(const v1::Pose& pose) {
  const v1::Quat& q = pose.orientation();
  return Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).toRotationMatrix();
}

v1::GetScene WithDataFor(std::vector<std::string> names) {
  v1::GetScene request;
  for (const std::string& name : names) request.add_mesh_data_for(name);
  return request;
}

RequestError Refusal(const scene::SceneSnapshot& scene, const v1::GetScene& request, std::size_t bound) {
  try {
    DescribeScene(scene, request, bound);
  } catch (const RequestError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted: " << request.DebugString();
  return RequestError(v1::Error::CODE_UNSPECIFIED, "");
}

TEST(SceneDescription, EveryPrimitiveReadsBackItsParameters) {
  scene::SceneBuilder builder;
  builder.Add(Named("ball", scene::SphereShape{0.25}));
  builder.Add(Named("crate", scene::BoxShape{Vector3(0.1, 0.2, 0.3)}));
  builder.Add(Named("pill", scene::CapsuleShape{0.05, 0.4}));
  builder.Add(Named("floor", scene::PlaneShape{}));
  // a cube's corners and its centre: the hull is the eight corners
  scene::ConvexSpec cube;
  for (int i = 0; i < 8; ++i) cube.points.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  cube.points.emplace_back(0, 0, 0);
  builder.Add(Named("hull", cube));
  const v1::SceneDescription scene = DescribeScene(*builder.Build(1), v1::GetScene{});

  ASSERT_EQ(scene.objects_size(), 5);
  EXPECT_EQ(scene.objects(0).represented_shape().sphere().radius(), 0.25);
  EXPECT_EQ(Read(scene.objects(1).represented_shape().box().half_extents()), Vector3(0.1, 0.2, 0.3));
  EXPECT_EQ(scene.objects(2).represented_shape().capsule().radius(), 0.05);
  EXPECT_EQ(scene.objects(2).represented_shape().capsule().half_length(), 0.4);
  EXPECT_TRUE(scene.objects(3).represented_shape().has_plane());
  const auto& points = scene.objects(4).represented_shape().convex().points();
  ASSERT_EQ(points.size(), 24);
  for (int i = 0; i < points.size(); ++i) EXPECT_EQ(std::abs(points[i]), 1.0) << i;
  // none was given as a mesh, none moves
  for (const v1::ObjectInfo& info : scene.objects()) {
    EXPECT_FALSE(info.has_mesh()) << info.name();
    EXPECT_FALSE(info.has_mesh_pose()) << info.name();
    EXPECT_FALSE(info.has_velocity()) << info.name();
  }
}

// A mesh pinned to a box: the box in the pose's frame, the mesh in its own frame M, and
// M's pose composed with the box's place in M is the pose.
TEST(SceneDescription, AMeshReadsBackAsGivenWithItsFrame) {
  scene::SceneBuilder builder;
  geometry::TriangleMesh ball = geometry::MakeIcosphere(2, 0.5);
  std::vector<Vector3> shifted = ball.vertices();
  for (Vector3& v : shifted) v += Vector3(0.3, 0, 0);
  scene::ObjectSpec boxed = Named("boxed", MeshOf(shifted, ball.triangles(), scene::Representation::kBox));
  boxed.X_WB.rotation = Eigen::AngleAxisd(0.7, Vector3(1, 2, 3).normalized()).toRotationMatrix();
  boxed.X_WB.translation = {1, -2, 0.5};
  builder.Add(boxed);
  builder.Add(Named("tetra", MeshOf(kTetra, kTetraTriangles, scene::Representation::kMesh)));
  v1::GetScene everything;
  everything.set_include_mesh_data(true);
  const v1::SceneDescription scene = DescribeScene(*builder.Build(1), everything);

  const v1::ObjectInfo& info = scene.objects(0);
  EXPECT_EQ(info.representation(), "box");
  EXPECT_TRUE(info.represented_shape().has_box());
  EXPECT_EQ(info.mesh().representation(), v1::REPRESENTATION_BOX);
  ASSERT_EQ(info.mesh().vertices_size(), static_cast<int>(3 * shifted.size()));
  for (std::size_t i = 0; i < shifted.size(); ++i) {
    EXPECT_EQ(info.mesh().vertices(3 * i), shifted[i].x()) << i;
  }
  EXPECT_EQ(info.mesh().triangles_size(), 3 * ball.num_triangles());
  EXPECT_TRUE((Read(info.mesh_pose().position()) - boxed.X_WB.translation).norm() < 1e-12);
  EXPECT_TRUE((RotationOf(info.mesh_pose()) - boxed.X_WB.rotation).norm() < 1e-12);
  // the box sits about the shifted centre: pose = mesh_pose moved by 0.3 along M's x
  const Vector3 centre_W = boxed.X_WB.translation + boxed.X_WB.rotation * Vector3(0.3, 0, 0);
  EXPECT_LT((Read(info.pose().position()) - centre_W).norm(), 1e-3);

  // kept as a mesh: the data once, in `mesh`; the represented shape says only "mesh"
  const v1::ObjectInfo& tetra = scene.objects(1);
  EXPECT_EQ(tetra.represented_shape().mesh().vertices_size(), 0);
  EXPECT_EQ(tetra.represented_shape().mesh().representation(), v1::REPRESENTATION_MESH);
  EXPECT_EQ(tetra.mesh().vertices_size(), 12);
  EXPECT_EQ(std::vector<uint32_t>(tetra.mesh().triangles().begin(), tetra.mesh().triangles().end()),
            (std::vector<uint32_t>{0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}));
}

// Velocities are those of the client's frame M, not of where the representation sits,
// and stay so as the object moves.
TEST(SceneDescription, AKinematicMeshReadsBackTheVelocitiesItWasGiven) {
  scene::SceneBuilder builder;
  geometry::TriangleMesh ball = geometry::MakeIcosphere(2, 0.5);
  std::vector<Vector3> shifted = ball.vertices();
  for (Vector3& v : shifted) v += Vector3(0.3, 0, 0);
  scene::ObjectSpec spec = Named("spinner", MeshOf(shifted, ball.triangles(), scene::Representation::kBox));
  spec.motion = scene::Motion::kKinematic;
  spec.v_WB = {0.1, 0, 0};
  spec.w_WB = {0, 0, 2};
  builder.Add(spec);
  const uint64_t digest = DescribeScene(*builder.Build(1), {}).objects(0).shape_digest();
  for (int step = 0; step < 3; ++step) {
    const v1::ObjectInfo info = DescribeScene(*builder.Build(2 + step), {}).objects(0);
    EXPECT_LT((Read(info.velocity()) - spec.v_WB).norm(), 1e-12) << step;
    EXPECT_EQ(Read(info.angular_velocity()), spec.w_WB) << step;
    // M's origin moves at v, whatever the spin
    EXPECT_LT((Read(info.mesh_pose().position()) - Vector3(0.1 * 0.01 * step, 0, 0)).norm(), 1e-12) << step;
    EXPECT_EQ(info.shape_digest(), digest) << "moving is not a new shape";
    builder.AdvanceKinematic(0.01);
  }
}

TEST(SceneDescription, MeshDataComesOnlyWhenAskedForAndWithinItsBound) {
  scene::SceneBuilder builder;
  builder.Add(Named("a", MeshOf(kTetra, kTetraTriangles, scene::Representation::kMesh)));
  builder.Add(Named("b", MeshOf(kTetra, kTetraTriangles, scene::Representation::kConvex)));
  builder.Add(Named("ball", scene::SphereShape{0.1}));
  const auto snapshot = builder.Build(1);

  const v1::SceneDescription plain = DescribeScene(*snapshot, v1::GetScene{});
  EXPECT_EQ(plain.objects(0).mesh().vertices_size(), 0);
  EXPECT_EQ(plain.objects(1).mesh().vertices_size(), 0);
  EXPECT_EQ(plain.objects(1).mesh().representation(), v1::REPRESENTATION_CONVEX);
  const v1::SceneDescription only_b = DescribeScene(*snapshot, WithDataFor({"b", "ball"}));
  EXPECT_EQ(only_b.objects(0).mesh().vertices_size(), 0);
  EXPECT_EQ(only_b.objects(1).mesh().vertices_size(), 12);

  // a tetrahedron's data is 4 * 24 + 4 * 12 = 144 bytes
  v1::GetScene both;
  both.set_include_mesh_data(true);
  EXPECT_EQ(DescribeScene(*snapshot, both, 288).objects(1).mesh().triangles_size(), 12);
  const RequestError over = Refusal(*snapshot, both, 287);
  EXPECT_EQ(over.code(), v1::Error::CODE_RESOURCE_EXHAUSTED);
  EXPECT_STREQ(over.what(), "get_scene asks for the vertices and triangles of 2 meshes, 288 bytes; one reply "
                            "carries at most 287 bytes of mesh data: name fewer in get_scene.mesh_data_for");
  EXPECT_EQ(DescribeScene(*snapshot, WithDataFor({"a"}), 144).objects(0).mesh().vertices_size(), 12);

  const RequestError unknown = Refusal(*snapshot, WithDataFor({"a", "cup"}), kMaxMeshDataBytes);
  EXPECT_EQ(unknown.code(), v1::Error::CODE_NOT_FOUND);
  EXPECT_STREQ(unknown.what(), "get_scene.mesh_data_for[1] is \"cup\"; the scene has no object of that name");
  v1::GetScene twice = WithDataFor({"a"});
  twice.set_include_mesh_data(true);
  const RequestError conflict = Refusal(*snapshot, twice, kMaxMeshDataBytes);
  EXPECT_EQ(conflict.code(), v1::Error::CODE_BAD_REQUEST);
  EXPECT_STREQ(conflict.what(), "get_scene has include_mesh_data and 1 names in mesh_data_for; give one "
                                "(include_mesh_data: every mesh's data)");
}

TEST(SceneDescription, TheDigestFollowsTheShapeAndNothingElse) {
  scene::SceneBuilder builder;
  builder.Add(Named("a", MeshOf(kTetra, kTetraTriangles, scene::Representation::kMesh)));
  scene::ObjectSpec same = Named("same", MeshOf(kTetra, kTetraTriangles, scene::Representation::kMesh));
  same.X_WB.translation = {5, 0, 0};
  same.material.stiffness = 123;
  builder.Add(same);
  std::vector<Vector3> moved_vertex = kTetra;
  moved_vertex[3].z() = 1.5;
  builder.Add(Named("other_vertex", MeshOf(moved_vertex, kTetraTriangles, scene::Representation::kMesh)));
  builder.Add(Named("other_pin", MeshOf(kTetra, kTetraTriangles, scene::Representation::kConvex)));
  builder.Add(Named("ball", scene::SphereShape{0.1}));
  builder.Add(Named("bigger_ball", scene::SphereShape{0.2}));
  const v1::SceneDescription scene = DescribeScene(*builder.Build(1), {});
  const auto digest = [&](int i) { return scene.objects(i).shape_digest(); };
  EXPECT_EQ(digest(0), digest(1)) << "pose and material are not the shape";
  EXPECT_NE(digest(0), digest(2));
  EXPECT_NE(digest(0), digest(3));
  EXPECT_NE(digest(4), digest(5));
  EXPECT_NE(digest(0), 0u);
}

// Through the service: GetScene's refusals are error replies that name the field.
TEST(SceneDescription, TheServiceAnswersGetSceneWithItsErrors) {
  testing::Harness harness;
  v1::Request request;
  request.set_request_id(5);
  *request.mutable_get_scene() = WithDataFor({"nothing_here"});
  const v1::Reply reply = harness.Call(request);
  ASSERT_TRUE(reply.has_error()) << reply.DebugString();
  EXPECT_EQ(reply.error().code(), v1::Error::CODE_NOT_FOUND);
  EXPECT_EQ(reply.error().message(),
            "get_scene.mesh_data_for[0] is \"nothing_here\"; the scene has no object of that name");
  request.mutable_get_scene()->Clear();
  EXPECT_GT(harness.Call(request).scene().objects_size(), 0);
}

}  // namespace
}  // namespace hapticd::net
