#pragma once
// The local model on the wire (hapticd.v1.LocalModel), and its fragments.
//
// The server encodes each model it cuts (EncodeLocalModel) and sends it in fragments of
// kModelChunkSize bytes, one per command (DeviceCommand.model, datagram_codec.h); the
// device puts them together (ModelAssembler) and decodes the model once every fragment
// of one version is there. A newer version's first fragment drops what an older one had
// gathered: only the newest model is worth finishing.
#include <bitset>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "server/net/datagram_codec.h"
#include "server/remote/local_model.h"

namespace hapticd::net {

// model's encoding. The objects that would make it longer than kMaxModelBytes are left
// out (from the last one cut), counted in left_out.
std::string EncodeLocalModel(const remote::LocalModel& model);

// The model in bytes. Throws RequestError naming the bad field ("local_model.objects[2]
// .shape is not set ...") when they do not parse or do not describe valid objects.
remote::LocalModel DecodeLocalModel(std::span<const uint8_t> bytes);

// How many fragments bytes of encoding take (at least 1), and fragment index of them.
uint32_t FragmentCount(std::size_t bytes);
ModelFragmentView Fragment(std::span<const uint8_t> encoded, uint64_t version, uint32_t index);

// The device's side: gathers fragments into a preallocated buffer (no allocation).
class ModelAssembler {
 public:
  ModelAssembler();
  // Takes a fragment (parsed, so within the bounds); true when it completed its
  // version. Older versions than the one gathered, and fragments whose length is not
  // what their index needs (a full chunk but for the last), are ignored (false).
  bool Offer(const ModelFragmentView& fragment);
  // The completed model's bytes and version (valid until the next Offer).
  std::span<const uint8_t> bytes() const { return {buffer_.data(), size_}; }
  uint64_t version() const { return version_; }
  // Fragments ignored for being malformed (wrong length) so far.
  uint64_t rejected() const { return rejected_; }

 private:
  std::vector<uint8_t> buffer_;  // kMaxModelBytes, sized once
  uint64_t version_ = 0;
  uint32_t count_ = 0;
  std::size_t size_ = 0;
  std::bitset<kMaxModelFragments> have_;
  bool complete_ = false;
  uint64_t rejected_ = 0;
};

}  // namespace hapticd::net
