#include "server/geometry/triangle_mesh.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>
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

// One directed edge of a triangle, filed under the smaller of its vertex indices.
struct EdgeEntry {
  int hi;       // the larger vertex index of the edge
  int slot;     // 3 * triangle + edge
  bool upward;  // traversed from the smaller index to the larger
};

// Solid angle (sr) that triangle tri subtends at p, positive where p lies behind the
// face (against its right-handed normal); Van Oosterom & Strackee 1983, whose atan2 form
// stays accurate for tiny and for near-2 pi angles. 0 when p is a corner.
double CalcSolidAngle(const Vector3& p, const Triangle& tri) {
  const Vector3 a = tri.v0 - p, b = tri.v1 - p, c = tri.v2 - p;
  const double la = a.norm(), lb = b.norm(), lc = c.norm();
  const double numerator = a.dot(b.cross(c));
  const double denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
  return 2 * std::atan2(numerator, denominator);
}

// Edges are matched by vertex index. Each directed edge a->b of a non-degenerate
// triangle goes into the bucket of min(a, b) (a counting sort, linear time); inside a
// bucket, which holds only the edges around one vertex, equal max(a, b) are grouped
// by a small sort. visit(first, last) is called once per undirected edge with the
// range of its directed edges.
template <typename Visit>
void ForEachEdgeGroup(const std::vector<TriangleMesh::TriangleIndices>& triangles,
                      const std::vector<int>& which, int num_vertices, Visit visit) {
  std::vector<int> start(num_vertices + 1, 0);
  auto edge_ends = [&](int t, int e) {
    const TriangleMesh::TriangleIndices& f = triangles[t];
    return std::pair<int, int>(f[e], f[(e + 1) % 3]);
  };
  // count edges per bucket, then place them
  for (int t : which) {
    for (int e = 0; e < 3; ++e) {
      const auto [a, b] = edge_ends(t, e);
      ++start[std::min(a, b) + 1];
    }
  }
  for (int v = 0; v < num_vertices; ++v) start[v + 1] += start[v];
  std::vector<EdgeEntry> entries(start[num_vertices]);
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (int t : which) {
    for (int e = 0; e < 3; ++e) {
      const auto [a, b] = edge_ends(t, e);
      entries[fill[std::min(a, b)]++] = {std::max(a, b), 3 * t + e, a < b};
    }
  }
  // group each bucket by the other end
  for (int v = 0; v < num_vertices; ++v) {
    auto first = entries.begin() + start[v];
    auto last = entries.begin() + start[v + 1];
    std::sort(first, last, [](const EdgeEntry& x, const EdgeEntry& y) { return x.hi < y.hi; });
    for (auto group = first; group != last;) {
      auto end = group;
      while (end != last && end->hi == group->hi) ++end;
      visit(group, end);
      group = end;
    }
  }
}

}  // namespace

TriangleMesh::TriangleMesh(std::vector<Vector3> vertices, std::vector<TriangleIndices> triangles)
    : vertices_(std::move(vertices)), triangles_(std::move(triangles)) {
  Validate();
  FindDegenerateTriangles();
  if (nondegenerate_.empty()) {
    throw std::invalid_argument("mesh has no triangle of non-zero area: all " +
                                std::to_string(triangles_.size()) +
                                " triangles are degenerate (collinear or coincident corners)");
  }
  OrientShells();
  ComputeFaceData();
  ComputeEdgeData();
  ComputeVertexNormals();
}

std::string_view MeshClosureName(MeshClosure closure) {
  switch (closure) {
    case MeshClosure::kClosed: return "closed";
    case MeshClosure::kOpen: return "open";
    case MeshClosure::kNonOrientable: return "non-orientable";
    case MeshClosure::kCount: break;
  }
  return "unknown";
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

void TriangleMesh::FindDegenerateTriangles() {
  const int num = num_triangles();
  degenerate_.assign(num, 0);
  nondegenerate_.reserve(num);
  for (int t = 0; t < num; ++t) {
    const Triangle tri = triangle(t);
    // zero area, decided exactly, or too small for a normal (the queries divide by its
    // length): dropped from every query
    const double normal_squared = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).squaredNorm();
    if (IsDegenerateTriangle(tri.v0, tri.v1, tri.v2) || !(normal_squared >= std::numeric_limits<double>::min())) {
      degenerate_[t] = 1;
      continue;
    }
    nondegenerate_.push_back(t);
  }
  DropRepeatedTriangles();
}

