#include "server/net/datagram_codec.h"

#include <sodium.h>

#include <google/protobuf/arena.h>

#include "hapticd/v1/hapticd.pb.h"

namespace hapticd::net {
namespace {

namespace pb = ::hapticd::v1;

// Enough for one message of either kind and its sub-messages many times over.
constexpr std::size_t kArenaBlockSize = 16 * 1024;

// Zero vectors and the identity are left out: absent reads back as exactly them, and
// the datagram stays short.
template <typename Message>
void SetVector(Message* message, pb::Vec3* (Message::*mutable_field)(), const Vector3& v) {
  if (v.isZero(0)) return;
  pb::Vec3* out = (message->*mutable_field)();
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

template <typename Message>
void SetQuaternion(Message* message, pb::Quat* (Message::*mutable_field)(), const Quaternion& q) {
  if (q.w() == 1 && q.vec().isZero(0)) return;
  pb::Quat* out = (message->*mutable_field)();
  out->set_w(q.w());
  out->set_x(q.x());
  out->set_y(q.y());
  out->set_z(q.z());
}

// An absent vector reads as zero, an absent quaternion as the identity.
Vector3 FromProto(const pb::Vec3& v) { return {v.x(), v.y(), v.z()}; }
Quaternion FromProto(const pb::Quat& q, bool present) {
  return present ? Quaternion(q.w(), q.x(), q.y(), q.z()) : Quaternion::Identity();
}

void ComputeTag(std::span<const uint8_t> message, const SessionKey& key, uint8_t* tag) {
  crypto_generichash(tag, kTagSize, message.data(), message.size(), key.data(), key.size());
}

// Serializes message and appends its tag; 0 when it does not fit.
std::size_t SealInto(const google::protobuf::MessageLite& message, const SessionKey& key,
                     std::span<uint8_t> out) {
  const std::size_t limit = std::min(out.size(), kMaxDatagramSize);
  const std::size_t size = message.ByteSizeLong();
  if (size + kTagSize > limit) return 0;
  if (!message.SerializeToArray(out.data(), static_cast<int>(size))) return 0;
  ComputeTag(out.first(size), key, out.data() + size);
  return size + kTagSize;
}

}  // namespace

std::string_view DatagramErrorName(DatagramError error) {
  switch (error) {
    case DatagramError::kNone: return "none";
    case DatagramError::kOversized: return "oversized";
    case DatagramError::kMalformed: return "malformed";
    case DatagramError::kBadTag: return "bad_tag";
    case DatagramError::kCount: break;
  }
  return "unknown";
}

struct DatagramCodec::Impl {
  Impl() : arena(Options(block.data())) {}

  static google::protobuf::ArenaOptions Options(char* initial_block) {
    google::protobuf::ArenaOptions options;
    options.initial_block = initial_block;
    options.initial_block_size = kArenaBlockSize;
    return options;
  }

