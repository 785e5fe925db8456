#include "server/geometry/separating_plane.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace hapticd::geometry {
namespace {

constexpr int kMaxUnknowns = 5;
// Constraint slack tolerated as satisfied (the rows are of unit scale).
constexpr double kSlack = 1e-12;
// Optimal margins at or below this (in the unit box) read as touching.
constexpr double kMinMargin = 1e-12;

// One constraint a.x <= b over the first d unknowns.
struct Row {
  std::array<double, kMaxUnknowns> a{};
  double b = 0;
};

// A bounded LP: maximize c.x over lo <= x <= hi and the rows.
struct Problem {
  int d = 0;
  std::array<double, kMaxUnknowns> c{}, lo{}, hi{};
};

// Seidel's algorithm. Theory of operation: start at the best corner of the box; add
// the rows one by one in random order; when the current optimum violates row i, the
// new optimum lies on row i's boundary, so eliminate one unknown with that equation
// and solve the (d - 1)-dimensional problem of the earlier rows recursively. The
// eliminated unknown's bounds become two ordinary rows there; the other unknowns keep
// their bounds, so every subproblem stays bounded. One row buffer per depth.
class SeidelLp {
 public:
  explicit SeidelLp(std::uint64_t seed) : rng_(seed), buffers_(kMaxUnknowns + 1) {}

  // Returns false when infeasible; x receives an optimum otherwise.
  bool Solve(const Problem& p, std::vector<Row>& rows, double* x, int depth) {
    for (int k = 0; k < p.d; ++k) x[k] = p.c[k] > 0 ? p.hi[k] : p.lo[k];
    if (p.d == 1) return SolveInterval(p, rows, x);
    for (size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      double ax = 0;
      for (int k = 0; k < p.d; ++k) ax += r.a[k] * x[k];
      if (ax <= r.b + kSlack) continue;
      ++violations_;
      // eliminate x_k = beta - sum gamma_j x_j, k the largest coefficient (|gamma| <= 1)
      int k = 0;
      for (int j = 1; j < p.d; ++j) {
        if (std::abs(r.a[j]) > std::abs(r.a[k])) k = j;
      }
      // the row reads 0 <= b < 0 (or NaN): nothing satisfies it
      if (!(std::abs(r.a[k]) > 0)) return false;
      std::array<double, kMaxUnknowns> gamma{};
      for (int j = 0; j < p.d; ++j) gamma[j] = r.a[j] / r.a[k];
      const double beta = r.b / r.a[k];
      Problem sub;
      sub.d = p.d - 1;
      for (int j = 0, s = 0; j < p.d; ++j) {
        if (j == k) continue;
        sub.c[s] = p.c[j] - p.c[k] * gamma[j], sub.lo[s] = p.lo[j], sub.hi[s] = p.hi[j];
        ++s;
      }
      std::vector<Row>& sub_rows = Buffer(depth + 1);
      sub_rows.clear();
      // the earlier rows, on the hyperplane
      for (size_t l = 0; l < i; ++l) {
        Row q;
        for (int j = 0, s = 0; j < p.d; ++j) {
          if (j != k) q.a[s++] = rows[l].a[j] - rows[l].a[k] * gamma[j];
        }
        q.b = rows[l].b - rows[l].a[k] * beta;
        sub_rows.push_back(q);
      }
      // the eliminated unknown's bounds: x_k <= hi_k and x_k >= lo_k
      Row upper, lower;
      for (int j = 0, s = 0; j < p.d; ++j) {
        if (j != k) upper.a[s] = -gamma[j], lower.a[s] = gamma[j], ++s;
      }
      upper.b = p.hi[k] - beta;
      lower.b = beta - p.lo[k];
      sub_rows.push_back(upper);
      sub_rows.push_back(lower);
      std::shuffle(sub_rows.begin(), sub_rows.end(), rng_);
      std::array<double, kMaxUnknowns> y{};
      if (!Solve(sub, sub_rows, y.data(), depth + 1)) return false;
      // lift the sub-optimum back onto the hyperplane
      double rest = beta;
      for (int j = 0, s = 0; j < p.d; ++j) {
        if (j != k) x[j] = y[s], rest -= gamma[j] * y[s], ++s;
      }
      x[k] = rest;
      // move-to-front: a row that was violated once tends to bind again, so later
      // subproblems meet it first (Clarkson's heuristic; the answer is unchanged)
      std::rotate(rows.begin(), rows.begin() + i, rows.begin() + i + 1);
    }
    return true;
  }

