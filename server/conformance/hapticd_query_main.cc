// hapticd-query: the conformance runner. Reads one JSON case per line on stdin and
// writes one JSON answer per line on stdout, in order (../shared/conformance/FORMAT.md).

#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "hapticd/version.h"
#include "server/conformance/query_runner.h"
#include "server/embree/embree_device.h"

int main(int argc, char** argv) {
  // --ray-backend native|embree: what answers the mesh ops (the same answers)
  hapticd::conformance::QueryBackend backend;
  const std::vector<std::string> args(argv + 1, argv + argc);
  const bool help = args.size() == 1 && args[0] == "--help";
  const bool native = args.empty() || (args.size() == 2 && args[0] == "--ray-backend" && args[1] == "native");
  const bool embree = args.size() == 2 && args[0] == "--ray-backend" && args[1] == "embree";
  const bool embree_info = args.size() == 1 && args[0] == "--embree-info";
  if (args.size() == 1 && args[0] == "--version") {
    std::cout << "hapticd-query " << hapticd::kVersion << '\n';
    return 0;
  }
  if (help || !(native || embree || embree_info)) {
    std::cerr << "usage: " << argv[0] << " [--ray-backend native|embree] < CASES.jsonl > ANSWERS.jsonl\n"
              << "       " << argv[0] << " --embree-info\n"
              << "       " << argv[0] << " --version\n"
              << "Answers geometry conformance cases, one JSON line each; the mesh ops run on the\n"
              << "native BVH (default) or the Embree backend. --embree-info prints one JSON line:\n"
              << "Embree's version, the kernel ISA it picked on this CPU, and its native packet widths.\n";
    return help ? 0 : 2;
  }
  if (embree_info) {
    const hapticd::embree::EmbreeIsaReport report = hapticd::embree::ReportEmbreeIsa();
    std::cout << "{\"embree\": \"" << report.version << "\", \"kernels\": \"" << report.kernels
              << "\", \"compiled\": [";
    for (size_t i = 0; i < report.compiled.size(); ++i) {
      std::cout << (i ? ", " : "") << '"' << report.compiled[i] << '"';
    }
    std::cout << "], \"native_packet_widths\": [";
    for (size_t i = 0; i < report.native_packet_widths.size(); ++i) {
      std::cout << (i ? ", " : "") << report.native_packet_widths[i];
    }
    std::cout << "]}\n";
    return 0;
  }
  if (embree) backend.embree = std::make_shared<const hapticd::embree::EmbreeDevice>();

  std::ios::sync_with_stdio(false);
  std::string line;
  while (std::getline(std::cin, line)) {
    // blank lines are not cases
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::cout << hapticd::conformance::AnswerCaseLine(line, backend) << '\n';
  }
  std::cout.flush();
  return 0;
}
