#include "server/sim/scenario_parser.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace hapticd::sim {
namespace {

// FORMAT.md's example, trimmed to what is required plus a channel.
constexpr std::string_view kScenario = R"({
  "rate_hz": 1000,
  "duration_s": 2.0,
  "scene": {
    "objects": [
      {
        "name": "plate",
        "shape": {"type": "box", "half_extents": [0.1, 0.1, 0.0005]},
        "position": [0, 0, 0],
        "material": {"stiffness": 2000}
      }
    ]
  },
  "avatar": {"type": "point", "method": "god_object"},
  "device": {"mode": "impedance", "mass": 0.05, "damping": 0.5, "max_force": 8.0, "start": [0, 0, 0.02]},
  "hand": {"mass": 0.3, "stiffness": 300, "damping": 5,
           "path": [[0.0, 0, 0, 0.02], [1.0, 0, 0, -0.02], [2.0, 0, 0, -0.02]]}
})";

Scenario Parse(std::vector<std::string> overrides = {}, const std::filesystem::path& base_dir = ".") {
  return ParseScenario(kScenario, base_dir, overrides);
}

// The message of the ScenarioError that parsing with overrides throws.
std::string ErrorWith(std::vector<std::string> overrides, const std::filesystem::path& base_dir = ".") {
  try {
    Parse(std::move(overrides), base_dir);
  } catch (const ScenarioError& error) {
    return error.what();
  }
  ADD_FAILURE() << "no ScenarioError";
  return "";
}

TEST(ParseScenario, ReadsTheFieldsAndTheDefaults) {
  const Scenario s = Parse();
  EXPECT_EQ(s.rate_hz, 1000);
  EXPECT_EQ(s.ticks, 2000);
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].name, "plate");
  EXPECT_EQ(std::get<scene::BoxShape>(s.objects[0].shape).half_extents, Vector3(0.1, 0.1, 0.0005));
  EXPECT_EQ(s.objects[0].X_WB.rotation, geometry::Matrix3::Identity());
  EXPECT_EQ(s.objects[0].motion, scene::Motion::kStatic);
  EXPECT_EQ(s.objects[0].material.stiffness, 2000);
  EXPECT_EQ(s.objects[0].material.damping, 0);
  EXPECT_EQ(s.objects[0].material.static_friction, 0);
  EXPECT_TRUE(s.objects[0].material.force_shading);
  EXPECT_EQ(s.session.avatar.type, force::AvatarType::kPoint);
  EXPECT_EQ(s.session.avatar.radius, 0);
  EXPECT_EQ(s.session.avatar.method, force::ForceMethod::kGodObject);
  EXPECT_FALSE(s.session.avatar.force_shading);
  EXPECT_EQ(s.session.device.mode, force::DeviceMode::kImpedance);
  EXPECT_EQ(s.session.device.max_force, 8);
  EXPECT_EQ(s.session.device.rate_hz, 1000);
  EXPECT_EQ(s.device.mass, 0.05);
  EXPECT_EQ(s.device.position_resolution, 0);
  EXPECT_EQ(s.device.start_W, Vector3(0, 0, 0.02));
  EXPECT_EQ(s.hand.path.size(), 3u);
  EXPECT_EQ(s.hand.path[1].t, 1.0);
  EXPECT_EQ(s.hand.path[1].p_W, Vector3(0, 0, -0.02));
  // channel and control left out
  EXPECT_EQ(s.channel.delay_s, 0);
  EXPECT_EQ(s.channel.loss, 0);
  EXPECT_EQ(s.channel.seed, 1u);
  EXPECT_FALSE(s.session.control.passivity);
}

