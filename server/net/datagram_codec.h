#pragma once
// The realtime channel's datagrams (proto/hapticd/v1/hapticd.proto): a DeviceState or
// DeviceCommand in protobuf's wire format, followed by a 16-byte keyed BLAKE2b tag under the
// session's key (RFC 7693; the same bytes as libsodium's crypto_generichash).
//
// Both messages are written and read here by hand, in protobuf's wire format: written
// byte for byte as protobuf's serializer writes them, read as its generated parser reads
// them (its arena, generic serializer and parser cost as much as the rest of a datagram,
// tag included; a bytes field parsed by protobuf would allocate). A command may carry
// one fragment of a local model (DeviceCommand.model, written as its last field).
//
// Encoding and decoding hold no state, allocate nothing and are real-time safe.
// Decoding never throws; a datagram that is too long, does not parse or carries a
// bad tag yields an error code for the caller to count.
//
// Tagging. Keyed BLAKE2b hashes the key, zero-padded to a 128-byte block, as the first
// block of the message; a TagKey keeps the hash state after that block, so a tag costs
// one compression per 128 bytes of datagram (two for a typical state without it). Make a
// TagKey once per session and tag with it; the SessionKey overloads make one per call.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hapticd::net {

using Vector3 = Eigen::Vector3d;
using Quaternion = Eigen::Quaterniond;

// Bytes, tag included: a state at most 512 (what a device sends the server), a command at
// most 1400 (it may carry a model fragment; under Ethernet's 1472-byte UDP payload with
// room for a tunnel's headers). kMaxDatagramSize is the larger: a buffer for either.
inline constexpr std::size_t kMaxStateSize = 512;
inline constexpr std::size_t kMaxCommandSize = 1400;
inline constexpr std::size_t kMaxDatagramSize = kMaxCommandSize;
// A local model travels in fragments of kModelChunkSize bytes (the last one shorter),
// at most kMaxModelFragments of them.
inline constexpr std::size_t kModelChunkSize = 1024;
inline constexpr std::size_t kMaxModelFragments = 96;
inline constexpr std::size_t kMaxModelBytes = kModelChunkSize * kMaxModelFragments;
inline constexpr std::size_t kTagSize = 16;
inline constexpr std::size_t kSessionKeySize = 32;
using SessionKey = std::array<uint8_t, kSessionKeySize>;

// A device's state, as sent at its rate (hapticd.v1.DeviceState). World frame W, SI.
struct DeviceStateSample {
  uint32_t session_id = 0;
  uint64_t sequence = 0;
  uint64_t send_time_ns = 0;  // device clock
  Vector3 p_WD = Vector3::Zero();
  Quaternion q_WD = Quaternion::Identity();
  Vector3 v_WD = Vector3::Zero();
  Vector3 w_WD = Vector3::Zero();
  uint32_t buttons = 0;
  Vector3 f_sensed_W = Vector3::Zero();  // admittance: the person's force, N
  Vector3 f_held_W = Vector3::Zero();    // impedance: the force held since the last state
  uint32_t rtt_us = 0;
  uint64_t model_version = 0;            // local model: the newest the device holds
  Vector3 avatar_W = Vector3::Zero();    // local model: the device's own proxy
  double energy_in = 0;                  // the device end's channel energies, J
  double energy_out = 0;
  uint64_t states_held = 0;              // deadband: states held back so far
  bool keepalive = false;                // deadband: sent for the keep-alive alone
};

// One fragment of a local model's encoding (hapticd.v1.ModelFragment); count 0: none.
// data points into the buffer it was encoded from or parsed out of.
struct ModelFragmentView {
  uint64_t version = 0;
  uint32_t index = 0;
  uint32_t count = 0;
  std::span<const uint8_t> data;
};

