#include "server/geometry/convex_hull.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numeric>

#include "server/geometry/exact_predicates.h"

namespace hapticd::geometry {
namespace {

constexpr int kNone = -1;

// The first affinely independent points found: dimension + 1 of them are valid.
struct InitialSimplex {
  int dimension = -1;
  std::array<int, 4> index = {kNone, kNone, kNone, kNone};
};

// Picks well-spread points (extremes along the widest axis, then the farthest from
// their line and plane, in floating point) and confirms each step exactly; when the
// farthest candidate is exactly degenerate, scans for any point that is not.
InitialSimplex FindInitialSimplex(std::span<const Vector3> p) {
  InitialSimplex s;
  const int n = static_cast<int>(p.size());
  std::array<int, 3> lo = {0, 0, 0}, hi = {0, 0, 0};
  for (int i = 1; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      if (p[i][k] < p[lo[k]][k]) lo[k] = i;
      if (p[i][k] > p[hi[k]][k]) hi[k] = i;
    }
  }
  int axis = 0;
  for (int k = 1; k < 3; ++k) {
    if (p[hi[k]][k] - p[lo[k]][k] > p[hi[axis]][axis] - p[lo[axis]][axis]) axis = k;
  }
  s.index[0] = lo[axis];
  s.index[1] = hi[axis];
  s.dimension = 0;
  // all points coincide: the widest extent is zero
  if (!(p[hi[axis]][axis] > p[lo[axis]][axis])) return s;
  s.dimension = 1;

  // third point: farthest from the line, exactly off it
  const Vector3& a = p[s.index[0]];
  const Vector3& b = p[s.index[1]];
  int best = kNone;
  double best_d = 0;
  for (int i = 0; i < n; ++i) {
    const double d = (p[i] - a).cross(b - a).squaredNorm();
    if (d > best_d) best_d = d, best = i;
  }
  if (best == kNone || IsDegenerateTriangle(a, b, p[best])) {
    best = kNone;
    for (int i = 0; i < n && best == kNone; ++i) {
      if (!IsDegenerateTriangle(a, b, p[i])) best = i;
    }
  }
  if (best == kNone) return s;
  s.index[2] = best;
  s.dimension = 2;

  // fourth point: farthest from the plane, exactly off it
  const Vector3& c = p[best];
  const Vector3 normal = (b - a).cross(c - a);
  best = kNone;
  best_d = 0;
  for (int i = 0; i < n; ++i) {
    const double d = std::abs(normal.dot(p[i] - a));
    if (d > best_d) best_d = d, best = i;
  }
  if (best == kNone || Orient3d(a, b, c, p[best]) == 0) {
    best = kNone;
    for (int i = 0; i < n && best == kNone; ++i) {
      if (Orient3d(a, b, c, p[i]) != 0) best = i;
    }
  }
  if (best == kNone) return s;
  s.index[3] = best;
  s.dimension = 3;
  return s;
}

// Fills edges' adjacency lists (compressed) from the edge list.
void BuildAdjacency(ConvexHull& hull) {
  const int n = hull.num_vertices();
  std::vector<int> degree(n, 0);
  for (const auto& e : hull.edges) ++degree[e[0]], ++degree[e[1]];
  hull.adjacency_start.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) hull.adjacency_start[v + 1] = hull.adjacency_start[v] + degree[v];
  hull.adjacency.assign(hull.adjacency_start[n], kNone);
  std::vector<int> fill(hull.adjacency_start.begin(), hull.adjacency_start.end() - 1);
  for (const auto& e : hull.edges) {
    hull.adjacency[fill[e[0]]++] = e[1];
    hull.adjacency[fill[e[1]]++] = e[0];
  }
}

// Copies the chosen input points into hull.vertices, in the given order.
void SetVertices(std::span<const Vector3> p, const std::vector<int>& chosen, ConvexHull& hull) {
  hull.input_index = chosen;
  hull.vertices.clear();
  for (int i : chosen) hull.vertices.push_back(p[i]);
}

// Lower-dimensional hulls. A point: one vertex, no edges.
ConvexHull BuildPointHull(std::span<const Vector3> p, int i) {
  ConvexHull hull;
  hull.dimension = 0;
  SetVertices(p, {i}, hull);
  BuildAdjacency(hull);
  return hull;
}

