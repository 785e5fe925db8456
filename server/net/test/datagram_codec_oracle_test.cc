#include <array>
#include <bit>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/datagram_codec.h"
#include "server/net/test/codec_test_support.h"

// The codec writes and reads DeviceState and DeviceCommand by hand; these tests hold it
// to protobuf's own serializer and parser, on random messages and random wire bytes.

namespace hapticd::net {
namespace {

// The codec writes both messages by hand; protobuf's own serializer is the oracle. The
// reference message is built by protobuf's setters with the codec's rules (a zero vector
// and the identity left out, -0.0 counting as zero there), from random samples whose
// values are often special: zeros of both signs, NaN, infinities, the extremes.
template <typename Message>
void SetVectorAsTheCodecDoes(Message& message, v1::Vec3* (Message::*mutable_field)(), const Vector3& v) {
  if (v.isZero(0)) return;
  v1::Vec3* out = (message.*mutable_field)();
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

template <typename Message>
void SetQuaternionAsTheCodecDoes(Message& message, v1::Quat* (Message::*mutable_field)(), const Quaternion& q) {
  if (q.w() == 1 && q.vec().isZero(0)) return;
  v1::Quat* out = (message.*mutable_field)();
  out->set_w(q.w());
  out->set_x(q.x());
  out->set_y(q.y());
  out->set_z(q.z());
}

struct RandomValues {
  std::mt19937_64 random;
  double Double() {
    static const double kSpecial[] = {0.0, -0.0, 1.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                                      std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                                      std::numeric_limits<double>::denorm_min(), std::numeric_limits<double>::max()};
    if (random() % 2 == 0) return kSpecial[random() % std::size(kSpecial)];
    return std::uniform_real_distribution<double>(-10, 10)(random);
  }
  Vector3 Vector() { return random() % 3 == 0 ? Vector3::Zero() : Vector3(Double(), Double(), Double()); }
  Quaternion Rotation() {
    return random() % 3 == 0 ? Quaternion::Identity() : Quaternion(Double(), Double(), Double(), Double());
  }
  template <typename T>
  T Integer() {
    // zero a third of the time; else small (a one-byte varint) or any
    if (random() % 3 == 0) return 0;
    return static_cast<T>(random() % 2 == 0 ? random() % 200 : random());
  }
};

TEST(DatagramCodec, HandWrittenMessagesAreProtobufsOwnSerialization) {
  const SessionKey key = TestKey(8);
  RandomValues r{std::mt19937_64(44)};
  std::array<uint8_t, kMaxDatagramSize> buffer;
  for (int i = 0; i < 2000; ++i) {
    SCOPED_TRACE(::testing::Message() << "sample " << i);
    DeviceStateSample state;
    state.session_id = r.Integer<uint32_t>();
    state.sequence = r.Integer<uint64_t>();
    state.send_time_ns = r.Integer<uint64_t>();
    state.p_WD = r.Vector();
    state.q_WD = r.Rotation();
    state.v_WD = r.Vector();
    state.w_WD = r.Vector();
    state.buttons = r.Integer<uint32_t>();
    state.f_sensed_W = r.Vector();
    state.f_held_W = r.Vector();
    state.rtt_us = r.Integer<uint32_t>();
    state.model_version = r.Integer<uint64_t>();
    state.avatar_W = r.Vector();
    state.energy_in = r.Double();
    state.energy_out = r.Double();
    state.states_held = r.Integer<uint64_t>();
    state.keepalive = r.random() % 2 == 0;
    v1::DeviceState state_message;
    state_message.set_session_id(state.session_id);
    state_message.set_sequence(state.sequence);
    state_message.set_send_time_ns(state.send_time_ns);
    SetVectorAsTheCodecDoes(state_message, &v1::DeviceState::mutable_position, state.p_WD);
    SetQuaternionAsTheCodecDoes(state_message, &v1::DeviceState::mutable_orientation, state.q_WD);
    SetVectorAsTheCodecDoes(state_message, &v1::DeviceState::mutable_velocity, state.v_WD);
    SetVectorAsTheCodecDoes(state_message, &v1::DeviceState::mutable_angular_velocity, state.w_WD);
    state_message.set_buttons(state.buttons);
    SetVectorAsTheCodecDoes(state_message, &v1::DeviceState::mutable_sensed_force, state.f_sensed_W);
    SetVectorAsTheCodecDoes(state_message, &v1::DeviceState::mutable_held_force, state.f_held_W);
    state_message.set_rtt_us(state.rtt_us);
    state_message.set_model_version(state.model_version);
    SetVectorAsTheCodecDoes(state_message, &v1::DeviceState::mutable_avatar, state.avatar_W);
    state_message.set_energy_in(state.energy_in);
    state_message.set_energy_out(state.energy_out);
    state_message.set_states_held(state.states_held);
    state_message.set_keepalive(state.keepalive);
    std::size_t size = EncodeState(state, key, buffer);
    ASSERT_GT(size, 0u);
    EXPECT_EQ(AsString(std::span<const uint8_t>(buffer).first(size - kTagSize)), state_message.SerializeAsString());
    EXPECT_TRUE(CheckTag({buffer.data(), size}, key));

    DeviceCommandSample command;
    command.session_id = r.Integer<uint32_t>();
    command.sequence = r.Integer<uint64_t>();
    command.echo_send_time_ns = r.Integer<uint64_t>();
    command.scene_version = r.Integer<uint64_t>();
    command.f_W = r.Vector();
    command.tau_W = r.Vector();
    command.p_command_W = r.Vector();
    command.q_command_W = r.Rotation();
    command.avatar_W = r.Vector();
    command.contact = r.random() % 2 == 0;
    command.flags = r.Integer<uint32_t>();
    command.energy_in = r.Double();
    command.energy_out = r.Double();
    command.commands_held = r.Integer<uint64_t>();
    command.command_number = r.Integer<uint64_t>();
    v1::DeviceCommand command_message;
    command_message.set_session_id(command.session_id);
    command_message.set_sequence(command.sequence);
    command_message.set_echo_send_time_ns(command.echo_send_time_ns);
    command_message.set_scene_version(command.scene_version);
    SetVectorAsTheCodecDoes(command_message, &v1::DeviceCommand::mutable_force, command.f_W);
    SetVectorAsTheCodecDoes(command_message, &v1::DeviceCommand::mutable_torque, command.tau_W);
    SetVectorAsTheCodecDoes(command_message, &v1::DeviceCommand::mutable_position, command.p_command_W);
    SetQuaternionAsTheCodecDoes(command_message, &v1::DeviceCommand::mutable_orientation, command.q_command_W);
    SetVectorAsTheCodecDoes(command_message, &v1::DeviceCommand::mutable_avatar, command.avatar_W);
    command_message.set_contact(command.contact);
    command_message.set_flags(command.flags);
    command_message.set_energy_in(command.energy_in);
    command_message.set_energy_out(command.energy_out);
    command_message.set_commands_held(command.commands_held);
    command_message.set_command_number(command.command_number);
    size = EncodeCommand(command, key, buffer);
    ASSERT_GT(size, 0u);
    EXPECT_EQ(AsString(std::span<const uint8_t>(buffer).first(size - kTagSize)), command_message.SerializeAsString());
    EXPECT_TRUE(CheckTag({buffer.data(), size}, key));
  }
}

// The fields the hand-written encoder writes (WriteState and WriteCommand in
// datagram_codec.cc; the command's model fragment, 12, is written on its own): a field
// added to either message fails here until the encoder writes it and the test above sets it.
std::vector<int> FieldNumbers(const google::protobuf::Descriptor* descriptor) {
  std::vector<int> numbers;
  for (int i = 0; i < descriptor->field_count(); ++i) numbers.push_back(descriptor->field(i)->number());
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}

TEST(DatagramCodec, TheHandWrittenEncoderCoversEveryField) {
  EXPECT_EQ(FieldNumbers(v1::DeviceState::descriptor()),
            (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 40, 41, 42, 43}));
  EXPECT_EQ(FieldNumbers(v1::DeviceCommand::descriptor()),
            (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 40, 41, 42, 43}));
  EXPECT_EQ(FieldNumbers(v1::Vec3::descriptor()), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(FieldNumbers(v1::Quat::descriptor()), (std::vector<int>{1, 2, 3, 4}));
}

// The codec reads both messages by hand; protobuf's generated parser is the oracle. The
// inputs are random wire bytes: the message's own fields with their wire types and with
// others, unknown fields, sub-messages (of their own random fields), groups nested up to
// past protobuf's recursion limit, end-group tags out of place, tags of field 0, wire
// types 6 and 7, overlong varints, tags and lengths; a third of them then have a byte
// changed, inserted or cut. Whatever protobuf accepts, the codec must accept with the
// same values (bit for bit), and refuse whatever protobuf refuses.
class WireSoup {
 public:
  explicit WireSoup(uint64_t seed) : values_{std::mt19937_64(seed)} {}