TEST(ParseScenario, OverridesSetExistingAndOptionalFieldsBeforeValidation) {
  const Scenario s = Parse({"scene.objects.0.material.stiffness=5000", "avatar.method=penalty",
                            "device.start=[0.1, 0.2, 0.3]", "channel.delay_ms=20", "channel.seed=18446744073709551615",
                            "control.passivity=true", "hand.path.2.0=3", "scene.objects.0.name=\"7\""});
  EXPECT_EQ(s.objects[0].material.stiffness, 5000);
  EXPECT_EQ(s.session.avatar.method, force::ForceMethod::kPenalty);
  EXPECT_EQ(s.device.start_W, Vector3(0.1, 0.2, 0.3));
  EXPECT_EQ(s.channel.delay_s, 0.02);
  EXPECT_EQ(s.channel.seed, 18446744073709551615u);
  EXPECT_TRUE(s.session.control.passivity);
  EXPECT_EQ(s.hand.path[2].t, 3);
  EXPECT_EQ(s.objects[0].name, "7");
  // the last override of a field wins, and an invalid value is fixed by a later one
  EXPECT_EQ(Parse({"device.mass=-1", "device.mass=2"}).device.mass, 2);
}

TEST(ParseScenario, OverrideErrorsNameThePath) {
  EXPECT_EQ(ErrorWith({"scene.objects.5.name=x"}),
            "--set scene.objects.5.name=x: scene.objects is an array of length 1, so there is no scene.objects[5]");
  EXPECT_EQ(ErrorWith({"scene.objects.first.name=x"}),
            "--set scene.objects.first.name=x: scene.objects is an array; 'first' is not an index");
  EXPECT_EQ(ErrorWith({"rate_hz.x=1"}), "--set rate_hz.x=1: rate_hz is a number, so it has no field 'x'");
  EXPECT_EQ(ErrorWith({"rate_hz"}), "--set rate_hz: expected key.path=value");
  EXPECT_EQ(ErrorWith({"device..mass=1"}), "--set device..mass=1: the path 'device..mass' has an empty segment");
  // a path that is not in the scenario is created, then refused unless it is a known field
  EXPECT_EQ(ErrorWith({"device.maxforce=3"}),
            "device.maxforce is not a known field; device has: mode, mass, damping, max_force, "
            "position_resolution, start, virtual_mass, virtual_damping, response_time_s");
  EXPECT_EQ(ErrorWith({"chanel.delay_ms=3"}),
            "chanel is not a known field; the scenario has: rate_hz, duration_s, scene, avatar, device, hand, "
            "channel, control, remote");
}

TEST(ParseScenario, WrongTypesAreNamed) {
  EXPECT_EQ(ErrorWith({"device.mass=heavy"}), "device.mass is a string; it must be a number");
  EXPECT_EQ(ErrorWith({"device.start=[0, 0]"}), "device.start has 2 elements; it must be [x, y, z]");
  EXPECT_EQ(ErrorWith({"device.start=0"}), "device.start is a number; it must be an array of 3 numbers [x, y, z]");
  EXPECT_EQ(ErrorWith({"control.passivity=1"}), "control.passivity is a number; it must be a boolean (true or false)");
  EXPECT_EQ(ErrorWith({"channel.seed=1.5"}), "channel.seed is 1.5; it must be an integer in [0, 2^64)");
  EXPECT_EQ(ErrorWith({"channel.seed=-1"}), "channel.seed is -1; it must be an integer in [0, 2^64)");
  EXPECT_EQ(ErrorWith({"avatar.type=null"}), "avatar.type is null; it must be one of the strings point, sphere");
  EXPECT_EQ(ErrorWith({"scene=[]"}), "scene is an array; it must be an object");
  EXPECT_EQ(ErrorWith({"hand.path.1=[1, 0, 0]"}), "hand.path[1] has 3 elements; it must be [t, x, y, z]");
}

