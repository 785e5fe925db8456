#pragma once

// The conformance runner's core, free of I/O: one JSON case line in, one JSON answer
// line out (../shared/conformance/FORMAT.md). Never throws: a case that cannot be
// answered (malformed JSON, an unknown op, invalid arguments) gets an error line
// that says why, with "id": null when the id could not be read.

#include <string>
#include <string_view>

#include "server/conformance/query_ops.h"

namespace hapticd::conformance {

// Answers one case line: {"id": ..., "op": ..., "args": {...}} ->
// {"id": ..., "result": {...}} or {"id": ..., "error": "..."}. No trailing newline.
// The mesh ops run on backend (native by default).
std::string AnswerCaseLine(std::string_view line, const QueryBackend& backend = {});

}  // namespace hapticd::conformance