// The server's answer (hapticd.v1.DeviceCommand).
struct DeviceCommandSample {
  uint32_t session_id = 0;
  uint64_t sequence = 0;  // the state answered; 0 for a watchdog command
  uint64_t echo_send_time_ns = 0;
  uint64_t scene_version = 0;
  Vector3 f_W = Vector3::Zero();    // impedance: force to render, N
  Vector3 tau_W = Vector3::Zero();  // impedance: torque, N·m
  Vector3 p_command_W = Vector3::Zero();  // admittance: where to go
  Quaternion q_command_W = Quaternion::Identity();
  Vector3 avatar_W = Vector3::Zero();
  bool contact = false;
  uint32_t flags = 0;  // hapticd.v1.CommandFlags
  ModelFragmentView model;  // count 0: the command carries none
  double energy_in = 0;     // the server end's channel energies, J
  double energy_out = 0;
  uint64_t commands_held = 0;   // deadband: commands held back so far
  uint64_t command_number = 0;  // the server's count of the session's commands (0: none)
};

// A session key ready to tag with: BLAKE2b's chaining value after the key block (one
// compression, done here). Cheap to copy (96 bytes); the default is the all-zero key's.
class TagKey {
 public:
  TagKey() : TagKey(SessionKey{}) {}
  explicit TagKey(const SessionKey& key);

  const SessionKey& key() const { return key_; }
  // The 8 words of hash state after the key block.
  const std::array<uint64_t, 8>& state() const { return h_; }

 private:
  SessionKey key_;
  std::array<uint64_t, 8> h_;
};

// Why a datagram was dropped.
enum class DatagramError {
  kNone,
  kOversized,  // longer than kMaxDatagramSize
  kMalformed,  // shorter than a tag, or the message does not parse
  kBadTag,     // the tag does not match the session key
  kCount
};

// "none", "oversized", "malformed", "bad_tag".
std::string_view DatagramErrorName(DatagramError error);

// Encode a message and its tag into out; returns the datagram's size, or 0 when it does
// not fit in out (or in kMaxStateSize, kMaxCommandSize), or when the command's model
// fragment is one ParseCommand would refuse. Real-time safe.
std::size_t EncodeState(const DeviceStateSample& state, const TagKey& key, std::span<uint8_t> out);
std::size_t EncodeCommand(const DeviceCommandSample& command, const TagKey& key, std::span<uint8_t> out);
// The same, preparing the key on each call (one compression more).
inline std::size_t EncodeState(const DeviceStateSample& state, const SessionKey& key, std::span<uint8_t> out) {
  return EncodeState(state, TagKey(key), out);
}
inline std::size_t EncodeCommand(const DeviceCommandSample& command, const SessionKey& key,
                                 std::span<uint8_t> out) {
  return EncodeCommand(command, TagKey(key), out);
}

// Parse a datagram's message without checking its tag (the session id in it says which
// key to check it with: CheckTag). kNone, kOversized or kMalformed; out is unspecified
// unless kNone. A command's model fragment points into datagram. A fragment of more than
// kMaxModelFragments, an index not below its count or more than kModelChunkSize bytes is
// malformed, and so is a second fragment. Real-time safe.
DatagramError ParseState(std::span<const uint8_t> datagram, DeviceStateSample& out);
DatagramError ParseCommand(std::span<const uint8_t> datagram, DeviceCommandSample& out);

// Whether a datagram's last kTagSize bytes are the tag of the rest under key; constant
// time in the tag. False for datagrams shorter than a tag. Real-time safe.
bool CheckTag(std::span<const uint8_t> datagram, const TagKey& key);
inline bool CheckTag(std::span<const uint8_t> datagram, const SessionKey& key) {
  return CheckTag(datagram, TagKey(key));
}

// The 16-byte keyed BLAKE2b tag of message (any length, empty included) under key: what
// crypto_generichash(tag, 16, message, size, key, 32) writes. Real-time safe.
void ComputeTag(std::span<const uint8_t> message, const TagKey& key, uint8_t* tag);

// A new random session key (libsodium's CSPRNG). Not real-time.
SessionKey MakeSessionKey();

}  // namespace hapticd::net
