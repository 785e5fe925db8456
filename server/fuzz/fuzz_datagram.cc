// The realtime channel's datagram decoder and tag check (server/net/datagram_codec.h),
// on any bytes a device or an attacker could send.
//
// Checks, for each input parsed both as a DeviceState and as a DeviceCommand:
//   - the error is one of the decoder's (oversized exactly when over kMaxStateSize,
//     kMaxCommandSize);
//   - a decoded message re-encodes, and decoding that gives the same sample (NaN
//     included), and re-encoding again gives the same bytes: the codec's canonical form;
//   - CheckTag agrees with libsodium's keyed BLAKE2b computed here, accepts the tag of
//     the re-encoding and refuses it with any one bit of the tag flipped;
//   - the message parses exactly when protobuf's generated parser accepts it (a command
//     that protobuf reads with a model fragment aside: one fragment within bounds is the
//     codec's own rule).
// Seeds: the golden datagrams (key 00 01 .. 1f), which carry valid tags.

#include <sodium.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <span>
#include <type_traits>

#include "hapticd/v1/hapticd.pb.h"
#include "server/fuzz/fuzz_check.h"
#include "server/net/datagram_codec.h"

namespace hapticd::fuzz {
namespace {

using net::DatagramError;
using net::DeviceCommandSample;
using net::DeviceStateSample;
using net::kMaxCommandSize;
using net::kMaxDatagramSize;
using net::kMaxStateSize;
using net::kTagSize;
using net::SessionKey;

// The golden vectors' key (proto/golden/vectors.json).
SessionKey GoldenKey() {
  SessionKey key;
  for (std::size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(i);
  return key;
}

bool SameSample(const DeviceStateSample& a, const DeviceStateSample& b) {
  return a.session_id == b.session_id && a.sequence == b.sequence && a.send_time_ns == b.send_time_ns &&
         SameValues(a.p_WD, b.p_WD) && SameValues(a.q_WD.coeffs(), b.q_WD.coeffs()) &&
         SameValues(a.v_WD, b.v_WD) && SameValues(a.w_WD, b.w_WD) && a.buttons == b.buttons &&
         SameValues(a.f_sensed_W, b.f_sensed_W) && SameValues(a.f_held_W, b.f_held_W) && a.rtt_us == b.rtt_us &&
         a.model_version == b.model_version && SameValues(a.avatar_W, b.avatar_W);
}

bool SameSample(const DeviceCommandSample& a, const DeviceCommandSample& b) {
  return a.session_id == b.session_id && a.sequence == b.sequence &&
         a.echo_send_time_ns == b.echo_send_time_ns && a.scene_version == b.scene_version &&
         SameValues(a.f_W, b.f_W) && SameValues(a.tau_W, b.tau_W) && SameValues(a.p_command_W, b.p_command_W) &&
         SameValues(a.q_command_W.coeffs(), b.q_command_W.coeffs()) && SameValues(a.avatar_W, b.avatar_W) &&
         a.contact == b.contact && a.flags == b.flags && a.model.version == b.model.version &&
         a.model.index == b.model.index && a.model.count == b.model.count &&
         std::equal(a.model.data.begin(), a.model.data.end(), b.model.data.begin(), b.model.data.end());
}

// CheckTag's answer, computed independently.
bool ExpectedTagMatch(std::span<const uint8_t> datagram, const SessionKey& key) {
  if (datagram.size() < kTagSize) return false;
  const std::size_t body = datagram.size() - kTagSize;
  uint8_t tag[kTagSize];
  crypto_generichash(tag, kTagSize, datagram.data(), body, key.data(), key.size());
  return std::memcmp(tag, datagram.data() + body, kTagSize) == 0;
}

// A decoded datagram's sample survives encode -> decode, the re-encoding is a fixed
// point, and its tag checks (and fails with a flipped bit).
template <typename Sample, typename Encode, typename Parse>
void CheckRoundTrip(const Sample& decoded, const SessionKey& key, Encode encode, Parse parse) {
  std::array<uint8_t, kMaxDatagramSize> first{};
  const std::size_t size = encode(decoded, key, std::span<uint8_t>(first));
  FUZZ_CHECK(size >= kTagSize, "a decoded sample does not re-encode into %zu bytes", kMaxDatagramSize);
  const auto reencoded = std::span<const uint8_t>(first).first(size);
  Sample again;
  FUZZ_CHECK(parse(reencoded, again) == DatagramError::kNone, "a re-encoded datagram does not decode");
  FUZZ_CHECK(SameSample(decoded, again), "decode(encode(sample)) differs from the sample");
  std::array<uint8_t, kMaxDatagramSize> second{};
  const std::size_t size_again = encode(again, key, std::span<uint8_t>(second));
  FUZZ_CHECK(size_again == size && std::equal(first.begin(), first.begin() + size, second.begin()),
             "re-encoding is not a fixed point (%zu then %zu bytes)", size, size_again);
  FUZZ_CHECK(net::CheckTag(reencoded, key), "the tag of a re-encoding does not check");
  for (std::size_t bit = 0; bit < 8 * kTagSize; bit += 13) {
    first[size - kTagSize + bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    FUZZ_CHECK(!net::CheckTag(reencoded, key), "a tag with bit %zu flipped still checks", bit);
    first[size - kTagSize + bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
  }
}

// The codec's verdict on a datagram within its limit against protobuf's on its message.
template <typename Message>
void CheckAgreesWithProtobuf(std::span<const uint8_t> datagram, DatagramError error, std::size_t limit) {
  if (datagram.size() < kTagSize || datagram.size() > limit) return;
  Message message;
  const bool parses = message.ParseFromArray(datagram.data(), static_cast<int>(datagram.size() - kTagSize));
  if constexpr (std::is_same_v<Message, hapticd::v1::DeviceCommand>) {
    if (parses && message.has_model()) return;
  }
  FUZZ_CHECK(parses == (error == DatagramError::kNone), "protobuf %s a message the codec %s",
             parses ? "accepts" : "refuses", error == DatagramError::kNone ? "accepts" : "refuses");
}

void CheckError(DatagramError error, std::size_t size, std::size_t limit) {
  FUZZ_CHECK(error == DatagramError::kNone || error == DatagramError::kOversized ||
                 error == DatagramError::kMalformed,
             "the parser answered %d", static_cast<int>(error));
  FUZZ_CHECK((error == DatagramError::kOversized) == (size > limit),
             "a datagram of %zu bytes was answered %.*s", size,
             static_cast<int>(net::DatagramErrorName(error).size()), net::DatagramErrorName(error).data());
  if (size < kTagSize) FUZZ_CHECK(error == DatagramError::kMalformed, "a datagram shorter than a tag parsed");
}

}  // namespace
}  // namespace hapticd::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace hapticd::fuzz;
  using namespace hapticd::net;
  static const bool sodium_ready = sodium_init() >= 0;  // before ExpectedTagMatch's libsodium
  FUZZ_CHECK(sodium_ready, "libsodium did not start");
  static const SessionKey golden_key = GoldenKey();
  const std::span<const uint8_t> datagram(data, size);

  // The tag check, against the golden key and against the key of all zeros.
  for (const SessionKey& key : {golden_key, SessionKey{}}) {
    FUZZ_CHECK(CheckTag(datagram, key) == ExpectedTagMatch(datagram, key), "CheckTag disagrees with BLAKE2b");
  }

  const auto encode_state = [](const DeviceStateSample& s, const SessionKey& k, std::span<uint8_t> out) {
    return EncodeState(s, k, out);
  };
  const auto parse_state = [](std::span<const uint8_t> d, DeviceStateSample& s) { return ParseState(d, s); };
  DeviceStateSample state;
  const DatagramError state_error = ParseState(datagram, state);
  CheckError(state_error, size, kMaxStateSize);
  CheckAgreesWithProtobuf<hapticd::v1::DeviceState>(datagram, state_error, kMaxStateSize);
  if (state_error == DatagramError::kNone) CheckRoundTrip(state, golden_key, encode_state, parse_state);

  const auto encode_command = [](const DeviceCommandSample& c, const SessionKey& k, std::span<uint8_t> out) {
    return EncodeCommand(c, k, out);
  };
  const auto parse_command = [](std::span<const uint8_t> d, DeviceCommandSample& c) {
    return ParseCommand(d, c);
  };
  DeviceCommandSample command;
  const DatagramError command_error = ParseCommand(datagram, command);
  CheckError(command_error, size, kMaxCommandSize);
  CheckAgreesWithProtobuf<hapticd::v1::DeviceCommand>(datagram, command_error, kMaxCommandSize);
  if (command_error == DatagramError::kNone) CheckRoundTrip(command, golden_key, encode_command, parse_command);
  return 0;
}
