#include "server/conformance/query_runner.h"

#include <rapidjson/error/en.h>

#include <exception>

#include <fmt/format.h>

#include "server/conformance/query_ops.h"
#include "server/json/exact_json.h"

namespace hapticd::conformance {
namespace {

using Writer = rapidjson::Writer<rapidjson::StringBuffer>;

std::string ErrorLine(const rapidjson::Value* id, const std::string& message) {
  rapidjson::StringBuffer buffer;
  Writer writer(buffer);
  writer.StartObject();
  writer.Key("id");
  if (id != nullptr) {
    id->Accept(writer);
  } else {
    writer.Null();
  }
  writer.Key("error");
  writer.String(message.c_str(), static_cast<rapidjson::SizeType>(message.size()));
  writer.EndObject();
  return buffer.GetString();
}

}  // namespace

std::string AnswerCaseLine(std::string_view line, const QueryBackend& backend) {
  rapidjson::Document doc;
  // NaN and infinities arrive as bare tokens; every number is read exactly
  // (exact_json.h); the iterative parser bounds stack use whatever the nesting depth.
  constexpr unsigned kFlags = rapidjson::kParseNanAndInfFlag | rapidjson::kParseIterativeFlag;
  const rapidjson::ParseResult error = json::ParseDocument<kFlags>(line, doc);
  if (error.IsError()) {
    return ErrorLine(nullptr, fmt::format("malformed JSON at offset {}: {}", error.Offset(),
                                          rapidjson::GetParseError_En(error.Code())));
  }
  if (!doc.IsObject()) return ErrorLine(nullptr, "a case must be a JSON object");
  const auto id_member = doc.FindMember("id");
  const rapidjson::Value* id = id_member != doc.MemberEnd() ? &id_member->value : nullptr;

  try {
    const JsonAt root{doc, "case"};
    const JsonAt op_name = root["op"];
    if (!op_name.value.IsString()) throw CaseError("case.op must be a string");
    const std::string_view name(op_name.value.GetString(), op_name.value.GetStringLength());
    const QueryOp op = FindQueryOp(name);
    if (op == nullptr) throw CaseError(fmt::format("unknown op \"{}\"", name));
    const JsonAt args{root["args"].value, "args"};

    // The result is written first to its own buffer, so a failure halfway leaves
    // nothing to undo.
    rapidjson::StringBuffer buffer;
    Writer writer(buffer);
    writer.StartObject();
    writer.Key("id");
    if (id != nullptr) {
      id->Accept(writer);
    } else {
      writer.Null();
    }
    writer.Key("result");
    writer.StartObject();
    ResultWriter result(writer);
    op(args, backend, result);
    writer.EndObject();
    writer.EndObject();
    return buffer.GetString();
  } catch (const CaseError& e) {
    return ErrorLine(id, e.what());
  } catch (const std::exception& e) {
    return ErrorLine(id, e.what());
  }
}

}  // namespace hapticd::conformance
