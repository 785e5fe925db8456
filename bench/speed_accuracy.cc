// Speed against accuracy: for the queries a haptic tick makes near a curved surface
// (closest point, first hit of a segment, the force on a point avatar and on a sphere
// avatar), the time per query and the error against the analytic truth, for every
// representation hapticd offers: the analytic primitive, the convex hull, and meshes at
// five tessellation levels on the native and the Embree backend. Surfaces: a sphere
// (R = 50 mm) and a torus (R = 50 mm, r = 20 mm), which has no primitive.
//
// Also prints what the scene itself chooses for each tessellation at three tolerances
// (scene::ChooseMeshRepresentation), for the chart's check of its rule, and writes the
// inputs, the ground truth and the meshes as .npy so that the peers answer the same
// questions (bench/speed_accuracy_peers.py).
//
//   speed_accuracy [--out DIR] [--seed N] [--quick]
// writes DIR/hapticd.csv (one row per query, surface, representation, level, backend),
// DIR/choices.csv, DIR/manifest.json and DIR/*.npy. --quick: three levels, fewer inputs.

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/speed_accuracy_forces.h"
#include "bench/speed_accuracy_io.h"
#include "bench/speed_accuracy_queries.h"
#include "bench/speed_accuracy_surfaces.h"
#include "server/embree/embree_device.h"
#include "server/scene/scene_builder.h"

