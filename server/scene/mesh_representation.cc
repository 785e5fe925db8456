#include "server/scene/mesh_representation.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "server/geometry/bvh.h"
#include "server/geometry/capsule_triangle.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/convex_hull.h"
#include "server/geometry/exact_predicates.h"
#include "server/scene/value_text.h"

// Every candidate's error bound is a true two-sided (Hausdorff) bound between the mesh
// surface M and the candidate surface S, from two arguments:
//
// M -> S: the distance from a mesh point to S is bounded per triangle, where it is
//   convex or affine in the point so its extreme is at a vertex or at the triangle's
//   point closest to a centre (sphere, capsule), or bounded by the distance to one face
//   plane (box, hull: a solid containing the mesh, whose depth is a minimum over face
//   planes, so any one plane bounds it).
// S -> M: coverage, by a star-shape argument. If M is closed and every triangle faces
//   away from a point c (exact orientation test), every ray from c crosses M (the
//   surface winds around c a positive number of times and each crossing counts +1).
//   - Sphere (centre c) and capsule (every point of its axis, which suffices at both
//     ends since a triangle's signed volume is affine in c): the ray from the axis point
//     a through a surface point s meets M at m, and |s - m| = |dist(m, axis) - r|,
//     which the M -> S bound covers: the bound is exact both ways.
//   - Box and hull (solids containing M): the ray from c through s meets M at
//     m = c + t (s - c) with t <= 1; the solid holds the ball B(c, rho), hence the ball
//     B(m, (1 - t) rho), so |s - m| = (1 - t)|s - c| <= depth(m) R / rho with R the
//     farthest point from c. The bound is the M -> S bound times R / rho.
// Without coverage (an open or non-star-shaped mesh) no two-sided bound is proven and
// the candidate reports an infinite bound.

