#pragma once

// The conformance ops: each reads its arguments, runs one geometry query and writes
// the members of the answer's "result" object.

#include <memory>
#include <string_view>

#include "server/conformance/case_json.h"

namespace hapticd::embree {
class EmbreeDevice;
}  // namespace hapticd::embree

namespace hapticd::conformance {

// What answers the mesh ops: the native BVH, or the Embree backend when `embree` is set
// (the same answers; `hapticd-query --ray-backend embree`).
struct QueryBackend {
  std::shared_ptr<const embree::EmbreeDevice> embree;
};

using QueryOp = void (*)(const JsonAt& args, const QueryBackend& backend, ResultWriter& result);

// The op named `name`, or nullptr when there is none.
QueryOp FindQueryOp(std::string_view name);

}  // namespace hapticd::conformance
