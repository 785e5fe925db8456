#pragma once

// Reading a scenario (../shared/scenarios/FORMAT.md) from JSON into a validated Scenario.
//
// Every field of FORMAT.md is read; a member that is not a known field, a value of the
// wrong type and an impossible value are refused with a ScenarioError that names the
// field by its path. What may be left out, and its default:
//   - channel (no delay, jitter or loss, seed 1) and control (passivity off), and each of
//     their fields;
//   - scene.tolerance (SceneSettings' 1e-4 m);
//   - an object's rotation (identity); its material's damping and frictions (0) and
//     force_shading (true); stiffness is required;
//   - avatar.radius for a point (0), avatar.force_shading (false);
//   - device.position_resolution (0), device.virtual_mass and device.virtual_damping
//     (AdmittanceSettings' 1 kg and 20 N·s/m);
// everything else is required. Extensions (bench/scenarios/README.md): an object's
// "motion" {"velocity", "angular_velocity"} (both optional, default 0) makes it
// kinematic; a mesh object's "representation" pins its representation and its
// "ray_backend" ("native" or "embree") picks its query backend; the material's
// "force_shading"; the scene's "tolerance".

#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "server/sim/scenario.h"

namespace hapticd::sim {

// The longest run accepted, in ticks.
inline constexpr int64_t kMaxTicks = 1'000'000'000;

// Parses json, applies the overrides ("key.path=value", scenario_overrides.h) in order,
// then reads and validates the result. Relative mesh file paths are resolved against
// base_dir. Throws ScenarioError.
Scenario ParseScenario(std::string_view json, const std::filesystem::path& base_dir,
                       std::span<const std::string> overrides = {});

// ParseScenario of the file at path, with mesh files relative to its folder. Throws
// ScenarioError, also when the file cannot be read ("the scenario file does not exist";
// the caller names the file).
Scenario LoadScenario(const std::filesystem::path& path, std::span<const std::string> overrides = {});

// A scene on its own, as a scene file holds it: {"scene": {...}} with the scenario
// format's scene section (a whole scenario is accepted too; its scene is read).
struct SceneFile {
  scene::SceneSettings settings;
  std::vector<scene::ObjectSpec> objects;
};
SceneFile ParseSceneFile(std::string_view json, const std::filesystem::path& base_dir);
// ParseSceneFile of the file at path, meshes relative to its folder. Throws ScenarioError.
SceneFile LoadSceneFile(const std::filesystem::path& path);

}  // namespace hapticd::sim
