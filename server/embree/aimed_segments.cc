#include "server/embree/aimed_segments.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace hapticd::embree {
namespace {

using geometry::Vector3;

// A unit vector uniform over the cap of directions within max_angle of unit n.
Vector3 RandomDirectionNear(const Vector3& n, double max_angle, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  // an orthonormal frame around n
  const Vector3 helper = std::abs(n.x()) < 0.9 ? Vector3::UnitX() : Vector3::UnitY();
  const Vector3 a = n.cross(helper).normalized();
  const Vector3 b = n.cross(a);
  // uniform on the cap: cos(angle) uniform in [cos(max_angle), 1]
  const double cos_angle = 1 - unit(rng) * (1 - std::cos(max_angle));
  const double sin_angle = std::sqrt(std::max(0.0, 1 - cos_angle * cos_angle));
  const double phi = 2 * std::numbers::pi * unit(rng);
  return cos_angle * n + sin_angle * (std::cos(phi) * a + std::sin(phi) * b);
}

}  // namespace

std::vector<AimedSegment> MakeAimedSegments(const geometry::TriangleMesh& mesh,
                                            const AimedSegmentOptions& options,
                                            std::mt19937_64& rng) {
  const double size = mesh.size();
  std::vector<AimedSegment> segments;
  auto add = [&](const Vector3& target, const Vector3& normal) {
    // a feature without a usable normal (unused vertex) gets no segments
    if (!(normal.norm() > 0.5)) return;
    for (int k = 0; k < options.per_target; ++k) {
      const Vector3 u = RandomDirectionNear(normal, options.max_angle, rng);
      segments.push_back({target + options.reach * size * u, target - options.depth * size * u});
    }
  };

  // every vertex of a non-degenerate triangle
  std::vector<char> used(mesh.num_vertices(), 0);
  for (int t : mesh.nondegenerate_triangles()) {
    for (int v : mesh.triangles()[t]) used[v] = 1;
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (used[v]) add(mesh.vertices()[v], mesh.vertex_pseudo_normal(v));
  }

  // every undirected edge once, at its midpoint, along the edge's pseudo-normal
  std::vector<std::pair<std::pair<int, int>, std::pair<int, int>>> edges;  // (a, b), (t, e)
  for (int t : mesh.nondegenerate_triangles()) {
    const auto& f = mesh.triangles()[t];
    for (int e = 0; e < 3; ++e) {
      const int a = f[e], b = f[(e + 1) % 3];
      edges.push_back({{std::min(a, b), std::max(a, b)}, {t, e}});
    }
  }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size(); ++i) {
    if (i > 0 && edges[i].first == edges[i - 1].first) continue;
    const auto [a, b] = edges[i].first;
    const auto [t, e] = edges[i].second;
    add(0.5 * (mesh.vertices()[a] + mesh.vertices()[b]), mesh.edge_pseudo_normal(t, e));
  }
  return segments;
}

double FloatRoundingSlack(const Vector3& p, const Vector3& q) {
  constexpr double kUlps = 1.0 / (1 << 16);
  return kUlps * (p.cwiseAbs().maxCoeff() + (q - p).cwiseAbs().maxCoeff());
}

bool IsLeak(const geometry::SegmentMeshHit& exact, const geometry::SegmentMeshHit& answer,
            const Vector3& p, const Vector3& q) {
  if (!exact.hit) return false;
  if (!answer.hit) return true;
  return (answer.t - exact.t) * (q - p).norm() > FloatRoundingSlack(p, q);
}

}  // namespace hapticd::embree
