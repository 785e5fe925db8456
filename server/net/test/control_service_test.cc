// The control service's requests: scene edits, queries, sessions, subscriptions, and the
// error replies that name what was wrong.
#include "server/net/control_service.h"

#include <cmath>
#include <map>
#include <random>
#include <tuple>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "server/geometry/mesh_generators.h"
#include "server/net/test/net_harness.h"

namespace hapticd::net {
namespace {

using testing::Harness;

v1::Object MakeSphere(const std::string& name, double radius, double x) {
  v1::Object object;
  object.set_name(name);
  object.mutable_shape()->mutable_sphere()->set_radius(radius);
  object.mutable_pose()->mutable_position()->set_x(x);
  object.mutable_material()->set_stiffness(800);
  return object;
}

v1::Request Add(const v1::Object& object) {
  v1::Request request;
  request.set_request_id(11);
  *request.mutable_add_object()->mutable_object() = object;
  return request;
}

void ExpectError(const v1::Reply& reply, v1::Error::Code code, const std::string& message) {
  ASSERT_TRUE(reply.has_error()) << reply.DebugString();
  EXPECT_EQ(reply.error().code(), code) << reply.error().message();
  EXPECT_EQ(reply.error().message(), message);
}

TEST(ControlService, EditsPublishNewVersionsAndNameTheirErrors) {
  Harness harness;
  v1::Reply added = harness.Call(Add(MakeSphere("ball", 0.1, 1)));
  ASSERT_TRUE(added.has_done()) << added.DebugString();
  EXPECT_EQ(added.request_id(), 11u);
  EXPECT_EQ(added.done().scene_version(), 2u);
  EXPECT_EQ(harness.publisher.current()->version(), 2u);
  EXPECT_EQ(harness.publisher.current()->num_objects(), 3);

  ExpectError(harness.Call(Add(MakeSphere("ball", 0.1, 1))), v1::Error::CODE_ALREADY_EXISTS,
              "add_object.object.name is \"ball\"; an object of that name exists (use update_object to replace it)");
  ExpectError(harness.Call(Add(MakeSphere("bad", -0.1, 1))), v1::Error::CODE_BAD_REQUEST,
              "objects[bad].shape.radius is -0.1; it must be in (0, 1000] m");
  v1::Request remove;
  remove.mutable_remove_object()->set_name("cup");
  ExpectError(harness.Call(remove), v1::Error::CODE_NOT_FOUND,
              "remove_object.name is \"cup\"; the scene has no object of that name");
  remove.mutable_remove_object()->set_name("ball");
  EXPECT_EQ(harness.Call(remove).done().scene_version(), 3u);
  EXPECT_EQ(harness.publisher.current()->FindObject("ball"), -1);
  // A refused edit publishes nothing.
  EXPECT_EQ(harness.publisher.current()->version(), 3u);
}

// A material change replaces only the fields it has, against the object's material as
// the server holds it, and checks the whole result.
TEST(ControlService, AMaterialChangeKeepsTheFieldsItDoesNotHave) {
  Harness harness;
  v1::Object box = MakeSphere("ball", 0.1, 1);
  box.mutable_material()->set_static_friction(0.6);
  box.mutable_material()->set_force_shading(false);
  ASSERT_TRUE(harness.Call(Add(box)).has_done());
  v1::Request set;
  set.mutable_set_material()->set_name("ball");
  set.mutable_set_material()->mutable_change()->set_damping(3);
  // a dynamic friction under the static one kept: valid only beside it
  set.mutable_set_material()->mutable_change()->set_dynamic_friction(0.5);
  ASSERT_TRUE(harness.Call(set).has_done());
  const auto scene = harness.publisher.current();
  const scene::Material& material = scene->object(scene->FindObject("ball")).material;
  EXPECT_EQ(material.stiffness, 800);
  EXPECT_EQ(material.damping, 3);
  EXPECT_EQ(material.static_friction, 0.6);
  EXPECT_EQ(material.dynamic_friction, 0.5);
  EXPECT_FALSE(material.force_shading);

  set.mutable_set_material()->mutable_change()->Clear();
  set.mutable_set_material()->mutable_change()->set_static_friction(0.2);
  ExpectError(harness.Call(set), v1::Error::CODE_BAD_REQUEST,
              "set_material.change.dynamic_friction is 0.5; it must be <= static_friction (0.2)");
  set.mutable_set_material()->set_name("cup");
  ExpectError(harness.Call(set), v1::Error::CODE_NOT_FOUND,
              "set_material.name is \"cup\"; the scene has no object of that name");
  EXPECT_EQ(harness.publisher.current()->version(), scene->version());
}

// A batch applies all its edits as one new version, or, when one is refused, none of
// them, naming the edit by its index.
TEST(ControlService, ABatchOfEditsIsAppliedAsOne) {
  Harness harness;
  const int before = harness.publisher.current()->num_objects();
  v1::Request batch;
  batch.set_request_id(12);
  v1::EditScene* edits = batch.mutable_edit_scene();
  for (int i = 0; i < 50; ++i) *edits->add_edits()->mutable_add_object()->mutable_object() = MakeSphere(fmt::format("s{}", i), 0.01, 0.1 * i);
  v1::Object moving = MakeSphere("mover", 0.02, 0);
  moving.set_kinematic(true);
  *edits->add_edits()->mutable_add_object()->mutable_object() = moving;
  v1::MoveKinematic* move = edits->add_edits()->mutable_move_kinematic();
  move->set_name("mover");
  move->mutable_pose()->mutable_position()->set_z(0.5);
  move->mutable_pose()->mutable_orientation()->set_w(1);
  edits->add_edits()->mutable_remove_object()->set_name("s7");
  v1::SetMaterial* set = edits->add_edits()->mutable_set_material();
  set->set_name("s8");
  set->mutable_material()->set_stiffness(123);
  const v1::Reply done = harness.Call(batch);
  ASSERT_TRUE(done.has_done()) << done.DebugString();
  EXPECT_EQ(done.done().scene_version(), 2u);
  const auto scene = harness.publisher.current();
  EXPECT_EQ(scene->version(), 2u);
  EXPECT_EQ(scene->num_objects(), before + 50);
  EXPECT_EQ(scene->FindObject("s7"), -1);
  EXPECT_EQ(scene->object(scene->FindObject("s8")).material.stiffness, 123);
  EXPECT_EQ(scene->object(scene->FindObject("mover")).X_WB.translation.z(), 0.5);

  // one bad edit: nothing changes, and the error says which
  v1::Request bad;
  v1::EditScene* more = bad.mutable_edit_scene();
  *more->add_edits()->mutable_add_object()->mutable_object() = MakeSphere("t0", 0.01, 0);
  *more->add_edits()->mutable_add_object()->mutable_object() = MakeSphere("t1", -0.01, 0);
  ExpectError(harness.Call(bad), v1::Error::CODE_BAD_REQUEST,
              "edit_scene.edits[1].add_object: objects[t1].shape.radius is -0.01; it must be in (0, 1000] m");
  more->mutable_edits(1)->mutable_add_object()->mutable_object()->set_name("t0");
  more->mutable_edits(1)->mutable_add_object()->mutable_object()->mutable_shape()->mutable_sphere()->set_radius(0.01);
  ExpectError(harness.Call(bad), v1::Error::CODE_ALREADY_EXISTS,
              "edit_scene.edits[1].add_object.object.name is \"t0\"; an object of that name exists (use "
              "update_object to replace it)");
  more->mutable_edits(1)->Clear();
  more->mutable_edits(1)->mutable_remove_object()->set_name("s7");
  ExpectError(harness.Call(bad), v1::Error::CODE_NOT_FOUND,
              "edit_scene.edits[1].remove_object.name is \"s7\"; the scene has no object of that name");
  more->mutable_edits(1)->Clear();
  ExpectError(harness.Call(bad), v1::Error::CODE_BAD_REQUEST,
              "edit_scene.edits[1] is empty; it needs one of add_object, update_object, remove_object, "
              "set_material, move_kinematic");
  EXPECT_EQ(harness.publisher.current()->version(), 2u);
  EXPECT_EQ(harness.publisher.current()->FindObject("t0"), -1);
  EXPECT_EQ(harness.publisher.current()->num_objects(), before + 50);

  // the bound, named
  v1::Request huge;
  for (int i = 0; i <= kMaxEditsPerBatch; ++i) huge.mutable_edit_scene()->add_edits()->mutable_remove_object()->set_name("x");
  ExpectError(harness.Call(huge), v1::Error::CODE_BAD_REQUEST,
              "edit_scene has 100001 edits; at most 100000 are served in one request");
  // an empty batch is a no-op that still publishes a version
  v1::Request empty;
  empty.mutable_edit_scene();
  EXPECT_EQ(harness.Call(empty).done().scene_version(), 3u);
}

TEST(ControlService, MeshesArriveAsFlatArraysAndAreChecked) {
  Harness harness;
  v1::Object tetra;
  tetra.set_name("tetra");
  tetra.mutable_material()->set_stiffness(1000);
  v1::Mesh* mesh = tetra.mutable_shape()->mutable_mesh();
  for (double v : {0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.}) mesh->add_vertices(v);
  for (uint32_t i : {0u, 2u, 1u, 0u, 1u, 3u, 0u, 3u, 2u, 1u, 2u, 3u}) mesh->add_triangles(i);
  mesh->set_representation(v1::REPRESENTATION_MESH);
  ASSERT_TRUE(harness.Call(Add(tetra)).has_done());
  tetra.set_name("tetra_on_embree");
  tetra.set_ray_backend(v1::RAY_BACKEND_EMBREE);
  ASSERT_TRUE(harness.Call(Add(tetra)).has_done());
  v1::Request get;
  get.mutable_get_scene();
  const v1::Reply scene = harness.Call(get);
  ASSERT_EQ(scene.scene().objects_size(), 4);
  EXPECT_EQ(scene.scene().objects(2).shape(), "mesh");
  EXPECT_EQ(scene.scene().objects(2).representation(), "mesh");
  EXPECT_EQ(scene.scene().objects(2).triangles(), 4u);
  EXPECT_EQ(scene.scene().objects(2).dropped_triangles(), 0u);
  EXPECT_EQ(scene.scene().objects(2).ray_backend(), "native");
  EXPECT_EQ(scene.scene().objects(3).ray_backend(), "embree");
  EXPECT_EQ(scene.scene().objects(0).ray_backend(), "");  // the box is no mesh
  tetra.set_name("tetra_elsewhere");
  tetra.set_ray_backend(static_cast<v1::RayBackend>(9));
  ExpectError(harness.Call(Add(tetra)), v1::Error::CODE_BAD_REQUEST,
              "add_object.object.ray_backend is 9; it must be default, native or embree");
  tetra.set_ray_backend(v1::RAY_BACKEND_DEFAULT);

  mesh->set_triangles(4, 9);
  tetra.set_name("tetra2");
  ExpectError(harness.Call(Add(tetra)), v1::Error::CODE_BAD_REQUEST,
              "add_object.object.shape.mesh.triangles[4] is 9; the mesh has 4 vertices");
  mesh->add_vertices(1);
  ExpectError(harness.Call(Add(tetra)), v1::Error::CODE_BAD_REQUEST,
              "add_object.object.shape.mesh.vertices has 13 values; it needs x, y, z for each point (a multiple of 3)");
}

// One triangle sent a hundred thousand times is one triangle: the repeats are counted in
// the object's info and no query visits them. (Before, each copy was a BVH leaf that a
// tick near it visited: ticks of 71 ms at a million copies.)
TEST(ControlService, RepeatedTrianglesAreDroppedAndCounted) {
  Harness harness;
  v1::Object sheet;
  sheet.set_name("sheet");
  sheet.mutable_material()->set_stiffness(1000);
  v1::Mesh* mesh = sheet.mutable_shape()->mutable_mesh();
  for (double v : {0., 0., 0.5, 1., 0., 0.5, 0., 1., 0.5}) mesh->add_vertices(v);
  for (int copy = 0; copy < 100'000; ++copy) {
    for (uint32_t i : {0u, 1u, 2u}) mesh->add_triangles(copy % 2 ? 2 - i : i);
  }
  mesh->set_representation(v1::REPRESENTATION_MESH);
  ASSERT_TRUE(harness.Call(Add(sheet)).has_done());
  v1::Request get;
  get.mutable_get_scene();
  const v1::ObjectInfo info = harness.Call(get).scene().objects(2);
  EXPECT_EQ(info.triangles(), 100'000u);
  EXPECT_EQ(info.dropped_triangles(), 99'999u);
  EXPECT_EQ(info.repeated_triangles(), 99'999u);
  const auto& object = harness.publisher.current()->object(2);
  EXPECT_EQ(std::get<scene::MeshShape>(object.shape).bvh->num_primitives(), 1);
}

TEST(ControlService, RefusesMalformedObjects) {
  Harness harness;
  v1::Object object = MakeSphere("s", 0.1, 0);
  object.clear_shape();
  ExpectError(harness.Call(Add(object)), v1::Error::CODE_BAD_REQUEST, "add_object.object.shape is missing");
  object = MakeSphere("s", 0.1, 0);
  object.mutable_pose()->mutable_orientation()->set_w(2);
  const v1::Reply reply = harness.Call(Add(object));
  ASSERT_TRUE(reply.has_error());
  EXPECT_EQ(reply.error().message().rfind("add_object.object.pose.orientation is [2, 0, 0, 0] (w, x, y, z) with norm 2;", 0), 0u)
      << reply.error().message();
  object = MakeSphere("s", 0.1, 0);
  object.mutable_pose()->mutable_position()->set_y(NAN);
  ExpectError(harness.Call(Add(object)), v1::Error::CODE_BAD_REQUEST,
              "add_object.object.pose.position is [0, nan, 0]; it must be finite");
  object = MakeSphere("", 0.1, 0);
  ExpectError(harness.Call(Add(object)), v1::Error::CODE_BAD_REQUEST,
              "add_object.object.name is empty; every object needs a name");
}

TEST(ControlService, RefusesUnknownFieldsAndEmptyRequests) {
  Harness harness;
  v1::Request request = Add(MakeSphere("s", 0.1, 0));
  request.mutable_add_object()->mutable_object()->mutable_shape()->mutable_sphere()->GetReflection()
      ->MutableUnknownFields(request.mutable_add_object()->mutable_object()->mutable_shape()->mutable_sphere())
      ->AddVarint(99, 1);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "request.add_object.object.shape.sphere field number 99 is not part of hapticd.v1; is the client built "
              "for another version?");
  ExpectError(harness.Call(v1::Request()), v1::Error::CODE_BAD_REQUEST,
              "request has no body: it names none of the requests hapticd.v1 defines");
}

TEST(ControlService, AnUntrustedConnectionMustHelloWithTheToken) {
  Harness harness;
  ConnectionState remote;  // not authenticated
  v1::Request get;
  get.mutable_get_scene();
  ExpectError(harness.service.Handle(get, remote), v1::Error::CODE_UNAUTHENTICATED,
              "this connection must send a Hello with the server's access token first");
  v1::Request hello;
  hello.mutable_hello()->set_protocol_version(1);
  hello.mutable_hello()->set_access_token("wrong");
  // a failed Hello is the connection's last request, and it is counted
  ExpectError(harness.service.Handle(hello, remote), v1::Error::CODE_UNAUTHENTICATED,
              "hello.access_token is not this server's token; closing the connection");
  EXPECT_TRUE(remote.close_after_reply);
  EXPECT_FALSE(remote.said_hello);
  remote = ConnectionState{};
  hello.mutable_hello()->set_protocol_version(2);
  ExpectError(harness.service.Handle(hello, remote), v1::Error::CODE_BAD_REQUEST,
              "hello.protocol_version is 2; this server speaks 1");
  EXPECT_TRUE(remote.close_after_reply);
  EXPECT_EQ(harness.service.connection_counters().hello_failures, 2u);
  remote = ConnectionState{};
  hello.mutable_hello()->set_protocol_version(1);
  hello.mutable_hello()->set_access_token("0123456789abcdef-token");
  const v1::Reply welcome = harness.service.Handle(hello, remote);
  ASSERT_TRUE(welcome.has_hello());
  EXPECT_FALSE(remote.close_after_reply);
  EXPECT_TRUE(remote.said_hello);
  EXPECT_EQ(welcome.hello().udp_endpoint(), harness.service.options().udp_endpoint);
  EXPECT_TRUE(harness.service.Handle(get, remote).has_scene());
}

// With a token configured, a connection that starts authenticated (loopback) still
// needs the token in its Hello: a wrong one fails and closes, as anywhere else.
TEST(ControlService, WithATokenEveryHelloMustCarryIt) {
  Harness harness;  // its service has a token; harness.connection starts authenticated
  v1::Request hello;
  hello.mutable_hello()->set_protocol_version(1);
  hello.mutable_hello()->set_access_token("wrong");
  ExpectError(harness.Call(hello), v1::Error::CODE_UNAUTHENTICATED,
              "hello.access_token is not this server's token; closing the connection");
  EXPECT_TRUE(harness.connection.close_after_reply);
}

TEST(ControlService, QueriesAnswerInTheWorldFrame) {
  Harness harness;  // 0.1 m cube at the origin, floor at z = -1
  v1::Request ray;
  ray.mutable_ray_cast()->mutable_origin()->set_z(1);
  ray.mutable_ray_cast()->mutable_direction()->set_z(-3);
  ray.mutable_ray_cast()->set_max_distance(10);
  const v1::RayHit hit = harness.Call(ray).ray_hit();
  EXPECT_TRUE(hit.hit());
  EXPECT_EQ(hit.object(), "box");
  EXPECT_NEAR(hit.distance(), 0.95, 1e-12);
  EXPECT_NEAR(hit.point().z(), 0.05, 1e-12);
  EXPECT_NEAR(hit.normal().z(), 1, 1e-12);
  ray.mutable_ray_cast()->set_max_distance(0.5);
  EXPECT_FALSE(harness.Call(ray).ray_hit().hit());
  ray.mutable_ray_cast()->mutable_direction()->set_z(0);
  ExpectError(harness.Call(ray), v1::Error::CODE_BAD_REQUEST, "ray_cast.direction is zero; it needs a direction");

  v1::Request closest;
  closest.mutable_closest_point()->mutable_point()->set_x(0.2);
  closest.mutable_closest_point()->set_max_distance(1);
  const v1::ClosestPointResult nearest = harness.Call(closest).closest_point();
  EXPECT_TRUE(nearest.found());
  EXPECT_EQ(nearest.object(), "box");
  EXPECT_NEAR(nearest.signed_distance(), 0.15, 1e-12);
  EXPECT_NEAR(nearest.point().x(), 0.05, 1e-12);
  closest.mutable_closest_point()->mutable_point()->set_x(0.02);  // inside
  EXPECT_NEAR(harness.Call(closest).closest_point().signed_distance(), -0.03, 1e-12);

  v1::Request contacts;
  contacts.mutable_find_contacts()->mutable_center()->set_z(0.06);
  contacts.mutable_find_contacts()->set_radius(0.02);
  const v1::ContactsResult touching = harness.Call(contacts).contacts();
  ASSERT_EQ(touching.contacts_size(), 1);
  EXPECT_EQ(touching.contacts(0).object(), "box");
  EXPECT_NEAR(touching.contacts(0).depth(), 0.01, 1e-12);
  contacts.mutable_find_contacts()->mutable_center()->set_z(-0.99);
  EXPECT_EQ(harness.Call(contacts).contacts().contacts(0).object(), "floor");
  contacts.mutable_find_contacts()->set_radius(-1);
  ExpectError(harness.Call(contacts), v1::Error::CODE_BAD_REQUEST,
              "find_contacts.radius is -1; it must be a finite number >= 0");
}

TEST(ControlService, OpenSessionChecksTheHandshake) {
  Harness harness;
  v1::Request request;
  v1::OpenSession* open = request.mutable_open_session();
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.device_type is DEVICE_TYPE_UNSPECIFIED; it must be impedance or admittance");
  open->set_device_type(v1::DEVICE_TYPE_IMPEDANCE);
  open->set_degrees_of_freedom(4);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.degrees_of_freedom is 4; hapticd renders 3 or 6");
  open->set_degrees_of_freedom(6);
  open->set_max_force(NAN);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.max_force is nan; it must be in (0, 10000]");
  open->set_max_force(1e308);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.max_force is 1e+308; it must be in (0, 10000]");
  open->set_max_force(10);
  open->set_max_velocity(1e9);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.max_velocity is 1000000000; it must be in (0, 100]");
  open->set_max_velocity(1);
  // rates outside the range: the period arithmetic and the integration step stay bounded
  for (const auto& [rate, text] : {std::pair{20000.0, "20000"}, std::pair{1e-10, "1e-10"},
                                   std::pair{1e-300, "1e-300"}, std::pair{9.99, "9.99"}}) {
    open->set_rate_hz(rate);
    ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
                fmt::format("open_session.rate_hz is {}; it must be in [10, 10000]", text));
  }
  open->set_rate_hz(1000);
  open->set_avatar(v1::AVATAR_TYPE_SPHERE);
  const v1::Reply no_radius = harness.Call(request);
  ASSERT_TRUE(no_radius.has_error());
  EXPECT_EQ(no_radius.error().message().rfind("open_session.avatar.radius is 0", 0), 0u) << no_radius.error().message();
  open->set_avatar_radius(1e308);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.avatar.radius is 1e+308; a sphere avatar's radius must be at most 1 m");
  open->set_device_type(v1::DEVICE_TYPE_ADMITTANCE);
  open->set_avatar_radius(0.005);
  open->set_virtual_mass(1e-9);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.admittance.virtual_mass is 1e-09; it must be in [0.001, 1000]");
  open->set_virtual_mass(0);
  open->set_device_type(v1::DEVICE_TYPE_IMPEDANCE);
  open->set_avatar_radius(0.005);
  open->set_timeout_s(0.01);
  const v1::Reply short_timeout = harness.Call(request);
  ASSERT_TRUE(short_timeout.has_error());
  EXPECT_EQ(short_timeout.error().message().rfind("open_session.timeout_s is 0.01; it must be in [0.15", 0), 0u)
      << short_timeout.error().message();
  open->set_timeout_s(0);
  // the channel: two-port passivity and the deadband, within their documented bounds
  // (server/remote/deadband.h), and for impedance devices only
  open->set_deadband(1);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.deadband is 1; a Weber fraction must be in [0, 1) (0: off)");
  open->set_deadband(0.1);
  open->set_deadband_force_floor(-0.5);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.deadband_force_floor is -0.5; it must be in (0, 10]");
  open->set_deadband_force_floor(0);
  open->set_deadband_position_floor(0.5);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.deadband_position_floor is 0.5; it must be in (0, 0.01]");
  open->set_deadband_position_floor(0);
  open->set_deadband_velocity_floor(NAN);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.deadband_velocity_floor is nan; it must be in (0, 1]");
  open->set_deadband_velocity_floor(0);
  open->set_keepalive_s(0.1);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.keepalive_s is 0.1; it must be in (0, 0.025] (half the server's 50 ms watchdog at "
              "most)");
  open->set_keepalive_s(0);
  open->set_device_type(v1::DEVICE_TYPE_ADMITTANCE);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.deadband is 0.1 for an admittance device; the deadband is for impedance devices");
  open->set_deadband(0);
  open->set_tdpa(true);
  ExpectError(harness.Call(request), v1::Error::CODE_BAD_REQUEST,
              "open_session.tdpa is true for an admittance device; two-port passivity is for impedance devices "
              "(position up, force down)");
  open->set_tdpa(false);
  open->set_device_type(v1::DEVICE_TYPE_IMPEDANCE);
  const v1::Reply opened = harness.Call(request);
  ASSERT_TRUE(opened.has_session_opened()) << opened.DebugString();
  EXPECT_NE(opened.session_opened().session_id(), 0u);
  EXPECT_EQ(opened.session_opened().session_key().size(), kSessionKeySize);
  EXPECT_EQ(opened.session_opened().udp_endpoint(), harness.service.options().udp_endpoint);
  EXPECT_EQ(opened.session_opened().max_datagram(), kMaxStateSize);
  const int slot = harness.sessions.FindById(opened.session_opened().session_id());
  ASSERT_GE(slot, 0);
  EXPECT_EQ(harness.sessions.slot(slot).state.load(), SlotState::kWaiting);
  EXPECT_EQ(harness.sessions.slot(slot).render->settings().avatar.method, force::ForceMethod::kFingerProxy);
}

TEST(ControlService, SubscriptionsAreCheckedAndListed) {
  Harness harness;
  v1::Request subscribe;
  subscribe.set_request_id(5);
  subscribe.mutable_subscribe()->set_rate_hz(0);
  ExpectError(harness.Call(subscribe), v1::Error::CODE_BAD_REQUEST, "subscribe.rate_hz is 0; it must be in [0.1, 1000]");
  // a rate so low that its period overflows a timer is refused too
  subscribe.mutable_subscribe()->set_rate_hz(1e-12);
  ExpectError(harness.Call(subscribe), v1::Error::CODE_BAD_REQUEST,
              "subscribe.rate_hz is 1e-12; it must be in [0.1, 1000]");
  subscribe.mutable_subscribe()->set_rate_hz(50);
  const v1::Reply first = harness.Call(subscribe);
  ASSERT_TRUE(first.has_telemetry());
  EXPECT_EQ(first.request_id(), 5u);
  EXPECT_EQ(first.telemetry().scene_version(), 1u);
  EXPECT_TRUE(harness.connection.subscriptions_changed);
  ASSERT_EQ(harness.connection.subscriptions.count(5), 1u);
  EXPECT_EQ(harness.connection.subscriptions[5].rate_hz, 50);
  ExpectError(harness.Call(subscribe), v1::Error::CODE_ALREADY_EXISTS,
              "request_id 5 already names a subscription on this connection");
  v1::Request unsubscribe;
  unsubscribe.mutable_unsubscribe()->set_subscription_id(6);
  ExpectError(harness.Call(unsubscribe), v1::Error::CODE_NOT_FOUND,
              "unsubscribe.subscription_id is 6; this connection has no such subscription");
  unsubscribe.mutable_unsubscribe()->set_subscription_id(5);
  EXPECT_TRUE(harness.Call(unsubscribe).has_done());
  EXPECT_TRUE(harness.connection.subscriptions.empty());
  v1::Request stats;
  stats.mutable_get_stats();
  EXPECT_EQ(harness.Call(stats).stats().counters().control_errors(), 4u);
}

// A batch of segments answers as the same segments one at a time: meshes on Embree
// (traced in packets), native meshes and primitives alike.
TEST(ControlService, ABatchOfRaysAnswersAsSingleRays) {
  Harness harness;
  const geometry::TriangleMesh sphere = geometry::MakeIcosphere(6, 0.05);
  for (const auto& [name, x, backend] : {std::tuple{"on_embree", 0.2, v1::RAY_BACKEND_EMBREE},
                                        std::tuple{"on_native", -0.2, v1::RAY_BACKEND_NATIVE}}) {
    ASSERT_TRUE(harness.Call(Add(testing::MeshObject(name, sphere, x, v1::REPRESENTATION_MESH, backend))).has_done());
  }

  std::mt19937_64 random(3);
  std::uniform_real_distribution<double> place(-0.3, 0.3);
  std::normal_distribution<double> turn(0, 1);
  v1::Request batch;
  v1::RayCastBatch* rays = batch.mutable_ray_cast_batch();
  rays->set_max_distance(0.5);
  std::vector<v1::Request> singles;
  for (int i = 0; i < 500; ++i) {
    const Vector3 origin(place(random), place(random) / 3, place(random) / 3 + 0.1);
    const Vector3 direction(turn(random), turn(random), turn(random));
    v1::Request single;
    single.mutable_ray_cast()->set_max_distance(0.5);
    for (int k = 0; k < 3; ++k) {
      rays->add_origins(origin[k]);
      rays->add_directions(direction[k]);
    }
    single.mutable_ray_cast()->mutable_origin()->set_x(origin.x());
    single.mutable_ray_cast()->mutable_origin()->set_y(origin.y());
    single.mutable_ray_cast()->mutable_origin()->set_z(origin.z());
    single.mutable_ray_cast()->mutable_direction()->set_x(direction.x());
    single.mutable_ray_cast()->mutable_direction()->set_y(direction.y());
    single.mutable_ray_cast()->mutable_direction()->set_z(direction.z());
    singles.push_back(single);
  }
  const v1::Reply reply = harness.Call(batch);
  ASSERT_TRUE(reply.has_ray_hits()) << reply.DebugString();
  const v1::RayHits& hits = reply.ray_hits();
  ASSERT_EQ(hits.hit_size(), 500);
  std::map<std::string, int> by_object;
  for (int i = 0; i < 500; ++i) {
    const v1::RayHit one = harness.Call(singles[i]).ray_hit();
    ASSERT_EQ(hits.hit(i), one.hit()) << i;
    ASSERT_EQ(hits.objects(i), one.object()) << i;
    if (!one.hit()) continue;
    ++by_object[one.object()];
    EXPECT_NEAR(hits.distance(i), one.distance(), 1e-12) << i;
    EXPECT_NEAR(hits.points(3 * i), one.point().x(), 1e-12) << i;
    EXPECT_NEAR(hits.points(3 * i + 2), one.point().z(), 1e-12) << i;
    EXPECT_NEAR(hits.normals(3 * i) * one.normal().x() + hits.normals(3 * i + 1) * one.normal().y() +
                    hits.normals(3 * i + 2) * one.normal().z(),
                1, 1e-9)
        << i;
  }
  // every kind of object was hit
  EXPECT_GT(by_object["on_embree"], 10);
  EXPECT_GT(by_object["on_native"], 10);
  EXPECT_GT(by_object["box"], 10);

  rays->add_origins(0);
  ExpectError(harness.Call(batch), v1::Error::CODE_BAD_REQUEST,
              "ray_cast_batch has 1501 origin and 1500 direction values; it needs x, y, z of each, and one origin "
              "for every direction or one per direction");
  rays->mutable_origins()->RemoveLast();
  rays->set_directions(4, 0);
  rays->set_directions(3, 0);
  rays->set_directions(5, 0);
  const v1::Reply zero = harness.Call(batch);
  ASSERT_TRUE(zero.has_error());
  EXPECT_EQ(zero.error().message().rfind("ray_cast_batch segment 1 has origin [", 0), 0u) << zero.error().message();
}

// A query request's work is bounded (--max-request-work): over it the request is
// refused by name, RESOURCE_EXHAUSTED, while the same query in a smaller batch is
// answered and requests that are no queries are not metered. The budget here is 10,000
// units: 5,000 rays through a 720-triangle sphere, or points inside a hull of 18,000
// faces (2,250 units each), need more.
TEST(ControlService, AQueryOverTheRequestWorkBudgetIsRefused) {
  Harness harness(8, 10'000);
  const std::string over =
      " needs more than 10000 units of work, the most one request may take (--max-request-work; a unit is a "
      "BVH node, a primitive, an object or eight hull vertices or faces); ask it in smaller batches";
  for (const auto& [name, frequency, x, representation] : {std::tuple{"ball", 6, 0.5, v1::REPRESENTATION_MESH},
                                                           std::tuple{"hull", 30, -0.5, v1::REPRESENTATION_CONVEX}}) {
    const geometry::TriangleMesh sphere = geometry::MakeIcosphere(frequency, 0.05);
    ASSERT_TRUE(harness.Call(Add(testing::MeshObject(name, sphere, x, representation))).has_done());
  }
  // rays down through the mesh sphere
  const auto rays_through_the_ball = [](int n) {
    v1::Request request;
    v1::RayCastBatch* rays = request.mutable_ray_cast_batch();
    rays->set_max_distance(0.3);
    for (int i = 0; i < n; ++i) {
      for (const double value : {0.5 + 0.03 * std::cos(i), 0.03 * std::sin(i), 0.2}) rays->add_origins(value);
      for (const double value : {0.0, 0.0, -1.0}) rays->add_directions(value);
    }
    return request;
  };
  ExpectError(harness.Call(rays_through_the_ball(5000)), v1::Error::CODE_RESOURCE_EXHAUSTED, "ray_cast_batch" + over);
  const v1::Reply few_rays = harness.Call(rays_through_the_ball(50));
  ASSERT_TRUE(few_rays.has_ray_hits()) << few_rays.DebugString();
  for (int i = 0; i < 50; ++i) EXPECT_EQ(few_rays.ray_hits().objects(i), "ball") << i;
  // points inside the hull
  const auto points_in_the_hull = [](int n) {
    v1::Request request;
    v1::ClosestPointBatch* batch = request.mutable_closest_point_batch();
    batch->set_max_distance(1);
    for (int i = 0; i < n; ++i) {
      for (const double value : {-0.5 + 0.001 * i, 0.002, 0.01}) batch->add_points(value);
    }
    return request;
  };
  ExpectError(harness.Call(points_in_the_hull(10)), v1::Error::CODE_RESOURCE_EXHAUSTED,
              "closest_point_batch" + over);
  const v1::Reply one_point = harness.Call(points_in_the_hull(1));
  ASSERT_TRUE(one_point.has_closest_points()) << one_point.DebugString();
  EXPECT_TRUE(one_point.closest_points().found(0));
  EXPECT_LT(one_point.closest_points().signed_distance(0), 0);
  // a request that is no query is not metered
  v1::Request scene;
  scene.mutable_get_scene();
  EXPECT_TRUE(harness.Call(scene).has_scene());
}

}  // namespace
}  // namespace hapticd::net
