#pragma once

// The conformance ops: each reads its arguments, runs one geometry query and writes
// the members of the answer's "result" object.

#include <string_view>

#include "server/conformance/case_json.h"

namespace hapticd::conformance {

using QueryOp = void (*)(const JsonAt& args, ResultWriter& result);

// The op named `name`, or nullptr when there is none.
QueryOp FindQueryOp(std::string_view name);

}  // namespace hapticd::conformance
