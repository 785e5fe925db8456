#include "server/net/datagram_codec.h"

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <sodium.h>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/test/codec_test_support.h"
#include "server/net/test/count_allocations.h"

namespace hapticd::net {
namespace {

DeviceStateSample MakeState() {
  DeviceStateSample state;
  state.session_id = 0xdeadbeef;
  state.sequence = 1234567890123ull;
  state.send_time_ns = 42;
  state.p_WD = {0.1, -0.2, 0.3};
  state.q_WD = Quaternion(Eigen::AngleAxisd(0.3, Vector3(0, 0, 1)));
  state.v_WD = {-1e-3, 0, 2};
  state.w_WD = {0, 0.5, 0};
  state.buttons = 0b101;
  state.f_sensed_W = {1, 2, 3};
  state.f_held_W = {-4, 5, -6};
  state.rtt_us = 321;
  state.model_version = 0xfedcba9876543210ull;
  state.avatar_W = {0.1, -0.2, 0.29};
  return state;
}

TEST(DatagramCodec, StateRoundTripsExactly) {
  const SessionKey key = TestKey(1);
  const DeviceStateSample state = MakeState();
  std::array<uint8_t, kMaxDatagramSize> buffer;
  const std::size_t size = EncodeState(state, key, buffer);
  ASSERT_GT(size, kTagSize);
  const std::span<const uint8_t> datagram(buffer.data(), size);
  EXPECT_TRUE(CheckTag(datagram, key));

  DeviceStateSample back;
  ASSERT_EQ(ParseState(datagram, back), DatagramError::kNone);
  EXPECT_EQ(back.session_id, state.session_id);
  EXPECT_EQ(back.sequence, state.sequence);
  EXPECT_EQ(back.send_time_ns, state.send_time_ns);
  EXPECT_EQ(back.p_WD, state.p_WD);
  EXPECT_EQ(back.q_WD.coeffs(), state.q_WD.coeffs());
  EXPECT_EQ(back.v_WD, state.v_WD);
  EXPECT_EQ(back.w_WD, state.w_WD);
  EXPECT_EQ(back.buttons, state.buttons);
  EXPECT_EQ(back.f_sensed_W, state.f_sensed_W);
  EXPECT_EQ(back.f_held_W, state.f_held_W);
  EXPECT_EQ(back.rtt_us, state.rtt_us);
  EXPECT_EQ(back.model_version, state.model_version);
  EXPECT_EQ(back.avatar_W, state.avatar_W);

  // the local model's fields where hapticd.proto puts them (protobuf as the oracle)
  v1::DeviceState message;
  ASSERT_TRUE(message.ParseFromArray(buffer.data(), static_cast<int>(size - kTagSize)));
  EXPECT_EQ(message.model_version(), state.model_version);
  EXPECT_EQ(message.avatar().x(), state.avatar_W.x());
  EXPECT_EQ(message.avatar().y(), state.avatar_W.y());
  EXPECT_EQ(message.avatar().z(), state.avatar_W.z());
}

TEST(DatagramCodec, CommandRoundTripsAndAbsentMeansZeroOrIdentity) {
  const SessionKey key = TestKey(9);
  DeviceCommandSample command;
  command.session_id = 7;
  command.sequence = 3;
  command.f_W = {0, 0, 2.5};
  command.contact = true;
  std::array<uint8_t, kMaxDatagramSize> buffer;
  const std::size_t size = EncodeCommand(command, key, buffer);
  DeviceCommandSample back;
  back.tau_W = {9, 9, 9};  // must be overwritten with the absent field's zero
  ASSERT_EQ(ParseCommand({buffer.data(), size}, back), DatagramError::kNone);
  EXPECT_EQ(back.f_W, command.f_W);
  EXPECT_EQ(back.tau_W, Vector3::Zero());
  EXPECT_TRUE(back.q_command_W.coeffs().isApprox(Quaternion::Identity().coeffs(), 0));
  EXPECT_TRUE(back.contact);
  // Zero vectors are not sent: session id, sequence, force and contact only.
  EXPECT_EQ(size, 5u + 9u + 2u + 9u + 2u + kTagSize);
}

// Every field of a command set, none of them zero.
DeviceCommandSample MakeCommand() {
  DeviceCommandSample command;
  command.session_id = 0x12345678;
  command.sequence = 987654321;
  command.echo_send_time_ns = 1000000007;
  command.scene_version = 5;
  command.f_W = {0.5, -1.5, 2.5};
  command.tau_W = {0.01, 0.02, -0.03};
  command.p_command_W = {0.1, 0.2, 0.3};
  command.q_command_W = Quaternion(Eigen::AngleAxisd(0.5, Vector3(1, 0, 0)));
  command.avatar_W = {0.11, 0.19, 0.31};
  command.contact = true;
  command.flags = 3;
  return command;
}

// MakeCommand's fields, as protobuf has them (the fragment left to the caller).
v1::DeviceCommand MakeCommandMessage() {
  const DeviceCommandSample c = MakeCommand();
  v1::DeviceCommand message;
  message.set_session_id(c.session_id);
  message.set_sequence(c.sequence);
  message.set_echo_send_time_ns(c.echo_send_time_ns);
  message.set_scene_version(c.scene_version);
  const auto set = [](v1::Vec3* out, const Vector3& v) {
    out->set_x(v.x());
    out->set_y(v.y());
    out->set_z(v.z());
  };
  set(message.mutable_force(), c.f_W);
  set(message.mutable_torque(), c.tau_W);
  set(message.mutable_position(), c.p_command_W);
  message.mutable_orientation()->set_w(c.q_command_W.w());
  message.mutable_orientation()->set_x(c.q_command_W.x());
  message.mutable_orientation()->set_y(c.q_command_W.y());
  message.mutable_orientation()->set_z(c.q_command_W.z());
  set(message.mutable_avatar(), c.avatar_W);
  message.set_contact(c.contact);
  message.set_flags(c.flags);
  return message;
}

void ExpectSameCommandFields(const DeviceCommandSample& back, const DeviceCommandSample& command) {
  EXPECT_EQ(back.session_id, command.session_id);
  EXPECT_EQ(back.sequence, command.sequence);
  EXPECT_EQ(back.echo_send_time_ns, command.echo_send_time_ns);
  EXPECT_EQ(back.scene_version, command.scene_version);
  EXPECT_EQ(back.f_W, command.f_W);
  EXPECT_EQ(back.tau_W, command.tau_W);
  EXPECT_EQ(back.p_command_W, command.p_command_W);
  EXPECT_EQ(back.q_command_W.coeffs(), command.q_command_W.coeffs());
  EXPECT_EQ(back.avatar_W, command.avatar_W);
  EXPECT_EQ(back.contact, command.contact);
  EXPECT_EQ(back.flags, command.flags);
}

std::vector<uint8_t> RandomBytes(std::size_t size, std::mt19937_64& random) {
  std::vector<uint8_t> bytes(size);
  for (auto& byte : bytes) byte = static_cast<uint8_t>(random());
  return bytes;
}

// A message's bytes followed by their tag under key.
std::vector<uint8_t> Seal(const std::string& body, const SessionKey& key) {
  std::vector<uint8_t> datagram(body.begin(), body.end());
  datagram.resize(body.size() + kTagSize);
  ComputeTag({datagram.data(), body.size()}, TagKey(key), datagram.data() + body.size());
  return datagram;
}

TEST(DatagramCodec, CommandCarryingAFragmentRoundTrips) {
  const SessionKey key = TestKey(3);
  std::mt19937_64 random(41);
  const std::vector<uint8_t> data = RandomBytes(kModelChunkSize, random);
  DeviceCommandSample command = MakeCommand();
  command.model = {.version = 0x0123456789abcdefull, .index = 94, .count = 96, .data = data};
  std::array<uint8_t, kMaxCommandSize> buffer;
  const std::size_t size = EncodeCommand(command, key, buffer);
  ASSERT_GT(size, kMaxStateSize);
  const std::span<const uint8_t> datagram(buffer.data(), size);
  EXPECT_TRUE(CheckTag(datagram, key));

  DeviceCommandSample back;
  ASSERT_EQ(ParseCommand(datagram, back), DatagramError::kNone);
  ExpectSameCommandFields(back, command);
  EXPECT_EQ(back.model.version, command.model.version);
  EXPECT_EQ(back.model.index, command.model.index);
  EXPECT_EQ(back.model.count, command.model.count);
  EXPECT_TRUE(std::ranges::equal(back.model.data, data));
  // the data is a view into the datagram, not a copy
  EXPECT_GE(back.model.data.data(), datagram.data());
  EXPECT_LE(back.model.data.data() + back.model.data.size(), datagram.data() + datagram.size() - kTagSize);

  // a command without one, parsed into the same sample, clears it
  const std::size_t plain = EncodeCommand(MakeCommand(), key, buffer);
  ASSERT_EQ(ParseCommand({buffer.data(), plain}, back), DatagramError::kNone);
  EXPECT_EQ(back.model.count, 0u);
  EXPECT_TRUE(back.model.data.empty());
}

// The fragment is written by hand: it must be byte for byte what protobuf writes for the
// same DeviceCommand, zero fields left out, for every combination of absent fields and
// data lengths across the varint boundaries (127/128 bytes; a body past 127).
TEST(DatagramCodec, HandEncodedFragmentIsProtobufsOwnSerialization) {
  const SessionKey key = TestKey(6);
  std::mt19937_64 random(43);
  const std::vector<uint8_t> pool = RandomBytes(kModelChunkSize, random);
  std::vector<ModelFragmentView> fragments;
  for (const uint64_t version : {uint64_t{0}, uint64_t{1}, uint64_t{0xffffffffffffffffull}}) {
    for (const uint32_t index : {0u, 7u}) {
      for (const uint32_t count : {0u, 1u, 96u}) {
        if (count != 0 && index >= count) continue;  // the encoder refuses it (below)
        for (const std::size_t length : {0, 1, 100, 107, 108, 127, 128, 129, 1000, 1024}) {
          fragments.push_back({version, index, count, std::span<const uint8_t>(pool).first(length)});
        }
      }
    }
  }
  // and random ones
  for (int i = 0; i < 500; ++i) {
    const uint64_t version = random() % 3 == 0 ? 0 : random();
    const auto count = static_cast<uint32_t>(1 + random() % 96);
    const auto index = static_cast<uint32_t>(random() % count);
    fragments.push_back({version, index, count, std::span<const uint8_t>(pool).first(random() % (kModelChunkSize + 1))});
  }
  std::array<uint8_t, kMaxCommandSize> buffer;
  for (const bool full : {true, false}) {
    for (const ModelFragmentView& fragment : fragments) {
      SCOPED_TRACE(::testing::Message() << "full " << full << ", version " << fragment.version << ", index "
                                        << fragment.index << ", count " << fragment.count << ", "
                                        << fragment.data.size() << " bytes");
      DeviceCommandSample command = full ? MakeCommand() : DeviceCommandSample{};
      command.model = fragment;
      v1::DeviceCommand message = full ? MakeCommandMessage() : v1::DeviceCommand{};
      // count 0 means "no fragment": the field is left out
      if (fragment.count != 0) {
        v1::ModelFragment* model = message.mutable_model();
        model->set_version(fragment.version);
        model->set_index(fragment.index);
        model->set_count(fragment.count);
        model->set_data(AsString(fragment.data));
      }
      const std::size_t size = EncodeCommand(command, key, buffer);
      ASSERT_GT(size, 0u);
      const std::string body = AsString(std::span<const uint8_t>(buffer).first(size - kTagSize));
      ASSERT_EQ(body, message.SerializeAsString());
      EXPECT_TRUE(CheckTag({buffer.data(), size}, key));
    }
  }
}

// The largest command there is (every field set, a whole chunk of a model) fits under
// kMaxCommandSize with room to spare (a tunnel's headers), and needs its whole buffer.
TEST(DatagramCodec, TheLargestCommandFitsUnderItsLimit) {
  const SessionKey key = TestKey(8);
  const std::vector<uint8_t> data(kModelChunkSize, 0x5a);
  DeviceCommandSample command = MakeCommand();
  command.flags = 0xffffffffu;
  command.model = {0xffffffffffffffffull, kMaxModelFragments - 1, kMaxModelFragments, data};
  std::array<uint8_t, kMaxCommandSize + 8> buffer;
  const std::size_t size = EncodeCommand(command, key, buffer);
  EXPECT_GT(size, kModelChunkSize);
  EXPECT_LE(size, kMaxCommandSize);
  EXPECT_EQ(EncodeCommand(command, key, std::span<uint8_t>(buffer).first(size - 1)), 0u);
  DeviceCommandSample parsed;
  ASSERT_EQ(ParseCommand(std::span<const uint8_t>(buffer).first(size), parsed), DatagramError::kNone);
  EXPECT_EQ(parsed.model.data.size(), kModelChunkSize);
}

// A message's bytes with an unknown field (number 99, 2-byte length) appended, so that
// its datagram is datagram_size long.
std::string Padded(const std::string& body, std::size_t datagram_size) {
  const std::size_t padding = datagram_size - kTagSize - body.size() - 4;
  std::string padded = body;
  padded += {'\x9a', '\x06', static_cast<char>((padding & 0x7f) | 0x80), static_cast<char>(padding >> 7)};
  padded.append(padding, 'x');
  return padded;
}

TEST(DatagramCodec, StatesAndCommandsHaveTheirOwnLimits) {
  const SessionKey key = TestKey(2);
  std::mt19937_64 random(47);
  const std::vector<uint8_t> data = RandomBytes(kModelChunkSize, random);
  v1::DeviceCommand message = MakeCommandMessage();
  message.mutable_model()->set_version(3);
  message.mutable_model()->set_index(0);
  message.mutable_model()->set_count(1);
  message.mutable_model()->set_data(AsString(data));

  // a command of exactly 1400 bytes parses; one byte more is oversized
  DeviceCommandSample command;
  const std::vector<uint8_t> longest = Seal(Padded(message.SerializeAsString(), kMaxCommandSize), key);
  ASSERT_EQ(longest.size(), kMaxCommandSize);
  ASSERT_EQ(ParseCommand(longest, command), DatagramError::kNone);
  ExpectSameCommandFields(command, MakeCommand());
  EXPECT_EQ(command.model.version, 3u);
  EXPECT_EQ(command.model.count, 1u);
  EXPECT_TRUE(std::ranges::equal(command.model.data, data));
  const std::vector<uint8_t> too_long = Seal(Padded(message.SerializeAsString(), kMaxCommandSize + 1), key);
  EXPECT_EQ(ParseCommand(too_long, command), DatagramError::kOversized);

  // a state of 512 bytes parses; 513 is oversized, though a command could be that long
  v1::DeviceState state;
  state.set_session_id(4);
  DeviceStateSample state_back;
  EXPECT_EQ(ParseState(Seal(Padded(state.SerializeAsString(), kMaxStateSize), key), state_back),
            DatagramError::kNone);
  EXPECT_EQ(state_back.session_id, 4u);
  const std::vector<uint8_t> long_state = Seal(Padded(state.SerializeAsString(), kMaxStateSize + 1), key);
  EXPECT_EQ(ParseState(long_state, state_back), DatagramError::kOversized);
  EXPECT_EQ(ParseCommand(long_state, command), DatagramError::kNone);
}

// A command with the fragment's bytes as given, after MakeCommand's other fields.
std::vector<uint8_t> CommandWithFragmentBytes(const std::string& fragment_field) {
  return Seal(MakeCommandMessage().SerializeAsString() + fragment_field, TestKey(1));
}

// DeviceCommand.model's key and length, then body.
std::string FragmentField(const std::string& body) {
  return std::string{'\x62', static_cast<char>(body.size())} + body;
}

TEST(DatagramCodec, MalformedFragmentsAreRefused) {
  DeviceCommandSample command;
  // Within the bounds, and each bound broken by one. Built by protobuf, which takes
  // whatever values it is given.
  const auto parse = [&](uint64_t version, uint32_t index, uint32_t count, std::size_t length) {
    v1::DeviceCommand message = MakeCommandMessage();
    message.mutable_model()->set_version(version);
    message.mutable_model()->set_index(index);
    message.mutable_model()->set_count(count);
    message.mutable_model()->set_data(std::string(length, 'd'));
    return ParseCommand(Seal(message.SerializeAsString(), TestKey(1)), command);
  };
  EXPECT_EQ(parse(1, 95, kMaxModelFragments, kModelChunkSize), DatagramError::kNone);
  EXPECT_EQ(command.model.index, 95u);
  EXPECT_EQ(parse(1, 0, kMaxModelFragments + 1, 10), DatagramError::kMalformed);
  EXPECT_EQ(parse(1, 2, 2, 10), DatagramError::kMalformed);
  EXPECT_EQ(parse(1, 7, 3, 10), DatagramError::kMalformed);
  EXPECT_EQ(parse(1, 0, 1, kModelChunkSize + 1), DatagramError::kMalformed);
  // a fragment present with no count (an empty one included)
  EXPECT_EQ(parse(1, 0, 0, 10), DatagramError::kMalformed);
  EXPECT_EQ(ParseCommand(CommandWithFragmentBytes(FragmentField("")), command), DatagramError::kMalformed);

  // Built by hand: the fragment's own fields, a count of 1 (1d 01000000) and 3 bytes of
  // data (22 03 ...) around what is tested.
  const std::string count = {'\x1d', 1, 0, 0, 0};
  const std::string data = {'\x22', 3, 'a', 'b', 'c'};
  // the parsed fragment's data points into its datagram: kept alive while it is read
  const std::vector<uint8_t> plain = CommandWithFragmentBytes(FragmentField(count + data));
  EXPECT_EQ(ParseCommand(plain, command), DatagramError::kNone);
  EXPECT_EQ(AsString(command.model.data), "abc");
  // a field the fragment does not know is skipped
  const std::vector<uint8_t> unknown = CommandWithFragmentBytes(FragmentField(count + std::string{'\x28', 5} + data));
  EXPECT_EQ(ParseCommand(unknown, command), DatagramError::kNone);
  EXPECT_EQ(AsString(command.model.data), "abc");
  // the fragment's field claims more bytes than the message has
  std::string cut = FragmentField(count + data);
  cut[1] = static_cast<char>(cut.size());
  EXPECT_EQ(ParseCommand(CommandWithFragmentBytes(cut), command), DatagramError::kMalformed);
  // the data claims more than the fragment has
  EXPECT_EQ(ParseCommand(CommandWithFragmentBytes(FragmentField(count + std::string{'\x22', 4, 'a', 'b', 'c'})),
                               command),
            DatagramError::kMalformed);
  // a fixed64 version cut short at the fragment's end
  EXPECT_EQ(ParseCommand(CommandWithFragmentBytes(FragmentField(count + data + std::string{'\x09', 1, 2, 3})),
                               command),
            DatagramError::kMalformed);
  // a varint that never ends
  EXPECT_EQ(ParseCommand(CommandWithFragmentBytes(FragmentField(count + data + std::string{'\x28', '\xff'})),
                               command),
            DatagramError::kMalformed);
  // a wire type protobuf does not have (6)
  EXPECT_EQ(ParseCommand(CommandWithFragmentBytes(FragmentField(count + data + std::string{'\x2e', 0})),
                               command),
            DatagramError::kMalformed);
  // two fragments in one command
  EXPECT_EQ(ParseCommand(CommandWithFragmentBytes(FragmentField(count + data) + FragmentField(count + data)),
                               command),
            DatagramError::kMalformed);
}

// What the parser refuses the encoder does not write.
TEST(DatagramCodec, EncodeRefusesAFragmentTheParserWould) {
  std::array<uint8_t, kMaxCommandSize> out;
  const std::vector<uint8_t> data(kModelChunkSize + 1, 7);
  const auto encode = [&](uint32_t index, uint32_t count, std::size_t length) {
    DeviceCommandSample command;
    command.model = {1, index, count, std::span<const uint8_t>(data.data(), length)};
    return EncodeCommand(command, TestKey(1), out);
  };
  EXPECT_GT(encode(0, 1, kModelChunkSize), 0u);
  EXPECT_EQ(encode(0, 1, kModelChunkSize + 1), 0u);
  EXPECT_EQ(encode(1, 1, 10), 0u);
  EXPECT_EQ(encode(0, kMaxModelFragments + 1, 10), 0u);
}

// Protobuf may put fields in any order: a fragment ahead of the others is taken out of
// the middle, and the rest parses.
TEST(DatagramCodec, AFragmentMayComeFirst) {
  v1::DeviceCommand fragment_only;
  fragment_only.mutable_model()->set_version(2);
  fragment_only.mutable_model()->set_index(1);
  fragment_only.mutable_model()->set_count(2);
  fragment_only.mutable_model()->set_data("xyz");
  DeviceCommandSample command;
  const std::vector<uint8_t> datagram =
      Seal(fragment_only.SerializeAsString() + MakeCommandMessage().SerializeAsString(), TestKey(1));
  ASSERT_EQ(ParseCommand(datagram, command), DatagramError::kNone);
  ExpectSameCommandFields(command, MakeCommand());
  EXPECT_EQ(command.model.version, 2u);
  EXPECT_EQ(command.model.index, 1u);
  EXPECT_EQ(command.model.count, 2u);
  EXPECT_EQ(AsString(command.model.data), "xyz");
}

TEST(DatagramCodec, TagDependsOnKeyAndEveryByte) {
  const SessionKey key = TestKey(1);
  std::array<uint8_t, kMaxDatagramSize> buffer;
  const std::size_t size = EncodeState(MakeState(), key, buffer);
  EXPECT_FALSE(CheckTag({buffer.data(), size}, TestKey(2)));
  for (std::size_t i = 0; i < size; ++i) {
    buffer[i] ^= 0x01;
    EXPECT_FALSE(CheckTag({buffer.data(), size}, key)) << "flipped byte " << i;
    buffer[i] ^= 0x01;
  }
  EXPECT_TRUE(CheckTag({buffer.data(), size}, key));
  EXPECT_FALSE(CheckTag({buffer.data(), kTagSize - 1}, key));
}

// The tag from a prepared key is libsodium's keyed BLAKE2b (the independent oracle, which
// the device side and the Python client use), for every length a datagram's body can
// have, across block boundaries and for the empty message, under random keys.
TEST(DatagramCodec, TagIsLibsodiumKeyedBlake2b) {
  ASSERT_GE(sodium_init(), 0);
  std::mt19937_64 random(12);
  std::vector<uint8_t> message(kMaxDatagramSize);
  for (int trial = 0; trial < 4000; ++trial) {
    SessionKey key;
    for (auto& byte : key) byte = static_cast<uint8_t>(random());
    for (auto& byte : message) byte = static_cast<uint8_t>(random());
    const std::size_t size = trial < 520 ? trial % (kMaxDatagramSize + 1) : random() % (kMaxDatagramSize + 1);
    uint8_t expected[kTagSize];
    crypto_generichash(expected, kTagSize, message.data(), size, key.data(), key.size());
    uint8_t tag[kTagSize];
    ComputeTag({message.data(), size}, TagKey(key), tag);
    ASSERT_TRUE(std::equal(tag, tag + kTagSize, expected)) << "length " << size << ", trial " << trial;
  }
}

// A prepared key and a plain one are the same key to every call.
TEST(DatagramCodec, TagKeyAndSessionKeyAgree) {
  const SessionKey key = TestKey(4);
  const TagKey tag_key(key);
  EXPECT_EQ(tag_key.key(), key);
  std::array<uint8_t, kMaxDatagramSize> a;
  std::array<uint8_t, kMaxDatagramSize> b;
  const std::size_t size = EncodeState(MakeState(), key, a);
  ASSERT_EQ(EncodeState(MakeState(), tag_key, b), size);
  EXPECT_TRUE(std::equal(a.begin(), a.begin() + size, b.begin()));
  EXPECT_TRUE(CheckTag({a.data(), size}, tag_key));
  EXPECT_FALSE(CheckTag({a.data(), size}, TagKey(TestKey(5))));
  // the default is the all-zero key
  EXPECT_EQ(TagKey().state(), TagKey(SessionKey{}).state());
}

TEST(DatagramCodec, RefusesOversizedShortAndGarbage) {
  DeviceStateSample state;
  DeviceCommandSample command;
  std::vector<uint8_t> big(kMaxCommandSize + 1, 0);
  EXPECT_EQ(ParseState(big, state), DatagramError::kOversized);
  EXPECT_EQ(ParseCommand(big, command), DatagramError::kOversized);
  EXPECT_EQ(ParseState(std::span<const uint8_t>(big.data(), 3), state), DatagramError::kMalformed);
  EXPECT_EQ(ParseCommand(std::span<const uint8_t>(big.data(), 3), command), DatagramError::kMalformed);
  // A length-delimited field claiming more bytes than there are.
  std::vector<uint8_t> truncated = {0x22, 0x7f, 0x09};
  truncated.resize(truncated.size() + kTagSize, 0);
  EXPECT_EQ(ParseState(truncated, state), DatagramError::kMalformed);
  EXPECT_EQ(ParseCommand(truncated, command), DatagramError::kMalformed);
  // Random bytes never crash, up to each kind's limit; whatever parses still fails the tag.
  std::mt19937_64 random(3);
  const SessionKey key = TestKey(1);
  for (int i = 0; i < 20000; ++i) {
    const bool is_state = i % 2 == 0;
    std::vector<uint8_t> noise(
        std::uniform_int_distribution<std::size_t>(0, is_state ? kMaxStateSize : kMaxCommandSize)(random));
    for (auto& byte : noise) byte = static_cast<uint8_t>(random());
    const DatagramError error = is_state ? ParseState(noise, state) : ParseCommand(noise, command);
    EXPECT_TRUE(error == DatagramError::kNone || error == DatagramError::kMalformed);
    EXPECT_FALSE(CheckTag(noise, key));
  }
}

TEST(DatagramCodec, EncodeRefusesABufferTooSmall) {
  std::array<uint8_t, 20> small;
  EXPECT_EQ(EncodeState(MakeState(), TestKey(1), small), 0u);
}

TEST(DatagramCodec, EncodingAndDecodingAllocateNothing) {
  const SessionKey key = TestKey(1);
  std::array<uint8_t, kMaxDatagramSize> buffer;
  DeviceStateSample state;
  DeviceCommandSample command;
  command.f_W = {1, 2, 3};
  // and a command carrying a full fragment, parsed into another sample
  const std::vector<uint8_t> data(kModelChunkSize, 0x3c);
  DeviceCommandSample with_fragment = MakeCommand();
  with_fragment.model = {7, 3, 10, data};
  DeviceCommandSample parsed;
  const long before = hapticd::testing::AllocationCount();
  const TagKey tag_key(key);
  for (int i = 0; i < 1000; ++i) {
    const std::size_t size = EncodeState(MakeState(), key, buffer);
    ASSERT_EQ(ParseState({buffer.data(), size}, state), DatagramError::kNone);
    ASSERT_TRUE(CheckTag({buffer.data(), size}, key));
    ASSERT_TRUE(CheckTag({buffer.data(), size}, tag_key));
    const std::size_t command_size = EncodeCommand(command, tag_key, buffer);
    ASSERT_EQ(ParseCommand({buffer.data(), command_size}, command), DatagramError::kNone);
    const std::size_t fragment_size = EncodeCommand(with_fragment, tag_key, buffer);
    ASSERT_EQ(ParseCommand({buffer.data(), fragment_size}, parsed), DatagramError::kNone);
    ASSERT_EQ(parsed.model.data.size(), kModelChunkSize);
  }
  EXPECT_EQ(hapticd::testing::AllocationCount() - before, 0);
}

TEST(DatagramCodec, SessionKeysAreRandom) {
  EXPECT_NE(MakeSessionKey(), MakeSessionKey());
}

}  // namespace
}  // namespace hapticd::net
