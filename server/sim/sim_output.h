#pragma once

// What hapticd-sim prints: the summary as one line of JSON, and the trace as CSV with
// FORMAT.md's columns. Numbers are written in their shortest form that reads back to the
// same double; a non-finite number (a run that blew up) is written as null in the JSON.

#include <cstdio>
#include <string>

#include "server/sim/simulator.h"

namespace hapticd::sim {

// {"ticks": N, "max_force_n": ..., "max_penetration_m": ..., "energy_j": ..., extras}
// on one line, without a newline.
std::string FormatSummaryJson(const SimSummary& summary);

// "t,dev_x,dev_y,dev_z,dev_vx,dev_vy,dev_vz,avatar_x,avatar_y,avatar_z,f_x,f_y,f_z,contact"
inline constexpr const char* kTraceHeader =
    "t,dev_x,dev_y,dev_z,dev_vx,dev_vy,dev_vz,avatar_x,avatar_y,avatar_z,f_x,f_y,f_z,contact";

// One CSV line for row, without a newline.
std::string FormatTraceRow(const TraceRow& row);

}  // namespace hapticd::sim
