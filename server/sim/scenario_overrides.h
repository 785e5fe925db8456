#pragma once

// `--set key.path=value`: one field of a scenario's JSON replaced before validation, so
// that a sweep needs no file per point. The path is dotted; on an array a segment is an
// index ("scene.objects.0.material.stiffness=5000"). The value is read as JSON when it
// parses as JSON ("5000", "true", "[0, 0, 0.02]"), else taken as a string
// ("penalty"). A member that does not exist yet is created (and an intermediate object
// with it), so that an optional field the file leaves out can be set
// ("channel.delay_ms=20"); a misspelt one is then refused by the scenario's validation
// as an unknown field. An array index out of range, or a path through a number or
// string, is refused here.

#include <rapidjson/document.h>

#include <string>
#include <string_view>

namespace hapticd::sim {

struct Override {
  std::string path;   // "scene.objects.0.material.stiffness"
  std::string value;  // "5000"
};

// Splits "key.path=value" at its first '='. Throws ScenarioError when there is no '=' or
// the path is empty or has an empty segment.
Override ParseOverride(std::string_view text);

// Sets the field at override.path of document (a JSON object) to override.value.
// Throws ScenarioError ("--set scene.objects.5.name=x: scene.objects is an array of
// length 2, so there is no scene.objects[5]").
void ApplyOverride(rapidjson::Document& document, const Override& override);

}  // namespace hapticd::sim