  // A message whose field n has wire type types(n) (-1: unknown) and is a message of
  // Vec3's or Quat's fields when that type is length-delimited.
  template <typename Types>
  std::string Message(Types&& types, int depth) {
    std::string out;
    const int fields = static_cast<int>(Random() % 8);
    for (int i = 0; i < fields; ++i) Field(out, types, depth);
    return out;
  }
  std::string Mutated(std::string bytes) {
    if (Random() % 3 != 0) return bytes;
    const std::size_t at = bytes.empty() ? 0 : Random() % bytes.size();
    switch (Random() % 3) {
      case 0:
        if (!bytes.empty()) bytes[at] = static_cast<char>(Random());
        break;
      case 1: bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(at), static_cast<char>(Random())); break;
      default: bytes.resize(at); break;
    }
    return bytes;
  }
  uint64_t Random() { return values_.random(); }

 private:
  static int Vec3Type(uint32_t n) { return n >= 1 && n <= 4 ? 1 : -1; }

  void Varint(std::string& out, uint64_t v) {
    // a tenth of them overlong: one to six more bytes than needed
    int extra = Random() % 10 == 0 ? 1 + static_cast<int>(Random() % 6) : 0;
    while (v >= 0x80 || extra > 0) {
      out.push_back(static_cast<char>((v & 0x7f) | 0x80));
      v >>= 7;
      if (v == 0) --extra;
    }
    out.push_back(static_cast<char>(v));
  }
  void Tag(std::string& out, uint64_t number, int type) { Varint(out, number << 3 | static_cast<uint64_t>(type)); }

