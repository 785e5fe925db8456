// The realtime datagram codec's cost per datagram (server/net/datagram_codec.h): encode
// (protobuf + keyed BLAKE2b tag) and decode (tag check + parse), for a typical
// DeviceState and DeviceCommand, with the session's key prepared once (TagKey, as the
// server and the proxy keep it); plus the tag alone, with a prepared key and with a plain
// one (prepared on every call), and preparing a key. bench/run_latency.sh reports them.
#include <array>
#include <benchmark/benchmark.h>

#include "server/net/datagram_codec.h"

namespace {

using namespace hapticd::net;

SessionKey BenchKey() {
  SessionKey key;
  for (std::size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(i * 13 + 5);
  return key;
}

// What an impedance device sends each tick: a pose, a velocity, the held force.
DeviceStateSample TypicalState() {
  DeviceStateSample state;
  state.session_id = 0x5eed1234;
  state.sequence = 123'456;
  state.send_time_ns = 9'876'543'210'123;
  state.p_WD = {0.0512, -0.0031, -0.0049};
  state.v_WD = {0.0874, 0.0012, -0.0003};
  state.f_held_W = {0.02, -0.01, 9.8};
  state.rtt_us = 87;
  return state;
}

// What the server answers: a force, the avatar, contact.
DeviceCommandSample TypicalCommand() {
  DeviceCommandSample command;
  command.session_id = 0x5eed1234;
  command.sequence = 123'456;
  command.echo_send_time_ns = 9'876'543'210'123;
  command.scene_version = 3;
  command.f_W = {0.0, 0.0, 9.8};
  command.avatar_W = {0.0512, -0.0031, 0.0};
  command.contact = true;
  return command;
}

void BM_EncodeState(benchmark::State& run) {
  const TagKey key(BenchKey());
  const DeviceStateSample state = TypicalState();
  std::array<uint8_t, kMaxDatagramSize> out;
  std::size_t size = 0;
  for (auto _ : run) {
    size = EncodeState(state, key, out);
    benchmark::DoNotOptimize(out.data());
  }
  run.counters["bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_EncodeState);

void BM_DecodeState(benchmark::State& run) {
  const TagKey key(BenchKey());
  std::array<uint8_t, kMaxDatagramSize> bytes;
  const std::size_t size = EncodeState(TypicalState(), key, bytes);
  const std::span<const uint8_t> datagram(bytes.data(), size);
  DeviceStateSample state;
  for (auto _ : run) {
    const bool ok = CheckTag(datagram, key) && ParseState(datagram, state) == DatagramError::kNone;
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(state);
  }
  run.counters["bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_DecodeState);

void BM_EncodeCommand(benchmark::State& run) {
  const TagKey key(BenchKey());
  const DeviceCommandSample command = TypicalCommand();
  std::array<uint8_t, kMaxDatagramSize> out;
  std::size_t size = 0;
  for (auto _ : run) {
    size = EncodeCommand(command, key, out);
    benchmark::DoNotOptimize(out.data());
  }
  run.counters["bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_EncodeCommand);

void BM_DecodeCommand(benchmark::State& run) {
  const TagKey key(BenchKey());
  std::array<uint8_t, kMaxDatagramSize> bytes;
  const std::size_t size = EncodeCommand(TypicalCommand(), key, bytes);
  const std::span<const uint8_t> datagram(bytes.data(), size);
  DeviceCommandSample command;
  for (auto _ : run) {
    const bool ok = CheckTag(datagram, key) && ParseCommand(datagram, command) == DatagramError::kNone;
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(command);
  }
  run.counters["bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_DecodeCommand);

// The tag check alone (keyed BLAKE2b over a state's bytes): the crypto share of a decode.
void BM_CheckTag(benchmark::State& run) {
  const TagKey key(BenchKey());
  std::array<uint8_t, kMaxDatagramSize> bytes;
  const std::size_t size = EncodeState(TypicalState(), key, bytes);
  const std::span<const uint8_t> datagram(bytes.data(), size);
  for (auto _ : run) benchmark::DoNotOptimize(CheckTag(datagram, key));
  run.counters["bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_CheckTag);

// The same check with the plain session key: the key's block hashed again every call.
void BM_CheckTagUnprepared(benchmark::State& run) {
  const SessionKey key = BenchKey();
  std::array<uint8_t, kMaxDatagramSize> bytes;
  const std::size_t size = EncodeState(TypicalState(), key, bytes);
  const std::span<const uint8_t> datagram(bytes.data(), size);
  for (auto _ : run) benchmark::DoNotOptimize(CheckTag(datagram, key));
  run.counters["bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_CheckTagUnprepared);

// Preparing a session's key (once per session).
void BM_PrepareTagKey(benchmark::State& run) {
  SessionKey key = BenchKey();
  for (auto _ : run) {
    key[0] += 1;
    benchmark::DoNotOptimize(TagKey(key));
  }
}
BENCHMARK(BM_PrepareTagKey);

}  // namespace

BENCHMARK_MAIN();
