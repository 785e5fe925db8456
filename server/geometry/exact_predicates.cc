#include "server/geometry/exact_predicates.h"

#include <array>
#include <cmath>
#include <limits>

namespace hapticd::geometry {
namespace {

// Shewchuk's epsilon: half an ulp of 1, and his first-stage error bounds.
constexpr double kEpsilon = std::numeric_limits<double>::epsilon() / 2;
constexpr double kOrient3dErrorBound = (7.0 + 56.0 * kEpsilon) * kEpsilon;
constexpr double kOrient2dErrorBound = (3.0 + 16.0 * kEpsilon) * kEpsilon;

// A real number held exactly as hi + lo.
struct Exact2 {
  double hi = 0;
  double lo = 0;
};

// a - b exactly (Knuth's two-difference).
Exact2 TwoDiff(double a, double b) {
  const double x = a - b;
  const double b_virtual = a - x;
  const double a_virtual = x + b_virtual;
  return {x, (a - a_virtual) + (b_virtual - b)};
}

// a + b exactly (Knuth's two-sum).
Exact2 TwoSum(double a, double b) {
  const double x = a + b;
  const double b_virtual = x - a;
  const double a_virtual = x - b_virtual;
  return {x, (a - a_virtual) + (b - b_virtual)};
}

// a * b exactly; fma computes the rounding error of the product.
Exact2 TwoProduct(double a, double b) {
  const double x = a * b;
  return {x, std::fma(a, b, -x)};
}

// A sum of doubles held exactly as a nonoverlapping expansion, smallest component
// first (Shewchuk's Grow-Expansion with zero elimination). Fixed capacity: the
// largest determinant below adds 192 terms.
class Expansion {
 public:
  void Add(double b) {
    if (b == 0) return;
    double q = b;
    int out = 0;
    for (int i = 0; i < size_; ++i) {
      const Exact2 s = TwoSum(q, components_[i]);
      q = s.hi;
      if (s.lo != 0) components_[out++] = s.lo;
    }
    if (q != 0) components_[out++] = q;
    size_ = out;
  }

  // The most significant component carries the sign of the whole sum.
  int Sign() const {
    if (size_ == 0) return 0;
    return components_[size_ - 1] > 0 ? 1 : -1;
  }

