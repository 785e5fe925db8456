#include "server/sim/scenario_parser.h"

#include <fmt/format.h>
#include <rapidjson/error/en.h>
#include <rapidjson/reader.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "server/json/exact_json.h"
#include "server/scene/mesh_file.h"
#include "server/sim/hand_device.h"
#include "server/sim/json_fields.h"
#include "server/sim/scenario_overrides.h"

namespace hapticd::sim {
namespace {

using scene::ObjectSpec;

// The names of an enum's values 0 .. last, as its name function spells them: choice i of
// ReadChoice is then the value i.
template <typename Enum>
std::vector<std::string_view> NamesOf(Enum last, std::string_view (*name_of)(Enum)) {
  std::vector<std::string_view> names;
  for (int i = 0; i <= static_cast<int>(last); ++i) names.push_back(name_of(static_cast<Enum>(i)));
  return names;
}

template <typename Enum>
Enum ReadEnum(const JsonAt& at, const std::vector<std::string_view>& names) {
  return static_cast<Enum>(ReadChoice(at, names));
}

// "line L, column C" of a byte offset into text (both 1-based).
std::string LineAndColumn(std::string_view text, size_t offset) {
  offset = std::min(offset, text.size());
  const std::string_view before = text.substr(0, offset);
  const size_t line = 1 + std::count(before.begin(), before.end(), '\n');
  const size_t line_start = before.rfind('\n');
  const size_t column = offset - (line_start == std::string_view::npos ? 0 : line_start + 1) + 1;
  return fmt::format("line {}, column {}", line, column);
}

// A mesh given inline: vertices [[x, y, z], ...] and triangles [[i, j, k], ...].
void ReadInlineMesh(const JsonObject& shape, scene::MeshSpec& mesh) {
  const JsonAt vertices = shape.Required("vertices");
  const int num_vertices = ReadArraySize(vertices);
  for (int i = 0; i < num_vertices; ++i) mesh.vertices.push_back(ReadVector3(Element(vertices, i)));
  const JsonAt triangles = shape.Required("triangles");
  const int num_triangles = ReadArraySize(triangles);
  for (int t = 0; t < num_triangles; ++t) {
    const JsonAt triangle = Element(triangles, t);
    if (ReadArraySize(triangle) != 3) {
      throw ScenarioError(
          fmt::format("{} has {} elements; it must be [i, j, k]", triangle.path, triangle.value.Size()));
    }
    std::array<int, 3> indices;
    for (int c = 0; c < 3; ++c) {
      const JsonAt index = Element(triangle, c);
      if (!index.value.IsInt() || index.value.GetInt() < 0 || index.value.GetInt() >= num_vertices) {
        const std::string value = index.value.IsNumber() ? fmt::format("{}", index.value.GetDouble())
                                                         : std::string(JsonTypeName(index.value));
        throw ScenarioError(fmt::format("{} is {}; it must be a vertex index, an integer in [0, {})",
                                        index.path, value, num_vertices));
      }
      indices[c] = index.value.GetInt();
    }
    mesh.triangles.push_back(indices);
  }
}

// A mesh from an OBJ or STL file, relative to base_dir.
void ReadMeshFromFile(const JsonAt& file_at, const std::filesystem::path& base_dir, scene::MeshSpec& mesh) {
  const std::string file = ReadString(file_at);
  const std::filesystem::path resolved = (base_dir / file).lexically_normal();
  std::error_code error;
  if (!std::filesystem::exists(resolved, error)) {
    throw ScenarioError(fmt::format("{} is \"{}\"; {} does not exist", file_at.path, file,
                                    std::filesystem::absolute(resolved, error).string()));
  }
  try {
    scene::MeshData data = scene::ReadMeshFile(resolved);
    mesh.vertices = std::move(data.vertices);
    mesh.triangles = std::move(data.triangles);
  } catch (const scene::MeshFileError& e) {
    throw ScenarioError(fmt::format("{}: {}", file_at.path, e.what()));
  }
}

// The shape: its type picks its fields.
scene::ShapeSpec ReadShape(const JsonAt& at, const std::filesystem::path& base_dir) {
  // the type first, so that the known fields can depend on it
  const JsonObject any_shape(
      at, {"type", "radius", "half_extents", "half_length", "points", "vertices", "triangles", "file"});
  const auto type = ReadEnum<scene::ShapeType>(any_shape.Required("type"),
                                               NamesOf(scene::ShapeType::kMesh, scene::ShapeTypeName));
  switch (type) {
    case scene::ShapeType::kSphere: {
      const JsonObject shape(at, {"type", "radius"});
      return scene::SphereShape{ReadNumber(shape.Required("radius"))};
    }
    case scene::ShapeType::kBox: {
      const JsonObject shape(at, {"type", "half_extents"});
      return scene::BoxShape{ReadVector3(shape.Required("half_extents"))};
    }
    case scene::ShapeType::kCapsule: {
      const JsonObject shape(at, {"type", "radius", "half_length"});
      return scene::CapsuleShape{ReadNumber(shape.Required("radius")),
                                ReadNumber(shape.Required("half_length"))};
    }
    case scene::ShapeType::kPlane: {
      const JsonObject shape(at, {"type"});
      return scene::PlaneShape{};
    }
    case scene::ShapeType::kConvex: {
      const JsonObject shape(at, {"type", "points"});
      const JsonAt points = shape.Required("points");
      scene::ConvexSpec convex;
      const int n = ReadArraySize(points);
      for (int i = 0; i < n; ++i) convex.points.push_back(ReadVector3(Element(points, i)));
      return convex;
    }
    case scene::ShapeType::kMesh:
    case scene::ShapeType::kCount: {
      const JsonObject shape(at, {"type", "vertices", "triangles", "file"});
      scene::MeshSpec mesh;
      // a file, or vertices and triangles, never both
      if (const auto file = shape.Optional("file")) {
        if (shape.Has("vertices") || shape.Has("triangles")) {
          throw ScenarioError(fmt::format(
              "{} has a file and inline vertices or triangles; give one or the other", at.path));
        }
        ReadMeshFromFile(*file, base_dir, mesh);
      } else {
        ReadInlineMesh(shape, mesh);
      }
      return mesh;
    }
  }
  return scene::SphereShape{};
}

scene::Material ReadMaterial(const JsonAt& at) {
  const JsonObject object(
      at, {"stiffness", "damping", "static_friction", "dynamic_friction", "force_shading"});
  scene::Material material;
  material.stiffness = ReadNumber(object.Required("stiffness"));
  if (const auto damping = object.Optional("damping")) material.damping = ReadNumber(*damping);
  if (const auto mu = object.Optional("static_friction")) material.static_friction = ReadNumber(*mu);
  if (const auto mu = object.Optional("dynamic_friction")) material.dynamic_friction = ReadNumber(*mu);
  if (const auto shading = object.Optional("force_shading")) material.force_shading = ReadBool(*shading);
  if (const auto error = scene::ValidateMaterial(material, at.path)) throw ScenarioError(*error);
  return material;
}

ObjectSpec ReadObject(const JsonAt& at, const std::filesystem::path& base_dir) {
  const JsonObject object(
      at, {"name", "shape", "position", "rotation", "material", "motion", "representation", "ray_backend"});
  ObjectSpec spec;
  spec.name = ReadString(object.Required("name"));
  spec.shape = ReadShape(object.Required("shape"), base_dir);
  spec.X_WB.translation = ReadVector3(object.Required("position"));
  if (const auto rotation = object.Optional("rotation")) spec.X_WB.rotation = ReadRotation(*rotation);
  spec.material = ReadMaterial(object.Required("material"));
  // extension: a kinematic object moving at a constant velocity
  if (const auto motion_at = object.Optional("motion")) {
    const JsonObject motion(*motion_at, {"velocity", "angular_velocity"});
    spec.motion = scene::Motion::kKinematic;
    if (const auto v = motion.Optional("velocity")) spec.v_WB = ReadVector3(*v);
    if (const auto w = motion.Optional("angular_velocity")) spec.w_WB = ReadVector3(*w);
  }
  // extension: a mesh's pinned representation
  if (const auto representation = object.Optional("representation")) {
    auto* mesh = std::get_if<scene::MeshSpec>(&spec.shape);
    if (mesh == nullptr) {
      const auto type = static_cast<scene::ShapeType>(spec.shape.index());
      throw ScenarioError(fmt::format("{} is only for mesh shapes; this shape is a {}", representation->path,
                                      scene::ShapeTypeName(type)));
    }
    mesh->pin = ReadEnum<scene::Representation>(
        *representation, NamesOf(scene::Representation::kMesh, scene::RepresentationName));
  }
  // extension: the backend of a mesh's queries
  if (const auto backend = object.Optional("ray_backend")) {
    spec.ray_backend =
        ReadEnum<scene::RayBackend>(*backend, NamesOf(scene::RayBackend::kEmbree, scene::RayBackendName));
    // like representation: meaningless off a mesh, so refused rather than ignored
    if (!std::holds_alternative<scene::MeshSpec>(spec.shape)) {
      const auto type = static_cast<scene::ShapeType>(spec.shape.index());
      throw ScenarioError(fmt::format("{} is only for mesh shapes; this shape is a {}", backend->path,
                                      scene::ShapeTypeName(type)));
    }
  }
  return spec;
}

void ReadScene(const JsonAt& at, const std::filesystem::path& base_dir, Scenario& scenario) {
  const JsonObject scene(at, {"objects", "tolerance"});
  if (const auto tolerance = scene.Optional("tolerance")) {
    scenario.scene_settings.tolerance = ReadPositive(*tolerance);
  }
  const JsonAt objects = scene.Required("objects");
  const int n = ReadArraySize(objects);
  for (int i = 0; i < n; ++i) scenario.objects.push_back(ReadObject(Element(objects, i), base_dir));
}

void ReadAvatar(const JsonAt& at, force::AvatarSettings& avatar) {
  const JsonObject object(at, {"type", "radius", "method", "force_shading"});
  avatar.type = ReadEnum<force::AvatarType>(object.Required("type"),
                                            NamesOf(force::AvatarType::kSphere, force::AvatarTypeName));
  // a point's radius is 0 unless given; a sphere's must be given
  if (avatar.type == force::AvatarType::kSphere || object.Has("radius")) {
    avatar.radius = ReadNonNegative(object.Required("radius"));
  }
  avatar.method = ReadEnum<force::ForceMethod>(
      object.Required("method"), NamesOf(force::ForceMethod::kFingerProxy, force::ForceMethodName));
  if (const auto shading = object.Optional("force_shading")) avatar.force_shading = ReadBool(*shading);
}

void ReadDevice(const JsonAt& at, Scenario& scenario) {
  const JsonObject object(at, {"mode", "mass", "damping", "max_force", "position_resolution", "start",
                               "virtual_mass", "virtual_damping", "response_time_s"});
  force::SessionSettings& session = scenario.session;
  session.device.mode = ReadEnum<force::DeviceMode>(
      object.Required("mode"), NamesOf(force::DeviceMode::kAdmittance, force::DeviceModeName));
  scenario.device.mass = ReadPositive(object.Required("mass"));
  scenario.device.damping = ReadNonNegative(object.Required("damping"));
  session.device.max_force = ReadPositive(object.Required("max_force"));
  if (const auto resolution = object.Optional("position_resolution")) {
    scenario.device.position_resolution = ReadNonNegative(*resolution);
  }
  scenario.device.start_W = ReadVector3(object.Required("start"));
  if (const auto mass = object.Optional("virtual_mass")) {
    session.admittance.virtual_mass = ReadPositive(*mass);
  }
  if (const auto damping = object.Optional("virtual_damping")) {
    session.admittance.virtual_damping = ReadNonNegative(*damping);
  }
  if (const auto response = object.Optional("response_time_s")) {
    scenario.device.response_time_s = ReadNonNegative(*response);
    if (scenario.device.response_time_s > 0 && session.device.mode != force::DeviceMode::kAdmittance) {
      throw ScenarioError(fmt::format("{} is {}; it applies to device.mode admittance only", response->path,
                                      scenario.device.response_time_s));
    }
  }
}

void ReadRemote(const JsonAt& at, Scenario& scenario) {
  const JsonObject object(at, {"mode", "passivity", "deadband"});
  RemoteSpec& remote = scenario.remote;
  if (const auto mode = object.Optional("mode")) {
    remote.mode = ReadEnum<RemoteMode>(*mode, NamesOf(RemoteMode::kLocalModel, RemoteModeName));
  }
  if (const auto passivity = object.Optional("passivity")) {
    static constexpr std::string_view kPassivities[] = {"none", "tdpa"};
    remote.tdpa = ReadChoice(*passivity, kPassivities) == 1;
    if (remote.tdpa && scenario.session.device.mode != force::DeviceMode::kImpedance) {
      throw ScenarioError(fmt::format(
          "{} is tdpa, which hapticd-sim implements for device.mode impedance only (the admittance end's "
          "damper is not built yet)",
          passivity->path));
    }
  }
  if (const auto deadband = object.Optional("deadband")) {
    remote.deadband = ReadNonNegative(*deadband);
    if (!(remote.deadband < 1)) {
      throw ScenarioError(
          fmt::format("{} is {}; a Weber fraction must be >= 0 and < 1", deadband->path, remote.deadband));
    }
  }
}

void ReadHand(const JsonAt& at, HandSpec& hand) {
  const JsonObject object(at, {"mass", "stiffness", "damping", "path"});
  hand.mass = ReadNonNegative(object.Required("mass"));
  hand.stiffness = ReadNonNegative(object.Required("stiffness"));
  hand.damping = ReadNonNegative(object.Required("damping"));
  const JsonAt path = object.Required("path");
  const int n = ReadArraySize(path);
  if (n == 0) {
    throw ScenarioError(fmt::format("{} is empty; it needs at least one [t, x, y, z] point", path.path));
  }
  for (int i = 0; i < n; ++i) {
    const JsonAt point = Element(path, i);
    if (ReadArraySize(point) != 4) {
      throw ScenarioError(
          fmt::format("{} has {} elements; it must be [t, x, y, z]", point.path, point.value.Size()));
    }
    PathPoint p;
    p.t = ReadNumber(Element(point, 0));
    for (int k = 0; k < 3; ++k) p.p_W[k] = ReadNumber(Element(point, k + 1));
    // times strictly increase
    if (i > 0 && !(p.t > hand.path.back().t)) {
      throw ScenarioError(fmt::format("{}[0] is {}; it must be > {}, the time of {}[{}]", point.path, p.t,
                                      hand.path.back().t, path.path, i - 1));
    }
    hand.path.push_back(p);
  }
}

void ReadChannel(const JsonAt& at, ChannelSpec& channel) {
  const JsonObject object(at, {"delay_ms", "jitter_ms", "loss", "seed"});
  if (const auto delay = object.Optional("delay_ms")) channel.delay_s = ReadNonNegative(*delay) / 1000;
  if (const auto jitter = object.Optional("jitter_ms")) channel.jitter_s = ReadNonNegative(*jitter) / 1000;
  if (const auto loss = object.Optional("loss")) channel.loss = ReadInRange(*loss, 0, 1);
  if (const auto seed = object.Optional("seed")) channel.seed = ReadUnsigned(*seed);
}

// The session settings' own check, in the scenario's words: the admittance avatar's
// fields are device fields here.
void ValidateSession(const force::SessionSettings& session) {
  std::optional<std::string> error = force::ValidateSessionSettings(session);
  if (!error) return;
  constexpr std::string_view kAdmittance = "admittance.";
  if (error->starts_with(kAdmittance)) error->replace(0, kAdmittance.size(), "device.");
  throw ScenarioError(*error);
}

// The hand-device body must be integrable at the loop's rate (hand_device.h).
void ValidatePlant(const Scenario& scenario) {
  const double mass = scenario.hand.mass + scenario.device.mass;
  const double dt = 1 / scenario.rate_hz;
  if (CalcSubsteps(mass, scenario.hand.stiffness, 0, dt) == 0) {
    throw ScenarioError(fmt::format(
        "hand.stiffness is {}; with {} kg moving (hand.mass + device.mass) it is too stiff to simulate at "
        "rate_hz {}",
        scenario.hand.stiffness, mass, scenario.rate_hz));
  }
  if (CalcSubsteps(mass, 0, scenario.hand.damping + scenario.device.damping, dt) == 0) {
    throw ScenarioError(fmt::format(
        "hand.damping + device.damping is {}; with {} kg moving (hand.mass + device.mass) it is too much to "
        "simulate at rate_hz {}",
        scenario.hand.damping + scenario.device.damping, mass, scenario.rate_hz));
  }
}

Scenario ReadScenario(const JsonAt& root, const std::filesystem::path& base_dir) {
  const JsonObject top(
      root, {"rate_hz", "duration_s", "scene", "avatar", "device", "hand", "channel", "control", "remote"});
  Scenario scenario;
  // time: a whole number of ticks, at least one
  scenario.rate_hz = ReadPositive(top.Required("rate_hz"));
  scenario.duration_s = ReadPositive(top.Required("duration_s"));
  const double ticks = std::round(scenario.duration_s * scenario.rate_hz);
  if (!(ticks >= 1 && ticks <= kMaxTicks)) {
    throw ScenarioError(fmt::format("duration_s is {}; at rate_hz {} that is {} ticks; it must be 1 to {}",
                                    scenario.duration_s, scenario.rate_hz, ticks, kMaxTicks));
  }
  scenario.ticks = static_cast<int64_t>(ticks);

  ReadScene(top.Required("scene"), base_dir, scenario);
  ReadAvatar(top.Required("avatar"), scenario.session.avatar);
  ReadDevice(top.Required("device"), scenario);
  ReadHand(top.Required("hand"), scenario.hand);
  if (const auto channel = top.Optional("channel")) ReadChannel(*channel, scenario.channel);
  if (const auto control_at = top.Optional("control")) {
    const JsonObject control(*control_at, {"passivity"});
    if (const auto passivity = control.Optional("passivity")) {
      scenario.session.control.passivity = ReadBool(*passivity);
    }
  }
  if (const auto remote = top.Optional("remote")) ReadRemote(*remote, scenario);
  scenario.session.device.rate_hz = scenario.rate_hz;
  ValidateSession(scenario.session);
  ValidatePlant(scenario);
  return scenario;
}

// Follows the path of the value being read (a SAX handler), so that a parse error can
// name the field it happened in: a member's value ("scene.objects[0].shape.radius"),
// an array's element ("position[3]"), or the object or array itself.
class PathTracker : public rapidjson::BaseReaderHandler<rapidjson::UTF8<>, PathTracker> {
 public:
  bool StartObject() { return Open(false); }
  bool StartArray() { return Open(true); }
  bool Key(const char* text, rapidjson::SizeType length, bool) {
    levels_.back().key.assign(text, length);
    levels_.back().in_value = true;
    return true;
  }
  bool EndObject(rapidjson::SizeType) { return Close(); }
  bool EndArray(rapidjson::SizeType) { return Close(); }
  // every scalar value
  bool Default() {
    ValueDone();
    return true;
  }

