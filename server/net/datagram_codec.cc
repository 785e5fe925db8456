#include "server/net/datagram_codec.h"

#include <sodium.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <utility>

namespace hapticd::net {
namespace {

// ---- BLAKE2b (RFC 7693), 16-byte digest, 32-byte key ----
//
// The hash state h starts as the IV xored with the parameter block (digest length, key
// length, fanout 1, depth 1); each 128-byte block is mixed into it by Compress, with t the
// bytes hashed so far (the padding excluded) and the last block flagged. A keyed hash
// hashes the key, zero-padded to a block, before the message: that first compression
// depends on the key alone, and TagKey keeps its result.
constexpr std::size_t kBlockSize = 128;
constexpr std::array<uint64_t, 8> kIv = {
    0x6a09e667f3bcc908, 0xbb67ae8584caa73b, 0x3c6ef372fe94f82b, 0xa54ff53a5f1d36f1,
    0x510e527fade682d1, 0x9b05688c2b3e6c1f, 0x1f83d9abfb41bd6b, 0x5be0cd19137e2179};
constexpr uint8_t kSigma[12][16] = {
    {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15}, {14, 10, 4, 8, 9, 15, 13, 6, 1, 12, 0, 2, 11, 7, 5, 3},
    {11, 8, 12, 0, 5, 2, 15, 13, 10, 14, 3, 6, 7, 1, 9, 4}, {7, 9, 3, 1, 13, 12, 11, 14, 2, 6, 5, 10, 4, 0, 15, 8},
    {9, 0, 5, 7, 2, 4, 10, 15, 14, 1, 11, 12, 6, 8, 3, 13}, {2, 12, 6, 10, 0, 11, 8, 3, 4, 13, 7, 5, 15, 14, 1, 9},
    {12, 5, 1, 15, 14, 13, 4, 10, 0, 7, 6, 3, 9, 2, 8, 11}, {13, 11, 7, 14, 12, 1, 3, 9, 5, 0, 15, 4, 8, 6, 2, 10},
    {6, 15, 14, 9, 11, 3, 0, 8, 12, 2, 13, 7, 1, 4, 10, 5}, {10, 2, 8, 4, 7, 6, 1, 5, 15, 11, 9, 14, 3, 12, 13, 0},
    {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15}, {14, 10, 4, 8, 9, 15, 13, 6, 1, 12, 0, 2, 11, 7, 5, 3}};

// Little-endian words, as BLAKE2b reads and writes them.
uint64_t Load64(const uint8_t* p) {
  uint64_t v = 0;
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(&v, p, sizeof v);
  } else {
    for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  }
  return v;
}
void Store64(uint64_t v, uint8_t* p) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

// The mixing function G on four words of the working vector and two message words.
inline void Mix(uint64_t& a, uint64_t& b, uint64_t& c, uint64_t& d, uint64_t x, uint64_t y) {
  a = a + b + x;
  d = std::rotr(d ^ a, 32);
  c = c + d;
  b = std::rotr(b ^ c, 24);
  a = a + b + y;
  d = std::rotr(d ^ a, 16);
  c = c + d;
  b = std::rotr(b ^ c, 63);
}

// One round: G on the columns, then on the diagonals, with the message words in round
// R's order. R is a template argument so that every index is a constant: the rounds
// unroll with the message words at fixed places (no index loads, fewer spills).
template <int R>
inline void Round(uint64_t (&v)[16], const uint64_t (&m)[16]) {
  constexpr const uint8_t* s = kSigma[R];
  Mix(v[0], v[4], v[8], v[12], m[s[0]], m[s[1]]);
  Mix(v[1], v[5], v[9], v[13], m[s[2]], m[s[3]]);
  Mix(v[2], v[6], v[10], v[14], m[s[4]], m[s[5]]);
  Mix(v[3], v[7], v[11], v[15], m[s[6]], m[s[7]]);
  Mix(v[0], v[5], v[10], v[15], m[s[8]], m[s[9]]);
  Mix(v[1], v[6], v[11], v[12], m[s[10]], m[s[11]]);
  Mix(v[2], v[7], v[8], v[13], m[s[12]], m[s[13]]);
  Mix(v[3], v[4], v[9], v[14], m[s[14]], m[s[15]]);
}

template <int... R>
inline void Rounds(uint64_t (&v)[16], const uint64_t (&m)[16], std::integer_sequence<int, R...>) {
  (Round<R>(v, m), ...);
}

// A block's 16 message words: n bytes from p (n <= 128), zero-padded. Word by word
// (unrolled: a copying loop becomes rep movs, whose start costs as much as a tag's
// bookkeeping).
void LoadBlock(const uint8_t* p, std::size_t n, uint64_t (&m)[16]) {
#pragma GCC unroll 16
  for (std::size_t i = 0; i < 16; ++i) {
    const std::size_t at = 8 * i;
    if (at + 8 <= n) {
      m[i] = Load64(p + at);
    } else {
      uint64_t partial = 0;
      for (std::size_t b = at; b < n; ++b) partial |= uint64_t{p[b]} << (8 * (b - at));
      m[i] = partial;
    }
  }
}

// Mixes one block (its message words m) into h; t: bytes hashed up to the end of this
// block.
void Compress(std::array<uint64_t, 8>& h, const uint64_t (&m)[16], uint64_t t, bool last) {
  uint64_t v[16];
  for (int i = 0; i < 8; ++i) {
    v[i] = h[i];
    v[i + 8] = kIv[i];
  }
  v[12] ^= t;  // the counter's high word (v[13]) stays 0: datagrams are short
  if (last) v[14] = ~v[14];
  Rounds(v, m, std::make_integer_sequence<int, 12>());
  for (int i = 0; i < 8; ++i) h[i] ^= v[i] ^ v[i + 8];
}

// The initial state of a 16-byte digest under a 32-byte key, and the key's block.
std::array<uint64_t, 8> InitialState() {
  std::array<uint64_t, 8> h = kIv;
  h[0] ^= 0x01010000 ^ (kSessionKeySize << 8) ^ kTagSize;
  return h;
}

// ---- protobuf's wire format: its wire types, and DeviceCommand.model (field 12) written ----
constexpr uint32_t kModelField = 12;
constexpr int kVarint = 0, kFixed64 = 1, kLengthDelimited = 2, kStartGroup = 3, kEndGroup = 4, kFixed32 = 5;

std::size_t VarintSize(uint64_t v) {
  std::size_t n = 1;
  while (v >= 0x80) {
    v >>= 7;
    ++n;
  }
  return n;
}
uint8_t* PutVarint(uint64_t v, uint8_t* p) {
  while (v >= 0x80) {
    *p++ = static_cast<uint8_t>(v | 0x80);
    v >>= 7;
  }
  *p++ = static_cast<uint8_t>(v);
  return p;
}
uint8_t* PutFixed(uint64_t v, int bytes, uint8_t* p) {
  for (int i = 0; i < bytes; ++i) *p++ = static_cast<uint8_t>(v >> (8 * i));
  return p;
}

// The ModelFragment message's bytes, as protobuf writes them (zero fields left out).
std::size_t FragmentBodySize(const ModelFragmentView& f) {
  return (f.version != 0 ? 9 : 0) + (f.index != 0 ? 5 : 0) + (f.count != 0 ? 5 : 0) +
         (f.data.empty() ? 0 : 1 + VarintSize(f.data.size()) + f.data.size());
}
std::size_t FragmentFieldSize(const ModelFragmentView& f) {
  const std::size_t body = FragmentBodySize(f);
  return 1 + VarintSize(body) + body;
}
// A field's key (its number and wire type), for numbers below 16: one byte.
uint8_t* PutKey(uint32_t field, int type, uint8_t* p) {
  *p++ = static_cast<uint8_t>(field << 3 | static_cast<uint32_t>(type));
  return p;
}
uint8_t* PutFragmentField(const ModelFragmentView& f, uint8_t* p) {
  p = PutVarint(FragmentBodySize(f), PutKey(kModelField, kLengthDelimited, p));
  if (f.version != 0) p = PutFixed(f.version, 8, PutKey(1, kFixed64, p));
  if (f.index != 0) p = PutFixed(f.index, 4, PutKey(2, kFixed32, p));
  if (f.count != 0) p = PutFixed(f.count, 4, PutKey(3, kFixed32, p));
  if (!f.data.empty()) {
    p = PutVarint(f.data.size(), PutKey(4, kLengthDelimited, p));
    p = std::copy(f.data.begin(), f.data.end(), p);
  }
  return p;
}

// ---- protobuf's wire format, read ----
//
// What protobuf's generated parser accepts, and no more (datagram_codec_test and
// fuzz_datagram compare the two on random and mutated messages): fields in any order, a
// scalar's last value wins, a sub-message given again merges into the first; a field
// not in the message, or in it with another wire type, is unknown and skipped, groups
// included. Refused: a value cut short, a tag of field 0 or of more than 5 bytes, a
// length of more than 5 bytes or past the message's end, an end-group tag without its
// group, wire types 6 and 7, and sub-messages and groups nested more than kMaxNesting
// deep (protobuf's default recursion limit).
constexpr int kMaxNesting = 100;

struct WireReader {
  std::span<const uint8_t> in;
  std::size_t at = 0;
  bool failed = false;