 private:
  std::array<double, 256> components_{};
  int size_ = 0;
};


using Exact3 = std::array<Exact2, 3>;

Exact3 ExactDifference(const Vector3& a, const Vector3& b) {
  return {TwoDiff(a.x(), b.x()), TwoDiff(a.y(), b.y()), TwoDiff(a.z(), b.z())};
}

Exact3 ExactVector(const Vector3& a) {
  return {Exact2{a.x(), 0}, Exact2{a.y(), 0}, Exact2{a.z(), 0}};
}

// Adds sign * x * y * z, each factor an exact two-term value, to the expansion.
void AddProduct3(int sign, const Exact2& x, const Exact2& y, const Exact2& z, Expansion& sum) {
  for (double xi : {x.hi, x.lo}) {
    if (xi == 0) continue;
    for (double yi : {y.hi, y.lo}) {
      if (yi == 0) continue;
      const Exact2 xy = TwoProduct(xi, yi);
      for (double zi : {z.hi, z.lo}) {
        if (zi == 0) continue;
        const Exact2 high = TwoProduct(xy.hi, zi);
        const Exact2 low = TwoProduct(xy.lo, zi);
        sum.Add(sign * high.hi);
        sum.Add(sign * high.lo);
        sum.Add(sign * low.hi);
        sum.Add(sign * low.lo);
      }
    }
  }
}

// Sign of det[u; v; w] = (u x v) . w, exactly. Each component is an exact two-term
// value (a difference of inputs, or an input with a zero tail).
int ExactTripleSign(const Exact3& u, const Exact3& v, const Exact3& w) {
  // Leibniz expansion: even permutations add, odd ones subtract.
  static constexpr int kPermutations[6][4] = {{0, 1, 2, 1},  {1, 2, 0, 1},  {2, 0, 1, 1},
                                              {0, 2, 1, -1}, {1, 0, 2, -1}, {2, 1, 0, -1}};
  Expansion sum;
  for (const auto& p : kPermutations) AddProduct3(p[3], u[p[0]], v[p[1]], w[p[2]], sum);
  return sum.Sign();
}

constexpr int kUndecided = 2;

// Fast path: the triple product (u x v) . w of the rounded vectors and Shewchuk's bound
// on its error. Returns the sign when the bound proves it, else kUndecided.
int FilteredTripleSign(const Vector3& u, const Vector3& v, const Vector3& w) {
  const double uv_x = u.y() * v.z() - u.z() * v.y();
  const double uv_y = u.z() * v.x() - u.x() * v.z();
  const double uv_z = u.x() * v.y() - u.y() * v.x();
  const double det = w.x() * uv_x + w.y() * uv_y + w.z() * uv_z;
  const double permanent =
      std::abs(w.x()) * (std::abs(u.y() * v.z()) + std::abs(u.z() * v.y())) +
      std::abs(w.y()) * (std::abs(u.z() * v.x()) + std::abs(u.x() * v.z())) +
      std::abs(w.z()) * (std::abs(u.x() * v.y()) + std::abs(u.y() * v.x()));
  const double bound = kOrient3dErrorBound * permanent;
  if (det > bound) return 1;
  if (-det > bound) return -1;
  return kUndecided;
}

}  // namespace

// Each predicate tries the filter on rounded differences first and forms the exact
// two-term differences only when it cannot decide.
int Orient3d(const Vector3& a, const Vector3& b, const Vector3& c, const Vector3& d) {
  const int fast = FilteredTripleSign(b - a, c - a, d - a);
  if (fast != kUndecided) return fast;
  return ExactTripleSign(ExactDifference(b, a), ExactDifference(c, a), ExactDifference(d, a));
}

int OrientLineEdge(const Vector3& o, const Vector3& dir, const Vector3& a, const Vector3& b) {
  // dir . ((a - o) x (b - o)) = ((a - o) x (b - o)) . dir
  const int fast = FilteredTripleSign(a - o, b - o, dir);
  if (fast != kUndecided) return fast;
  return ExactTripleSign(ExactDifference(a, o), ExactDifference(b, o), ExactVector(dir));
}

int TripleProductSign(const Vector3& u, const Vector3& v, const Vector3& w) {
  const int fast = FilteredTripleSign(u, v, w);
  if (fast != kUndecided) return fast;
  return ExactTripleSign(ExactVector(u), ExactVector(v), ExactVector(w));
}

int Orient2d(const Vector2& a, const Vector2& b, const Vector2& c) {
  const Exact2 ux = TwoDiff(b.x(), a.x());
  const Exact2 uy = TwoDiff(b.y(), a.y());
  const Exact2 vx = TwoDiff(c.x(), a.x());
  const Exact2 vy = TwoDiff(c.y(), a.y());
  // Fast path with Shewchuk's bound.
  const double left = ux.hi * vy.hi;
  const double right = uy.hi * vx.hi;
  const double det = left - right;
  const double bound = kOrient2dErrorBound * (std::abs(left) + std::abs(right));
  if (det > bound) return 1;
  if (-det > bound) return -1;
  // Exact: sum of the products of all head/tail pairs.
  Expansion sum;
  for (double a1 : {ux.hi, ux.lo}) {
    for (double b1 : {vy.hi, vy.lo}) {
      const Exact2 p = TwoProduct(a1, b1);
      sum.Add(p.hi);
      sum.Add(p.lo);
    }
  }
  for (double a1 : {uy.hi, uy.lo}) {
    for (double b1 : {vx.hi, vx.lo}) {
      const Exact2 p = TwoProduct(a1, b1);
      sum.Add(-p.hi);
      sum.Add(-p.lo);
    }
  }
  return sum.Sign();
}

bool IsDegenerateTriangle(const Vector3& a, const Vector3& b, const Vector3& c) {
  // The cross product is zero exactly when all three coordinate projections are collinear.
  for (int axis = 0; axis < 3; ++axis) {
    const int i = (axis + 1) % 3;
    const int j = (axis + 2) % 3;
    if (Orient2d({a[i], a[j]}, {b[i], b[j]}, {c[i], c[j]}) != 0) return false;
  }
  return true;
}

}  // namespace hapticd::geometry