namespace hapticd::bench {
namespace {

constexpr double kTolerances[] = {1e-3, 1e-4, 1e-5};

struct Options {
  std::string out = "build/speed_accuracy";
  uint64_t seed = 20261125;
  bool quick = false;
};

// Everything written so far, and where.
struct Outputs {
  std::string dir;
  std::ofstream rows;
  std::ofstream choices;
  std::string manifest_surfaces;  // JSON objects, comma-separated
};

void Log(const char* format, const std::string& what) {
  std::fprintf(stderr, format, what.c_str());
  std::fflush(stderr);
}

void Emit(Outputs& out, const std::vector<ResultRow>& rows) {
  for (const ResultRow& row : rows) {
    out.rows << CsvLine(row) << '\n';
    Log("  %s\n", CsvLine(row));
  }
  out.rows.flush();
}

// A one-object scene: shape at the origin with the chart's material, on the given backend.
std::shared_ptr<const scene::SceneSnapshot> BuildScene(scene::ShapeSpec shape, scene::RayBackend backend,
                                                       const ForceOptions& force) {
  scene::ObjectSpec spec;
  spec.name = "target";
  spec.shape = std::move(shape);
  spec.material.stiffness = force.stiffness;
  spec.ray_backend = backend;
  // the hulls of the finest tessellations take every vertex (655,362 for the sphere),
  // past a deployment's default budget
  scene::SceneSettings settings;
  settings.budgets.max_points_per_convex = std::numeric_limits<std::size_t>::max();
  scene::SceneBuilder builder(settings);
  builder.Add(spec);
  return builder.Build(1);
}

// A tessellation as a mesh spec that stays a mesh.
scene::MeshSpec PinnedMesh(const geometry::TriangleMesh& mesh) {
  scene::MeshSpec spec;
  spec.vertices = mesh.vertices();
  spec.triangles = mesh.triangles();
  spec.pin = scene::Representation::kMesh;
  return spec;
}

void WriteChoice(Outputs& out, const AnalyticSurface& surface, int level, int triangles,
                 const std::string& tolerance, const scene::RepresentationChoice& choice) {
  char line[160];
  std::snprintf(line, sizeof(line), "%s,%d,%d,%s,%s,%.6g,", surface.name().c_str(), level, triangles,
                tolerance.c_str(), std::string(scene::RepresentationName(choice.chosen)).c_str(),
                choice.error_bound);
  out.choices << line << CsvQuoted(choice.reason) << '\n';
}

// What the scene makes of this tessellation: each cheaper candidate pinned (its proven
// bound against the mesh: which ones a tolerance admits), then its own choice at each
// tolerance.
void RecordChoices(Outputs& out, const AnalyticSurface& surface, int level,
                   const std::shared_ptr<const geometry::TriangleMesh>& mesh) {
  const int triangles = mesh->num_triangles();
  for (scene::Representation pin : {scene::Representation::kSphere, scene::Representation::kBox,
                                     scene::Representation::kCapsule, scene::Representation::kConvex}) {
    // a pin whose error has no proven bound (a primitive around the torus) is refused:
    // no row, which the chart reads as an infinite bound
    try {
      const scene::RepresentedMesh pinned = scene::ChooseMeshRepresentation(mesh, 1, pin);
      WriteChoice(out, surface, level, triangles, "pinned", pinned.choice);
    } catch (const std::invalid_argument&) {
    }
  }
  for (double tolerance : kTolerances) {
    const scene::RepresentationChoice choice = scene::ChooseMeshRepresentation(mesh, tolerance).choice;
    char text[16];
    std::snprintf(text, sizeof(text), "%g", tolerance);
    WriteChoice(out, surface, level, triangles, text, choice);
    std::printf("scene choice: %s level %d (%d triangles), tolerance %g m -> %s (bound %.3g m)\n",
                surface.name().c_str(), level, triangles, tolerance,
                std::string(scene::RepresentationName(choice.chosen)).c_str(), choice.error_bound);
  }
  out.choices.flush();
  std::fflush(stdout);
}

// The inputs and truth, for the peers.
void WriteInputs(const std::string& dir, const std::string& name, const QueryInputs& in) {
  WriteNpy(dir + "/" + name + "_points.npy", in.points);
  WriteNpy(dir + "/" + name + "_true_closest.npy", in.true_closest);
  WriteNpy(dir + "/" + name + "_segment_p.npy", in.segment_p);
  WriteNpy(dir + "/" + name + "_segment_q.npy", in.segment_q);
  WriteNpy(dir + "/" + name + "_true_hit.npy", in.true_hit);
}

void WriteMesh(const std::string& path_stem, const geometry::TriangleMesh& mesh) {
  WriteNpy(path_stem + "_vertices.npy", mesh.vertices());
  std::vector<int32_t> indices;
  indices.reserve(3 * mesh.triangles().size());
  for (const auto& t : mesh.triangles()) indices.insert(indices.end(), {t[0], t[1], t[2]});
  WriteNpy(path_stem + "_triangles.npy", indices, {mesh.num_triangles(), 3});
}

void MeasureSurface(const AnalyticSurface& surface, const Options& options, Outputs& out,
                    std::mt19937_64& rng) {
  const std::string name = surface.name();
  InputOptions input_options;
  if (options.quick) input_options.num_points = input_options.num_segments = 500;
  const QueryInputs inputs = MakeQueryInputs(surface, input_options, rng);
  WriteInputs(out.dir, name, inputs);
  const TimingOptions timing;
  const ForceOptions force;
  const auto device = std::make_shared<const embree::EmbreeDevice>();

  // the analytic primitive, where hapticd has one
  if (surface.kind == SurfaceKind::kSphere) {
    Log("%s: primitive\n", name);
    Emit(out, MeasurePrimitiveQueries(surface, inputs, timing));
    const auto scene = BuildScene(scene::SphereShape{surface.radius}, scene::RayBackend::kNative, force);
    Emit(out, MeasureForces(*scene, inputs, force, timing,
                            MakeHapticdRow(name, "primitive", -1, 0, "native")));
  } else {
    Log("%s: no analytic primitive in hapticd (its shapes: sphere, box, capsule, plane, convex, "
        "mesh); hull and meshes only\n", name);
  }

  std::string levels_json;
  const int num_levels = options.quick ? 3 : kNumLevels;
  for (int level = 0; level < num_levels; ++level) {
    const auto mesh = std::make_shared<const geometry::TriangleMesh>(MakeTessellation(surface, level));
    Log("%s\n", name + ": level " + std::to_string(level) + ", " + std::to_string(mesh->num_triangles()) +
                    " triangles");
    const std::string stem = name + "_L" + std::to_string(level);
    WriteMesh(out.dir + "/" + stem, *mesh);
    levels_json += std::string(levels_json.empty() ? "" : ", ") + "{\"level\": " +
                   std::to_string(level) + ", \"triangles\": " + std::to_string(mesh->num_triangles()) +
                   ", \"stem\": \"" + stem + "\"}";
    RecordChoices(out, surface, level, mesh);

    // the hull of the tessellation's vertices
    const auto hull_scene =
        BuildScene(scene::ConvexSpec{mesh->vertices()}, scene::RayBackend::kNative, force);
    const auto& hull = std::get<scene::ConvexShape>(hull_scene->object(0).shape);
    const auto hull_faces = static_cast<int64_t>(hull.hull->faces.size());
    Emit(out, MeasureHullQueries(surface, level, hull, inputs, timing));
    Emit(out, MeasureForces(*hull_scene, inputs, force, timing,
                            MakeHapticdRow(name, "hull", level, hull_faces, "native")));

    // the mesh, on each backend (the queries use the Embree scene's BVH for native)
    const int triangles = mesh->num_triangles();
    const auto embree_scene = BuildScene(PinnedMesh(*mesh), scene::RayBackend::kEmbree, force);
    const auto& shape = std::get<scene::MeshShape>(embree_scene->object(0).shape);
    const MeshBackends backends{shape.bvh, shape.embree,
                                std::make_shared<const embree::EmbreeTriangleScene>(device, mesh)};
    Emit(out, MeasureMeshQueries(surface, level, backends, inputs, timing));
    Emit(out, MeasureForces(*embree_scene, inputs, force, timing,
                            MakeHapticdRow(name, "mesh", level, triangles, "embree")));
    const auto native_scene = BuildScene(PinnedMesh(*mesh), scene::RayBackend::kNative, force);
    Emit(out, MeasureForces(*native_scene, inputs, force, timing,
                            MakeHapticdRow(name, "mesh", level, triangles, "native")));
  }

  char surface_json[512];
  std::snprintf(surface_json, sizeof(surface_json),
                "{\"name\": \"%s\", \"radius\": %.17g, \"tube_radius\": %.17g, \"has_primitive\": %s, "
                "\"levels\": [",
                name.c_str(), surface.radius, surface.kind == SurfaceKind::kTorus ? surface.tube_radius : 0.0,
                surface.kind == SurfaceKind::kSphere ? "true" : "false");
  out.manifest_surfaces += std::string(out.manifest_surfaces.empty() ? "" : ",\n  ") + surface_json +
                           levels_json + "]}";
}

void WriteManifest(const Outputs& out, const Options& options, const ForceOptions& force) {
  const TimingOptions timing;
  std::ofstream manifest(out.dir + "/manifest.json");
  manifest << "{\"seed\": " << options.seed << ", \"quick\": " << (options.quick ? "true" : "false")
           << ", \"stiffness\": " << force.stiffness << ", \"avatar_radius\": " << force.avatar_radius
           << ", \"tolerances\": [1e-3, 1e-4, 1e-5]"
           << ", \"timing\": {\"min_reps\": " << timing.min_reps << ", \"max_reps\": " << timing.max_reps
           << ", \"budget_s\": " << timing.budget_s << "},\n \"surfaces\": [\n  " << out.manifest_surfaces
           << "]}\n";
}

int Run(const Options& options) {
  std::filesystem::create_directories(options.out);
  Outputs out;
  out.dir = options.out;
  out.rows.open(out.dir + "/hapticd.csv");
  out.choices.open(out.dir + "/choices.csv");
  out.rows << CsvHeader() << '\n';
  out.choices << "surface,level,triangles,tolerance,chosen,error_bound,reason\n";
  std::mt19937_64 rng(options.seed);
  AnalyticSurface sphere;
  sphere.kind = SurfaceKind::kSphere;
  AnalyticSurface torus;
  torus.kind = SurfaceKind::kTorus;
  MeasureSurface(sphere, options, out, rng);
  MeasureSurface(torus, options, out, rng);
  WriteManifest(out, options, ForceOptions{});
  return out.rows && out.choices ? 0 : 1;
}

}  // namespace
}  // namespace hapticd::bench

int main(int argc, char** argv) {
  hapticd::bench::Options options;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) {
      options.out = argv[++i];
    } else if (!std::strcmp(argv[i], "--seed") && i + 1 < argc) {
      options.seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (!std::strcmp(argv[i], "--quick")) {
      options.quick = true;
    } else {
      std::fprintf(stderr, "usage: %s [--out DIR] [--seed N] [--quick]\n", argv[0]);
      return 2;
    }
  }
  try {
    return hapticd::bench::Run(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "speed_accuracy: %s\n", e.what());
    return 1;
  }
}