  bool done() const { return failed || at >= in.size(); }
  // A varint of up to `max_bytes` bytes (the bits past 64 dropped, as protobuf does).
  uint64_t Varint(int max_bytes = 10) {
    if (at < in.size() && in[at] < 0x80) return in[at++];  // most tags and lengths
    uint64_t v = 0;
    for (int i = 0; i < max_bytes && at < in.size(); ++i) {
      const uint8_t byte = in[at++];
      v |= uint64_t{byte & 0x7fu} << (7 * i);
      if (!(byte & 0x80)) return v;
    }
    failed = true;
    return 0;
  }
  // A field's tag: its number (not 0) and wire type; a fifth byte's bits past 32 are
  // dropped, as protobuf does.
  uint32_t Tag() {
    const auto tag = static_cast<uint32_t>(Varint(5));
    if ((tag >> 3) == 0) failed = true;
    return tag;
  }
  // A fixed32 or fixed64 value (kBytes 4 or 8).
  template <std::size_t kBytes>
  uint64_t Fixed() {
    if (in.size() - at < kBytes) {
      failed = true;
      return 0;
    }
    uint64_t v = 0;
    if constexpr (std::endian::native == std::endian::little) {
      std::memcpy(&v, in.data() + at, kBytes);
      at += kBytes;
    } else {
      for (std::size_t i = 0; i < kBytes; ++i) v |= uint64_t{in[at++]} << (8 * i);
    }
    return v;
  }
  double Double() { return std::bit_cast<double>(Fixed<8>()); }
  // A length-delimited value's bytes.
  std::span<const uint8_t> Bytes() {
    const uint64_t size = Varint(5);
    if (failed || size > in.size() - at) {
      failed = true;
      return {};
    }
    const auto bytes = in.subspan(at, size);
    at += size;
    return bytes;
  }
  // Skips the value of an unknown field with this tag; a group (with the groups in it)
  // up to its end-group tag. nesting: the sub-messages and groups around the field.
  void Skip(uint32_t tag, int nesting) {
    switch (static_cast<int>(tag & 7)) {
      case kVarint: Varint(); return;
      case kFixed64: Fixed<8>(); return;
      case kLengthDelimited: Bytes(); return;
      case kFixed32: Fixed<4>(); return;
      case kStartGroup:
        if (nesting + 1 > kMaxNesting) break;
        while (!done()) {
          const uint32_t inner = Tag();
          if (failed) return;
          if ((inner & 7) == kEndGroup) {
            if ((inner >> 3) != (tag >> 3)) break;
            return;
          }
          Skip(inner, nesting + 1);
        }
        break;
      default: break;  // an end group without its start; wire types 6, 7
    }
    failed = true;
  }
};

// Reads the message in body, calling read(number, type, reader) on each field: it reads
// the value and says true, or says false to have the field skipped as unknown. nesting:
// the sub-messages and groups around body. False when the message does not parse.
template <class ReadField>
bool ReadMessage(std::span<const uint8_t> body, int nesting, ReadField&& read) {
  if (nesting > kMaxNesting) return false;
  WireReader reader{body};
  while (!reader.done()) {
    const uint32_t tag = reader.Tag();
    if (reader.failed) break;
    if (!read(tag >> 3, static_cast<int>(tag & 7), reader)) reader.Skip(tag, nesting);
  }
  return !reader.failed;
}

// A Vec3 or Quat field's value, merged into v[0..N) (its fields 1..N in order, doubles).
template <std::size_t N>
void ReadDoubles(WireReader& reader, int nesting, double* v) {
  const std::span<const uint8_t> body = reader.Bytes();
  const bool read = !reader.failed && ReadMessage(body, nesting + 1, [&](uint32_t number, int type, WireReader& r) {
    if (number < 1 || number > N || type != kFixed64) return false;
    v[number - 1] = r.Double();
    return true;
  });
  if (!read) reader.failed = true;
}
// The same into an Eigen vector; a quaternion (w, x, y, z on the wire) also notes that
// it was there (an absent one reads as the identity, a present one's absent fields as 0).
void ReadVector(WireReader& reader, int nesting, Vector3& v) { ReadDoubles<3>(reader, nesting, v.data()); }
void ReadRotation(WireReader& reader, int nesting, std::array<double, 4>& wxyz, bool& present) {
  ReadDoubles<4>(reader, nesting, wxyz.data());
  present = true;
}
Quaternion RotationOf(const std::array<double, 4>& wxyz, bool present) {
  return present ? Quaternion(wxyz[0], wxyz[1], wxyz[2], wxyz[3]) : Quaternion::Identity();
}

// The fragment in body (a ModelFragment's bytes); false when it does not parse or
// breaks the bounds.
bool ReadFragment(std::span<const uint8_t> body, int nesting, ModelFragmentView& out) {
  out = {};
  const bool read = ReadMessage(body, nesting, [&](uint32_t number, int type, WireReader& r) {
    if (number == 1 && type == kFixed64) {
      out.version = r.Fixed<8>();
    } else if (number == 2 && type == kFixed32) {
      out.index = static_cast<uint32_t>(r.Fixed<4>());
    } else if (number == 3 && type == kFixed32) {
      out.count = static_cast<uint32_t>(r.Fixed<4>());
    } else if (number == 4 && type == kLengthDelimited) {
      out.data = r.Bytes();
    } else {
      return false;
    }
    return true;
  });
  return read && out.count >= 1 && out.count <= kMaxModelFragments && out.index < out.count &&
         out.data.size() <= kModelChunkSize;
}

// ---- DeviceState and DeviceCommand, written by hand ----
//
// Byte for byte what protobuf's generated serializer writes for the same message
// (datagram_codec_test compares the two over many random samples; the golden vectors pin
// the bytes): fields in number order; a fixed or varint scalar only when it is not 0, a
// bool only when true, a double only when its bits are not all 0 (-0.0 is written); a
// vector only when it is not zero (-0.0 counts as zero: an absent one reads back as
// exactly zero), a quaternion only when it is not the identity. Protobuf's arena and
// generic serializer cost as much as the rest of an encoding, tag included.
class MessageWriter {
 public:
  explicit MessageWriter(uint8_t* p) : p_(p) {}
  uint8_t* end() const { return p_; }