TEST(ParseScenario, ImpossibleValuesAreNamed) {
  EXPECT_EQ(ErrorWith({"device.mass=-1"}), "device.mass is -1; it must be > 0");
  EXPECT_EQ(ErrorWith({"rate_hz=0"}), "rate_hz is 0; it must be > 0");
  EXPECT_EQ(ErrorWith({"duration_s=0.0001"}),
            "duration_s is 0.0001; at rate_hz 1000 that is 0 ticks; it must be 1 to 1000000000");
  EXPECT_EQ(ErrorWith({"hand.damping=-0.5"}), "hand.damping is -0.5; it must be >= 0");
  EXPECT_EQ(ErrorWith({"hand.path.1.0=0"}), "hand.path[1][0] is 0; it must be > 0, the time of hand.path[0]");
  EXPECT_EQ(ErrorWith({"hand.path=[]"}), "hand.path is empty; it needs at least one [t, x, y, z] point");
  EXPECT_EQ(ErrorWith({"channel.loss=1.5"}), "channel.loss is 1.5; it must be in [0, 1]");
  EXPECT_EQ(ErrorWith({"channel.delay_ms=-2"}), "channel.delay_ms is -2; it must be >= 0");
  EXPECT_EQ(ErrorWith({"device.virtual_mass=0"}), "device.virtual_mass is 0; it must be > 0");
  EXPECT_EQ(ErrorWith({"avatar.method=spring"}),
            "avatar.method is \"spring\"; it must be one of penalty, god_object, finger_proxy");
  EXPECT_EQ(ErrorWith({"scene.objects.0.shape.type=cone"}),
            "scene.objects[0].shape.type is \"cone\"; it must be one of sphere, box, capsule, plane, convex, mesh");
  EXPECT_EQ(ErrorWith({"scene.objects.0.shape.radius=1"}),
            "scene.objects[0].shape.radius is not a known field; scene.objects[0].shape has: type, half_extents");
  EXPECT_EQ(ErrorWith({"scene.objects.0.material.stiffness=-5"}),
            "scene.objects[0].material.stiffness is -5; it must be in (0, 1e+07] N/m");
  EXPECT_EQ(ErrorWith({"scene.objects.0.representation=box"}),
            "scene.objects[0].representation is only for mesh shapes; this shape is a box");
  EXPECT_EQ(ErrorWith({"hand.stiffness=1e30"}),
            "hand.stiffness is 1e+30; with 0.35 kg moving (hand.mass + device.mass) it is too stiff to simulate at "
            "rate_hz 1000");
  // the session's own check, with the admittance avatar's fields spelt as device fields
  EXPECT_EQ(ErrorWith({"avatar.radius=0.01"}), "avatar.radius is 0.01; a point avatar has radius 0");
  EXPECT_EQ(ErrorWith({"device.virtual_damping=-1"}), "device.virtual_damping is -1; it must be >= 0");
}

TEST(ParseScenario, RotationsMustBeRotations) {
  const Scenario turned = Parse({"scene.objects.0.rotation=[[0, -1, 0], [1, 0, 0], [0, 0, 1]]"});
  // row-major: the body's x axis (first column) is the world's y axis
  EXPECT_EQ(turned.objects[0].X_WB.rotation.col(0), Vector3(0, 1, 0));
  EXPECT_EQ(ErrorWith({"scene.objects.0.rotation=[[1, 0, 0], [0, 1, 0], [0, 0, -1]]"}),
            "scene.objects[0].rotation is not a rotation: it is a reflection (determinant -1)");
  EXPECT_EQ(ErrorWith({"scene.objects.0.rotation=[[1, 0, 0], [0, 2, 0], [0, 0, 1]]"}),
            "scene.objects[0].rotation is not a rotation: its columns are off orthonormal by 3 (more than 1e-06)");
  EXPECT_EQ(ErrorWith({"scene.objects.0.rotation=[[1, 0, 0], [0, 1, 0]]"}),
            "scene.objects[0].rotation has 2 rows; it must have 3");
}

