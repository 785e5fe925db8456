#include "server/scene/scene_builder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "server/geometry/mesh_generators.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::scene {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

ObjectSpec Sphere(std::string name, double radius = 0.1) {
  ObjectSpec spec;
  spec.name = std::move(name);
  spec.shape = SphereShape{radius};
  return spec;
}

ObjectSpec BoxObject(std::string name, const Vector3& half_extents) {
  ObjectSpec spec;
  spec.name = std::move(name);
  spec.shape = BoxShape{half_extents};
  return spec;
}

// A mesh spec with the vertices and triangles of mesh.
MeshSpec MeshOf(const geometry::TriangleMesh& mesh) {
  return {mesh.vertices(), mesh.triangles(), Representation::kAuto};
}

// The message of the SceneError that f throws ("" if none).
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

// Everything observable about the builder's objects, as text: what a failed edit must
// leave unchanged.
std::string Describe(const SceneBuilder& builder) {
  const auto snapshot = builder.Build(1);
  std::ostringstream out;
  out.precision(17);
  for (int i = 0; i < snapshot->num_objects(); ++i) {
    const SceneObject& o = snapshot->object(i);
    out << o.name << " " << ShapeTypeName(TypeOf(o.shape)) << " " << o.X_WB.rotation << " "
        << o.X_WB.translation.transpose() << " " << o.material.stiffness << " "
        << o.material.damping << " " << o.material.static_friction << " "
        << o.material.dynamic_friction << " " << static_cast<int>(o.motion) << " "
        << o.v_WB.transpose() << " " << o.w_WB.transpose() << " " << o.bounds_W.min.transpose()
        << " " << o.bounds_W.max.transpose() << "\n";
  }
  return out.str();
}

// ---------------------------------------------------------------------------------
// Validation: every refusal names the field and its value, and changes nothing.

class SceneBuilderErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    ObjectSpec box = BoxObject("box", {0.1, 0.2, 0.3});
    box.X_WB.translation = {1, 2, 3};
    builder_.Add(box);
    ObjectSpec mover = Sphere("mover");
    mover.motion = Motion::kKinematic;
    builder_.Add(mover);
    before_ = Describe(builder_);
  }
  // The error of adding spec, after checking the builder did not change.
  std::string AddError(const ObjectSpec& spec) {
    const std::string error = ErrorOf([&] { builder_.Add(spec); });
    EXPECT_EQ(Describe(builder_), before_) << "changed by: " << error;
    return error;
  }
  template <typename F>
  std::string EditError(F f) {
    const std::string error = ErrorOf([&] { f(builder_); });
    EXPECT_EQ(Describe(builder_), before_) << "changed by: " << error;
    return error;
  }

  SceneBuilder builder_;
  std::string before_;
};

TEST_F(SceneBuilderErrors, NamesAreNonEmptyAndUnique) {
  EXPECT_EQ(AddError(Sphere("")), "objects[] name is empty");
  EXPECT_EQ(AddError(Sphere("box")), "objects[box] already exists");
}

TEST_F(SceneBuilderErrors, PrimitiveSizes) {
  EXPECT_EQ(AddError(BoxObject("plate", {0.1, 0.1, -0.001})),
            "objects[plate].shape.half_extents[2] is -0.001; it must be in (0, 1000] m");
  EXPECT_EQ(AddError(BoxObject("plate", {kNan, 0.1, 0.1})),
            "objects[plate].shape.half_extents[0] is nan; it must be in (0, 1000] m");
  EXPECT_EQ(AddError(Sphere("ball", 0)),
            "objects[ball].shape.radius is 0; it must be in (0, 1000] m");
  EXPECT_EQ(AddError(Sphere("ball", kInf)),
            "objects[ball].shape.radius is inf; it must be in (0, 1000] m");
  ObjectSpec capsule = Sphere("pill");
  capsule.shape = CapsuleShape{0.1, -0.5};
  EXPECT_EQ(AddError(capsule),
            "objects[pill].shape.half_length is -0.5; it must be in [0, 1000] m");
  capsule.shape = CapsuleShape{-0.1, 0.5};
  EXPECT_EQ(AddError(capsule), "objects[pill].shape.radius is -0.1; it must be in (0, 1000] m");
}