  template <typename Types>
  void Field(std::string& out, Types&& types, int depth) {
    uint64_t number;
    switch (Random() % 20) {
      case 0: number = 0; break;
      case 1: number = Random() % (uint64_t{1} << 29); break;
      case 2: number = Random() % (uint64_t{1} << 32); break;  // a tag past 32 bits
      case 3: case 4: case 5: number = 1 + Random() % 60; break;
      default: number = 1 + Random() % 45; break;  // often the message's own
    }
    int type = types(static_cast<uint32_t>(number));
    const uint64_t pick = Random() % 40;
    if (type < 0 || pick < 6) type = static_cast<int>(pick < 3 ? Random() % 8 : std::array{0, 1, 2, 5}[Random() % 4]);
    if (type == 4 && Random() % 2 == 0) type = 3;
    Tag(out, number, type);
    switch (type) {
      case 0: Varint(out, Random() % 2 == 0 ? Random() % 3 : Random()); break;
      case 1: {
        const uint64_t bits = std::bit_cast<uint64_t>(values_.Double());
        for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>(bits >> (8 * i)));
        break;
      }
      case 5:
        for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(Random()));
        break;
      case 2: {
        const std::string body = depth < 3 ? Message(Vec3Type, depth + 1) : std::string();
        Varint(out, body.size() + (Random() % 30 == 0 ? 1 : 0));
        out += body;
        break;
      }
      case 3: {
        // a group: fields, then its end (now and then another field's), or a chain of
        // groups about protobuf's recursion limit deep
        if (depth == 0 && Random() % 8 == 0) {
          const int levels = 95 + static_cast<int>(Random() % 10);
          for (int i = 1; i < levels; ++i) Tag(out, number, 3);
          for (int i = 0; i < levels; ++i) Tag(out, number, 4);
          break;
        }
        out += depth < 3 ? Message(Vec3Type, depth + 1) : std::string();
        Tag(out, Random() % 10 == 0 ? number + 1 : number, 4);
        break;
      }
      default: break;  // an end group out of place; wire types 6 and 7 carry nothing
    }
  }

  RandomValues values_;
};

bool SameBits(double a, double b) { return std::bit_cast<uint64_t>(a) == std::bit_cast<uint64_t>(b); }
void ExpectSameBits(const Vector3& a, const v1::Vec3& b) {
  EXPECT_TRUE(SameBits(a.x(), b.x()) && SameBits(a.y(), b.y()) && SameBits(a.z(), b.z()))
      << a.transpose() << " against " << b.ShortDebugString();
}
void ExpectSameBits(const Quaternion& a, const v1::Quat& b, bool present) {
  const Quaternion expected = present ? Quaternion(b.w(), b.x(), b.y(), b.z()) : Quaternion::Identity();
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(SameBits(a.coeffs()[i], expected.coeffs()[i]));
}
std::vector<uint8_t> WithTagRoom(const std::string& body) {
  std::vector<uint8_t> datagram(body.begin(), body.end());
  datagram.resize(datagram.size() + kTagSize, 0);
  return datagram;
}