TEST(ParseScenario, SyntaxErrorsAndMissingFields) {
  auto error_of = [](std::string_view json) {
    try {
      ParseScenario(json, ".");
    } catch (const ScenarioError& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of("{\n  \"rate_hz\": 1000,\n  \"duration_s\" 2\n}"),
            "invalid JSON at line 3, column 16, in the value of duration_s: Missing a colon after a name of "
            "object member.");
  EXPECT_EQ(error_of("[]"), "the scenario is an array; it must be an object");
  EXPECT_EQ(error_of("{\"rate_hz\": 1000}"), "duration_s is missing; it is required");
  EXPECT_EQ(ErrorWith({"hand={\"mass\": 1, \"stiffness\": 1, \"damping\": 1}"}), "hand.path is missing; it is required");
  EXPECT_EQ(ErrorWith({"avatar.type=sphere"}), "avatar.radius is missing; it is required");
}

// A key given twice in one object is refused by its path (the reader would see only
// the first), at any depth, before any field is read; in different objects it is fine.
TEST(ParseScenario, RepeatedKeysAreRefusedByName) {
  auto error_of = [](std::string_view json) {
    try {
      ParseSceneFile(json, ".");
    } catch (const ScenarioError& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of(R"({"scene": {"objects": [{"name": "s", "shape": {"type": "sphere", "radius": 0.1,
                "radius": -1}, "position": [0, 0, 0], "material": {"stiffness": 1}}]}})"),
            "scene.objects[0].shape.radius is given twice; each key may appear once in an object");
  EXPECT_EQ(error_of(R"({"scene": {"objects": []}, "scene": {"objects": []}})"),
            "scene is given twice; each key may appear once in an object");
  EXPECT_EQ(error_of(R"({"scene": {"objects": [{"name": "a", "shape": {"type": "plane"}, "position": [0, 0, 0],
                "material": {"stiffness": 1}}, {"name": "b", "shape": {"type": "plane"}, "position": [0, 0, 1],
                "material": {"stiffness": 1, "damping": 1, "damping": 2}}]}})"),
            "scene.objects[1].material.damping is given twice; each key may appear once in an object");
  EXPECT_EQ(error_of(R"({"scene": {"objects": [{"name": "a", "shape": {"type": "plane"}, "position": [0, 0, 0],
                "material": {"stiffness": 1}}, {"name": "b", "shape": {"type": "plane"}, "position": [0, 0, 1],
                "material": {"stiffness": 1}}]}})"),
            "no error");
  // deep nesting neither overflows nor hides a repeat
  std::string deep = R"({"scene": {"objects": []}, "x": )";
  for (int i = 0; i < 100000; ++i) deep += "[";
  deep += R"({"k": 1, "k": 2})";
  for (int i = 0; i < 100000; ++i) deep += "]";
  deep += "}";
  const std::string deep_error = error_of(deep);
  EXPECT_TRUE(deep_error.starts_with("x[0][0][0]")) << deep_error.substr(0, 80);
  EXPECT_TRUE(deep_error.ends_with("[0].k is given twice; each key may appear once in an object"));
}

