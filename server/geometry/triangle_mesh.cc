#include "server/geometry/triangle_mesh.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "server/geometry/exact_predicates.h"

namespace hapticd::geometry {
namespace {

constexpr int kMaxTriangles = 1 << 28;

// Shortest text that reads back as x ("nan", "inf" and "-inf" included).
std::string FormatDouble(double x) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), x);
  return std::string(buffer, result.ptr);
}

std::string FormatVector(const Vector3& v) {
  return "[" + FormatDouble(v.x()) + ", " + FormatDouble(v.y()) + ", " + FormatDouble(v.z()) +
         "]";
}

// Unit vector along v, or zero where v has no usable direction.
Vector3 NormalizedOrZero(const Vector3& v) {
  const double n = v.norm();
  if (!(n > 0) || !std::isfinite(n)) return Vector3::Zero();
  return v / n;
}

}  // namespace

TriangleMesh::TriangleMesh(std::vector<Vector3> vertices, std::vector<TriangleIndices> triangles)
    : vertices_(std::move(vertices)), triangles_(std::move(triangles)) {
  Validate();
  ComputeFaceData();
  if (nondegenerate_.empty()) {
    throw std::invalid_argument("mesh has no triangle of non-zero area: all " +
                                std::to_string(triangles_.size()) +
                                " triangles are degenerate (collinear or coincident corners)");
  }
  ComputeEdgeData();
  ComputeVertexNormals();
}

const Vector3& TriangleMesh::FeatureNormal(int t, TriangleFeature feature) const {
  const TriangleIndices& f = triangles_[t];
  switch (feature) {
    case TriangleFeature::kVertex0: return vertex_normals_[f[0]];
    case TriangleFeature::kVertex1: return vertex_normals_[f[1]];
    case TriangleFeature::kVertex2: return vertex_normals_[f[2]];
    case TriangleFeature::kEdge01: return edge_normals_[3 * t + 0];
    case TriangleFeature::kEdge12: return edge_normals_[3 * t + 1];
    case TriangleFeature::kEdge20: return edge_normals_[3 * t + 2];
    case TriangleFeature::kFace: break;
  }
  return face_normals_[t];
}

void TriangleMesh::Validate() const {
  // an empty mesh has nothing to query
  if (vertices_.empty() || triangles_.empty()) {
    throw std::invalid_argument("mesh is empty: it has " + std::to_string(vertices_.size()) +
                                " vertices and " + std::to_string(triangles_.size()) +
                                " triangles");
  }
  // every coordinate finite
  for (size_t i = 0; i < vertices_.size(); ++i) {
    if (!vertices_[i].allFinite()) {
      throw std::invalid_argument("vertex " + std::to_string(i) +
                                  " has a non-finite coordinate: " + FormatVector(vertices_[i]));
    }
  }
  // indices are int; 3 per triangle must stay addressable
  if (triangles_.size() > static_cast<size_t>(kMaxTriangles)) {
    throw std::invalid_argument("mesh has " + std::to_string(triangles_.size()) +
                                " triangles; at most " + std::to_string(kMaxTriangles) +
                                " are supported");
  }
  // every index names a vertex
  const long long n = static_cast<long long>(vertices_.size());
  for (size_t t = 0; t < triangles_.size(); ++t) {
    for (int corner : triangles_[t]) {
      if (corner < 0 || corner >= n) {
        throw std::invalid_argument("triangle " + std::to_string(t) + " refers to vertex " +
                                    std::to_string(corner) + " but the mesh has " +
                                    std::to_string(n) + " vertices");
      }
    }
  }
}

void TriangleMesh::ComputeFaceData() {
  const int num = num_triangles();
  degenerate_.assign(num, 0);
  face_normals_.assign(num, Vector3::Zero());
  nondegenerate_.reserve(num);
  signed_volume_ = 0;
  for (int t = 0; t < num; ++t) {
    const Triangle tri = triangle(t);
    // zero area, decided exactly: dropped from every query
    if (IsDegenerateTriangle(tri.v0, tri.v1, tri.v2)) {
      degenerate_[t] = 1;
      continue;
    }
    nondegenerate_.push_back(t);
  }
  DropRepeatedTriangles();
  for (int t : nondegenerate_) {
    const Triangle tri = triangle(t);
    face_normals_[t] = NormalizedOrZero((tri.v1 - tri.v0).cross(tri.v2 - tri.v0));
    signed_volume_ += tri.v0.dot(tri.v1.cross(tri.v2));
    bounds_.Extend(Aabb::OfTriangle(tri));
  }
  // the sum above is six times the volume; divided once
  signed_volume_ /= 6;
}