  // Messages live on the arena, which is reset (not freed) after each use.
  alignas(64) std::array<char, kArenaBlockSize> block;
  google::protobuf::Arena arena;
};

DatagramCodec::DatagramCodec() : impl_(std::make_unique<Impl>()) {
  // libsodium picks its BLAKE2b implementation once; thread-safe and idempotent.
  if (sodium_init() < 0) std::abort();
}

DatagramCodec::~DatagramCodec() = default;

std::size_t DatagramCodec::EncodeState(const DeviceStateSample& state, const SessionKey& key,
                                       std::span<uint8_t> out) {
  auto* message = google::protobuf::Arena::CreateMessage<pb::DeviceState>(&impl_->arena);
  message->set_session_id(state.session_id);
  message->set_sequence(state.sequence);
  message->set_send_time_ns(state.send_time_ns);
  SetVector(message, &pb::DeviceState::mutable_position, state.p_WD);
  SetQuaternion(message, &pb::DeviceState::mutable_orientation, state.q_WD);
  SetVector(message, &pb::DeviceState::mutable_velocity, state.v_WD);
  SetVector(message, &pb::DeviceState::mutable_angular_velocity, state.w_WD);
  message->set_buttons(state.buttons);
  SetVector(message, &pb::DeviceState::mutable_sensed_force, state.f_sensed_W);
  SetVector(message, &pb::DeviceState::mutable_held_force, state.f_held_W);
  message->set_rtt_us(state.rtt_us);
  const std::size_t size = SealInto(*message, key, out);
  impl_->arena.Reset();
  return size;
}

std::size_t DatagramCodec::EncodeCommand(const DeviceCommandSample& command, const SessionKey& key,
                                         std::span<uint8_t> out) {
  auto* message = google::protobuf::Arena::CreateMessage<pb::DeviceCommand>(&impl_->arena);
  message->set_session_id(command.session_id);
  message->set_sequence(command.sequence);
  message->set_echo_send_time_ns(command.echo_send_time_ns);
  message->set_scene_version(command.scene_version);
  SetVector(message, &pb::DeviceCommand::mutable_force, command.f_W);
  SetVector(message, &pb::DeviceCommand::mutable_torque, command.tau_W);
  SetVector(message, &pb::DeviceCommand::mutable_position, command.p_command_W);
  SetQuaternion(message, &pb::DeviceCommand::mutable_orientation, command.q_command_W);
  SetVector(message, &pb::DeviceCommand::mutable_avatar, command.avatar_W);
  message->set_contact(command.contact);
  message->set_flags(command.flags);
  const std::size_t size = SealInto(*message, key, out);
  impl_->arena.Reset();
  return size;
}

DatagramError DatagramCodec::ParseState(std::span<const uint8_t> datagram, DeviceStateSample& out) {
  if (datagram.size() > kMaxDatagramSize) return DatagramError::kOversized;
  if (datagram.size() < kTagSize) return DatagramError::kMalformed;
  auto* message = google::protobuf::Arena::CreateMessage<pb::DeviceState>(&impl_->arena);
  const auto body = datagram.first(datagram.size() - kTagSize);
  DatagramError result = DatagramError::kMalformed;
  if (message->ParseFromArray(body.data(), static_cast<int>(body.size()))) {
    out.session_id = message->session_id();
    out.sequence = message->sequence();
    out.send_time_ns = message->send_time_ns();
    out.p_WD = FromProto(message->position());
    out.q_WD = FromProto(message->orientation(), message->has_orientation());
    out.v_WD = FromProto(message->velocity());
    out.w_WD = FromProto(message->angular_velocity());
    out.buttons = message->buttons();
    out.f_sensed_W = FromProto(message->sensed_force());
    out.f_held_W = FromProto(message->held_force());
    out.rtt_us = message->rtt_us();
    result = DatagramError::kNone;
  }
  impl_->arena.Reset();
  return result;
}

DatagramError DatagramCodec::ParseCommand(std::span<const uint8_t> datagram, DeviceCommandSample& out) {
  if (datagram.size() > kMaxDatagramSize) return DatagramError::kOversized;
  if (datagram.size() < kTagSize) return DatagramError::kMalformed;
  auto* message = google::protobuf::Arena::CreateMessage<pb::DeviceCommand>(&impl_->arena);
  const auto body = datagram.first(datagram.size() - kTagSize);
  DatagramError result = DatagramError::kMalformed;
  if (message->ParseFromArray(body.data(), static_cast<int>(body.size()))) {
    out.session_id = message->session_id();
    out.sequence = message->sequence();
    out.echo_send_time_ns = message->echo_send_time_ns();
    out.scene_version = message->scene_version();
    out.f_W = FromProto(message->force());
    out.tau_W = FromProto(message->torque());
    out.p_command_W = FromProto(message->position());
    out.q_command_W = FromProto(message->orientation(), message->has_orientation());
    out.avatar_W = FromProto(message->avatar());
    out.contact = message->contact();
    out.flags = message->flags();
    result = DatagramError::kNone;
  }
  impl_->arena.Reset();
  return result;
}

bool CheckTag(std::span<const uint8_t> datagram, const SessionKey& key) {
  if (datagram.size() < kTagSize) return false;
  const auto body = datagram.first(datagram.size() - kTagSize);
  uint8_t expected[kTagSize];
  ComputeTag(body, key, expected);
  return sodium_memcmp(expected, datagram.data() + body.size(), kTagSize) == 0;
}

SessionKey MakeSessionKey() {
  if (sodium_init() < 0) std::abort();
  SessionKey key;
  randombytes_buf(key.data(), key.size());
  return key;
}

}  // namespace hapticd::net
