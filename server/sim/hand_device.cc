#include "server/sim/hand_device.h"

#include <algorithm>
#include <cmath>

namespace hapticd::sim {
namespace {

// The largest omega h per substep: RK4's relative energy error per period is then
// ~(omega h)^4 / 72 ~ 1e-7 at most, far less in practice because hands are soft.
constexpr double kMaxOmegaH = 0.05;

}  // namespace

HandPath::HandPath(std::vector<PathPoint> points) : points_(std::move(points)) {}

int HandPath::SegmentAt(double t) const {
  // the first point with t_i > t, minus one
  const auto after = std::upper_bound(points_.begin(), points_.end(), t,
                                      [](double time, const PathPoint& point) { return time < point.t; });
  return static_cast<int>(after - points_.begin()) - 1;
}

Vector3 HandPath::PositionAt(double t) const {
  const int i = SegmentAt(t);
  // before the first point, and from the last one on, the path stands still
  if (i < 0) return points_.front().p_W;
  if (i + 1 >= static_cast<int>(points_.size())) return points_.back().p_W;
  const PathPoint& a = points_[i];
  const PathPoint& b = points_[i + 1];
  const double s = (t - a.t) / (b.t - a.t);
  return a.p_W + s * (b.p_W - a.p_W);
}

Vector3 HandPath::VelocityAt(double t) const {
  const int i = SegmentAt(t);
  if (i < 0 || i + 1 >= static_cast<int>(points_.size())) return Vector3::Zero();
  const PathPoint& a = points_[i];
  const PathPoint& b = points_[i + 1];
  return (b.p_W - a.p_W) / (b.t - a.t);
}

Hand::Hand(const HandSpec& spec)
    : mass_(spec.mass), stiffness_(spec.stiffness), damping_(spec.damping), path_(spec.path) {}

Vector3 Hand::CalcForce(double t, const Vector3& p_W, const Vector3& v_W) const {
  return stiffness_ * (path_.PositionAt(t) - p_W) + damping_ * (path_.VelocityAt(t) - v_W);
}

int CalcSubsteps(double mass, double stiffness, double damping, double dt) {
  // the fastest rate of the body: its natural frequency or its damping rate
  const double omega = std::max(std::sqrt(stiffness / mass), damping / mass);
  const double needed = std::ceil(omega * dt / kMaxOmegaH);
  if (!(needed <= kMaxSubsteps)) return 0;
  return std::max(kMinSubsteps, static_cast<int>(needed));
}

ImpedancePlant::ImpedancePlant(const HandSpec& hand, const DeviceSpec& device, double dt)
    : hand_(hand),
      mass_(hand.mass + device.mass),
      device_damping_(device.damping),
      dt_(dt),
      substeps_(CalcSubsteps(mass_, hand.stiffness, hand.damping + device.damping, dt)),
      p_W_(device.start_W) {}

Vector3 ImpedancePlant::CalcAcceleration(double t, const Vector3& p, const Vector3& v,
                                         const Vector3& f) const {
  return (hand_.CalcForce(t, p, v) - device_damping_ * v + f) / mass_;
}

void ImpedancePlant::Step(const Vector3& f_W, double t) {
  const double h = dt_ / substeps_;
  Vector3 p = p_W_;
  Vector3 v = v_W_;
  // classical RK4 on (p, v), the force held constant
  for (int i = 0; i < substeps_; ++i) {
    const double s = t + i * h;
    const Vector3 a1 = CalcAcceleration(s, p, v, f_W);
    const Vector3 v2 = v + 0.5 * h * a1;
    const Vector3 a2 = CalcAcceleration(s + 0.5 * h, p + 0.5 * h * v, v2, f_W);
    const Vector3 v3 = v + 0.5 * h * a2;
    const Vector3 a3 = CalcAcceleration(s + 0.5 * h, p + 0.5 * h * v2, v3, f_W);
    const Vector3 v4 = v + h * a3;
    const Vector3 a4 = CalcAcceleration(s + h, p + h * v3, v4, f_W);
    p += h / 6 * (v + 2 * v2 + 2 * v3 + v4);
    v += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
  }
  p_W_ = p;
  v_W_ = v;
}

}  // namespace hapticd::sim
