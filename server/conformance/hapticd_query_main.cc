// hapticd-query: the conformance runner. Reads one JSON case per line on stdin and
// writes one JSON answer per line on stdout, in order (../shared/conformance/FORMAT.md).

#include <iostream>
#include <string>

#include "server/conformance/query_runner.h"

int main(int argc, char** argv) {
  if (argc > 1) {
    std::cerr << "usage: " << argv[0] << " < CASES.jsonl > ANSWERS.jsonl\n"
              << "Answers geometry conformance cases, one JSON line each.\n";
    return std::string(argv[1]) == "--help" ? 0 : 2;
  }
  std::ios::sync_with_stdio(false);
  std::string line;
  while (std::getline(std::cin, line)) {
    // blank lines are not cases
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::cout << hapticd::conformance::AnswerCaseLine(line) << '\n';
  }
  std::cout.flush();
  return 0;
}