// A syntax error names the field whose value it is in, and says why a NaN or an
// infinity is not a number.
TEST(ParseScenario, SyntaxErrorsNameTheField) {
  auto error_of = [](std::string_view json) {
    try {
      ParseSceneFile(json, ".");
    } catch (const ScenarioError& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of(R"({"scene": {"objects": [{"name": "s", "shape": {"type": "sphere", "radius": NaN}}]}})"),
            "invalid JSON at line 1, column 76, in the value of scene.objects[0].shape.radius: Invalid value. "
            "(NaN and Infinity are not JSON numbers; every number must be finite)");
  EXPECT_EQ(error_of(R"({"scene": {"objects": [{"name": "s", "position": [0, -Infinity, 0]}]}})"),
            "invalid JSON at line 1, column 55, in the value of scene.objects[0].position[1]: Invalid value. "
            "(NaN and Infinity are not JSON numbers; every number must be finite)");
  EXPECT_EQ(error_of(R"({"scene": {"tolerance": 1e400, "objects": []}})"),
            "invalid JSON at line 1, column 25, in the value of scene.tolerance: Number too big to be stored in "
            "double.");
  // past the largest double, refused like 1e400 (RapidJSON 1.1.0 read 9e308 as -2.8e-308)
  EXPECT_EQ(error_of(R"({"scene": {"tolerance": 9e308, "objects": []}})"),
            "invalid JSON at line 1, column 25, in the value of scene.tolerance: Number too big to be stored in "
            "double.");
  EXPECT_EQ(error_of(R"({"scene": {"objects": [1, 2,]}})"),
            "invalid JSON at line 1, column 29, in the value of scene.objects[2]: Invalid value.");
  EXPECT_EQ(error_of(R"({"scene": {"objects": [], }})"),
            "invalid JSON at line 1, column 27, in scene: Missing a name for object member.");
  // a string that is not UTF-8 (a Latin-1 name; a lone continuation byte in a key)
  EXPECT_EQ(error_of("{\"scene\": {\"objects\": [{\"name\": \"caf\xe9\", \"shape\": {\"type\": \"plane\"}}]}}"),
            "invalid JSON at line 1, column 37, in the value of scene.objects[0].name: Invalid encoding in string. "
            "(byte 0xe9 there; every string must be UTF-8)");
  EXPECT_EQ(error_of("{\"scene\": {\"tolerance\": 1e-3, \"\x80\": 1, \"objects\": []}}"),
            "invalid JSON at line 1, column 32, in scene: Invalid encoding in string. (byte 0x80 there; every "
            "string must be UTF-8)");
}

// Numbers are the doubles they spell, in the file and in overrides: RapidJSON 1.1.0's
// full-precision parse read a zero with an exponent as garbage (0.0e50 as -1.9e-267 in
// a g++ -O2 build, 4.06e31 in hapticd-query; server/json/exact_json.h).
TEST(ParseScenario, NumbersAreReadExactly) {
  const SceneFile file = ParseSceneFile(R"({"scene": {"tolerance": 1e-3, "objects": [{"name": "b",
      "shape": {"type": "box", "half_extents": [0.05, 0.0002e2, 1e-320]}, "position": [0.0e50, -0e-400, 0E+0],
      "material": {"stiffness": 2000}}]}})", ".");
  ASSERT_EQ(file.objects.size(), 1u);
  EXPECT_EQ(file.settings.tolerance, 0.001);
  const Vector3 p_WB = file.objects[0].X_WB.translation;
  EXPECT_EQ(p_WB, Vector3(0, 0, 0));
  EXPECT_TRUE(std::signbit(p_WB.y()));
  const Vector3 half_extents = std::get<scene::BoxShape>(file.objects[0].shape).half_extents;
  EXPECT_EQ(half_extents, Vector3(0.05, 0.02, 2024 * std::numeric_limits<double>::denorm_min()));
  EXPECT_EQ(Parse({"device.start=[0.0e50, 0e80, 0.02]"}).device.start_W, Vector3(0, 0, 0.02));
  // a zero of 41 digits (more than 22 took the same wrong path)
  const Scenario long_zero =
      Parse({"hand.path=[[0.00000000000000000000000000000000000000000, 0, 0, 0.02], [1, 0, 0, 0]]"});
  EXPECT_EQ(long_zero.hand.path[0].t, 0.0);
}

// ray_backend, like representation, is for meshes only.
TEST(ParseScenario, RayBackendOffAMeshIsRefused) {
  EXPECT_EQ(ErrorWith({"scene.objects.0.ray_backend=embree"}),
            "scene.objects[0].ray_backend is only for mesh shapes; this shape is a box");
  EXPECT_EQ(ErrorWith({"scene.objects.0.representation=box"}),
            "scene.objects[0].representation is only for mesh shapes; this shape is a box");
}