  int violations() const { return violations_; }

 private:
  // One unknown: intersect the rows' half-lines with [lo, hi].
  static bool SolveInterval(const Problem& p, const std::vector<Row>& rows, double* x) {
    double lo = p.lo[0], hi = p.hi[0];
    for (const Row& r : rows) {
      if (r.a[0] > 0) {
        hi = std::min(hi, r.b / r.a[0]);
      } else if (r.a[0] < 0) {
        lo = std::max(lo, r.b / r.a[0]);
      } else if (!(r.b >= -kSlack)) {
        return false;
      }
    }
    if (!(lo <= hi + kSlack * (std::abs(lo) + std::abs(hi)))) return false;
    x[0] = p.c[0] > 0 ? std::max(hi, lo) : lo;
    return true;
  }
  // depth < kMaxUnknowns always (each level eliminates one unknown); the buffers are
  // made up front so references to them stay valid
  std::vector<Row>& Buffer(int depth) { return buffers_[depth]; }

  std::mt19937_64 rng_;
  std::vector<std::vector<Row>> buffers_;
  int violations_ = 0;
};

}  // namespace

SeparatingPlane FindSeparatingPlane(std::span<const Vector3> points_a, std::span<const Vector3> points_b,
                                    std::uint64_t seed) {
  SeparatingPlane result;
  if (points_a.empty() || points_b.empty()) return result;
  // move the points into [-1, 1]^3 (scaling keeps the LP's numbers of unit size)
  Vector3 lo = points_a[0], hi = points_a[0];
  for (const auto set : {points_a, points_b}) {
    for (const Vector3& p : set) {
      if (!p.allFinite()) return result;
      lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    }
  }
  const Vector3 center = 0.5 * (lo + hi);
  const double scale = 0.5 * (hi - lo).maxCoeff();
  // a single point shared by both sets: nothing to separate
  if (!(scale > 0)) return result;

  // rows over (n, c, delta): a above the plane is a violation, b below it
  std::vector<Row> rows;
  rows.reserve(points_a.size() + points_b.size());
  for (const Vector3& p : points_a) {
    const Vector3 q = (p - center) / scale;
    rows.push_back({{q.x(), q.y(), q.z(), -1, 1}, 0});
  }
  for (const Vector3& p : points_b) {
    const Vector3 q = (p - center) / scale;
    rows.push_back({{-q.x(), -q.y(), -q.z(), 1, 1}, 0});
  }
  Problem lp;
  lp.d = 5;
  lp.c = {0, 0, 0, 0, 1};
  lp.lo = {-1, -1, -1, -4, -1};
  lp.hi = {1, 1, 1, 4, 4};
  SeidelLp solver(seed);
  std::shuffle(rows.begin(), rows.end(), std::mt19937_64(seed ^ 0x9e3779b97f4a7c15ULL));
  std::array<double, kMaxUnknowns> x{};
  const bool feasible = solver.Solve(lp, rows, x.data(), 0);
  result.violations = solver.violations();
  const Vector3 n(x[0], x[1], x[2]);
  if (!feasible || !(x[4] > kMinMargin) || !(n.norm() > 0)) return result;

  // the plane in the input frame, placed midway and checked against every point
  result.normal = n.normalized();
  double top_a = -std::numeric_limits<double>::infinity(), bottom_b = std::numeric_limits<double>::infinity();
  for (const Vector3& p : points_a) top_a = std::max(top_a, result.normal.dot(p - center));
  for (const Vector3& p : points_b) bottom_b = std::min(bottom_b, result.normal.dot(p - center));
  result.margin = 0.5 * (bottom_b - top_a);
  result.offset = result.normal.dot(center) + 0.5 * (top_a + bottom_b);
  result.found = result.margin > 0;
  return result;
}

}  // namespace hapticd::geometry