TEST_F(SceneBuilderErrors, Materials) {
  ObjectSpec ball = Sphere("ball");
  ball.material.static_friction = 0.5;
  ball.material.dynamic_friction = 0.9;
  EXPECT_EQ(AddError(ball),
            "objects[ball].material.dynamic_friction is 0.9; it must be <= static_friction (0.5)");
  ball.material = {};
  ball.material.stiffness = -5;
  EXPECT_EQ(AddError(ball), "objects[ball].material.stiffness is -5; it must be in (0, 1e+07] N/m");
  ball.material = {};
  ball.material.damping = kNan;
  EXPECT_EQ(AddError(ball), "objects[ball].material.damping is nan; it must be in [0, 1e+05] N*s/m");
  ball.material = {};
  ball.material.static_friction = -0.25;
  EXPECT_EQ(AddError(ball),
            "objects[ball].material.static_friction is -0.25; it must be in [0, 10]");
  Material bad;
  bad.dynamic_friction = -kInf;
  EXPECT_EQ(EditError([&](SceneBuilder& b) { b.SetMaterial("box", bad); }),
            "objects[box].material.dynamic_friction is -inf; it must be in [0, 10]");
  EXPECT_EQ(EditError([&](SceneBuilder& b) { b.SetMaterial("nothing", Material{}); }),
            "objects[nothing] does not exist");
}

TEST_F(SceneBuilderErrors, Poses) {
  ObjectSpec a = Sphere("a");
  // R^T R - I = diag(0.3, 0, 0)
  a.X_WB.rotation(0, 0) = std::sqrt(1.3);
  EXPECT_EQ(AddError(a), "objects[a].rotation is not a rotation (|R^T R - I| = 0.3)");
  a.X_WB.rotation = Vector3(1, 1, -1).asDiagonal();
  EXPECT_EQ(AddError(a), "objects[a].rotation is a reflection (det R = -1); it must be right-handed");
  a.X_WB.rotation = Matrix3::Identity();
  a.X_WB.rotation(1, 2) = kNan;
  EXPECT_EQ(AddError(a), "objects[a].rotation[1][2] is nan; it must be finite");
  a.X_WB.rotation = Matrix3::Identity();
  a.X_WB.translation = {0, kInf, 0};
  EXPECT_EQ(AddError(a), "objects[a].translation is [0, inf, 0]; it must be finite");
  // within 1e-6 of a rotation is accepted
  a.X_WB.translation = Vector3::Zero();
  a.X_WB.rotation(0, 0) = 1 + 1e-8;
  EXPECT_NO_THROW(SceneBuilder().Add(a));
}

TEST_F(SceneBuilderErrors, Motion) {
  ObjectSpec a = Sphere("a");
  a.v_WB = {1, 0, 0};
  EXPECT_EQ(AddError(a), "objects[a].v_WB is [1, 0, 0]; a static object cannot move (make it kinematic)");
  a.v_WB = Vector3::Zero();
  a.w_WB = {0, 0, -2.5};
  EXPECT_EQ(AddError(a), "objects[a].w_WB is [0, 0, -2.5]; a static object cannot move (make it kinematic)");
  a.motion = Motion::kKinematic;
  a.v_WB = {kNan, 0, 0};
  EXPECT_EQ(AddError(a), "objects[a].v_WB is [nan, 0, 0]; it must be finite");
  a.v_WB = Vector3::Zero();
  a.motion = static_cast<Motion>(7);
  EXPECT_EQ(AddError(a), "objects[a].motion is 7; it must be static or kinematic");
  // moving: only kinematic objects, only to valid poses
  EXPECT_EQ(EditError([](SceneBuilder& b) { b.MoveKinematic("box", Pose{}, Vector3::Zero(), Vector3::Zero()); }),
            "objects[box] is static; only a kinematic object can be moved");
  EXPECT_EQ(EditError([](SceneBuilder& b) { b.MoveKinematic("ghost", Pose{}, Vector3::Zero(), Vector3::Zero()); }),
            "objects[ghost] does not exist");
  Pose bad;
  bad.translation.x() = kNan;
  EXPECT_EQ(EditError([&](SceneBuilder& b) { b.MoveKinematic("mover", bad, Vector3::Zero(), Vector3::Zero()); }),
            "objects[mover].translation is [nan, 0, 0]; it must be finite");
  EXPECT_EQ(EditError([](SceneBuilder& b) {
              b.MoveKinematic("mover", Pose{}, Vector3::Zero(), Vector3(0, kInf, 0));
            }),
            "objects[mover].w_WB is [0, inf, 0]; it must be finite");
}