TEST(DatagramCodec, ReadsStatesAsProtobufsParserDoes) {
  WireSoup soup(71);
  const auto types = [](uint32_t n) {
    if (n == 1 || n == 8 || n == 11) return 5;
    if (n == 2 || n == 3 || n == 12 || n == 40 || n == 41) return 1;
    if ((n >= 4 && n <= 7) || n == 9 || n == 10 || n == 13) return 2;
    if (n == 42 || n == 43) return 0;
    return -1;
  };
  int accepted = 0;
  for (int i = 0; i < 40000; ++i) {
    const std::string body = soup.Mutated(soup.Message(types, 0));
    if (body.size() + kTagSize > kMaxStateSize) continue;
    SCOPED_TRACE(::testing::Message() << "case " << i << ": " << ::testing::PrintToString(body));
    v1::DeviceState expected;
    const bool parses = expected.ParseFromString(body);
    DeviceStateSample state;
    state.session_id = 99;  // whatever was there before does not show through
    const DatagramError error = ParseState(WithTagRoom(body), state);
    ASSERT_EQ(error == DatagramError::kNone, parses) << DatagramErrorName(error);
    if (!parses) continue;
    ++accepted;
    EXPECT_EQ(state.session_id, expected.session_id());
    EXPECT_EQ(state.sequence, expected.sequence());
    EXPECT_EQ(state.send_time_ns, expected.send_time_ns());
    ExpectSameBits(state.p_WD, expected.position());
    ExpectSameBits(state.q_WD, expected.orientation(), expected.has_orientation());
    ExpectSameBits(state.v_WD, expected.velocity());
    ExpectSameBits(state.w_WD, expected.angular_velocity());
    EXPECT_EQ(state.buttons, expected.buttons());
    ExpectSameBits(state.f_sensed_W, expected.sensed_force());
    ExpectSameBits(state.f_held_W, expected.held_force());
    EXPECT_EQ(state.rtt_us, expected.rtt_us());
    EXPECT_EQ(state.model_version, expected.model_version());
    ExpectSameBits(state.avatar_W, expected.avatar());
    EXPECT_TRUE(SameBits(state.energy_in, expected.energy_in()));
    EXPECT_TRUE(SameBits(state.energy_out, expected.energy_out()));
    EXPECT_EQ(state.states_held, expected.states_held());
    EXPECT_EQ(state.keepalive, expected.keepalive());
  }
  // both sides of the line are well sampled
  EXPECT_GT(accepted, 8000);
  EXPECT_LT(accepted, 32000);
}

TEST(DatagramCodec, ReadsCommandsAsProtobufsParserDoes) {
  WireSoup soup(72);
  const auto types = [](uint32_t n) {
    if (n == 1 || n == 11) return 5;
    if ((n >= 2 && n <= 4) || n == 40 || n == 41 || n == 43) return 1;
    if (n >= 5 && n <= 9) return 2;
    if (n == 10 || n == 42) return 0;
    return -1;  // the model fragment (12) has tests of its own
  };
  int accepted = 0;
  for (int i = 0; i < 40000; ++i) {
    const std::string body = soup.Mutated(soup.Message(types, 0));
    SCOPED_TRACE(::testing::Message() << "case " << i << ": " << ::testing::PrintToString(body));
    v1::DeviceCommand expected;
    const bool parses = expected.ParseFromString(body);
    DeviceCommandSample command;
    command.flags = 99;
    const DatagramError error = ParseCommand(WithTagRoom(body), command);
    if (parses && expected.has_model()) continue;  // one fragment, within bounds: the codec's own rule
    ASSERT_EQ(error == DatagramError::kNone, parses) << DatagramErrorName(error);
    if (!parses) continue;
    ++accepted;
    EXPECT_EQ(command.session_id, expected.session_id());
    EXPECT_EQ(command.sequence, expected.sequence());
    EXPECT_EQ(command.echo_send_time_ns, expected.echo_send_time_ns());
    EXPECT_EQ(command.scene_version, expected.scene_version());
    ExpectSameBits(command.f_W, expected.force());
    ExpectSameBits(command.tau_W, expected.torque());
    ExpectSameBits(command.p_command_W, expected.position());
    ExpectSameBits(command.q_command_W, expected.orientation(), expected.has_orientation());
    ExpectSameBits(command.avatar_W, expected.avatar());
    EXPECT_EQ(command.contact, expected.contact());
    EXPECT_EQ(command.flags, expected.flags());
    EXPECT_EQ(command.model.count, 0u);
    EXPECT_TRUE(SameBits(command.energy_in, expected.energy_in()));
    EXPECT_TRUE(SameBits(command.energy_out, expected.energy_out()));
    EXPECT_EQ(command.commands_held, expected.commands_held());
    EXPECT_EQ(command.command_number, expected.command_number());
  }
  EXPECT_GT(accepted, 8000);
  EXPECT_LT(accepted, 32000);
}

}  // namespace
}  // namespace hapticd::net