  void Fixed32(uint32_t field, uint32_t v) {
    if (v == 0) return;
    Key(field, kFixed32);
    p_ = PutFixed(v, 4, p_);
  }
  void Fixed64(uint32_t field, uint64_t v) {
    if (v == 0) return;
    Key(field, kFixed64);
    p_ = PutFixed(v, 8, p_);
  }
  void Double(uint32_t field, double v) { Fixed64(field, std::bit_cast<uint64_t>(v)); }
  void Varint(uint32_t field, uint64_t v) {
    if (v == 0) return;
    Key(field, kVarint);
    p_ = PutVarint(v, p_);
  }
  void Bool(uint32_t field, bool v) { Varint(field, v ? 1 : 0); }
  // A Vec3 (at most 27 bytes) or a Quat (at most 36): the size fits one byte.
  void Vector(uint32_t field, const Vector3& v) {
    if (v.isZero(0)) return;
    MessageWriter body = Open(field);
    body.Double(1, v.x());
    body.Double(2, v.y());
    body.Double(3, v.z());
    Close(body);
  }
  void Rotation(uint32_t field, const Quaternion& q) {
    if (q.w() == 1 && q.vec().isZero(0)) return;
    MessageWriter body = Open(field);
    body.Double(1, q.w());
    body.Double(2, q.x());
    body.Double(3, q.y());
    body.Double(4, q.z());
    Close(body);
  }