TEST_F(SceneBuilderErrors, ConvexPointSets) {
  ObjectSpec c = Sphere("c");
  c.shape = ConvexSpec{};
  EXPECT_EQ(AddError(c), "objects[c].shape.points is empty; a convex shape needs at least 4 points");
  c.shape = ConvexSpec{{{0, 0, 0}, {1, 0, 0}, {kNan, 0, 0}, {0, 0, 1}}};
  EXPECT_EQ(AddError(c), "objects[c].shape.points[2] is [nan, 0, 0]; it must be finite");
  c.shape = ConvexSpec{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1e101}}};
  EXPECT_EQ(AddError(c),
            "objects[c].shape.points[3] is [0, 0, 1e+101]; each coordinate must be within +-10000 m");
  c.shape = ConvexSpec{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}};
  EXPECT_EQ(AddError(c),
            "objects[c].shape.points are coplanar (their hull has dimension 2); a convex shape "
            "needs a solid hull");
  c.shape = ConvexSpec{{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}};
  EXPECT_EQ(AddError(c),
            "objects[c].shape.points are collinear (their hull has dimension 1); a convex shape "
            "needs a solid hull");
  c.shape = ConvexSpec{{{1, 2, 3}, {1, 2, 3}}};
  EXPECT_EQ(AddError(c),
            "objects[c].shape.points coincide (their hull has dimension 0); a convex shape needs "
            "a solid hull");
}

TEST_F(SceneBuilderErrors, Meshes) {
  const geometry::TriangleMesh cube = geometry::MakeBoxMesh({1, 1, 1});
  ObjectSpec m = Sphere("m");
  MeshSpec mesh = MeshOf(cube);
  ASSERT_EQ(mesh.vertices.size(), 8u);
  mesh.triangles[3] = {1, 2, 9};
  m.shape = mesh;
  EXPECT_EQ(AddError(m), "objects[m].shape: triangle 3 refers to vertex 9 but the mesh has 8 vertices");
  // all triangles of zero area
  m.shape = MeshSpec{{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}, {{0, 1, 2}, {0, 0, 1}}};
  EXPECT_EQ(AddError(m),
            "objects[m].shape: mesh has no triangle of non-zero area: all 2 triangles are "
            "degenerate (collinear or coincident corners)");
  mesh = MeshOf(cube);
  mesh.vertices[5].y() = -kInf;
  m.shape = mesh;
  EXPECT_EQ(AddError(m), "objects[m].shape: vertex 5 has a non-finite coordinate: [-1, -inf, 1]");
  // a flat mesh cannot be pinned to a hull
  m.shape = MeshSpec{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, Representation::kConvex};
  EXPECT_EQ(AddError(m),
            "objects[m].shape.pin: cannot represent the mesh as a convex: the mesh's vertices are "
            "coplanar (hull dimension 2)");
  m.shape = MeshSpec{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, static_cast<Representation>(9)};
  EXPECT_EQ(AddError(m),
            "objects[m].shape.pin is 9; it must be one of auto, sphere, box, capsule, convex, mesh");
}

// Lengths, coefficients and speeds outside SceneLimits are refused by name, at either
// end: a sphere of radius 1e308 once rendered 0 N to a device deep inside it.
TEST_F(SceneBuilderErrors, ValuesOutsideTheirRanges) {
  EXPECT_EQ(AddError(Sphere("ball", 1e308)), "objects[ball].shape.radius is 1e+308; it must be in (0, 1000] m");
  EXPECT_EQ(AddError(Sphere("ball", 1000.5)), "objects[ball].shape.radius is 1000.5; it must be in (0, 1000] m");
  EXPECT_EQ(AddError(BoxObject("slab", {1, 1e4, 1})),
            "objects[slab].shape.half_extents[1] is 10000; it must be in (0, 1000] m");
  ObjectSpec far = Sphere("far");
  far.X_WB.translation = {0, 0, -2e4};
  EXPECT_EQ(AddError(far), "objects[far].translation is [0, 0, -20000]; each coordinate must be within +-10000 m");
  ObjectSpec mesh_far;
  mesh_far.name = "tri";
  mesh_far.shape = MeshSpec{{{0, 0, 0}, {1, 0, 0}, {0, 1e5, 0}}, {{0, 1, 2}}, Representation::kMesh};
  EXPECT_EQ(AddError(mesh_far),
            "objects[tri].shape.vertices[2] is [0, 1e+05, 0]; each coordinate must be within +-10000 m");
  ObjectSpec stiff = Sphere("stiff");
  stiff.material.stiffness = 2e7;
  EXPECT_EQ(AddError(stiff), "objects[stiff].material.stiffness is 2e+07; it must be in (0, 1e+07] N/m");
  stiff.material.stiffness = 1000;
  stiff.material.damping = 1e6;
  EXPECT_EQ(AddError(stiff), "objects[stiff].material.damping is 1e+06; it must be in [0, 1e+05] N*s/m");
  stiff.material.damping = 0;
  stiff.material.static_friction = 11;
  EXPECT_EQ(AddError(stiff), "objects[stiff].material.static_friction is 11; it must be in [0, 10]");
  ObjectSpec fast = Sphere("fast");
  fast.motion = Motion::kKinematic;
  fast.v_WB = {300, 0, 0};
  EXPECT_EQ(AddError(fast), "objects[fast].v_WB is [300, 0, 0]; its speed must be at most 100 m/s");
  EXPECT_EQ(EditError([](SceneBuilder& b) { b.MoveKinematic("mover", Pose{}, Vector3::Zero(), {0, 0, 2e3}); }),
            "objects[mover].w_WB is [0, 0, 2000]; its rate must be at most 1000 rad/s");
  // the ends themselves are allowed
  SceneBuilder builder;
  ObjectSpec edge = Sphere("edge", SceneLimits::kMaxSize);
  edge.X_WB.translation = {SceneLimits::kMaxCoordinate, 0, -SceneLimits::kMaxCoordinate};
  edge.material.stiffness = SceneLimits::kMaxStiffness;
  EXPECT_NO_THROW(builder.Add(edge));
}

