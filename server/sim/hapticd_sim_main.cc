// hapticd-sim: runs one haptic scenario (../shared/scenarios/FORMAT.md) in simulated time.
//
//   hapticd-sim SCENARIO.json [--trace TRACE.csv] [--set key.path=value ...]
//   hapticd-sim --version
//
// Prints one JSON summary line on stdout; with --trace, writes one CSV row per tick.
// Exit status: 0 when the run completed; 2 for a bad command line or a scenario that is
// refused (the error, naming the field, on stderr); 1 when the trace cannot be written
// or the simulation fails unexpectedly.

#include <cstdio>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "hapticd/version.h"
#include "server/sim/scenario_parser.h"
#include "server/sim/sim_output.h"
#include "server/sim/simulator.h"

namespace {

constexpr int kUsageError = 2;
constexpr int kRunError = 1;
constexpr const char* kUsage =
    "usage: hapticd-sim SCENARIO.json [--trace TRACE.csv] [--set key.path=value ...]\n"
    "       hapticd-sim --version\n";

struct Arguments {
  std::string scenario;
  std::string trace;  // empty: no trace
  std::vector<std::string> overrides;
};

// Parses argv; returns false (after printing why) when it is not a valid command line.
bool ParseArguments(int argc, char** argv, Arguments& arguments) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    // options that take the next argument
    if (arg == "--trace" || arg == "--set") {
      if (i + 1 == argc) {
        std::fprintf(stderr, "hapticd-sim: %s needs a value\n%s", argv[i], kUsage);
        return false;
      }
      (arg == "--trace" ? arguments.trace : arguments.overrides.emplace_back()) = argv[++i];
      continue;
    }
    if (arg.starts_with("-")) {
      std::fprintf(stderr, "hapticd-sim: unknown option %s\n%s", argv[i], kUsage);
      return false;
    }
    if (!arguments.scenario.empty()) {
      std::fprintf(stderr, "hapticd-sim: more than one scenario given (%s)\n%s", argv[i], kUsage);
      return false;
    }
    arguments.scenario = arg;
  }
  if (arguments.scenario.empty()) {
    std::fprintf(stderr, "hapticd-sim: no scenario given\n%s", kUsage);
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::string_view(argv[1]) == "--version") {
    std::printf("hapticd-sim %.*s\n", static_cast<int>(hapticd::kVersion.size()), hapticd::kVersion.data());
    return 0;
  }
  Arguments arguments;
  if (!ParseArguments(argc, argv, arguments)) return kUsageError;

  // read, validate and set up; a refusal names the field
  std::FILE* trace_file = nullptr;
  hapticd::sim::SimSummary summary;
  try {
    hapticd::sim::Simulator simulator(hapticd::sim::LoadScenario(arguments.scenario, arguments.overrides));
    if (!arguments.trace.empty()) {
      trace_file = std::fopen(arguments.trace.c_str(), "w");
      if (trace_file == nullptr) {
        std::fprintf(stderr, "hapticd-sim: cannot write the trace to %s\n", arguments.trace.c_str());
        return kUsageError;
      }
      std::fprintf(trace_file, "%s\n", hapticd::sim::kTraceHeader);
    }
    // run, writing the trace as it goes
    summary = simulator.Run([&](const hapticd::sim::TraceRow& row) {
      if (trace_file != nullptr) std::fprintf(trace_file, "%s\n", hapticd::sim::FormatTraceRow(row).c_str());
    });
  } catch (const hapticd::sim::ScenarioError& error) {
    std::fprintf(stderr, "hapticd-sim: %s: %s\n", arguments.scenario.c_str(), error.what());
    return kUsageError;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "hapticd-sim: %s: the simulation failed: %s\n", arguments.scenario.c_str(),
                 error.what());
    if (trace_file != nullptr) std::fclose(trace_file);
    return kRunError;
  }
  if (trace_file != nullptr && (std::ferror(trace_file) != 0 || std::fclose(trace_file) != 0)) {
    std::fprintf(stderr, "hapticd-sim: writing the trace to %s failed\n", arguments.trace.c_str());
    return kRunError;
  }
  std::printf("%s\n", hapticd::sim::FormatSummaryJson(summary).c_str());
  return 0;
}