 private:
  void Key(uint32_t field, int type) { p_ = PutVarint(uint64_t{field} << 3 | static_cast<uint32_t>(type), p_); }
  // A sub-message: its key, a byte for its size, then its fields (Close writes the size).
  MessageWriter Open(uint32_t field) {
    Key(field, kLengthDelimited);
    return MessageWriter(p_ + 1);
  }
  void Close(const MessageWriter& body) {
    *p_ = static_cast<uint8_t>(body.end() - (p_ + 1));
    p_ = body.end();
  }

  uint8_t* p_;
};

// The most bytes either message takes without a model fragment (every field at its
// longest: a DeviceState's is about 300).
constexpr std::size_t kMaxMessageBytes = 512;

void WriteState(const DeviceStateSample& state, MessageWriter& w) {
  w.Fixed32(1, state.session_id);
  w.Fixed64(2, state.sequence);
  w.Fixed64(3, state.send_time_ns);
  w.Vector(4, state.p_WD);
  w.Rotation(5, state.q_WD);
  w.Vector(6, state.v_WD);
  w.Vector(7, state.w_WD);
  w.Fixed32(8, state.buttons);
  w.Vector(9, state.f_sensed_W);
  w.Vector(10, state.f_held_W);
  w.Fixed32(11, state.rtt_us);
  w.Fixed64(12, state.model_version);
  w.Vector(13, state.avatar_W);
  w.Double(40, state.energy_in);
  w.Double(41, state.energy_out);
  w.Varint(42, state.states_held);
  w.Bool(43, state.keepalive);
}

void WriteCommand(const DeviceCommandSample& command, MessageWriter& w) {
  w.Fixed32(1, command.session_id);
  w.Fixed64(2, command.sequence);
  w.Fixed64(3, command.echo_send_time_ns);
  w.Fixed64(4, command.scene_version);
  w.Vector(5, command.f_W);
  w.Vector(6, command.tau_W);
  w.Vector(7, command.p_command_W);
  w.Rotation(8, command.q_command_W);
  w.Vector(9, command.avatar_W);
  w.Bool(10, command.contact);
  w.Fixed32(11, command.flags);
  w.Double(40, command.energy_in);
  w.Double(41, command.energy_out);
  w.Varint(42, command.commands_held);
  w.Fixed64(43, command.command_number);
}

// The message's bytes (written into a scratch buffer), then `fragment` (when it has a
// count) as its last field, then the tag; 0 when they do not fit in min(out, limit).
std::size_t SealInto(std::span<const uint8_t> message, const ModelFragmentView* fragment, const TagKey& key,
                     std::span<uint8_t> out, std::size_t limit) {
  limit = std::min(out.size(), limit);
  const std::size_t size = message.size();
  const std::size_t extra = fragment != nullptr && fragment->count != 0 ? FragmentFieldSize(*fragment) : 0;
  if (size + extra + kTagSize > limit) return 0;
  std::copy(message.begin(), message.end(), out.begin());
  if (extra != 0) PutFragmentField(*fragment, out.data() + size);
  ComputeTag(out.first(size + extra), key, out.data() + size + extra);
  return size + extra + kTagSize;
}

}  // namespace