// Budgets bound the work one scene can ask for; each refusal names its budget and
// leaves the scene as it was.
TEST(SceneBudgets, EachRefusalNamesItsBudget) {
  SceneSettings settings;
  settings.budgets.max_objects = 3;
  settings.budgets.max_triangles_per_mesh = 1000;
  settings.budgets.max_triangles = 1500;
  settings.budgets.max_points_per_convex = 8;
  settings.budgets.max_name_bytes = 10;
  SceneBuilder builder(settings);
  const geometry::TriangleMesh sphere = geometry::MakeIcosphere(6, 1.0);  // 720 triangles
  ASSERT_EQ(sphere.num_triangles(), 720);
  ObjectSpec mesh;
  mesh.name = "m1";
  mesh.shape = MeshSpec{sphere.vertices(), sphere.triangles(), Representation::kMesh};
  builder.Add(mesh);
  // a second mesh fits the total (1440 <= 1500); a third does not
  mesh.name = "m2";
  builder.Add(mesh);
  mesh.name = "m3";
  EXPECT_EQ(ErrorOf([&] { builder.Add(mesh); }),
            "objects[m3] would bring the scene to 2160 triangles; the budget is 1500 (max_triangles)");
  // replacing a mesh counts the new one in place of the old
  EXPECT_NO_THROW(builder.Update([&] { ObjectSpec m = mesh; m.name = "m2"; return m; }()));
  // removing a mesh frees its triangles: now the third fits
  builder.Remove("m2");
  EXPECT_NO_THROW(builder.Add(mesh));
  // and so does replacing one by a sphere, until it is a mesh again
  builder.Update(Sphere("m1"));
  mesh.name = "m2";
  EXPECT_NO_THROW(builder.Add(mesh));
  builder.Remove("m2");
  builder.Update([&] { ObjectSpec m = mesh; m.name = "m1"; return m; }());
  EXPECT_EQ(ErrorOf([&] { builder.Add(mesh); }),
            "objects[m2] would bring the scene to 2160 triangles; the budget is 1500 (max_triangles)");
  // one mesh over the per-mesh budget is refused before any work is spent on it
  const geometry::TriangleMesh big = geometry::MakeIcosphere(10, 1.0);
  ASSERT_GT(big.num_triangles(), 1000);
  mesh.shape = MeshSpec{big.vertices(), big.triangles(), Representation::kMesh};
  EXPECT_EQ(ErrorOf([&] { builder.Update([&] { ObjectSpec m = mesh; m.name = "m1"; return m; }()); }),
            "objects[m1].shape has " + std::to_string(big.num_triangles()) +
                " triangles; the budget is 1000 per mesh (max_triangles_per_mesh)");
  // names
  EXPECT_EQ(ErrorOf([&] { builder.Add(Sphere("a_very_long_name")); }),
            "objects[a_very_long_name...].name has 16 bytes; the budget is 10 (max_name_bytes)");
  EXPECT_EQ(ErrorOf([&] { builder.Add(Sphere("bad\nname")); }),
            "objects[] name has the control character 10; names must be printable");
  // hull points
  ObjectSpec hull;
  hull.name = "hull";
  hull.shape = ConvexSpec{std::vector<Vector3>(9, Vector3::Zero())};
  EXPECT_EQ(ErrorOf([&] { builder.Add(hull); }),
            "objects[hull].shape.points has 9 points; the budget is 8 (max_points_per_convex)");
  // objects
  builder.Add(Sphere("s"));
  EXPECT_EQ(builder.num_objects(), 3);
  EXPECT_EQ(ErrorOf([&] { builder.Add(Sphere("t")); }), "the scene has 3 objects; the budget is 3 (max_objects)");
  EXPECT_EQ(builder.num_objects(), 3);
}

