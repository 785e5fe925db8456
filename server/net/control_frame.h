#pragma once
// The control channel's framing: a 4-byte big-endian length, then that many bytes of
// one protobuf message. Bounded: a frame longer than the limit is refused before any
// of it is read.
#include <array>
#include <cstdint>
#include <string>
#include <google/protobuf/message_lite.h>

namespace hapticd::net {

inline constexpr std::size_t kFrameHeaderSize = 4;
inline constexpr uint32_t kMaxFrameSize = 64u << 20;  // bytes of message

// The message length a frame header announces.
inline uint32_t ReadFrameLength(const std::array<uint8_t, kFrameHeaderSize>& header) {
  return uint32_t{header[0]} << 24 | uint32_t{header[1]} << 16 | uint32_t{header[2]} << 8 | header[3];
}

// Header and message, ready to write.
inline std::string EncodeFrame(const google::protobuf::MessageLite& message) {
  const std::size_t size = message.ByteSizeLong();
  std::string frame(kFrameHeaderSize + size, '\0');
  for (int i = 0; i < 4; ++i) frame[i] = static_cast<char>(size >> (24 - 8 * i));
  message.SerializeToArray(frame.data() + kFrameHeaderSize, static_cast<int>(size));
  return frame;
}

}  // namespace hapticd::net
