#include "server/net/datagram_codec.h"

#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <sodium.h>

#include "server/net/test/count_allocations.h"

namespace hapticd::net {
namespace {

SessionKey TestKey(uint8_t seed) {
  SessionKey key;
  for (std::size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(seed + i);
  return key;
}

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
  return state;
}

TEST(DatagramCodec, StateRoundTripsExactly) {
  DatagramCodec codec;
  const SessionKey key = TestKey(1);
  const DeviceStateSample state = MakeState();
  std::array<uint8_t, kMaxDatagramSize> buffer;
  const std::size_t size = codec.EncodeState(state, key, buffer);
  ASSERT_GT(size, kTagSize);
  const std::span<const uint8_t> datagram(buffer.data(), size);
  EXPECT_TRUE(CheckTag(datagram, key));

  DeviceStateSample back;
  ASSERT_EQ(codec.ParseState(datagram, back), DatagramError::kNone);
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
}

TEST(DatagramCodec, CommandRoundTripsAndAbsentMeansZeroOrIdentity) {
  DatagramCodec codec;
  const SessionKey key = TestKey(9);
  DeviceCommandSample command;
  command.session_id = 7;
  command.sequence = 3;
  command.f_W = {0, 0, 2.5};
  command.contact = true;
  std::array<uint8_t, kMaxDatagramSize> buffer;
  const std::size_t size = codec.EncodeCommand(command, key, buffer);
  DeviceCommandSample back;
  back.tau_W = {9, 9, 9};  // must be overwritten with the absent field's zero
  ASSERT_EQ(codec.ParseCommand({buffer.data(), size}, back), DatagramError::kNone);
  EXPECT_EQ(back.f_W, command.f_W);
  EXPECT_EQ(back.tau_W, Vector3::Zero());
  EXPECT_TRUE(back.q_command_W.coeffs().isApprox(Quaternion::Identity().coeffs(), 0));
  EXPECT_TRUE(back.contact);
  // Zero vectors are not sent: session id, sequence, force and contact only.
  EXPECT_EQ(size, 5u + 9u + 2u + 9u + 2u + kTagSize);
}

TEST(DatagramCodec, TagDependsOnKeyAndEveryByte) {
  DatagramCodec codec;
  const SessionKey key = TestKey(1);
  std::array<uint8_t, kMaxDatagramSize> buffer;
  const std::size_t size = codec.EncodeState(MakeState(), key, buffer);
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
  DatagramCodec codec;
  const SessionKey key = TestKey(4);
  const TagKey tag_key(key);
  EXPECT_EQ(tag_key.key(), key);
  std::array<uint8_t, kMaxDatagramSize> a;
  std::array<uint8_t, kMaxDatagramSize> b;
  const std::size_t size = codec.EncodeState(MakeState(), key, a);
  ASSERT_EQ(codec.EncodeState(MakeState(), tag_key, b), size);
  EXPECT_TRUE(std::equal(a.begin(), a.begin() + size, b.begin()));
  EXPECT_TRUE(CheckTag({a.data(), size}, tag_key));
  EXPECT_FALSE(CheckTag({a.data(), size}, TagKey(TestKey(5))));
  // the default is the all-zero key
  EXPECT_EQ(TagKey().state(), TagKey(SessionKey{}).state());
}

TEST(DatagramCodec, RefusesOversizedShortAndGarbage) {
  DatagramCodec codec;
  DeviceStateSample state;
  std::vector<uint8_t> big(kMaxDatagramSize + 1, 0);
  EXPECT_EQ(codec.ParseState(big, state), DatagramError::kOversized);
  EXPECT_EQ(codec.ParseState(std::span<const uint8_t>(big.data(), 3), state), DatagramError::kMalformed);
  // A length-delimited field claiming more bytes than there are.
  std::vector<uint8_t> truncated = {0x22, 0x7f, 0x09};
  truncated.resize(truncated.size() + kTagSize, 0);
  EXPECT_EQ(codec.ParseState(truncated, state), DatagramError::kMalformed);
  // Random bytes never crash; whatever parses still fails the tag.
  std::mt19937_64 random(3);
  const SessionKey key = TestKey(1);
  for (int i = 0; i < 20000; ++i) {
    std::vector<uint8_t> noise(std::uniform_int_distribution<int>(0, kMaxDatagramSize)(random));
    for (auto& byte : noise) byte = static_cast<uint8_t>(random());
    const DatagramError error = codec.ParseState(noise, state);
    EXPECT_TRUE(error == DatagramError::kNone || error == DatagramError::kMalformed);
    EXPECT_FALSE(CheckTag(noise, key));
  }
}

TEST(DatagramCodec, EncodeRefusesABufferTooSmall) {
  DatagramCodec codec;
  std::array<uint8_t, 20> small;
  EXPECT_EQ(codec.EncodeState(MakeState(), TestKey(1), small), 0u);
}

TEST(DatagramCodec, AllocatesNothingAfterConstruction) {
  DatagramCodec codec;
  const SessionKey key = TestKey(1);
  std::array<uint8_t, kMaxDatagramSize> buffer;
  DeviceStateSample state;
  DeviceCommandSample command;
  command.f_W = {1, 2, 3};
  const long before = hapticd::testing::AllocationCount();
  const TagKey tag_key(key);
  for (int i = 0; i < 1000; ++i) {
    const std::size_t size = codec.EncodeState(MakeState(), key, buffer);
    ASSERT_EQ(codec.ParseState({buffer.data(), size}, state), DatagramError::kNone);
    ASSERT_TRUE(CheckTag({buffer.data(), size}, key));
    ASSERT_TRUE(CheckTag({buffer.data(), size}, tag_key));
    const std::size_t command_size = codec.EncodeCommand(command, tag_key, buffer);
    ASSERT_EQ(codec.ParseCommand({buffer.data(), command_size}, command), DatagramError::kNone);
  }
  EXPECT_EQ(hapticd::testing::AllocationCount() - before, 0);
}

TEST(DatagramCodec, SessionKeysAreRandom) {
  EXPECT_NE(MakeSessionKey(), MakeSessionKey());
}

}  // namespace
}  // namespace hapticd::net