// A million copies of one triangle are one triangle: the repeats are dropped at
// validation (counted), so a query near them visits one leaf, not a million.
TEST(SceneBudgets, RepeatedTrianglesAreDroppedAtValidation) {
  ObjectSpec copies;
  copies.name = "copies";
  MeshSpec spec{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {}, Representation::kMesh};
  spec.triangles.assign(100'000, {0, 1, 2});
  copies.shape = spec;
  SceneBuilder builder;
  const SceneObject& object = builder.Add(copies);
  const auto& bvh = std::get<MeshShape>(object.shape).bvh;
  EXPECT_EQ(bvh->mesh().num_triangles(), 100'000);
  EXPECT_EQ(bvh->mesh().num_repeated_triangles(), 99'999);
  EXPECT_EQ(bvh->num_primitives(), 1);
}

TEST_F(SceneBuilderErrors, MissingObjectsAndSettings) {
  EXPECT_EQ(EditError([](SceneBuilder& b) { b.Remove("nothing"); }), "objects[nothing] does not exist");
  EXPECT_EQ(EditError([](SceneBuilder& b) { b.Update(Sphere("nothing")); }),
            "objects[nothing] does not exist");
  // a bad update of an existing object leaves the old one
  EXPECT_EQ(EditError([](SceneBuilder& b) { b.Update(BoxObject("box", {1, 1, 0})); }),
            "objects[box].shape.half_extents[2] is 0; it must be in (0, 1000] m");
  EXPECT_EQ(ErrorOf([] {
              SceneSettings settings;
              settings.tolerance = -1;
              SceneBuilder builder(settings);
            }),
            "settings.tolerance is -1; it must be a finite number > 0");
  EXPECT_EQ(ErrorOf([&] { builder_.Build(0); }), "version is 0; snapshot versions run from 1 to 2^64 - 2");
}

// ---------------------------------------------------------------------------------
// Edits

TEST(SceneBuilder, AddUpdateRemoveAndBuild) {
  SceneBuilder builder;
  builder.Add(Sphere("a", 0.5));
  builder.Add(BoxObject("b", {1, 2, 3}));
  ObjectSpec plane = Sphere("floor");
  plane.shape = PlaneShape{};
  builder.Add(plane);
  EXPECT_EQ(builder.num_objects(), 3);
  const SceneObject& updated = builder.Update(Sphere("a", 0.25));
  EXPECT_EQ(std::get<SphereShape>(updated.shape).radius, 0.25);
  builder.Remove("b");
  Material soft;
  soft.stiffness = 200;
  soft.static_friction = 0.6;
  soft.dynamic_friction = 0.4;
  builder.SetMaterial("floor", soft);

  const auto snapshot = builder.Build(42);
  EXPECT_EQ(snapshot->version(), 42u);
  ASSERT_EQ(snapshot->num_objects(), 2);
  EXPECT_EQ(snapshot->FindObject("a"), 0);
  EXPECT_EQ(snapshot->FindObject("floor"), 1);
  EXPECT_EQ(snapshot->FindObject("b"), -1);
  EXPECT_EQ(snapshot->FindObject(""), -1);
  EXPECT_EQ(snapshot->object(1).material.stiffness, 200);
  EXPECT_EQ(snapshot->object(1).material.dynamic_friction, 0.4);
  EXPECT_EQ(snapshot->settings().tolerance, builder.settings().tolerance);
  // later edits do not reach a built snapshot
  builder.Remove("a");
  EXPECT_EQ(snapshot->num_objects(), 2);
  EXPECT_EQ(builder.num_objects(), 1);
}

// The builder's name index and the kinematic list it keeps agree with a scan of the
// objects through adds, updates (static <-> kinematic), removals from the middle.
TEST(SceneBuilder, NameIndexAndKinematicListFollowEveryEdit) {
  SceneBuilder builder;
  std::mt19937_64 random(5);
  std::vector<std::string> names;
  for (int step = 0; step < 600; ++step) {
    const int op = names.size() < 10 ? 0 : static_cast<int>(random() % 3);
    if (op == 0) {
      ObjectSpec spec = Sphere(std::string("o").append(std::to_string(step)));
      if (random() % 3 == 0) spec.motion = Motion::kKinematic;
      builder.Add(spec);
      names.push_back(spec.name);
    } else if (op == 1) {
      ObjectSpec spec = Sphere(names[random() % names.size()]);
      if (random() % 2 == 0) spec.motion = Motion::kKinematic;
      builder.Update(spec);
    } else {
      const size_t i = random() % names.size();
      builder.Remove(names[i]);
      names.erase(names.begin() + i);
    }
    if (step % 25 != 0) continue;
    const auto snapshot = builder.Build(step + 1);
    std::vector<int> kinematic;
    for (int i = 0; i < snapshot->num_objects(); ++i) {
      EXPECT_EQ(builder.FindObject(snapshot->object(i).name), i);
      if (snapshot->object(i).motion == Motion::kKinematic) kinematic.push_back(i);
    }
    EXPECT_EQ(std::vector<int>(snapshot->kinematic_objects().begin(), snapshot->kinematic_objects().end()),
              kinematic);
    EXPECT_EQ(builder.FindObject("o-none"), -1);
  }
  for (const std::string& name : names) EXPECT_GE(builder.FindObject(name), 0);
}

// An edit copies only what it changes: the objects it does not touch are the very
// objects of the snapshots before it, and those snapshots keep their old versions of
// the ones it does (a material, a kinematic move, an update, a removal).
TEST(SceneBuilder, SnapshotsShareWhatAnEditDoesNotTouch) {
  SceneBuilder builder;
  for (int i = 0; i < 4; ++i) builder.Add(Sphere("s" + std::to_string(i)));
  ObjectSpec moving = Sphere("moving");
  moving.motion = Motion::kKinematic;
  moving.v_WB = {1, 0, 0};
  builder.Add(moving);
  const auto before = builder.Build(1);
  Material soft;
  soft.stiffness = 10;
  builder.SetMaterial("s1", soft);
  builder.AdvanceKinematic(0.5);
  builder.Remove("s3");
  const auto after = builder.Build(2);
  ASSERT_EQ(after->num_objects(), 4);
  EXPECT_EQ(&after->object(0), &before->object(0));
  EXPECT_EQ(&after->object(2), &before->object(2));
  EXPECT_NE(&after->object(1), &before->object(1));
  EXPECT_EQ(after->object(1).material.stiffness, 10);
  EXPECT_EQ(before->object(1).material.stiffness, Sphere("s1").material.stiffness);
  EXPECT_EQ(after->object(3).X_WB.translation.x(), before->object(4).X_WB.translation.x() + 0.5);
  EXPECT_EQ(before->num_objects(), 5);
  EXPECT_EQ(before->object(3).name, "s3");
  // an edit after a build copies again
  builder.SetMaterial("s0", soft);
  const SceneObject* copied = &builder.Build(3)->object(0);
  EXPECT_NE(copied, &after->object(0));
}

TEST(SceneBuilder, MeshObjectsArePlacedThroughTheirRepresentation) {
  // a box mesh centred at (1, 0, 0) of its frame M, M placed at (0, 2, 0) turned about z
  const geometry::TriangleMesh box = geometry::MakeBoxMesh({0.5, 0.25, 0.125}, 2);
  MeshSpec mesh = MeshOf(box);
  for (Vector3& v : mesh.vertices) v += Vector3(1, 0, 0);
  ObjectSpec spec = Sphere("crate");
  spec.shape = mesh;
  spec.motion = Motion::kKinematic;
  spec.X_WB.rotation = Eigen::AngleAxisd(0.5 * std::numbers::pi, Vector3::UnitZ()).toRotationMatrix();
  spec.X_WB.translation = {0, 2, 0};
  spec.w_WB = {0, 0, 3};
  spec.v_WB = {0.5, 0, 0};
  SceneBuilder builder;
  const SceneObject& object = builder.Add(spec);
  ASSERT_EQ(TypeOf(object.shape), ShapeType::kBox);
  EXPECT_EQ(object.representation.chosen, Representation::kBox);
  EXPECT_LT((object.representation.X_MS.translation - Vector3(1, 0, 0)).norm(), 1e-15);
  // S's origin: M's point (1, 0, 0), turned to (0, 1, 0), moved to (0, 3, 0)
  EXPECT_LT((object.X_WB.translation - Vector3(0, 3, 0)).norm(), 1e-15);
  // every body point moves as the client's frame says: v + w x (p - p_WM)
  for (const Vector3& p_M : box.vertices()) {
    const Vector3 p_W = spec.X_WB.ToWorld(p_M + Vector3(1, 0, 0));
    const Vector3 expected = spec.v_WB + spec.w_WB.cross(p_W - spec.X_WB.translation);
    EXPECT_LT((object.CalcPointVelocity(p_W) - expected).norm(), 1e-14);
  }
  // the box turned a quarter: extents 0.25 along x, 0.5 along y
  EXPECT_LT((object.bounds_W.min - Vector3(-0.25, 2.5, -0.125)).norm(), 1e-15);
  EXPECT_LT((object.bounds_W.max - Vector3(0.25, 3.5, 0.125)).norm(), 1e-15);

  // moving it applies the same offset
  Pose X_WM;
  X_WM.translation = {5, 0, 0};
  builder.MoveKinematic("crate", X_WM, Vector3(0, 1, 0), Vector3::Zero());
  const auto snapshot = builder.Build(1);
  const SceneObject& moved = snapshot->object(0);
  EXPECT_LT((moved.X_WB.translation - Vector3(6, 0, 0)).norm(), 1e-15);
  EXPECT_EQ(moved.v_WB, Vector3(0, 1, 0));
  EXPECT_LT((moved.bounds_W.min - Vector3(5.5, -0.25, -0.125)).norm(), 1e-15);
}

// ---------------------------------------------------------------------------------
// Shapes: names and world bounds

TEST(Shape, Names) {
  EXPECT_EQ(ShapeTypeName(ShapeType::kSphere), "sphere");
  EXPECT_EQ(ShapeTypeName(ShapeType::kBox), "box");
  EXPECT_EQ(ShapeTypeName(ShapeType::kCapsule), "capsule");
  EXPECT_EQ(ShapeTypeName(ShapeType::kPlane), "plane");
  EXPECT_EQ(ShapeTypeName(ShapeType::kConvex), "convex");
  EXPECT_EQ(ShapeTypeName(ShapeType::kMesh), "mesh");
  EXPECT_EQ(TypeOf(Shape{CapsuleShape{}}), ShapeType::kCapsule);
}

// The bounds are the box of the placed shape: they contain sampled surface points, and
// each face of the box is reached by the shape's extreme point along that axis.
TEST(Shape, WorldBoundsAreTightForRandomPoses) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> coordinate(-5, 5);
  const std::vector<Vector3> points = geometry::RandomBall(rng, 40, 0.7);
  const auto hull = std::make_shared<const geometry::ConvexHull>(geometry::BuildConvexHull(points));
  for (int trial = 0; trial < 50; ++trial) {
    const Pose X{geometry::RandomRotation(rng), Vector3(coordinate(rng), coordinate(rng), coordinate(rng))};
    // box: the extreme corners
    const Vector3 h(0.3, 0.1, 0.7);
    const geometry::Aabb box = CalcWorldBounds(BoxShape{h}, X);
    geometry::Aabb corners;
    for (int k = 0; k < 8; ++k) {
      corners.Extend(X.ToWorld(Vector3((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z())));
    }
    EXPECT_LT((box.min - corners.min).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((box.max - corners.max).cwiseAbs().maxCoeff(), 1e-12);
    // capsule: the ends of the axis, pushed out by the radius
    const geometry::Aabb capsule = CalcWorldBounds(CapsuleShape{0.2, 0.5}, X);
    const Vector3 a = X.ToWorld({0, 0, -0.5}), b = X.ToWorld({0, 0, 0.5});
    EXPECT_LT((capsule.min - (a.cwiseMin(b).array() - 0.2).matrix()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((capsule.max - (a.cwiseMax(b).array() + 0.2).matrix()).cwiseAbs().maxCoeff(), 1e-12);
    // sphere
    const geometry::Aabb sphere = CalcWorldBounds(SphereShape{0.4}, X);
    EXPECT_EQ(sphere.min, (X.translation.array() - 0.4).matrix());
    EXPECT_EQ(sphere.max, (X.translation.array() + 0.4).matrix());
    // convex: exactly the placed hull vertices' box
    const geometry::Aabb convex = CalcWorldBounds(ConvexShape{hull}, X);
    geometry::Aabb placed;
    for (const Vector3& p : hull->vertices) placed.Extend(X.ToWorld(p));
    EXPECT_EQ(convex.min, placed.min);
    EXPECT_EQ(convex.max, placed.max);
    // tilted plane: everywhere
    const geometry::Aabb plane = CalcWorldBounds(PlaneShape{}, X);
    EXPECT_EQ(plane.min, Vector3::Constant(-kInf));
    EXPECT_EQ(plane.max, Vector3::Constant(kInf));
  }
}

TEST(Shape, MeshBoundsContainTheMesh) {
  auto mesh = std::make_shared<const geometry::TriangleMesh>(geometry::MakeTorus(1, 0.3, 24, 12));
  const MeshShape shape{std::make_shared<const geometry::MeshBvh>(mesh)};
  std::mt19937_64 rng(4);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose X{geometry::RandomRotation(rng), Vector3(trial, -trial, 0.5)};
    const geometry::Aabb bounds = CalcWorldBounds(shape, X);
    for (const Vector3& v : mesh->vertices()) {
      EXPECT_TRUE(bounds.Inflated(1e-12).Contains(X.ToWorld(v)));
    }
    // not looser than the rotated box of the mesh's box allows
    EXPECT_LE(bounds.size().maxCoeff(), std::sqrt(3.0) * mesh->bounds().size().norm() + 1e-12);
  }
}

TEST(Shape, AxisAlignedPlanesAreBoundedOnTheirOuterSide) {
  Pose floor;
  floor.translation = {1, 2, 3};
  const geometry::Aabb up = CalcWorldBounds(PlaneShape{}, floor);
  EXPECT_EQ(up.min, Vector3::Constant(-kInf));
  EXPECT_EQ(up.max, Vector3(kInf, kInf, 3));
  // a wall whose outward normal is -x: the solid (z_B <= 0) is x >= 1
  Pose wall;
  wall.rotation << 0, 0, -1, 0, 1, 0, 1, 0, 0;
  wall.translation = {1, 2, 3};
  ASSERT_EQ(wall.rotation.col(2), Vector3(-1, 0, 0));
  const geometry::Aabb left = CalcWorldBounds(PlaneShape{}, wall);
  EXPECT_EQ(left.min, Vector3(1, -kInf, -kInf));
  EXPECT_EQ(left.max, Vector3::Constant(kInf));
}


// A kinematic object moves by its velocity between edits: advanced in steps, it lands
// where the closed form of its rigid motion puts it (rotation about the frame its spec
// was given in, which for a mesh is not the frame its representation sits in).
TEST(SceneBuilder, KinematicObjectsAdvanceByTheirExactRigidMotion) {
  SceneBuilder builder;
  ObjectSpec mover;
  mover.name = "mover";
  // an off-centre box mesh: its box representation sits away from the mesh frame's origin
  const geometry::TriangleMesh box = geometry::MakeBoxMesh({0.1, 0.2, 0.05}, 1);
  std::vector<Vector3> vertices = box.vertices();
  for (Vector3& v : vertices) v += Vector3(0.3, 0, 0);
  mover.shape = MeshSpec{vertices, box.triangles(), Representation::kAuto};
  mover.motion = Motion::kKinematic;
  mover.X_WB.translation = {1, 2, 3};
  mover.v_WB = {0.1, -0.2, 0.05};
  mover.w_WB = {0, 0, 2};
  const SceneObject& added = builder.Add(mover);
  ASSERT_EQ(TypeOf(added.shape), ShapeType::kBox);
  ObjectSpec still = Sphere("still");
  builder.Add(still);
  for (int step = 0; step < 1000; ++step) ASSERT_TRUE(builder.AdvanceKinematic(0.001));
  // after 1 s: B's origin moved by v, B turned by 2 rad about z; the box centre is
  // where the mesh frame's (0.3, 0, 0) went
  const auto snapshot = builder.Build(2);
  const SceneObject& moved = snapshot->object(0);
  const Matrix3 R = Eigen::AngleAxisd(2.0, Vector3::UnitZ()).toRotationMatrix();
  const Vector3 p_WB = Vector3(1, 2, 3) + mover.v_WB;
  EXPECT_LT((moved.X_WB.translation - (p_WB + R * Vector3(0.3, 0, 0))).norm(), 1e-12);
  EXPECT_LT((moved.X_WB.rotation - R).norm(), 1e-12);
  // its velocity is the box centre's, now
  EXPECT_LT((moved.v_WB - (mover.v_WB + mover.w_WB.cross(R * Vector3(0.3, 0, 0)))).norm(), 1e-12);
  EXPECT_EQ(snapshot->object(1).X_WB.translation, Vector3::Zero());
  // nothing moves: nothing to publish
  SceneBuilder quiet;
  quiet.Add(still);
  EXPECT_FALSE(quiet.AdvanceKinematic(0.001));
}

}  // namespace
}  // namespace hapticd::scene