TagKey::TagKey(const SessionKey& key) : key_(key), h_(InitialState()) {
  uint64_t m[16];
  LoadBlock(key.data(), key.size(), m);  // the key, zero-padded to a block
  Compress(h_, m, kBlockSize, false);
}

void ComputeTag(std::span<const uint8_t> message, const TagKey& key, uint8_t* tag) {
  std::array<uint64_t, 8> h;
  uint64_t t = kBlockSize;
  uint64_t m[16];
  if (message.empty()) {
    // the key's block is the last one
    h = InitialState();
    LoadBlock(key.key().data(), key.key().size(), m);
  } else {
    // from the state after the key's block: every full block but the last, then the
    // rest zero-padded (a message of whole blocks ends on a full one)
    h = key.state();
    while (message.size() > kBlockSize) {
      t += kBlockSize;
      LoadBlock(message.data(), kBlockSize, m);
      Compress(h, m, t, false);
      message = message.subspan(kBlockSize);
    }
    LoadBlock(message.data(), message.size(), m);
    t += message.size();
  }
  Compress(h, m, t, true);
  for (std::size_t i = 0; i < kTagSize / 8; ++i) Store64(h[i], tag + 8 * i);
}

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

std::size_t EncodeState(const DeviceStateSample& state, const TagKey& key, std::span<uint8_t> out) {
  std::array<uint8_t, kMaxMessageBytes> message;
  MessageWriter writer(message.data());
  WriteState(state, writer);
  const auto size = static_cast<std::size_t>(writer.end() - message.data());
  return SealInto(std::span(message).first(size), nullptr, key, out, kMaxStateSize);
}

