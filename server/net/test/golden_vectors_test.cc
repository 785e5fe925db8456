// The golden encodings of proto/golden/vectors.json, checked from C++ (the Python
// package checks the same file): the two languages cannot drift apart.
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/text_format.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>
#include <rapidjson/document.h>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/datagram_codec.h"
#include "server/net/model_codec.h"
#include "server/net/proto_convert.h"
#include "server/net/scene_description.h"
#include "server/scene/scene_builder.h"

namespace hapticd::net {
namespace {

std::string FromHex(const std::string& hex) {
  std::string bytes;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) bytes.push_back(static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return bytes;
}

std::string ToHex(const std::string& bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string hex;
  for (unsigned char c : bytes) {
    hex.push_back(kDigits[c >> 4]);
    hex.push_back(kDigits[c & 15]);
  }
  return hex;
}

rapidjson::Document LoadVectors() {
  std::ifstream file(std::string(HAPTICD_SOURCE_DIR) + "/proto/golden/vectors.json");
  std::stringstream text;
  text << file.rdbuf();
  rapidjson::Document document;
  document.Parse(text.str().c_str());
  return document;
}

TEST(GoldenVectors, EveryVectorEncodesAndDecodesExactly) {
  const rapidjson::Document document = LoadVectors();
  ASSERT_TRUE(document.IsObject()) << "proto/golden/vectors.json does not parse";
  const auto& vectors = document["vectors"].GetArray();
  ASSERT_GE(vectors.Size(), 13u);
  // Make sure the generated descriptors are linked in before looking them up by name.
  v1::Request::descriptor();
  for (const auto& vector : vectors) {
    const std::string name = vector["name"].GetString();
    const auto* descriptor =
        google::protobuf::DescriptorPool::generated_pool()->FindMessageTypeByName(vector["message"].GetString());
    ASSERT_NE(descriptor, nullptr) << name;
    const auto* prototype = google::protobuf::MessageFactory::generated_factory()->GetPrototype(descriptor);
    std::unique_ptr<google::protobuf::Message> from_text(prototype->New());
    std::unique_ptr<google::protobuf::Message> from_bytes(prototype->New());

    ASSERT_TRUE(google::protobuf::TextFormat::ParseFromString(vector["text"].GetString(), from_text.get())) << name;
    EXPECT_EQ(ToHex(from_text->SerializeAsString()), vector["hex"].GetString()) << name;
    ASSERT_TRUE(from_bytes->ParseFromString(FromHex(vector["hex"].GetString()))) << name;
    EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(*from_text, *from_bytes)) << name;
  }
}

// The datagram vectors through the realtime codec: parsed, tag checked, and encoded
// again from the parsed sample to the same bytes.
TEST(GoldenVectors, DatagramsMatchTheCodec) {
  const rapidjson::Document document = LoadVectors();
  ASSERT_TRUE(document.IsObject());
  int checked = 0;
  for (const auto& vector : document["vectors"].GetArray()) {
    if (!vector.HasMember("datagram_hex")) continue;
    const std::string name = vector["name"].GetString();
    const std::string key_bytes = FromHex(vector["key_hex"].GetString());
    SessionKey key;
    ASSERT_EQ(key_bytes.size(), key.size());
    std::copy(key_bytes.begin(), key_bytes.end(), key.begin());
    const std::string datagram = FromHex(vector["datagram_hex"].GetString());
    const std::span<const uint8_t> bytes(reinterpret_cast<const uint8_t*>(datagram.data()), datagram.size());
    EXPECT_TRUE(CheckTag(bytes, key)) << name;

    std::array<uint8_t, kMaxDatagramSize> encoded;
    std::size_t size = 0;
    if (std::string(vector["message"].GetString()) == "hapticd.v1.DeviceState") {
      DeviceStateSample state;
      ASSERT_EQ(ParseState(bytes, state), DatagramError::kNone) << name;
      size = EncodeState(state, key, encoded);
    } else {
      DeviceCommandSample command;
      ASSERT_EQ(ParseCommand(bytes, command), DatagramError::kNone) << name;
      // the hand-read fragment is the one protobuf reads
      v1::DeviceCommand message;
      ASSERT_TRUE(message.ParseFromString(FromHex(vector["hex"].GetString()))) << name;
      EXPECT_EQ(command.model.version, message.model().version()) << name;
      EXPECT_EQ(command.model.index, message.model().index()) << name;
      EXPECT_EQ(command.model.count, message.model().count()) << name;
      EXPECT_EQ(std::string(command.model.data.begin(), command.model.data.end()), message.model().data()) << name;
      size = EncodeCommand(command, key, encoded);
    }
    EXPECT_EQ(ToHex(std::string(encoded.begin(), encoded.begin() + size)), vector["datagram_hex"].GetString())
        << name;
    ++checked;
  }
  EXPECT_EQ(checked, 7);
}

// The vectors a local model session sends: the command's fragment checked above, the
// model itself through its codec, and the session's request.
const rapidjson::Value& FindVector(const rapidjson::Document& document, const std::string& name) {
  for (const auto& vector : document["vectors"].GetArray()) {
    if (vector["name"].GetString() == name) return vector;
  }
  ADD_FAILURE() << "no vector named " << name;
  static const rapidjson::Value kNone;
  return kNone;
}

TEST(GoldenVectors, TheLocalModelMatchesItsCodec) {
  const rapidjson::Document document = LoadVectors();
  ASSERT_TRUE(document.IsObject());
  const auto& vector = FindVector(document, "local_model");
  ASSERT_TRUE(vector.IsObject());
  const std::string bytes = FromHex(vector["hex"].GetString());
  const remote::LocalModel model =
      DecodeLocalModel({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
  EXPECT_EQ(model.version, 2u);
  EXPECT_EQ(model.left_out, 1);
  ASSERT_EQ(model.objects.size(), 1u);
  EXPECT_EQ(model.objects[0].name, "table");
  EXPECT_TRUE(std::holds_alternative<scene::BoxShape>(model.objects[0].shape));
  EXPECT_EQ(model.objects[0].material.stiffness, 2000);
  // the server's encoder writes exactly these bytes for it
  EXPECT_EQ(ToHex(EncodeLocalModel(model)), vector["hex"].GetString());
}

TEST(GoldenVectors, TheLocalModelSessionAsksForOne) {
  const rapidjson::Document document = LoadVectors();
  ASSERT_TRUE(document.IsObject());
  const auto& vector = FindVector(document, "open_session_local_model");
  ASSERT_TRUE(vector.IsObject());
  v1::Request request;
  ASSERT_TRUE(request.ParseFromString(FromHex(vector["hex"].GetString())));
  EXPECT_TRUE(ReadLocalModelMode(request.open_session()));
  Vector3 start_W;
  double timeout_s = 0;
  EXPECT_NO_THROW(ReadSessionRequest(request.open_session(), start_W, timeout_s));
}

// The scene read back: the server describes the scene the vector shows exactly so, for
// the GetScene vector (a digest is opaque, so not compared).
TEST(GoldenVectors, TheSceneReplyIsWhatTheServerDescribes) {
  const rapidjson::Document document = LoadVectors();
  ASSERT_TRUE(document.IsObject());
  v1::Request request;
  ASSERT_TRUE(request.ParseFromString(FromHex(FindVector(document, "get_scene_mesh_data")["hex"].GetString())));
  v1::Reply expected;
  ASSERT_TRUE(expected.ParseFromString(FromHex(FindVector(document, "scene_reply")["hex"].GetString())));

  scene::SceneBuilder builder;
  scene::ObjectSpec mover;
  mover.name = "mover";
  mover.shape = scene::SphereShape{0.05};
  mover.X_WB.translation = {0.1, 0, 0.05};
  mover.material.stiffness = 2000;
  mover.motion = scene::Motion::kKinematic;
  mover.v_WB = {0.5, 0, 0};
  mover.w_WB = {0, 0, 2};
  builder.Add(mover);
  scene::ObjectSpec tetra;
  tetra.name = "tetra";
  scene::MeshSpec mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  mesh.pin = scene::Representation::kMesh;
  tetra.shape = mesh;
  tetra.X_WB.translation = {1, 0, 0};
  tetra.material.stiffness = 1000;
  builder.Add(tetra);
  v1::SceneDescription described = DescribeScene(*builder.Build(5), request.get_scene());

  v1::SceneDescription want = expected.scene();
  for (auto* scene : {&described, &want}) {
    for (auto& object : *scene->mutable_objects()) object.clear_shape_digest();
  }
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(described, want))
      << "server: " << described.ShortDebugString() << "\nvector: " << want.ShortDebugString();
}

// The channel's fields: a session that asks for two-port passivity and a deadband, and
// the energies and counts its datagrams carry, as the codec reads them.
TEST(GoldenVectors, TheChannelsSettingsAndEnergiesReadBack) {
  const rapidjson::Document document = LoadVectors();
  ASSERT_TRUE(document.IsObject());
  v1::Request request;
  ASSERT_TRUE(request.ParseFromString(FromHex(FindVector(document, "open_session_channel")["hex"].GetString())));
  const ChannelRequest channel = ReadChannelRequest(request.open_session());
  EXPECT_TRUE(channel.tdpa);
  EXPECT_EQ(channel.deadband.weber, 0.1);
  EXPECT_EQ(channel.deadband.force_floor_n, 0.05);
  EXPECT_EQ(channel.deadband.position_floor_m, 0.0002);
  EXPECT_EQ(channel.deadband.velocity_floor_mps, 0.004);
  EXPECT_EQ(channel.deadband.keepalive_s, 0.02);

  const auto datagram = [&](const char* name) {
    return FromHex(FindVector(document, name)["datagram_hex"].GetString());
  };
  const std::string state_bytes = datagram("device_state_channel");
  DeviceStateSample state;
  ASSERT_EQ(ParseState({reinterpret_cast<const uint8_t*>(state_bytes.data()), state_bytes.size()}, state),
            DatagramError::kNone);
  EXPECT_EQ(state.energy_in, 0.0125);
  EXPECT_EQ(state.energy_out, 0.00375);
  EXPECT_EQ(state.states_held, 918u);
  EXPECT_TRUE(state.keepalive);
  const std::string command_bytes = datagram("device_command_predicted");
  DeviceCommandSample command;
  ASSERT_EQ(ParseCommand({reinterpret_cast<const uint8_t*>(command_bytes.data()), command_bytes.size()},
                               command),
            DatagramError::kNone);
  EXPECT_EQ(command.flags, static_cast<uint32_t>(v1::COMMAND_FLAGS_PREDICTED));
  EXPECT_EQ(command.energy_in, 0.005);
  EXPECT_EQ(command.energy_out, 0.0025);
  EXPECT_EQ(command.commands_held, 907u);
  EXPECT_EQ(command.command_number, 94u);
}

}  // namespace
}  // namespace hapticd::net