namespace hapticd::scene {
namespace {

using geometry::ConvexHull;
using geometry::Triangle;
using geometry::TriangleMesh;

constexpr double kInf = std::numeric_limits<double>::infinity();

// What the candidates share: the mesh, the vertices its triangles use, and whether
// and which way it encloses a solid.
struct MeshFacts {
  const TriangleMesh* mesh = nullptr;
  std::vector<Vector3> points;  // vertices of the non-degenerate triangles
  bool closed = false;
  int outward = 1;       // +1 when the normals point out of the solid, -1 when in
  double rounding = 0;   // allowance for rounding in every bound, m
};

MeshFacts CollectFacts(const TriangleMesh& mesh) {
  MeshFacts facts;
  facts.mesh = &mesh;
  std::vector<char> used(mesh.num_vertices(), 0);
  for (int t : mesh.nondegenerate_triangles()) {
    for (int v : mesh.triangles()[t]) used[v] = 1;
  }
  double scale = 0;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (!used[v]) continue;
    facts.points.push_back(mesh.vertices()[v]);
    scale = std::max(scale, mesh.vertices()[v].cwiseAbs().maxCoeff());
  }
  facts.closed = mesh.is_closed();
  // a closed mesh with inward normals is treated as its outward twin
  facts.outward = mesh.signed_volume() < 0 ? -1 : 1;
  facts.rounding = 64 * std::numeric_limits<double>::epsilon() * (scale + mesh.size());
  return facts;
}

// A candidate representation: the shape in frame S, S in the mesh frame M, its bound.
struct Candidate {
  Representation kind = Representation::kMesh;
  Shape shape;
  Pose X_MS;
  double bound = kInf;     // two-sided; infinite when not proven
  std::string summary;     // "sphere fit within 3.1e-05 m", or why not
  std::string impossible;  // non-empty when the shape cannot be built at all
};

// -1 when every non-degenerate triangle faces away from c (c strictly on its inner
// side, exactly); otherwise the first triangle that does not.
int FindTriangleNotFacingAway(const MeshFacts& facts, const Vector3& c) {
  const TriangleMesh& mesh = *facts.mesh;
  for (int t : mesh.nondegenerate_triangles()) {
    const Triangle tri = mesh.triangle(t);
    if (geometry::Orient3d(tri.v0, tri.v1, tri.v2, c) != -facts.outward) return t;
  }
  return -1;
}

// Why M may not cover a shape around the given centre points, or "" when it does.
std::string CoverageProblem(const MeshFacts& facts, std::initializer_list<Vector3> centres,
                            std::string_view centre_name) {
  if (!facts.closed) return "the mesh is open, so it need not cover the shape";
  for (const Vector3& c : centres) {
    // a non-finite centre (overflowing fit) proves nothing
    if (!c.allFinite()) return "the fit is not finite";
    const int t = FindTriangleNotFacingAway(facts, c);
    if (t >= 0) {
      return "the mesh is not star-shaped around the " + std::string(centre_name) +
             " (triangle " + std::to_string(t) + " does not face away from it)";
    }
  }
  return "";
}

// Mean of the points.
Vector3 Mean(const std::vector<Vector3>& points) {
  Vector3 sum = Vector3::Zero();
  for (const Vector3& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

// Covariance of the points about mean, and its eigenvectors (columns, ascending
// eigenvalues) made right-handed.
Matrix3 PrincipalAxes(const std::vector<Vector3>& points, const Vector3& mean) {
  Matrix3 covariance = Matrix3::Zero();
  for (const Vector3& p : points) covariance += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Matrix3> solver(covariance);
  Matrix3 axes = solver.eigenvectors();
  // a solver that failed (non-finite input) leaves no usable axes
  if (solver.info() != Eigen::Success || !axes.allFinite()) return Matrix3::Identity();
  if (axes.determinant() < 0) axes.col(0) = -axes.col(0);
  return axes;
}

// A rotation whose z axis is the unit vector z.
Matrix3 RotationWithZ(const Vector3& z) {
  const Vector3 helper = std::abs(z.x()) < 0.9 ? Vector3::UnitX() : Vector3::UnitY();
  const Vector3 x = helper.cross(z).normalized();
  Matrix3 R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

// ---------------------------------------------------------------------------------
// Sphere: centre by an algebraic least-squares fit (|p|^2 = 2 c.p + k), radius halfway
// between the nearest and farthest mesh points, so the bound is (far - near) / 2.

Vector3 FitSphereCentre(const std::vector<Vector3>& points) {
  const Vector3 mean = Mean(points);
  Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
  Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
  for (const Vector3& p : points) {
    const Vector3 q = p - mean;
    const Eigen::Vector4d row(2 * q.x(), 2 * q.y(), 2 * q.z(), 1);
    normal += row * row.transpose();
    rhs += row * q.squaredNorm();
  }
  Eigen::FullPivLU<Eigen::Matrix4d> lu(normal);
  lu.setThreshold(1e-10);
  // coplanar points leave the centre undetermined: use their mean
  if (lu.rank() < 4) return mean;
  const Eigen::Vector4d x = lu.solve(rhs);
  const Vector3 centre = mean + x.head<3>();
  return centre.allFinite() ? centre : mean;
}

Candidate FitSphere(const MeshFacts& facts) {
  Candidate out;
  out.kind = Representation::kSphere;
  const TriangleMesh& mesh = *facts.mesh;
  const Vector3 c = FitSphereCentre(facts.points);
  // the farthest point of a triangle from c is a corner; the nearest, its closest point
  double far = 0;
  for (const Vector3& p : facts.points) far = std::max(far, (p - c).norm());
  double near = kInf;
  for (int t : mesh.nondegenerate_triangles()) {
    const double d2 = geometry::FindClosestPointOnTriangle(c, mesh.triangle(t)).distance_squared;
    near = std::min(near, std::sqrt(d2));
  }
  const double radius = 0.5 * (near + far);
  if (!(radius > 0) || !std::isfinite(radius)) {
    out.impossible = "the sphere fit has radius " + FormatShort(radius);
    return out;
  }
  out.shape = SphereShape{radius};
  out.X_MS.translation = c;
  const double one_sided = 0.5 * (far - near) + facts.rounding;
  const std::string problem = CoverageProblem(facts, {c}, "sphere's centre");
  if (!problem.empty()) {
    out.summary = "sphere (mesh within " + FormatShort(one_sided) + " m of it) unproven: " +
                  problem;
    return out;
  }
  out.bound = one_sided;
  out.summary = "sphere fit within " + FormatShort(out.bound) + " m";
  return out;
}

// ---------------------------------------------------------------------------------
// Box: axes from the mesh's largest face and the largest face perpendicular to it (a
// box mesh's faces), or from the principal axes; the box is the mesh's bounding box in
// those axes. A triangle's depth in the box is at most its farthest corner's distance
// below the face plane it lies closest to.

// Reorders and flips the columns of a box rotation (a box is symmetric under both)
// to lie closest to the identity; exactly the identity when within 1e-12 of it.
Matrix3 CanonicalBoxRotation(const Matrix3& R) {
  Matrix3 out;
  std::array<bool, 3> taken = {false, false, false};
  for (int i = 0; i < 3; ++i) {
    int best = -1;
    for (int j = 0; j < 3; ++j) {
      if (!taken[j] && (best < 0 || std::abs(R(i, j)) > std::abs(R(i, best)))) best = j;
    }
    taken[best] = true;
    out.col(i) = R(i, best) < 0 ? Vector3(-R.col(best)) : Vector3(R.col(best));
  }
  // flipping an axis keeps the box: restore right-handedness on the weakest axis
  if (out.determinant() < 0) {
    int weakest = 0;
    for (int i = 1; i < 3; ++i) {
      if (std::abs(out(i, i)) < std::abs(out(weakest, weakest))) weakest = i;
    }
    out.col(weakest) = -out.col(weakest);
  }
  if ((out - Matrix3::Identity()).cwiseAbs().maxCoeff() < 1e-12) return Matrix3::Identity();
  return out;
}

// Axes of the largest triangle and of the largest one roughly perpendicular to it
// (|cos| < 0.05, made exactly perpendicular), or nullopt when there is none.
std::optional<Matrix3> FaceAxes(const TriangleMesh& mesh) {
  auto area = [&](int t) {
    const Triangle tri = mesh.triangle(t);
    return (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).norm();
  };
  int first = -1;
  double first_area = 0;
  for (int t : mesh.nondegenerate_triangles()) {
    const double a = area(t);
    if (a > first_area && mesh.face_normal(t).squaredNorm() > 0) first = t, first_area = a;
  }
  if (first < 0) return std::nullopt;
  const Vector3 n1 = mesh.face_normal(first);
  int second = -1;
  double second_area = 0;
  for (int t : mesh.nondegenerate_triangles()) {
    if (std::abs(mesh.face_normal(t).dot(n1)) > 0.05) continue;
    const double a = area(t);
    if (a > second_area && mesh.face_normal(t).squaredNorm() > 0) second = t, second_area = a;
  }
  if (second < 0) return std::nullopt;
  const Vector3 n2 = (mesh.face_normal(second) - mesh.face_normal(second).dot(n1) * n1).normalized();
  Matrix3 R;
  R << n1, n2, n1.cross(n2);
  return R;
}

// Axes turned to the area-weighted mean normal of the triangles facing along each
// (within about 18 degrees), made orthonormal again (the nearest rotation, by SVD):
// what levels a box whose largest triangle is tilted by noise. Unchanged when an axis
// has no triangle facing along it.
Matrix3 RefineBoxAxes(const TriangleMesh& mesh, const Matrix3& axes) {
  Matrix3 R = axes;
  for (int iteration = 0; iteration < 2; ++iteration) {
    Matrix3 sums = Matrix3::Zero();
    for (int t : mesh.nondegenerate_triangles()) {
      const Triangle tri = mesh.triangle(t);
      const Vector3 area_normal = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
      const Vector3 n = mesh.face_normal(t);
      for (int k = 0; k < 3; ++k) {
        const double c = n.dot(R.col(k));
        if (std::abs(c) > 0.95) sums.col(k) += (c > 0 ? 1 : -1) * area_normal;
      }
    }
    if (!(sums.colwise().norm().minCoeff() > 0) || !sums.allFinite()) return R;
    Eigen::JacobiSVD<Matrix3> svd(sums, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Matrix3 U = svd.matrixU();
    if ((U * svd.matrixV().transpose()).determinant() < 0) U.col(2) = -U.col(2);
    R = U * svd.matrixV().transpose();
  }
  return R;
}

Candidate FitBoxWithAxes(const MeshFacts& facts, const Matrix3& axes) {
  Candidate out;
  out.kind = Representation::kBox;
  const TriangleMesh& mesh = *facts.mesh;
  const Matrix3 R = CanonicalBoxRotation(RefineBoxAxes(mesh, axes));
  // bounding box of the vertices in the box's axes
  geometry::Aabb local;
  for (const Vector3& p : facts.points) local.Extend(R.transpose() * p);
  const Vector3 centre_B = local.center();
  const Vector3 h = 0.5 * local.size();
  if (!(h.minCoeff() > 0) || !h.allFinite()) {
    out.impossible = "the mesh is flat along a box axis (half extents " + FormatExact(h) + ")";
    return out;
  }
  out.shape = BoxShape{h};
  out.X_MS.rotation = R;
  out.X_MS.translation = R * centre_B;
  // each triangle's depth: its corners' worst distance to its nearest face plane
  double depth = 0;
  for (int t : mesh.nondegenerate_triangles()) {
    const Triangle tri = mesh.triangle(t);
    const Vector3 q[3] = {R.transpose() * tri.v0 - centre_B, R.transpose() * tri.v1 - centre_B,
                          R.transpose() * tri.v2 - centre_B};
    double best = kInf;
    for (int k = 0; k < 3; ++k) {
      for (double side : {-1.0, 1.0}) {
        double worst = 0;
        for (const Vector3& v : q) worst = std::max(worst, h[k] - side * v[k]);
        best = std::min(best, worst);
      }
    }
    depth = std::max(depth, best);
  }
  const double one_sided = depth + facts.rounding;
  const std::string problem = CoverageProblem(facts, {out.X_MS.translation}, "box's centre");
  if (!problem.empty()) {
    out.summary = "box (mesh within " + FormatShort(one_sided) + " m of it) unproven: " + problem;
    return out;
  }
  out.bound = one_sided * h.norm() / h.minCoeff() + facts.rounding;
  out.summary = "box fit within " + FormatShort(out.bound) + " m";
  return out;
}

Candidate FitBox(const MeshFacts& facts) {
  Candidate best = FitBoxWithAxes(facts, PrincipalAxes(facts.points, Mean(facts.points)));
  if (const std::optional<Matrix3> axes = FaceAxes(*facts.mesh)) {
    Candidate by_faces = FitBoxWithAxes(facts, *axes);
    // a buildable box beats none; then the smaller bound
    const bool better = !by_faces.impossible.empty() ? false
                        : !best.impossible.empty()   ? true
                                                     : by_faces.bound <= best.bound;
    if (better) best = std::move(by_faces);
  }
  return best;
}

// ---------------------------------------------------------------------------------
// Capsule: axis along the vertices' principal axis through their mean; the radius
// from the widest vertex, the half length from the extent along the axis; then, like
// the sphere, radius halfway between the nearest and farthest mesh points from the
// axis segment.

Candidate FitCapsule(const MeshFacts& facts) {
  Candidate out;
  out.kind = Representation::kCapsule;
  const TriangleMesh& mesh = *facts.mesh;
  const Vector3 mean = Mean(facts.points);
  const Vector3 axis = PrincipalAxes(facts.points, mean).col(2);
  double t_min = kInf, t_max = -kInf, widest = 0;
  for (const Vector3& p : facts.points) {
    const double t = (p - mean).dot(axis);
    t_min = std::min(t_min, t);
    t_max = std::max(t_max, t);
    widest = std::max(widest, (p - mean - t * axis).norm());
  }
  // a mesh shorter than it is wide gets a zero-length axis (a sphere)
  const double half_length = std::max(0.0, 0.5 * (t_max - t_min) - widest);
  const Vector3 centre = mean + 0.5 * (t_min + t_max) * axis;
  const Vector3 p0 = centre - half_length * axis, p1 = centre + half_length * axis;
  // farthest: a corner (distance to a segment is convex); nearest: segment-triangle
  double far = 0;
  for (const Vector3& p : facts.points) {
    const double s = std::clamp((p - p0).dot(axis), 0.0, 2 * half_length);
    far = std::max(far, (p - p0 - s * axis).norm());
  }
  double near = kInf;
  const geometry::Capsule segment{p0, p1, 0};
  for (int t : mesh.nondegenerate_triangles()) {
    near = std::min(near, geometry::CalcCapsuleTriangleContact(segment, mesh.triangle(t)).distance);
  }
  const double radius = 0.5 * (near + far);
  if (!(radius > 0) || !std::isfinite(radius) || !centre.allFinite()) {
    out.impossible = "the capsule fit has radius " + FormatShort(radius);
    return out;
  }
  out.shape = CapsuleShape{radius, half_length};
  out.X_MS.rotation = RotationWithZ(axis);
  out.X_MS.translation = centre;
  const double one_sided = 0.5 * (far - near) + facts.rounding;
  const std::string problem = CoverageProblem(facts, {p0, p1}, "capsule's axis");
  if (!problem.empty()) {
    out.summary = "capsule (mesh within " + FormatShort(one_sided) + " m of it) unproven: " +
                  problem;
    return out;
  }
  out.bound = one_sided;
  out.summary = "capsule fit within " + FormatShort(out.bound) + " m";
  return out;
}

// ---------------------------------------------------------------------------------
// Convex hull of the vertices. A triangle's depth under the hull's boundary is at most
// its corners' worst distance below any one hull face plane (its "gap" to that face).
// The face: among those around the hull's support vertices in the triangle's normal
// direction and in its direction from the centre (found by hill climbing over the
// hull's vertex adjacency, exact for a linear objective on a convex polytope), the one
// with the smallest gap, then improved by climbing the face adjacency.

class HullFaceFinder {
 public:
  explicit HullFaceFinder(const ConvexHull& hull) : hull_(hull) {
    const int num_faces = static_cast<int>(hull.faces.size());
    normal_ = hull.face_normals;
    offset_.resize(num_faces);
    for (int f = 0; f < num_faces; ++f) offset_[f] = normal_[f].dot(hull.vertices[hull.faces[f][0]]);
    // face neighbours across edges
    neighbours_.assign(num_faces, {-1, -1, -1});
    std::vector<int> filled(num_faces, 0);
    for (const std::array<int, 2>& faces : hull.edge_faces) {
      if (filled[faces[0]] < 3) neighbours_[faces[0]][filled[faces[0]]++] = faces[1];
      if (filled[faces[1]] < 3) neighbours_[faces[1]][filled[faces[1]]++] = faces[0];
    }
    // faces around each vertex, compressed
    face_start_.assign(hull.num_vertices() + 1, 0);
    for (const auto& face : hull.faces) {
      for (int v : face) ++face_start_[v + 1];
    }
    for (int v = 0; v < hull.num_vertices(); ++v) face_start_[v + 1] += face_start_[v];
    vertex_faces_.resize(face_start_.back());
    std::vector<int> next(face_start_.begin(), face_start_.end() - 1);
    for (int f = 0; f < num_faces; ++f) {
      for (int v : hull.faces[f]) vertex_faces_[next[v]++] = f;
    }
  }

  int num_faces() const { return static_cast<int>(normal_.size()); }
  const Vector3& normal(int f) const { return normal_[f]; }
  double offset(int f) const { return offset_[f]; }

  // Worst distance of the triangle's corners below face f's plane (negative: above).
  double Gap(int f, const Triangle& tri) const {
    const Vector3& m = normal_[f];
    return offset_[f] - std::min({m.dot(tri.v0), m.dot(tri.v1), m.dot(tri.v2)});
  }

  // The smallest gap found for tri, seeded by support vertices along the given
  // directions; start is a vertex to climb from (updated, for coherence).
  double FindGap(const Triangle& tri, std::initializer_list<Vector3> directions, int& start) const {
    int best = -1;
    double best_gap = kInf;
    for (const Vector3& d : directions) {
      start = Support(start, d);
      for (int k = face_start_[start]; k < face_start_[start + 1]; ++k) {
        const int f = vertex_faces_[k];
        const double g = Gap(f, tri);
        if (g < best_gap) best_gap = g, best = f;
      }
    }
    // descend the gap across face neighbours
    for (;;) {
      int next = best;
      for (int g : neighbours_[best]) {
        if (g < 0) continue;
        const double gap = Gap(g, tri);
        if (gap < best_gap) best_gap = gap, next = g;
      }
      if (next == best) return best_gap;
      best = next;
    }
  }

 private:
  // The hull vertex farthest along d, climbing from v.
  int Support(int v, const Vector3& d) const {
    double best = hull_.vertices[v].dot(d);
    for (;;) {
      int next = v;
      for (int w : hull_.neighbors(v)) {
        const double s = hull_.vertices[w].dot(d);
        if (s > best) best = s, next = w;
      }
      if (next == v) return v;
      v = next;
    }
  }

  const ConvexHull& hull_;
  std::vector<Vector3> normal_;
  std::vector<double> offset_;  // normal . x <= offset inside
  std::vector<std::array<int, 3>> neighbours_;
  std::vector<int> face_start_;
  std::vector<int> vertex_faces_;
};

// Centroid of the solid a closed mesh encloses (orientation-independent), or the
// vertices' mean when its volume is zero.
Vector3 SolidCentroid(const MeshFacts& facts) {
  const TriangleMesh& mesh = *facts.mesh;
  const Vector3 origin = facts.points.front();
  Vector3 moment = Vector3::Zero();
  double volume = 0;
  for (int t : mesh.nondegenerate_triangles()) {
    const Triangle tri = mesh.triangle(t);
    const double v = (tri.v0 - origin).dot((tri.v1 - origin).cross(tri.v2 - origin));
    volume += v;
    moment += v * (origin + tri.v0 + tri.v1 + tri.v2);
  }
  if (!(std::abs(volume) > 0)) return Mean(facts.points);
  return moment / (4 * volume);
}

// The hull of the points, or why there is none.
std::variant<std::shared_ptr<const ConvexHull>, std::string> BuildSolidHull(
    const std::vector<Vector3>& points) {
  if (const std::optional<std::string> problem = geometry::ValidatePointSet(points, "vertices")) {
    return *problem;
  }
  auto hull = std::make_shared<ConvexHull>(geometry::BuildConvexHull(points));
  if (hull->dimension != 3) {
    return "the mesh's vertices are " +
           std::string(hull->dimension == 2 ? "coplanar" : "collinear or coincident") +
           " (hull dimension " + std::to_string(hull->dimension) + ")";
  }
  return std::shared_ptr<const ConvexHull>(std::move(hull));
}

Candidate FitConvex(const MeshFacts& facts) {
  Candidate out;
  out.kind = Representation::kConvex;
  const TriangleMesh& mesh = *facts.mesh;
  // the bound needs the mesh star-shaped around its centroid; without it the error is
  // still measured one way and reported as unproven
  const Vector3 c = facts.closed ? SolidCentroid(facts) : Mean(facts.points);
  const std::string problem = CoverageProblem(facts, {c}, "mesh's centroid");
  auto built = BuildSolidHull(facts.points);
  if (std::string* why = std::get_if<std::string>(&built)) {
    out.impossible = *why;
    return out;
  }
  auto hull = std::get<std::shared_ptr<const ConvexHull>>(std::move(built));
  const HullFaceFinder finder(*hull);
  // each triangle's depth under the hull, through the best face plane found
  double depth = 0;
  int start = 0;
  for (int t : mesh.nondegenerate_triangles()) {
    const Triangle tri = mesh.triangle(t);
    const Vector3 radial = (tri.v0 + tri.v1 + tri.v2) / 3 - c;
    depth = std::max(depth, finder.FindGap(tri, {facts.outward * mesh.face_normal(t), radial}, start));
  }
  const double one_sided = depth + facts.rounding;
  out.shape = ConvexShape{hull};
  // without coverage, the hull's faces bound the way back: each face's corners are mesh
  // vertices, and every point of a triangle lies within min(circumradius, longest
  // side) of one of its corners
  double face_reach = 0;
  for (const auto& face : hull->faces) {
    const Vector3& a = hull->vertices[face[0]];
    const Vector3& b = hull->vertices[face[1]];
    const Vector3& c = hull->vertices[face[2]];
    const double ab = (b - a).norm(), bc = (c - b).norm(), ca = (a - c).norm();
    const double twice_area = (b - a).cross(c - a).norm();
    const double longest = std::max({ab, bc, ca});
    const double circumradius = twice_area > 0 ? ab * bc * ca / (2 * twice_area) : kInf;
    face_reach = std::max(face_reach, std::min(longest, circumradius));
  }
  const double by_faces = std::max(one_sided, face_reach) + facts.rounding;
  if (!problem.empty()) {
    out.bound = by_faces;
    out.summary = "convex hull within " + FormatShort(out.bound) + " m (bounded by its faces' corners: " +
                  problem + ")";
    return out;
  }
  // the ball around c inside the hull, and the farthest hull vertex from c
  double inner = kInf, outer = 0;
  for (int f = 0; f < finder.num_faces(); ++f) {
    inner = std::min(inner, finder.offset(f) - finder.normal(f).dot(c));
  }
  for (const Vector3& v : hull->vertices) outer = std::max(outer, (v - c).norm());
  if (!(inner > 0)) {
    out.bound = by_faces;
    out.summary = "convex hull within " + FormatShort(out.bound) +
                  " m (bounded by its faces' corners: the mesh's centroid is on the hull's boundary)";
    return out;
  }
  out.bound = one_sided * outer / inner + facts.rounding;
  out.summary = "convex hull within " + FormatShort(out.bound) + " m";
  return out;
}

// ---------------------------------------------------------------------------------

Candidate KeepMesh(std::shared_ptr<const TriangleMesh> mesh) {
  Candidate out;
  out.kind = Representation::kMesh;
  out.shape = MeshShape{std::make_shared<const geometry::MeshBvh>(std::move(mesh))};
  out.bound = 0;
  out.summary = "the mesh itself";
  return out;
}

Candidate Fit(Representation kind, const MeshFacts& facts) {
  switch (kind) {
    case Representation::kSphere: return FitSphere(facts);
    case Representation::kBox: return FitBox(facts);
    case Representation::kCapsule: return FitCapsule(facts);
    default: return FitConvex(facts);
  }
}

// What the client is told about the mesh itself, whatever represents it.
void DescribeMesh(const TriangleMesh& mesh, RepresentationChoice& choice) {
  choice.closure = mesh.closure();
  choice.rewound_triangles = mesh.num_rewound_triangles();
  if (choice.rewound_triangles > 0) {
    choice.warnings.push_back("rewound " + std::to_string(choice.rewound_triangles) + " of " +
                              std::to_string(mesh.nondegenerate_triangles().size()) +
                              " triangles so that the mesh's normals point out of its solid");
  }
  if (!mesh.nesting_checked()) {
    choice.warnings.push_back("the mesh has " + std::to_string(mesh.num_shells()) +
                              " closed shells, too many inside each other's bounds to tell which are "
                              "cavities: each was turned to face outwards");
  }
  if (!mesh.is_closed()) {
    choice.warnings.push_back(
        std::string("the mesh is ") + std::string(geometry::MeshClosureName(mesh.closure())) +
        (mesh.closure() == geometry::MeshClosure::kOpen
             ? " (an edge has one triangle or more than two)"
             : " (every edge has two triangles, but no winding agrees across them)") +
        ": it is a surface with no inside; distances to it are unsigned and nothing is inside it");
  }
}

RepresentedMesh Finish(Candidate candidate, std::string reason, const TriangleMesh& mesh) {
  RepresentedMesh out;
  out.shape = std::move(candidate.shape);
  out.choice.chosen = candidate.kind;
  out.choice.error_bound = candidate.bound;
  out.choice.X_MS = candidate.X_MS;
  out.choice.reason = std::move(reason);
  DescribeMesh(mesh, out.choice);
  return out;
}

}  // namespace

std::string_view RepresentationName(Representation representation) {
  switch (representation) {
    case Representation::kAuto: return "auto";
    case Representation::kSphere: return "sphere";
    case Representation::kBox: return "box";
    case Representation::kCapsule: return "capsule";
    case Representation::kConvex: return "convex";
    case Representation::kMesh: return "mesh";
    case Representation::kCount: break;
  }
  return "unknown";
}

RepresentedMesh ChooseMeshRepresentation(std::shared_ptr<const TriangleMesh> mesh,
                                         double tolerance, Representation pin) {
  if (!mesh) throw std::invalid_argument("no mesh to represent");
  if (!(tolerance > 0) || !std::isfinite(tolerance)) {
    throw std::invalid_argument("tolerance is " + FormatExact(tolerance) +
                                "; it must be a finite number > 0");
  }
  const int pin_index = static_cast<int>(pin);
  if (pin_index < 0 || pin_index >= static_cast<int>(Representation::kCount)) {
    throw std::invalid_argument("representation " + std::to_string(pin_index) +
                                " does not exist");
  }
  const std::string within = " <= tolerance " + FormatShort(tolerance) + " m";

  // pinned: that representation, whatever its finite error
  const TriangleMesh& validated = *mesh;
  if (pin == Representation::kMesh) {
    return Finish(KeepMesh(std::move(mesh)), "pinned: the mesh itself", validated);
  }
  const MeshFacts facts = CollectFacts(validated);
  if (pin != Representation::kAuto) {
    const std::string pinned(RepresentationName(pin));
    Candidate candidate = Fit(pin, facts);
    if (!candidate.impossible.empty()) {
      throw std::invalid_argument("cannot represent the mesh as a " + pinned + ": " + candidate.impossible);
    }
    // no finite bound: the pin could be anywhere from the mesh
    if (!std::isfinite(candidate.bound)) {
      throw std::invalid_argument("cannot represent the mesh as a " + pinned + ": its distance from the mesh has "
                                  "no finite bound (" + candidate.summary + ")");
    }
    const double bound = candidate.bound;
    std::string reason = "pinned: " + candidate.summary;
    RepresentedMesh out = Finish(std::move(candidate), std::move(reason), validated);
    if (bound > tolerance) {
      out.choice.warnings.push_back("the pinned " + pinned + " is within " + FormatShort(bound) +
                                    " m of the mesh, beyond the scene's tolerance " + FormatShort(tolerance) +
                                    " m");
    }
    return out;
  }

  // automatic: the first (cheapest) primitive within tolerance, else the mesh. The
  // convex hull is not a candidate: wherever it is as accurate as the mesh, the mesh's
  // BVH answered faster (bench/results/speed_accuracy.md), so it is only ever pinned.
  std::string rejected;
  for (Representation kind : {Representation::kSphere, Representation::kBox, Representation::kCapsule}) {
    Candidate candidate = Fit(kind, facts);
    if (candidate.impossible.empty() && candidate.bound <= tolerance) {
      std::string reason = candidate.summary + within;
      return Finish(std::move(candidate), std::move(reason), validated);
    }
    if (!rejected.empty()) rejected += "; ";
    rejected += candidate.impossible.empty()
                    ? candidate.summary
                    : std::string(RepresentationName(kind)) + " impossible: " + candidate.impossible;
  }
  return Finish(KeepMesh(std::move(mesh)),
                "mesh kept, nothing cheaper within tolerance " + FormatShort(tolerance) +
                    " m: " + rejected,
                validated);
}

}  // namespace hapticd::scene
