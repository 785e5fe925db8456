#include "server/remote/two_port_passivity.h"

#include <algorithm>
#include <cmath>

namespace hapticd::remote {

ChannelPort::ChannelPort(bool control, double mass) : control_(control), mass_(mass) {}

void ChannelPort::Reset() {
  energy_ = {};
  other_in_ = 0;
  repaid_ = 0;
  f_last_W_.setZero();
  active_ = false;
}

void ChannelPort::Observe(double work) {
  if (!std::isfinite(work)) return;
  if (work > 0) {
    energy_.out += work;
    return;
  }
  // energy in: first what this end owes (kept in the channel), the rest passed on;
  // without control nothing is limited and nothing owed, the observer only counts
  const double entered = -work;
  const double repay = control_ ? std::min(entered, owed()) : 0.0;
  energy_.out -= repay;
  repaid_ += repay;
  energy_.in += entered - repay;
}

void ChannelPort::ReceiveOtherIn(double other_in) {
  if (std::isfinite(other_in)) other_in_ = std::max(other_in_, other_in);
}

Vector3 ChannelPort::LimitForce(const Vector3& f_desired, const Vector3& v_mid, double dt) {
  active_ = false;
  if (!control_) return f_desired;
  // The tick's predicted work: the force over the handle's motion at its velocity, and
  // over the motion its own change from the last force causes (at least the handle's
  // mass moves: an overestimate for a hand-held one).
  const auto work = [&](const Vector3& f) {
    const double own = mass_ > 0 ? f.dot(f - f_last_W_) * dt * dt / (2 * mass_) : 0.0;
    return f.dot(v_mid) * dt + own;
  };
  const double allowed = available();  // negative: an excess to take back
  Vector3 f = f_desired;
  if (work(f) > allowed) {
    active_ = true;
    // first a damper on the handle's real velocity: down to none of the force along
    // it, and braking (up to mass / dt, stable) where more has to be taken back
    const double speed2 = v_mid.squaredNorm();
    if (speed2 > 0) {
      const double alpha = (work(f) - allowed) / (speed2 * dt);
      const double cap = std::max(f.dot(v_mid), 0.0) / speed2 + (mass_ > 0 ? mass_ / dt : 0.0);
      f -= std::min(alpha, cap) * v_mid;
    }
    // then, what the damper cannot pay for (a handle at rest whose force jumps, which
    // the jump itself moves): the force is scaled down until its work is at most what
    // is left, or zero (no force does no work)
    const double target = std::max(allowed, 0.0);
    if (mass_ > 0 && work(f) > target) {
      double lo = 0, hi = 1;  // work(lo f) <= target < work(hi f)
      for (int i = 0; i < 40; ++i) {
        const double mid = 0.5 * (lo + hi);
        (work(mid * f) <= target ? lo : hi) = mid;
      }
      f *= lo;
    }
  }
  f_last_W_ = f;
  return f;
}

Vector3 ChannelPort::LimitStep(const Vector3& step, const EnvironmentNear& near, double dt) {
  active_ = false;
  if (!control_ || !(near.stiffness >= 0) || !(dt > 0)) return step;
  const double force = near.f_W.norm();
  const bool touching = force > 0;
  const Vector3 n = touching ? Vector3(near.f_W / force) : near.normal_W;  // the way it pushes
  const double into = -step.dot(n);  // how far the step goes against it
  // free motion up to just short of the surface costs nothing (the clearance keeps the
  // avatar outside the proxies' contact skin)
  constexpr double kClearance = 1e-6;
  // a moving surface closes the gap by itself (and presses a touching avatar)
  const double approach = std::max(near.approach, 0.0);
  const double gap = touching ? -approach : near.gap - kClearance - approach;
  // The work the observer will count: the force at the step's end (the spring pressed
  // a - gap further, the damper at the step's speed and the surface's, (a + approach) / dt)
  // times the step a:
  //   W(a) = (force + k (a - gap) + b (a + approach) / dt) a = K a^2 + linear a,
  // K = k + b / dt, linear = force - k gap + b approach / dt (negative gap: the input
  // is inside already, pressed by the spring; a < 0 backs out, W < 0 then takes energy in).
  const double k = near.stiffness;
  const double b = std::max(near.damping, 0.0);
  const double big_k = k + b / dt;
  const double linear = force - k * gap + b * approach / dt;
  const double allowed = available();
  // Owing: back out of a pushing environment (linear > 0) just far enough that its push
  // repays the debt, W(-back) = K back^2 - linear back = allowed < 0 (the smaller root),
  // or, when no step does, as far as takes the most (back = linear / 2K, W = -linear^2 / 4K).
  if (allowed < 0 && big_k > 0 && linear > 0) {
    const double discriminant = linear * linear + 4 * big_k * allowed;
    const double back = discriminant > 0 ? (linear - std::sqrt(discriminant)) / (2 * big_k) : linear / (2 * big_k);
    if (into <= -back) return step;  // backs out at least as far already
    active_ = true;
    return step + (into + back) * n;
  }
  if (!(into > 0) || (!touching && into < gap)) return step;  // away, or not reaching it
  const double kept_allowed = std::max(allowed, 0.0);
  if (big_k * into * into + linear * into <= kept_allowed) return step;
  active_ = true;
  // the larger root of K a^2 + linear a - allowed (K > 0: a surface is there)
  double kept = big_k > 0 ? (-linear + std::sqrt(linear * linear + 4 * big_k * kept_allowed)) / (2 * big_k) : 0.0;
  kept = std::max(kept, std::max(gap, 0.0));
  kept = std::clamp(kept, 0.0, into);
  return step + (into - kept) * n;
}

}  // namespace hapticd::remote