// Collinear points: the extremes along the widest axis are the segment's ends (exact:
// the points are ordered along the line in that coordinate).
ConvexHull BuildSegmentHull(std::span<const Vector3> p, int i0, int i1) {
  ConvexHull hull;
  hull.dimension = 1;
  SetVertices(p, {i0, i1}, hull);
  hull.edges = {{0, 1}};
  hull.axis = (p[i1] - p[i0]).normalized();
  BuildAdjacency(hull);
  return hull;
}

// Drops coordinate k, keeping the cyclic order, so Orient2d of the projections is the
// sign of the k-th component of the 3D triangle normal.
Vector2 DropAxis(const Vector3& v, int k) { return {v[(k + 1) % 3], v[(k + 2) % 3]}; }

// Coplanar points: Andrew's monotone chain in a projection that is exactly
// non-degenerate for the plane; collinear boundary points are dropped.
ConvexHull BuildPolygonHull(std::span<const Vector3> p, const InitialSimplex& s) {
  const Vector3& a = p[s.index[0]];
  const Vector3& b = p[s.index[1]];
  const Vector3& c = p[s.index[2]];
  const Vector3 normal = (b - a).cross(c - a);
  Eigen::Index largest = 0;
  normal.cwiseAbs().maxCoeff(&largest);
  int k = static_cast<int>(largest);
  // if rounding chose an axis the plane projects onto a line, take one that works
  for (int tries = 0; tries < 3; ++tries, k = (k + 1) % 3) {
    if (Orient2d(DropAxis(a, k), DropAxis(b, k), DropAxis(c, k)) != 0) break;
  }
  std::vector<int> order(p.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int i, int j) {
    const Vector2 u = DropAxis(p[i], k), v = DropAxis(p[j], k);
    return u.x() < v.x() || (u.x() == v.x() && u.y() < v.y());
  });
  std::vector<int> chain;
  const auto turns_left = [&](int i, int j, int m) {
    return Orient2d(DropAxis(p[i], k), DropAxis(p[j], k), DropAxis(p[m], k)) > 0;
  };
  // lower chain left to right, then upper chain right to left
  for (int pass = 0; pass < 2; ++pass) {
    const size_t base = chain.size();
    for (size_t t = 0; t < order.size(); ++t) {
      const int i = pass == 0 ? order[t] : order[order.size() - 1 - t];
      while (chain.size() >= base + 2 && !turns_left(chain[chain.size() - 2], chain.back(), i)) {
        chain.pop_back();
      }
      chain.push_back(i);
    }
    chain.pop_back();  // the last point starts the other chain
  }
  ConvexHull hull;
  hull.dimension = 2;
  SetVertices(p, chain, hull);
  const int m = hull.num_vertices();
  for (int i = 1; i + 1 < m; ++i) hull.faces.push_back({0, i, i + 1});
  for (int i = 0; i < m; ++i) hull.edges.push_back({std::min(i, (i + 1) % m), std::max(i, (i + 1) % m)});
  hull.axis = (hull.vertices[1] - hull.vertices[0]).cross(hull.vertices[2] - hull.vertices[0]).normalized();
  hull.face_normals.assign(hull.faces.size(), hull.axis);
  BuildAdjacency(hull);
  return hull;
}

// Quickhull state for a full-dimensional hull. Faces are triangles of input point
// indices; adj[k] is the face across the edge v[k] -> v[k + 1]. Each face keeps the
// points strictly outside it as a linked list through next_outside.
struct QuickhullFace {
  std::array<int, 3> v;
  std::array<int, 3> adj = {kNone, kNone, kNone};
  Vector3 normal;  // unnormalized, rounded: only ranks the points outside this face
  int outside_head = kNone;
  int farthest = kNone;
  double farthest_distance = 0;
  int mark = 0;
  bool alive = true;
};

class Quickhull {
 public:
  explicit Quickhull(std::span<const Vector3> points)
      : p_(points), next_outside_(points.size(), kNone) {}

  // Returns false when the predicates contradicted each other (possible only on input
  // outside the preconditions); the caller then reports an empty hull.
  bool Run(const InitialSimplex& s, ConvexHull& hull);