void TriangleMesh::ComputeFaceData() {
  face_normals_.assign(num_triangles(), Vector3::Zero());
  signed_volume_ = 0;
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

// Theory of operation. Triangles sharing an edge are neighbours; two neighbours agree
// when they traverse the edge in opposite directions. If every edge has exactly two
// triangles, a flip bit per triangle is propagated over the neighbours (breadth first,
// one connected shell at a time) so that every pair agrees after flipping; a pair that
// cannot agree makes the mesh non-orientable. Each shell is then one closed oriented
// surface with a signed volume. Its nesting depth, the number of other shells that
// enclose it, is the sum of their winding numbers (sum of solid angles / 4 pi, each
// shell counted with its volume made positive) at the centroid of one of its
// triangles; a shell at an even depth bounds a body and must have positive volume, at
// an odd depth a cavity and negative volume. A shell that must change sign has all
// its flip bits inverted. Shells whose box cannot hold that centroid are skipped; past
// kMaxNestingWork box tests and triangle visits the remaining shells count as not
// nested (outward), and nesting_checked() says so.
void TriangleMesh::OrientShells() {
  const int num = num_triangles();
  // the neighbour across each edge slot, and whether the two run the edge the same way
  std::vector<int> neighbour(3 * num, -1);
  std::vector<char> same_way(3 * num, 0);
  bool manifold = true;
  ForEachEdgeGroup(triangles_, nondegenerate_, num_vertices(), [&](auto first, auto last) {
    if (last - first != 2) {
      manifold = false;
      return;
    }
    const EdgeEntry& x = first[0];
    const EdgeEntry& y = first[1];
    neighbour[x.slot] = y.slot / 3;
    neighbour[y.slot] = x.slot / 3;
    same_way[x.slot] = same_way[y.slot] = x.upward == y.upward;
  });
  closure_ = MeshClosure::kOpen;
  if (!manifold) return;

  // flip bits and shells, breadth first
  std::vector<signed char> flip(num, -1);
  std::vector<int> shell_start;  // into order: the triangles of each shell in turn
  std::vector<int> order;
  order.reserve(nondegenerate_.size());
  for (int seed : nondegenerate_) {
    if (flip[seed] >= 0) continue;
    shell_start.push_back(static_cast<int>(order.size()));
    flip[seed] = 0;
    order.push_back(seed);
    for (size_t next = shell_start.back(); next < order.size(); ++next) {
      const int t = order[next];
      for (int e = 0; e < 3; ++e) {
        const int u = neighbour[3 * t + e];
        const signed char wanted = static_cast<signed char>(flip[t] ^ same_way[3 * t + e]);
        if (flip[u] < 0) {
          flip[u] = wanted;
          order.push_back(u);
        } else if (flip[u] != wanted) {
          closure_ = MeshClosure::kNonOrientable;
          return;
        }
      }
    }
  }
  const int num_shells = static_cast<int>(shell_start.size());
  shell_start.push_back(static_cast<int>(order.size()));
  closure_ = MeshClosure::kClosed;
  num_shells_ = num_shells;

  // each shell's corners after flipping, its volume (six times, about its first corner)
  auto corners = [&](int t) {
    Triangle tri = triangle(t);
    if (flip[t]) std::swap(tri.v1, tri.v2);
    return tri;
  };
  std::vector<double> volume(num_shells, 0);
  std::vector<Aabb> box(num_shells);
  for (int s = 0; s < num_shells; ++s) {
    const Vector3 origin = vertices_[triangles_[order[shell_start[s]]][0]];
    for (int k = shell_start[s]; k < shell_start[s + 1]; ++k) {
      const Triangle tri = corners(order[k]);
      volume[s] += (tri.v0 - origin).dot((tri.v1 - origin).cross(tri.v2 - origin));
      box[s].Extend(Aabb::OfTriangle(tri));
    }
  }

  // nesting depth of each shell among the others; each box test and each triangle
  // visited counts against the work bound
  constexpr long long kMaxNestingWork = 1LL << 25;
  long long work = 0;
  std::vector<char> cavity(num_shells, 0);
  for (int s = 0; s < num_shells && num_shells > 1 && nesting_checked_; ++s) {
    int depth = 0;
    const Triangle probe = corners(order[shell_start[s]]);
    const Vector3 p = (probe.v0 + probe.v1 + probe.v2) / 3;
    for (int other = 0; other < num_shells && nesting_checked_; ++other) {
      if (other == s || volume[other] == 0) continue;
      if (++work > kMaxNestingWork) nesting_checked_ = false;
      if (!nesting_checked_ || !box[other].Contains(p)) continue;
      work += shell_start[other + 1] - shell_start[other];
      if (work > kMaxNestingWork) {
        nesting_checked_ = false;
        continue;
      }
      double angle = 0;
      for (int k = shell_start[other]; k < shell_start[other + 1]; ++k) {
        angle += CalcSolidAngle(p, corners(order[k]));
      }
      const double winding = (volume[other] > 0 ? 1 : -1) * angle / (4 * std::numbers::pi);
      depth += static_cast<int>(std::lround(winding));
    }
    cavity[s] = depth % 2 != 0;
  }
  // past the work bound: none counts as a cavity, every shell is turned outwards
  if (!nesting_checked_) cavity.assign(num_shells, 0);
  for (int s = 0; s < num_shells; ++s) {
    // a shell enclosing no volume has no side to turn outwards
    if (volume[s] == 0 || (volume[s] < 0) == (cavity[s] != 0)) continue;
    for (int k = shell_start[s]; k < shell_start[s + 1]; ++k) flip[order[k]] ^= 1;
  }

  // rewind: corners 1 and 2 swapped
  for (int t : nondegenerate_) {
    if (!flip[t]) continue;
    std::swap(triangles_[t][1], triangles_[t][2]);
    ++num_rewound_;
  }
}

// Each entry's pseudo-normal is the normalised sum of its edge group's face normals.
void TriangleMesh::ComputeEdgeData() {
  edge_normals_.assign(3 * triangles_.size(), Vector3::Zero());
  ForEachEdgeGroup(triangles_, nondegenerate_, num_vertices(), [&](auto first, auto last) {
    Vector3 sum = Vector3::Zero();
    for (auto it = first; it != last; ++it) sum += face_normals_[it->slot / 3];
    const Vector3 normal = NormalizedOrZero(sum);
    for (auto it = first; it != last; ++it) edge_normals_[it->slot] = normal;
  });
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
