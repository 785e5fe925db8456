#pragma once
// Helpers shared by the datagram codec's tests.

#include <cstdint>
#include <span>
#include <string>

#include "server/net/datagram_codec.h"

namespace hapticd::net {

// A session key whose bytes count up from seed: distinct seeds, distinct keys.
inline SessionKey TestKey(uint8_t seed) {
  SessionKey key;
  for (std::size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(seed + i);
  return key;
}

// Bytes as a string, to compare with protobuf's serialization.
inline std::string AsString(std::span<const uint8_t> bytes) { return {bytes.begin(), bytes.end()}; }

}  // namespace hapticd::net