 private:
  int AddFace(int a, int b, int c) {
    QuickhullFace f;
    f.v = {a, b, c};
    f.normal = (p_[b] - p_[a]).cross(p_[c] - p_[a]);
    faces_.push_back(f);
    return static_cast<int>(faces_.size()) - 1;
  }
  bool Sees(int f, int i) const {
    const auto& v = faces_[f].v;
    return Orient3d(p_[v[0]], p_[v[1]], p_[v[2]], p_[i]) > 0;
  }
  // Puts point i on the outside list of the first listed face that sees it.
  void Assign(int i, std::span<const int> candidates) {
    for (int f : candidates) {
      if (!Sees(f, i)) continue;
      QuickhullFace& face = faces_[f];
      next_outside_[i] = face.outside_head;
      face.outside_head = i;
      const double d = face.normal.dot(p_[i] - p_[face.v[0]]);
      if (face.farthest == kNone || d > face.farthest_distance) face.farthest = i, face.farthest_distance = d;
      return;
    }
  }
  // Makes face f's edge b -> a point to face g (f had the edge b -> a).
  bool Link(int f, int a, int b, int g) {
    auto& face = faces_[f];
    for (int k = 0; k < 3; ++k) {
      if (face.v[k] == b && face.v[(k + 1) % 3] == a) return face.adj[k] = g, true;
    }
    return false;
  }
  bool AddPoint(int eye, int start);
  void Output(ConvexHull& hull) const;

  std::span<const Vector3> p_;
  std::vector<QuickhullFace> faces_;
  std::vector<int> next_outside_;
  int stamp_ = 0;
};

bool Quickhull::Run(const InitialSimplex& s, ConvexHull& hull) {
  // the initial tetrahedron, wound so that every face looks away from the fourth point
  std::array<int, 4> t = s.index;
  if (Orient3d(p_[t[0]], p_[t[1]], p_[t[2]], p_[t[3]]) > 0) std::swap(t[1], t[2]);
  const std::array<std::array<int, 3>, 4> tetra = {
      {{t[0], t[1], t[2]}, {t[0], t[3], t[1]}, {t[1], t[3], t[2]}, {t[2], t[3], t[0]}}};
  for (const auto& f : tetra) AddFace(f[0], f[1], f[2]);
  for (int f = 0; f < 4; ++f) {
    for (int g = 0; g < 4; ++g) {
      for (int k = 0; k < 3 && f != g; ++k) Link(g, faces_[f].v[k], faces_[f].v[(k + 1) % 3], f);
    }
  }
  const std::array<int, 4> all = {0, 1, 2, 3};
  for (int i = 0; i < static_cast<int>(p_.size()); ++i) {
    if (i != t[0] && i != t[1] && i != t[2] && i != t[3]) Assign(i, all);
  }
  // each step removes its eye point from the outside lists, so the loop ends
  std::vector<int> work = {0, 1, 2, 3};
  while (!work.empty()) {
    const int f = work.back();
    work.pop_back();
    if (!faces_[f].alive || faces_[f].farthest == kNone) continue;
    const size_t first_new = faces_.size();
    if (!AddPoint(faces_[f].farthest, f)) return false;
    for (size_t g = first_new; g < faces_.size(); ++g) {
      if (faces_[g].farthest != kNone) work.push_back(static_cast<int>(g));
    }
  }
  Output(hull);
  return true;
}

// Adds eye, which face start sees: removes every face that sees it (a connected
// patch, exactly) and fans new faces from its horizon to eye.
bool Quickhull::AddPoint(int eye, int start) {
  const int visible = ++stamp_, hidden = ++stamp_;
  struct HorizonEdge {
    int a, b, neighbor;
  };
  std::vector<int> patch = {start}, stack = {start};
  std::vector<HorizonEdge> horizon;
  faces_[start].mark = visible;
  while (!stack.empty()) {
    const int f = stack.back();
    stack.pop_back();
    for (int k = 0; k < 3; ++k) {
      const int g = faces_[f].adj[k];
      if (g == kNone) return false;
      if (faces_[g].mark != visible && faces_[g].mark != hidden) {
        faces_[g].mark = Sees(g, eye) ? visible : hidden;
        if (faces_[g].mark == visible) patch.push_back(g), stack.push_back(g);
      }
      if (faces_[g].mark == hidden) horizon.push_back({faces_[f].v[k], faces_[f].v[(k + 1) % 3], g});
    }
  }
  // order the horizon into one cycle; anything else means contradictory predicates
  const int m = static_cast<int>(horizon.size());
  if (m < 3) return false;
  std::vector<int> cycle;
  std::vector<char> used(m, 0);
  int e = 0;
  for (int j = 0; j < m; ++j) {
    if (used[e]) return false;
    used[e] = 1;
    cycle.push_back(e);
    int next = kNone;
    for (int g = 0; g < m; ++g) {
      if (horizon[g].a == horizon[e].b) next = next == kNone ? g : -2;
    }
    if (next < 0) return false;
    e = next;
  }
  if (e != 0) return false;

  // collect the orphaned points and retire the patch
  std::vector<int> orphans;
  for (int f : patch) {
    for (int i = faces_[f].outside_head; i != kNone; i = next_outside_[i]) {
      if (i != eye) orphans.push_back(i);
    }
    faces_[f].alive = false;
  }
  // fan: new face j is (a_j, b_j, eye), beside the hidden face across a_j -> b_j and
  // beside its fan neighbours across b_j -> eye and eye -> a_j
  const int first = static_cast<int>(faces_.size());
  for (int j = 0; j < m; ++j) {
    const HorizonEdge& edge = horizon[cycle[j]];
    const int f = AddFace(edge.a, edge.b, eye);
    faces_[f].adj = {edge.neighbor, first + (j + 1) % m, first + (j + m - 1) % m};
    if (!Link(edge.neighbor, edge.a, edge.b, f)) return false;
  }
  std::vector<int> fan(m);
  std::iota(fan.begin(), fan.end(), first);
  for (int i : orphans) Assign(i, fan);
  return true;
}