// Repeats are found by sorting: each triangle's corners ordered by position, then the
// triangles by those corners and index, so that a repeat follows the first of its kind.
// Positions, not indices, decide: two vertices at one point are one corner.
void TriangleMesh::DropRepeatedTriangles() {
  const auto less = [this](int a, int b) {
    const Vector3& p = vertices_[a];
    const Vector3& q = vertices_[b];
    return std::tie(p.x(), p.y(), p.z()) < std::tie(q.x(), q.y(), q.z());
  };
  std::vector<TriangleIndices> corners(nondegenerate_.size());
  for (size_t i = 0; i < nondegenerate_.size(); ++i) {
    corners[i] = triangles_[nondegenerate_[i]];
    std::sort(corners[i].begin(), corners[i].end(), less);
  }
  const auto same = [this](const TriangleIndices& a, const TriangleIndices& b) {
    return vertices_[a[0]] == vertices_[b[0]] && vertices_[a[1]] == vertices_[b[1]] &&
           vertices_[a[2]] == vertices_[b[2]];
  };
  std::vector<int> order(nondegenerate_.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    for (int k = 0; k < 3; ++k) {
      if (less(corners[a][k], corners[b][k])) return true;
      if (less(corners[b][k], corners[a][k])) return false;
    }
    return a < b;
  });
  // a repeat of the triangle before it in that order: dropped like a zero-area one
  for (size_t i = 1; i < order.size(); ++i) {
    if (!same(corners[order[i]], corners[order[i - 1]])) continue;
    degenerate_[nondegenerate_[order[i]]] = 1;
    ++num_repeated_;
  }
  if (num_repeated_ == 0) return;
  std::erase_if(nondegenerate_, [this](int t) { return degenerate_[t] != 0; });
}

// Edges are matched by vertex index. Each directed edge a->b of a non-degenerate
// triangle goes into the bucket of min(a, b) (a counting sort, linear time); inside a
// bucket, which holds only the edges around one vertex, equal max(a, b) are grouped
// by a small sort. A group is a closed-mesh edge when it holds exactly two entries of
// opposite direction; each entry's pseudo-normal is the normalised sum of its group's
// face normals.
void TriangleMesh::ComputeEdgeData() {
  struct Entry {
    int hi;        // the larger vertex index of the edge
    int slot;      // 3 * triangle + edge
    bool upward;   // traversed from the smaller index to the larger
  };
  const int nv = num_vertices();
  std::vector<int> start(nv + 1, 0);
  auto edge_ends = [&](int t, int e) {
    const TriangleIndices& f = triangles_[t];
    return std::pair<int, int>(f[e], f[(e + 1) % 3]);
  };
  // count edges per bucket, then place them
  for (int t : nondegenerate_) {
    for (int e = 0; e < 3; ++e) {
      const auto [a, b] = edge_ends(t, e);
      ++start[std::min(a, b) + 1];
    }
  }
  for (int v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<Entry> entries(start[nv]);
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (int t : nondegenerate_) {
    for (int e = 0; e < 3; ++e) {
      const auto [a, b] = edge_ends(t, e);
      entries[fill[std::min(a, b)]++] = {std::max(a, b), 3 * t + e, a < b};
    }
  }

  // group each bucket by the other end and sum the face normals of each group
  edge_normals_.assign(3 * triangles_.size(), Vector3::Zero());
  closed_ = true;
  for (int v = 0; v < nv; ++v) {
    auto first = entries.begin() + start[v];
    auto last = entries.begin() + start[v + 1];
    std::sort(first, last, [](const Entry& x, const Entry& y) { return x.hi < y.hi; });
    for (auto group = first; group != last;) {
      auto end = group;
      Vector3 sum = Vector3::Zero();
      int ups = 0;
      for (; end != last && end->hi == group->hi; ++end) {
        sum += face_normals_[end->slot / 3];
        ups += end->upward ? 1 : 0;
      }
      // closed needs exactly one triangle on each side, traversing it oppositely
      if (end - group != 2 || ups != 1) closed_ = false;
      const Vector3 normal = NormalizedOrZero(sum);
      for (auto it = group; it != end; ++it) edge_normals_[it->slot] = normal;
      group = end;
    }
  }
}

// The weight of a corner is its angle, atan2(|e1 x e2|, e1 . e2), which stays accurate
// for angles near 0 and pi where acos would not.
void TriangleMesh::ComputeVertexNormals() {
  vertex_normals_.assign(vertices_.size(), Vector3::Zero());
  for (int t : nondegenerate_) {
    const TriangleIndices& f = triangles_[t];
    for (int c = 0; c < 3; ++c) {
      const Vector3& corner = vertices_[f[c]];
      const Vector3 e1 = vertices_[f[(c + 1) % 3]] - corner;
      const Vector3 e2 = vertices_[f[(c + 2) % 3]] - corner;
      const double angle = std::atan2(e1.cross(e2).norm(), e1.dot(e2));
      vertex_normals_[f[c]] += angle * face_normals_[t];
    }
  }
  for (Vector3& n : vertex_normals_) n = NormalizedOrZero(n);
}

}  // namespace hapticd::geometry
