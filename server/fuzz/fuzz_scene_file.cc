// The scene-file reader (sim::ParseSceneFile, what `hapticd --scene FILE` loads) and the
// scene builder it feeds, as server/app/hapticd_main.cc runs them.
//
// Checks: parsing either throws ScenarioError or gives settings with a finite tolerance
// > 0 and objects with unique names that are valid UTF-8 (the control channel's replies
// carry them in protobuf strings; RapidJSON's writer, validating, is the oracle);
// building those objects either stops at a SceneError or gives a snapshot whose objects
// pass CheckSnapshot (scene_checks.h). Any other exception escapes and is reported as a
// crash. Mesh files named by the input are read relative to bench/scenarios (where the
// seeds' meshes/icosphere.obj is).

#include <cmath>
#include <set>
#include <string>
#include <string_view>

#include <rapidjson/stringbuffer.h>
#include <rapidjson/writer.h>

#include "server/fuzz/scene_checks.h"
#include "server/scene/scene_builder.h"
#include "server/sim/scenario_parser.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace hapticd;
  const std::string_view json(reinterpret_cast<const char*>(data), size);
  sim::SceneFile file;
  try {
    file = sim::ParseSceneFile(json, HAPTICD_FUZZ_SCENARIO_DIR);
  } catch (const sim::ScenarioError&) {
    return 0;
  }
  FUZZ_CHECK(std::isfinite(file.settings.tolerance) && file.settings.tolerance > 0, "scene.tolerance is %g",
             file.settings.tolerance);
  std::set<std::string> names;
  for (const scene::ObjectSpec& spec : file.objects) {
    names.insert(spec.name);
    rapidjson::StringBuffer buffer;
    rapidjson::Writer<rapidjson::StringBuffer, rapidjson::UTF8<>, rapidjson::UTF8<>, rapidjson::CrtAllocator,
                      rapidjson::kWriteValidateEncodingFlag>
        writer(buffer);
    FUZZ_CHECK(writer.String(spec.name.data(), static_cast<rapidjson::SizeType>(spec.name.size())),
               "the reader accepted a name that is not UTF-8 (%zu bytes)", spec.name.size());
  }

  scene::SceneBuilder builder(file.settings);
  try {
    for (const scene::ObjectSpec& spec : file.objects) builder.Add(spec);
  } catch (const scene::SceneError& error) {
    FUZZ_CHECK(error.what()[0] != '\0', "a SceneError without a message");
    return 0;
  }
  FUZZ_CHECK(names.size() == file.objects.size(), "the builder accepted two objects of one name");
  fuzz::CheckSnapshot(*builder.Build(1));
  return 0;
}