// Compacts the live faces into hull: vertices in first-use order, edges, adjacency.
void Quickhull::Output(ConvexHull& hull) const {
  hull.dimension = 3;
  std::vector<int> vertex_of(p_.size(), kNone), face_of(faces_.size(), kNone);
  std::vector<int> chosen;
  for (size_t f = 0; f < faces_.size(); ++f) {
    if (!faces_[f].alive) continue;
    face_of[f] = static_cast<int>(hull.faces.size());
    std::array<int, 3> tri;
    for (int k = 0; k < 3; ++k) {
      const int i = faces_[f].v[k];
      if (vertex_of[i] == kNone) vertex_of[i] = static_cast<int>(chosen.size()), chosen.push_back(i);
      tri[k] = vertex_of[i];
    }
    hull.faces.push_back(tri);
    hull.face_normals.push_back(faces_[f].normal.normalized());
  }
  SetVertices(p_, chosen, hull);
  for (size_t f = 0; f < faces_.size(); ++f) {
    if (!faces_[f].alive) continue;
    for (int k = 0; k < 3; ++k) {
      const int i = vertex_of[faces_[f].v[k]], j = vertex_of[faces_[f].v[(k + 1) % 3]];
      if (i < j) {
        hull.edges.push_back({i, j});
        hull.edge_faces.push_back({face_of[f], face_of[faces_[f].adj[k]]});
      }
    }
  }
  BuildAdjacency(hull);
}

}  // namespace

ConvexHull BuildConvexHull(std::span<const Vector3> points) {
  // empty or non-finite input: no hull (the predicates' signs would be meaningless)
  if (points.empty()) return {};
  for (const Vector3& q : points) {
    if (!q.allFinite()) return {};
  }
  const InitialSimplex s = FindInitialSimplex(points);
  switch (s.dimension) {
    case 0:
      return BuildPointHull(points, s.index[0]);
    case 1:
      return BuildSegmentHull(points, s.index[0], s.index[1]);
    case 2:
      return BuildPolygonHull(points, s);
    default:
      break;
  }
  ConvexHull hull;
  Quickhull builder(points);
  if (!builder.Run(s, hull)) return {};
  return hull;
}

std::optional<std::string> ValidatePointSet(std::span<const Vector3> points, std::string_view name) {
  if (points.empty()) return "point set " + std::string(name) + " is empty";
  for (size_t i = 0; i < points.size(); ++i) {
    const Vector3& q = points[i];
    const bool finite = q.allFinite();
    if (finite && q.cwiseAbs().maxCoeff() <= kMaxHullCoordinate) continue;
    // shortest round-trip spelling of each coordinate
    std::string value = "(";
    for (int k = 0; k < 3; ++k) {
      char buffer[32];
      const auto end = std::to_chars(buffer, buffer + sizeof(buffer), q[k]).ptr;
      value.append(buffer, end).append(k < 2 ? ", " : ")");
    }
    return "point " + std::to_string(i) + " of set " + std::string(name) + " is " + value +
           (finite ? ": a coordinate exceeds 1e100 in magnitude" : ": coordinates must be finite");
  }
  return std::nullopt;
}

}  // namespace hapticd::geometry
