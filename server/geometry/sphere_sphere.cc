#include "server/geometry/sphere_sphere.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace hapticd::geometry {
namespace {

// Half an ulp of 1.
constexpr double kUnitRoundoff = std::numeric_limits<double>::epsilon() / 2;

// A forward error bound of the floating-point evaluation of |cb - ca|^2 - (ra + rb)^2,
// relative to |cb - ca|^2 + (ra + rb)^2 (derivation in CompareCenterDistanceToRadiusSum).
constexpr double kFilterBound = 16 * kUnitRoundoff;

// A real number held exactly as hi + lo.
struct TwoTerm {
  double hi = 0;
  double lo = 0;
};

// a + b exactly (Knuth's two-sum).
TwoTerm TwoSum(double a, double b) {
  const double x = a + b;
  const double b_virtual = x - a;
  const double a_virtual = x - b_virtual;
  return {x, (a - a_virtual) + (b - b_virtual)};
}

// a - b exactly (Knuth's two-difference).
TwoTerm TwoDiff(double a, double b) {
  const double x = a - b;
  const double b_virtual = a - x;
  const double a_virtual = x + b_virtual;
  return {x, (a - a_virtual) + (b_virtual - b)};
}

// a * b exactly; the fused multiply-add yields the rounding error of the product.
TwoTerm TwoProduct(double a, double b) {
  const double x = a * b;
  return {x, std::fma(a, b, -x)};
}

// An exact sum of up to kCapacity doubles as a nonoverlapping expansion, smallest
// component first (Shewchuk's Grow-Expansion with zero elimination).
class SmallExpansion {
 public:
  void Add(double b) {
    double q = b;
    int out = 0;
    for (int i = 0; i < size_; ++i) {
      const TwoTerm s = TwoSum(q, components_[i]);
      q = s.hi;
      if (s.lo != 0) components_[out++] = s.lo;
    }
    if (q != 0 && out < kCapacity) components_[out++] = q;
    size_ = out;
  }

  // (hi + lo)^2 = hi^2 + 2 hi lo + lo^2, each product added exactly, times sign.
  void AddSquare(const TwoTerm& x, double sign) {
    for (const TwoTerm& p :
         {TwoProduct(x.hi, x.hi), TwoProduct(2 * x.hi, x.lo), TwoProduct(x.lo, x.lo)}) {
      Add(sign * p.hi);
      Add(sign * p.lo);
    }
  }

  // The most significant component carries the sign of the whole sum.
  int Sign() const {
    if (size_ == 0) return 0;
    return components_[size_ - 1] > 0 ? 1 : -1;
  }

 private:
  static constexpr int kCapacity = 32;
  std::array<double, kCapacity> components_{};
  int size_ = 0;
};

bool IsFinite(const Sphere& s) { return s.center.allFinite() && std::isfinite(s.radius); }

}  // namespace

// Derivation of the filter. With u the unit roundoff, each computed difference
// d_i = (a_i - b_i)(1 + e), |e| <= u; squaring and two additions of non-negative
// terms leave |fl(D) - D| <= 6u D (+ O(u^2)) for D = sum d_i^2. Likewise
// |fl(S) - S| <= 4u S for S = (ra + rb)^2, and the final subtraction adds u |D - S|.
// So |fl(D - S) - (D - S)| <= 8u (D + S) to first order; 16u (D + S) is safe. When the
// computed value is smaller than that, the sum is evaluated exactly: each difference
// and the radius sum become exact two-term numbers, and their squares become six
// exact products each (24 terms in all), summed in a nonoverlapping expansion.
int CompareCenterDistanceToRadiusSum(const Sphere& a, const Sphere& b) {
  // Non-finite input: apart, as CollideSpheres answers it.
  if (!IsFinite(a) || !IsFinite(b)) return 1;
  const Vector3 delta = b.center - a.center;
  const double d2 = delta.squaredNorm();
  const double sum = a.radius + b.radius;
  const double s2 = sum * sum;
  const double det = d2 - s2;
  // Fast path: the floating-point sign is proven right.
  if (std::abs(det) > kFilterBound * (d2 + s2)) return det > 0 ? 1 : -1;
  // Finite input whose squares overflow: no meaningful sign; report touching.
  if (!std::isfinite(det)) return 0;
  // Slow path: exact evaluation.
  SmallExpansion exact;
  for (int i = 0; i < 3; ++i) exact.AddSquare(TwoDiff(b.center[i], a.center[i]), 1.0);
  exact.AddSquare(TwoSum(a.radius, b.radius), -1.0);
  return exact.Sign();
}

SphereSphereResult CollideSpheres(const Sphere& a, const Sphere& b) {
  SphereSphereResult result;
  // Non-finite input: no contact, every field zero (the normal included).
  if (!IsFinite(a) || !IsFinite(b)) {
    result.normal = Vector3::Zero();
    return result;
  }
  const CenterLine line = CalcCenterLine(a.center, b.center);
  result.normal = line.direction;
  const int sign = CompareCenterDistanceToRadiusSum(a, b);
  result.intersect = sign <= 0;
  // Keep the sign of distance consistent with the exact decision; exactly 0 when
  // the spheres touch.
  const double distance = line.distance - (a.radius + b.radius);
  if (sign == 0) {
    result.distance = 0;
  } else if (sign < 0) {
    result.distance = std::min(distance, 0.0);
  } else {
    result.distance = std::max(distance, std::numeric_limits<double>::denorm_min());
  }
  // Witness points on each surface along the normal.
  result.point_a = a.center + a.radius * result.normal;
  result.point_b = b.center - b.radius * result.normal;
  return result;
}

}  // namespace hapticd::geometry
