// Leak rates of raw Embree and of hapticd's Embree backend on the same segments:
// segments aimed exactly through every vertex and every edge midpoint of a few closed
// meshes (one small and far from the origin), from outside to just inside, in
// directions within 69 degrees ("steep") or 89 degrees ("grazing") of the feature's
// normal. A leak is a segment the exact native query hits where the answer misses, or
// hits further on than float rounding explains (IsLeak): a proxy would pop through.
// Raw Embree is measured with RTC_SCENE_FLAG_ROBUST on and off; the backend has no
// such switch (its exact callbacks decide, see embree_mesh.h).
//
// Usage: embree_leak_rate [segments per target, default 8] [seed, default 1]
// Prints one JSON object on stdout.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "server/embree/aimed_segments.h"
#include "server/embree/embree_device.h"
#include "server/embree/embree_mesh.h"
#include "server/embree/embree_segment_queries.h"
#include "server/embree/embree_triangle_scene.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/mesh_queries.h"

namespace hapticd::embree {
namespace {

using geometry::SegmentMeshHit;

// Answers compared with the exact native ones.
struct Tally {
  bool float_answers = false;  // t may differ by FloatRoundingSlack; else must be equal
  int leaks = 0;               // exact hits missed, or hit only further on
  int false_hits = 0;          // hits where the exact answer misses
  int differences = 0;         // a different hit/miss, or t beyond the tolerance
  void Add(const AimedSegment& s, const SegmentMeshHit& exact, const SegmentMeshHit& answer) {
    leaks += IsLeak(exact, answer, s.p, s.q) ? 1 : 0;
    false_hits += (!exact.hit && answer.hit) ? 1 : 0;
    const double tolerance = float_answers ? FloatRoundingSlack(s.p, s.q) : 0.0;
    const bool same = exact.hit == answer.hit &&
                      (!exact.hit || std::abs(exact.t - answer.t) * (s.q - s.p).norm() <= tolerance);
    differences += same ? 0 : 1;
  }
};

struct NamedMesh {
  std::string name;
  std::shared_ptr<const geometry::TriangleMesh> mesh;
};

// The mesh moved by t (a small object far from the origin, as in a world frame).
geometry::TriangleMesh Translated(const geometry::TriangleMesh& mesh, const geometry::Vector3& t) {
  std::vector<geometry::Vector3> vertices;
  for (const geometry::Vector3& v : mesh.vertices()) vertices.push_back(v + t);
  return geometry::TriangleMesh(vertices, mesh.triangles());
}

// One tally as a JSON object; the rate is per exact hit.
std::string TallyJson(const Tally& t, int exact_hits) {
  char text[256];
  std::snprintf(text, sizeof(text),
                "{\"leaks\": %d, \"leak_rate\": %.6f, \"false_hits\": %d, \"differences\": %d}",
                t.leaks, exact_hits > 0 ? static_cast<double>(t.leaks) / exact_hits : 0.0,
                t.false_hits, t.differences);
  return text;
}

// Measures every mesh and direction set, prints the JSON; exit status 1 if the backend leaked.
int Run(int per_target, unsigned seed) {
  auto share = [](geometry::TriangleMesh m) {
    return std::make_shared<const geometry::TriangleMesh>(std::move(m));
  };
  const std::vector<NamedMesh> meshes = {
      {"icosphere_f9", share(geometry::MakeIcosphere(9, 1.0))},
      {"icosphere_f40", share(geometry::MakeIcosphere(40, 0.05))},
      {"torus_48x24", share(geometry::MakeTorus(1.0, 0.35, 48, 24))},
      {"box_8", share(geometry::MakeBoxMesh({0.5, 0.25, 0.125}, 8))},
      {"icosphere_f9_far", share(Translated(geometry::MakeIcosphere(9, 0.05), {10, -5, 3}))},
  };
  // directions within this angle of the feature's normal: steep, and up to grazing
  const std::pair<const char*, double> direction_sets[] = {{"steep", 1.2}, {"grazing", 1.55}};
  auto device = std::make_shared<const EmbreeDevice>();
  std::mt19937_64 rng(seed);
  AimedSegmentOptions options;
  options.per_target = per_target;

  Tally total_robust{.float_answers = true}, total_fast{.float_answers = true};
  Tally total_backend{.float_answers = false};
  int total_segments = 0, total_hits = 0;
  std::string mesh_json;
  for (const NamedMesh& named : meshes) {
    const auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeMesh backend(device, bvh);
    const EmbreeTriangleScene robust(device, named.mesh, {.robust = true});
    const EmbreeTriangleScene fast(device, named.mesh, {.robust = false});
    for (const auto& [directions, max_angle] : direction_sets) {
      options.max_angle = max_angle;
      const std::vector<AimedSegment> segments = MakeAimedSegments(*named.mesh, options, rng);

      // every segment through the exact oracle and the three Embree paths
      Tally t_robust{.float_answers = true}, t_fast{.float_answers = true};
      Tally t_backend{.float_answers = false};
      int hits = 0;
      for (const AimedSegment& s : segments) {
        const SegmentMeshHit exact = geometry::FindFirstSegmentHit(*bvh, s.p, s.q);
        hits += exact.hit ? 1 : 0;
        t_robust.Add(s, exact, CastSegmentUnconfirmed(robust, s.p, s.q));
        t_fast.Add(s, exact, CastSegmentUnconfirmed(fast, s.p, s.q));
        t_backend.Add(s, exact, FindFirstSegmentHit(backend, s.p, s.q));
      }
      for (auto [total, part] : {std::pair{&total_robust, &t_robust}, std::pair{&total_fast, &t_fast},
                                 std::pair{&total_backend, &t_backend}}) {
        total->leaks += part->leaks;
        total->false_hits += part->false_hits;
        total->differences += part->differences;
      }
      total_segments += static_cast<int>(segments.size());
      total_hits += hits;
      if (!mesh_json.empty()) mesh_json += ",\n";
      mesh_json += "    {\"mesh\": \"" + named.name + "\", \"triangles\": " +
                   std::to_string(named.mesh->num_triangles()) + ", \"directions\": \"" +
                   directions + "\", \"segments\": " + std::to_string(segments.size()) +
                   ", \"exact_hits\": " + std::to_string(hits) +
                   ",\n     \"raw_embree_robust\": " + TallyJson(t_robust, hits) +
                   ",\n     \"raw_embree_not_robust\": " + TallyJson(t_fast, hits) +
                   ",\n     \"backend\": " + TallyJson(t_backend, hits) + "}";
    }
  }
  std::printf("{\n  \"embree_version\": \"%s\",\n  \"segments_per_target\": %d,\n  \"seed\": %u,\n",
              RTC_VERSION_STRING, per_target, seed);
  std::printf("  \"cases\": [\n%s\n  ],\n", mesh_json.c_str());
  std::printf("  \"total\": {\"segments\": %d, \"exact_hits\": %d,\n", total_segments, total_hits);
  std::printf("    \"raw_embree_robust\": %s,\n", TallyJson(total_robust, total_hits).c_str());
  std::printf("    \"raw_embree_not_robust\": %s,\n", TallyJson(total_fast, total_hits).c_str());
  std::printf("    \"backend\": %s}\n}\n", TallyJson(total_backend, total_hits).c_str());
  return total_backend.leaks == 0 ? 0 : 1;
}

}  // namespace
}  // namespace hapticd::embree

int main(int argc, char** argv) {
  const int per_target = argc > 1 ? std::atoi(argv[1]) : 8;
  const unsigned seed = argc > 2 ? static_cast<unsigned>(std::atoi(argv[2])) : 1u;
  if (per_target < 1) {
    std::fprintf(stderr, "segments per target must be >= 1, got %s\n", argv[1]);
    return 2;
  }
  return hapticd::embree::Run(per_target, seed);
}