TEST(ParseScenario, MeshesInlineFromFilesAndExtensions) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "scenario_parser_test";
  std::filesystem::create_directories(dir / "meshes");
  std::ofstream(dir / "meshes" / "tetra.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  std::ofstream(dir / "meshes" / "broken.obj") << "v 0 0 0\nf 1 2 3\n";

  const std::string mesh_file = R"(scene.objects.0.shape={"type": "mesh", "file": "meshes/tetra.obj"})";
  const Scenario from_file = Parse({mesh_file, "scene.objects.0.representation=convex"}, dir);
  const auto& mesh = std::get<scene::MeshSpec>(from_file.objects[0].shape);
  EXPECT_EQ(mesh.vertices.size(), 4u);
  EXPECT_EQ(mesh.triangles[3], (std::array<int, 3>{1, 2, 3}));
  EXPECT_EQ(mesh.pin, scene::Representation::kConvex);
  EXPECT_FALSE(from_file.objects[0].ray_backend.has_value());
  const Scenario on_embree = Parse({mesh_file, "scene.objects.0.ray_backend=embree"}, dir);
  EXPECT_EQ(on_embree.objects[0].ray_backend, scene::RayBackend::kEmbree);
  EXPECT_EQ(ErrorWith({"scene.objects.0.ray_backend=optix"}),
            "scene.objects[0].ray_backend is \"optix\"; it must be one of native, embree");

  const Scenario inline_mesh = Parse(
      {R"(scene.objects.0.shape={"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]})"});
  EXPECT_EQ(std::get<scene::MeshSpec>(inline_mesh.objects[0].shape).triangles.size(), 1u);
  EXPECT_EQ(std::get<scene::MeshSpec>(inline_mesh.objects[0].shape).pin, scene::Representation::kAuto);

  EXPECT_EQ(ErrorWith({R"(scene.objects.0.shape={"type": "mesh", "file": "meshes/none.obj"})"}, dir),
            "scene.objects[0].shape.file is \"meshes/none.obj\"; " +
                std::filesystem::absolute(dir / "meshes" / "none.obj").lexically_normal().string() + " does not exist");
  EXPECT_EQ(ErrorWith({R"(scene.objects.0.shape={"type": "mesh", "file": "meshes/broken.obj"})"}, dir),
            "scene.objects[0].shape.file: " + (dir / "meshes" / "broken.obj").lexically_normal().string() +
                ":2: face index 2 refers to vertex 2, but the file has 1 vertices");
  EXPECT_EQ(
      ErrorWith({R"(scene.objects.0.shape={"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,3]]})"}),
      "scene.objects[0].shape.triangles[0][2] is 3; it must be a vertex index, an integer in [0, 3)");
  EXPECT_EQ(ErrorWith({R"(scene.objects.0.shape={"type": "mesh", "file": "a.obj", "triangles": []})"}),
            "scene.objects[0].shape has a file and inline vertices or triangles; give one or the other");

  // a kinematic object
  const Scenario moving = Parse({"scene.objects.0.motion={\"velocity\": [0, 0, -0.01]}"});
  EXPECT_EQ(moving.objects[0].motion, scene::Motion::kKinematic);
  EXPECT_EQ(moving.objects[0].v_WB, Vector3(0, 0, -0.01));
  EXPECT_EQ(moving.objects[0].w_WB, Vector3::Zero());
  EXPECT_EQ(ErrorWith({"scene.objects.0.motion.spin=1"}),
            "scene.objects[0].motion.spin is not a known field; scene.objects[0].motion has: velocity, angular_velocity");
}

TEST(LoadScenario, ResolvesMeshesNextToTheFileAndNamesAMissingFile) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "load_scenario_test";
  std::filesystem::create_directories(dir / "meshes");
  std::ofstream(dir / "meshes" / "tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(dir / "s.json") << kScenario;
  const std::vector<std::string> overrides = {R"(scene.objects.0.shape={"type": "mesh", "file": "meshes/tri.obj"})"};
  EXPECT_EQ(std::get<scene::MeshSpec>(LoadScenario(dir / "s.json", overrides).objects[0].shape).vertices.size(), 3u);
  try {
    LoadScenario(dir / "none.json");
    ADD_FAILURE() << "no error";
  } catch (const ScenarioError& error) {
    EXPECT_EQ(std::string(error.what()), "the scenario file does not exist");
  }
}

}  // namespace
}  // namespace hapticd::sim
