#include "server/sim/sim_output.h"

#include <fmt/format.h>
#include <rapidjson/stringbuffer.h>
#include <rapidjson/writer.h>

#include <cmath>

namespace hapticd::sim {
namespace {

using Writer = rapidjson::Writer<rapidjson::StringBuffer>;

void WriteNumber(Writer& writer, const char* key, double value) {
  writer.Key(key);
  // a run that blew up: JSON has no NaN
  if (!std::isfinite(value)) {
    writer.Null();
    return;
  }
  writer.Double(value);
}

void WriteCount(Writer& writer, const char* key, uint64_t value) {
  writer.Key(key);
  writer.Uint64(value);
}

void WriteVector(Writer& writer, const char* key, const Vector3& value) {
  writer.Key(key);
  writer.StartArray();
  for (double x : value) {
    if (std::isfinite(x)) {
      writer.Double(x);
    } else {
      writer.Null();
    }
  }
  writer.EndArray();
}

}  // namespace

std::string FormatSummaryJson(const SimSummary& summary) {
  rapidjson::StringBuffer buffer;
  Writer writer(buffer);
  writer.StartObject();
  // FORMAT.md's four first
  WriteCount(writer, "ticks", static_cast<uint64_t>(summary.ticks));
  WriteNumber(writer, "max_force_n", summary.max_force_n);
  WriteNumber(writer, "max_penetration_m", summary.max_penetration_m);
  WriteNumber(writer, "energy_j", summary.energy_j);
  // then the extras
  WriteNumber(writer, "max_avatar_penetration_m", summary.max_avatar_penetration_m);
  WriteNumber(writer, "max_proxy_penetration_m", summary.max_proxy_penetration_m);
  WriteCount(writer, "contact_ticks", static_cast<uint64_t>(summary.contact_ticks));
  WriteVector(writer, "final_device", summary.final_device_W);
  WriteVector(writer, "final_avatar", summary.final_avatar_W);
  WriteNumber(writer, "observed_energy_j", summary.observed_energy_j);
  const force::SessionCounters& counters = summary.counters;
  WriteCount(writer, "nonfinite_inputs", counters.nonfinite_inputs);
  WriteCount(writer, "absurd_inputs", counters.absurd_inputs);
  WriteCount(writer, "force_saturations", counters.force_saturations);
  WriteCount(writer, "passivity_activations", counters.passivity_activations);
  WriteCount(writer, "watchdog_trips", counters.watchdog_trips);
  WriteCount(writer, "constraint_overflows", counters.constraint_overflows);
  WriteCount(writer, "packets_lost_up", summary.packets_lost_up);
  WriteCount(writer, "packets_lost_down", summary.packets_lost_down);
  WriteCount(writer, "ticks_without_input", static_cast<uint64_t>(summary.ticks_without_input));
  WriteCount(writer, "ticks_without_command", static_cast<uint64_t>(summary.ticks_without_command));
  WriteCount(writer, "substeps", static_cast<uint64_t>(summary.substeps));
  // remote (FORMAT.md's three, then the extras)
  WriteCount(writer, "packets_up", summary.packets_up);
  WriteCount(writer, "packets_down", summary.packets_down);
  WriteNumber(writer, "channel_energy_j", summary.channel_energy_j);
  WriteNumber(writer, "max_drift_m", summary.max_drift_m);
  WriteCount(writer, "tdpa_device_activations", summary.tdpa_device_activations);
  WriteCount(writer, "tdpa_renderer_activations", summary.tdpa_renderer_activations);
  WriteCount(writer, "models_taken", summary.models_taken);
  WriteCount(writer, "model_blends", summary.model_blends);
  WriteCount(writer, "ticks_outside_model", static_cast<uint64_t>(summary.ticks_outside_model));
  WriteNumber(writer, "max_model_radius_m", summary.max_model_radius_m);
  writer.EndObject();
  return buffer.GetString();
}

std::string FormatTraceRow(const TraceRow& row) {
  // fmt's {} is the shortest representation that reads back exactly
  return fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{}", row.t, row.p_device_W.x(),
                     row.p_device_W.y(), row.p_device_W.z(), row.v_device_W.x(), row.v_device_W.y(),
                     row.v_device_W.z(), row.avatar_W.x(), row.avatar_W.y(), row.avatar_W.z(), row.f_W.x(),
                     row.f_W.y(), row.f_W.z(), row.contact ? 1 : 0);
}

}  // namespace hapticd::sim
