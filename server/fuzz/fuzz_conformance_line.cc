// The conformance runner's line parser and ops (conformance::AnswerCaseLine), on any
// line, answered by the native backend and by the Embree backend.
//
// Checks: each answer is one line of strict JSON (no NaN or Infinity tokens), an
// object with exactly the members "id" and one of "result" or "error" (a non-empty
// string); its id is the case's id when the case is a JSON object with one, else null;
// and the two backends agree on whether the case has an answer (but that Embree refuses
// meshes beyond float's range, by name), on every boolean of the
// result ("hit", "inside", "intersect"), and byte for byte on ops that no backend
// answers (everything but the mesh ops).

#include <rapidjson/document.h>

#include <cstring>
#include <memory>
#include <string>
#include <string_view>

#include "server/conformance/query_runner.h"
#include "server/embree/embree_device.h"
#include "server/fuzz/fuzz_check.h"
#include "server/json/exact_json.h"

namespace hapticd::fuzz {
namespace {

bool IsMeshOp(std::string_view op) {
  return op == "segment_mesh" || op == "closest_point_mesh" || op == "point_inside_mesh";
}

// The answer parsed, after its shape is checked against the case (in: the case as the
// runner parses it, null when it does not parse).
rapidjson::Document CheckAnswer(const std::string& answer, const rapidjson::Document& in, const char* backend) {
  FUZZ_CHECK(answer.find('\n') == std::string::npos, "%s: an answer of more than one line: %s", backend,
             answer.c_str());
  rapidjson::Document out;
  out.Parse(answer.data(), answer.size());
  FUZZ_CHECK(!out.HasParseError() && out.IsObject(), "%s: an answer that is not a strict JSON object: %s", backend,
             answer.c_str());
  FUZZ_CHECK(out.MemberCount() == 2 && out.HasMember("id"), "%s: an answer without exactly two members: %s", backend,
             answer.c_str());
  const bool is_error = out.HasMember("error");
  FUZZ_CHECK(is_error || (out.HasMember("result") && out["result"].IsObject()), "%s: neither result nor error: %s",
             backend, answer.c_str());
  if (is_error) {
    FUZZ_CHECK(out["error"].IsString() && out["error"].GetStringLength() > 0, "%s: an empty error: %s", backend,
               answer.c_str());
  }
  const bool has_id = in.IsObject() && in.HasMember("id");
  if (has_id) {
    FUZZ_CHECK(out["id"] == in["id"], "%s: the answer's id is not the case's: %s", backend, answer.c_str());
  } else {
    FUZZ_CHECK(out["id"].IsNull(), "%s: an id for a case without one: %s", backend, answer.c_str());
  }
  return out;
}

}  // namespace
}  // namespace hapticd::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace hapticd;
  static const conformance::QueryBackend native;
  static const conformance::QueryBackend embree{std::make_shared<const embree::EmbreeDevice>()};
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  // the runner reads lines: a newline ends the case
  if (line.find('\n') != std::string_view::npos) return 0;

  // the case as the runner parses it (query_runner.cc), left null when it does not parse
  rapidjson::Document in;
  json::ParseDocument<rapidjson::kParseNanAndInfFlag | rapidjson::kParseIterativeFlag>(line, in);
  const std::string native_answer = conformance::AnswerCaseLine(line, native);
  const std::string embree_answer = conformance::AnswerCaseLine(line, embree);
  const rapidjson::Document a = fuzz::CheckAnswer(native_answer, in, "native");
  const rapidjson::Document b = fuzz::CheckAnswer(embree_answer, in, "embree");

  const bool mesh_op = in.IsObject() && in.HasMember("op") && in["op"].IsString() &&
                       fuzz::IsMeshOp(in["op"].GetString());
  if (!mesh_op) {
    FUZZ_CHECK(native_answer == embree_answer, "the backends differ on a non-mesh case:\n%s\n%s",
               native_answer.c_str(), embree_answer.c_str());
    return 0;
  }
  // Embree stores floats: it refuses meshes beyond their range, by name (server/embree/embree_mesh.cc)
  const bool embree_out_of_range =
      b.HasMember("error") && std::string_view(b["error"].GetString()).starts_with("Cannot build an Embree scene");
  FUZZ_CHECK(a.HasMember("error") == b.HasMember("error") || (!a.HasMember("error") && embree_out_of_range),
             "one backend answers, the other refuses:\n%s\n%s", native_answer.c_str(), embree_answer.c_str());
  // (Embree's refusal of a mesh beyond float range leaves nothing to compare)
  if (a.HasMember("error") || b.HasMember("error")) return 0;
  for (const char* flag : {"hit", "inside", "intersect"}) {
    const bool in_a = a["result"].HasMember(flag);
    FUZZ_CHECK(in_a == b["result"].HasMember(flag) && (!in_a || a["result"][flag] == b["result"][flag]),
               "the backends differ on %s:\n%s\n%s", flag, native_answer.c_str(), embree_answer.c_str());
  }
  return 0;
}