std::size_t EncodeCommand(const DeviceCommandSample& command, const TagKey& key, std::span<uint8_t> out) {
  // a fragment the parser would refuse is not sent either
  const ModelFragmentView& model = command.model;
  if (model.count != 0 && !(model.count <= kMaxModelFragments && model.index < model.count &&
                            model.data.size() <= kModelChunkSize)) {
    return 0;
  }
  std::array<uint8_t, kMaxMessageBytes> message;
  MessageWriter writer(message.data());
  WriteCommand(command, writer);
  const auto size = static_cast<std::size_t>(writer.end() - message.data());
  return SealInto(std::span(message).first(size), &command.model, key, out, kMaxCommandSize);
}

DatagramError ParseState(std::span<const uint8_t> datagram, DeviceStateSample& out) {
  if (datagram.size() > kMaxStateSize) return DatagramError::kOversized;
  if (datagram.size() < kTagSize) return DatagramError::kMalformed;
  out = {};
  std::array<double, 4> orientation{};
  bool has_orientation = false;
  const bool read = ReadMessage(datagram.first(datagram.size() - kTagSize), 0,
                                [&](uint32_t number, int type, WireReader& r) {
    if (type == kFixed32) {
      switch (number) {
        case 1: out.session_id = static_cast<uint32_t>(r.Fixed<4>()); return true;
        case 8: out.buttons = static_cast<uint32_t>(r.Fixed<4>()); return true;
        case 11: out.rtt_us = static_cast<uint32_t>(r.Fixed<4>()); return true;
        default: return false;
      }
    }
    if (type == kFixed64) {
      switch (number) {
        case 2: out.sequence = r.Fixed<8>(); return true;
        case 3: out.send_time_ns = r.Fixed<8>(); return true;
        case 12: out.model_version = r.Fixed<8>(); return true;
        case 40: out.energy_in = r.Double(); return true;
        case 41: out.energy_out = r.Double(); return true;
        default: return false;
      }
    }
    if (type == kLengthDelimited) {
      switch (number) {
        case 4: ReadVector(r, 0, out.p_WD); return true;
        case 5: ReadRotation(r, 0, orientation, has_orientation); return true;
        case 6: ReadVector(r, 0, out.v_WD); return true;
        case 7: ReadVector(r, 0, out.w_WD); return true;
        case 9: ReadVector(r, 0, out.f_sensed_W); return true;
        case 10: ReadVector(r, 0, out.f_held_W); return true;
        case 13: ReadVector(r, 0, out.avatar_W); return true;
        default: return false;
      }
    }
    if (type == kVarint) {
      switch (number) {
        case 42: out.states_held = r.Varint(); return true;
        case 43: out.keepalive = r.Varint() != 0; return true;
        default: return false;
      }
    }
    return false;
  });
  if (!read) return DatagramError::kMalformed;
  out.q_WD = RotationOf(orientation, has_orientation);
  return DatagramError::kNone;
}