  // Where the reader stopped: "the value of P" (a member's or an element's value) or
  // "P" (between members or elements); "" at the top.
  std::string Where() const {
    std::string path;
    for (size_t i = 0; i < levels_.size(); ++i) {
      const Level& level = levels_[i];
      const bool last = i + 1 == levels_.size();
      if (level.array) {
        if (!last || level.in_value) path += fmt::format("[{}]", level.index);
      } else if (!last || level.in_value) {
        path = MemberPath(path, level.key);
      }
    }
    if (path.empty()) return "";
    const Level& top = levels_.back();
    return top.in_value ? "the value of " + path : path;
  }

 private:
  struct Level {
    bool array = false;
    int index = 0;        // arrays: the element being read
    std::string key;      // objects: the member being read
    bool in_value = false;  // between a key (or an array's start or comma) and its value's end
  };

  bool Open(bool array) {
    levels_.push_back({array, 0, "", array});
    return true;
  }
  bool Close() {
    levels_.pop_back();
    ValueDone();
    return true;
  }
  // the value of the innermost member or element is complete
  void ValueDone() {
    if (levels_.empty()) return;
    Level& level = levels_.back();
    if (level.array) {
      ++level.index;
    } else {
      level.in_value = false;
    }
  }

  std::vector<Level> levels_;
};

// The flags of every parse of a scenario: iterative, so that deep nesting cannot
// overflow the stack (numbers are exact: server/json/exact_json.h); every string valid
// UTF-8, as JSON requires (a name that is not would make every reply naming it
// unreadable: protobuf strings are UTF-8).
constexpr unsigned kParseFlags = rapidjson::kParseIterativeFlag | rapidjson::kParseValidateEncodingFlag;

// The parse error's position, and the field it is in where the tracker knows it (the
// tracker sees the parse that failed, up to where it failed).
std::string DescribeParseError(std::string_view json, const rapidjson::ParseResult& error) {
  PathTracker tracker;
  json::ParseEvents<kParseFlags>(json, tracker);
  std::string where = tracker.Where();
  std::string text = fmt::format("invalid JSON at {}", LineAndColumn(json, error.Offset()));
  if (!where.empty()) text += ", in " + where;
  text += fmt::format(": {}", rapidjson::GetParseError_En(error.Code()));
  // NaN and infinities are Python's json extensions, not JSON
  const std::string_view rest = json.substr(std::min(error.Offset(), json.size()));
  if (rest.starts_with("NaN") || rest.starts_with("Infinity") || rest.starts_with("-Infinity")) {
    text += " (NaN and Infinity are not JSON numbers; every number must be finite)";
  }
  if (error.Code() == rapidjson::kParseErrorStringInvalidEncoding && !rest.empty()) {
    text += fmt::format(" (byte 0x{:02x} there; every string must be UTF-8)", static_cast<uint8_t>(rest[0]));
  }
  return text;
}

// Refuses an object that names a member twice (the DOM would keep both, and lookups
// find the first): "scene.objects[0].shape.radius is given twice". The walk keeps its
// own stack, so deep nesting cannot overflow the thread's.
void RefuseRepeatedKeys(const rapidjson::Value& root) {
  std::vector<std::pair<const rapidjson::Value*, std::string>> pending = {{&root, ""}};
  std::vector<std::string_view> names;
  while (!pending.empty()) {
    auto [value, path] = std::move(pending.back());
    pending.pop_back();
    if (value->IsArray()) {
      for (rapidjson::SizeType i = 0; i < value->Size(); ++i) {
        pending.emplace_back(&(*value)[i], fmt::format("{}[{}]", path, i));
      }
      continue;
    }
    if (!value->IsObject()) continue;
    names.clear();
    for (const auto& member : value->GetObject()) {
      names.emplace_back(member.name.GetString(), member.name.GetStringLength());
      pending.emplace_back(&member.value, MemberPath(path, names.back()));
    }
    std::sort(names.begin(), names.end());
    const auto repeated = std::adjacent_find(names.begin(), names.end());
    if (repeated != names.end()) {
      throw ScenarioError(fmt::format("{} is given twice; each key may appear once in an object",
                                      MemberPath(path, *repeated)));
    }
  }
}

rapidjson::Document ParseJson(std::string_view json) {
  rapidjson::Document document;
  const rapidjson::ParseResult error = json::ParseDocument<kParseFlags>(json, document);
  if (error.IsError()) throw ScenarioError(DescribeParseError(json, error));
  RefuseRepeatedKeys(document);
  return document;
}

std::string ReadFile(const std::filesystem::path& path, std::string_view what) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    const bool exists = std::filesystem::exists(path, error);
    throw ScenarioError(exists ? fmt::format("the {} is not a regular file", what)
                               : fmt::format("the {} file does not exist", what));
  }
  std::ifstream file(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (!file.is_open() || file.bad()) throw ScenarioError(fmt::format("the {} file cannot be read", what));
  return text;
}

}  // namespace

Scenario ParseScenario(std::string_view json, const std::filesystem::path& base_dir,
                       std::span<const std::string> overrides) {
  rapidjson::Document document = ParseJson(json);
  for (const std::string& text : overrides) ApplyOverride(document, ParseOverride(text));
  return ReadScenario(JsonAt{document, ""}, base_dir);
}

SceneFile ParseSceneFile(std::string_view json, const std::filesystem::path& base_dir) {
  const rapidjson::Document document = ParseJson(json);
  const JsonAt root{document, ""};
  // A scene file, or a whole scenario whose scene is wanted.
  const JsonObject top(root, {"scene", "rate_hz", "duration_s", "avatar", "device", "hand", "channel", "control"});
  Scenario scenario;
  ReadScene(top.Required("scene"), base_dir, scenario);
  return {scenario.scene_settings, std::move(scenario.objects)};
}

SceneFile LoadSceneFile(const std::filesystem::path& path) {
  return ParseSceneFile(ReadFile(path, "scene"), path.parent_path());
}

Scenario LoadScenario(const std::filesystem::path& path, std::span<const std::string> overrides) {
  return ParseScenario(ReadFile(path, "scenario"), path.parent_path(), overrides);
}

}  // namespace hapticd::sim
