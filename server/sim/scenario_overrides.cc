#include "server/sim/scenario_overrides.h"

#include <fmt/format.h>

#include <charconv>
#include <vector>

#include "server/json/exact_json.h"
#include "server/sim/json_fields.h"
#include "server/sim/scenario.h"

namespace hapticd::sim {
namespace {

std::vector<std::string_view> SplitPath(std::string_view path) {
  std::vector<std::string_view> segments;
  size_t start = 0;
  while (true) {
    const size_t dot = path.find('.', start);
    const size_t length = dot == std::string_view::npos ? std::string_view::npos : dot - start;
    segments.push_back(path.substr(start, length));
    if (dot == std::string_view::npos) return segments;
    start = dot + 1;
  }
}

// A whole segment as an array index, or -1 when it is not a non-negative integer.
int64_t ParseIndex(std::string_view segment) {
  int64_t index = -1;
  const auto [end, error] = std::from_chars(segment.data(), segment.data() + segment.size(), index);
  if (error != std::errc() || end != segment.data() + segment.size() || index < 0) return -1;
  return index;
}

// The value text as JSON when it parses, else as a string, allocated in document.
rapidjson::Value ParseValue(std::string_view text, rapidjson::Document& document) {
  rapidjson::Document parsed;
  const rapidjson::ParseResult error = json::ParseDocument<rapidjson::kParseDefaultFlags>(text, parsed);
  rapidjson::Value value;
  if (error.IsError()) {
    value.SetString(text.data(), static_cast<rapidjson::SizeType>(text.size()), document.GetAllocator());
  } else {
    value.CopyFrom(parsed, document.GetAllocator());
  }
  return value;
}

}  // namespace

Override ParseOverride(std::string_view text) {
  const size_t equals = text.find('=');
  if (equals == std::string_view::npos) {
    throw ScenarioError(fmt::format("--set {}: expected key.path=value", text));
  }
  Override result{std::string(text.substr(0, equals)), std::string(text.substr(equals + 1))};
  for (std::string_view segment : SplitPath(result.path)) {
    if (segment.empty()) {
      throw ScenarioError(fmt::format("--set {}: the path '{}' has an empty segment", text, result.path));
    }
  }
  return result;
}

void ApplyOverride(rapidjson::Document& document, const Override& override) {
  auto& allocator = document.GetAllocator();
  const std::vector<std::string_view> segments = SplitPath(override.path);
  auto fail = [&](const std::string& why) {
    throw ScenarioError(fmt::format("--set {}={}: {}", override.path, override.value, why));
  };
  rapidjson::Value* at = &document;
  std::string path;  // of *at, in the scenario's error spelling ("scene.objects[0]")
  for (size_t i = 0; i < segments.size(); ++i) {
    const std::string_view segment = segments[i];
    const bool last = i + 1 == segments.size();
    // into an array by index
    if (at->IsArray()) {
      const int64_t index = ParseIndex(segment);
      if (index < 0) fail(fmt::format("{} is an array; '{}' is not an index", path, segment));
      if (index >= static_cast<int64_t>(at->Size())) {
        fail(fmt::format("{} is an array of length {}, so there is no {}[{}]", path, at->Size(), path,
                         index));
      }
      path = fmt::format("{}[{}]", path, index);
      at = &(*at)[static_cast<rapidjson::SizeType>(index)];
      continue;
    }
    // into an object by name, creating the member when it is missing
    if (!at->IsObject()) {
      fail(fmt::format("{} is {}, so it has no field '{}'", path.empty() ? "the scenario" : path,
                       JsonTypeName(*at), segment));
    }
    path = MemberPath(path, segment);
    const rapidjson::Value key(
        rapidjson::StringRef(segment.data(), static_cast<rapidjson::SizeType>(segment.size())));
    auto member = at->FindMember(key);
    if (member == at->MemberEnd()) {
      // a copy of the name that the document owns
      rapidjson::Value name(segment.data(), static_cast<rapidjson::SizeType>(segment.size()), allocator);
      rapidjson::Value empty(last ? rapidjson::kNullType : rapidjson::kObjectType);
      at->AddMember(name, empty, allocator);
      member = at->FindMember(key);
    }
    at = &member->value;
  }
  *at = ParseValue(override.value, document);
}

}  // namespace hapticd::sim