DatagramError ParseCommand(std::span<const uint8_t> datagram, DeviceCommandSample& out) {
  if (datagram.size() > kMaxCommandSize) return DatagramError::kOversized;
  if (datagram.size() < kTagSize) return DatagramError::kMalformed;
  out = {};
  std::array<double, 4> orientation{};
  bool has_orientation = false;
  bool has_model = false;
  const bool read = ReadMessage(datagram.first(datagram.size() - kTagSize), 0,
                                [&](uint32_t number, int type, WireReader& r) {
    if (type == kFixed32) {
      switch (number) {
        case 1: out.session_id = static_cast<uint32_t>(r.Fixed<4>()); return true;
        case 11: out.flags = static_cast<uint32_t>(r.Fixed<4>()); return true;
        default: return false;
      }
    }
    if (type == kFixed64) {
      switch (number) {
        case 2: out.sequence = r.Fixed<8>(); return true;
        case 3: out.echo_send_time_ns = r.Fixed<8>(); return true;
        case 4: out.scene_version = r.Fixed<8>(); return true;
        case 40: out.energy_in = r.Double(); return true;
        case 41: out.energy_out = r.Double(); return true;
        case 43: out.command_number = r.Fixed<8>(); return true;
        default: return false;
      }
    }
    if (type == kLengthDelimited) {
      switch (number) {
        case 5: ReadVector(r, 0, out.f_W); return true;
        case 6: ReadVector(r, 0, out.tau_W); return true;
        case 7: ReadVector(r, 0, out.p_command_W); return true;
        case 8: ReadRotation(r, 0, orientation, has_orientation); return true;
        case 9: ReadVector(r, 0, out.avatar_W); return true;
        case kModelField: {
          // one fragment at most, within its bounds (protobuf would merge a second)
          const std::span<const uint8_t> fragment = r.Bytes();
          if (r.failed || has_model || !ReadFragment(fragment, 1, out.model)) r.failed = true;
          has_model = true;
          return true;
        }
        default: return false;
      }
    }
    if (type == kVarint) {
      switch (number) {
        case 10: out.contact = r.Varint() != 0; return true;
        case 42: out.commands_held = r.Varint(); return true;
        default: return false;
      }
    }
    return false;
  });
  if (!read) return DatagramError::kMalformed;
  out.q_command_W = RotationOf(orientation, has_orientation);
  return DatagramError::kNone;
}

bool CheckTag(std::span<const uint8_t> datagram, const TagKey& key) {
  if (datagram.size() < kTagSize) return false;
  const auto body = datagram.first(datagram.size() - kTagSize);
  uint8_t expected[kTagSize];
  ComputeTag(body, key, expected);
  // constant time: every byte is compared, whatever the first difference
  static_assert(kTagSize == 16);
  uint64_t a[2], b[2];
  std::memcpy(a, expected, kTagSize);
  std::memcpy(b, datagram.data() + body.size(), kTagSize);
  return ((a[0] ^ b[0]) | (a[1] ^ b[1])) == 0;
}

SessionKey MakeSessionKey() {
  if (sodium_init() < 0) std::abort();
  SessionKey key;
  randombytes_buf(key.data(), key.size());
  return key;
}

}  // namespace hapticd::net
