"""The simulated arm, the person holding it and the force sensors, as plain state stepped
once per controller period. Frames: everything is in the robot base frame B; positions in
m, speeds in m/s, forces in N. No I/O, no clock: callers pass dt and the controller time.

Theory of operation (Arm):

    mode      what moves the tool centre point (TCP)
    idle      nothing; v = 0
    servo     first-order lag toward the servo target: v_des = (p_target - p) / tau,
              tau = servoL lookahead_time (or --response-time-s), |v| <= max speed,
              |dv/dt| <= max acceleration
    speed     toward the commanded speedL velocity at the commanded acceleration
    linear    moveL: toward the target at the commanded speed and acceleration
    stopping  decelerate along -v at the stop's deceleration until v = 0, then idle

Orientation (rx, ry, rz) is held at the start orientation: servoL's rotation is ignored.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

Vec3 = tuple[float, float, float]
ZERO3: Vec3 = (0.0, 0.0, 0.0)


def _add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _scale(a: Vec3, s: float) -> Vec3:
    return (a[0] * s, a[1] * s, a[2] * s)


def _norm(a: Vec3) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def _clamp_norm(a: Vec3, limit: float) -> Vec3:
    """a scaled down to length limit when longer (limit >= 0)."""
    n = _norm(a)
    return _scale(a, limit / n) if n > limit else a


def finite3(values) -> Vec3 | None:
    """The first three entries as floats, or None when any is NaN or infinite."""
    v = (float(values[0]), float(values[1]), float(values[2]))
    return v if all(math.isfinite(x) for x in v) else None


@dataclass(frozen=True)
class ArmLimits:
    """Immutable limits: max TCP speed (m/s) and acceleration (m/s^2); response_time_s
    overrides the servo time constant when set; safety_stop_decel is used by protective
    and emergency stops and program stops (m/s^2)."""

    max_speed: float = 1.0
    max_accel: float = 20.0
    response_time_s: float | None = None
    safety_stop_decel: float = 20.0


class Arm:
    """TCP kinematics of the simulated arm (see the module docstring)."""

    # joint angles of a UR5e-like home posture, and a fixed linear map from TCP offset
    # to joint offset: any plausible, smooth joints will do for actual_q
    Q_HOME = (0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0)
    Q_PER_M = (
        (1.0, 0.0, 0.0),
        (0.0, 1.2, 0.3),
        (0.0, -2.0, 0.5),
        (0.0, 0.8, -0.8),
        (0.5, 0.0, 0.0),
        (0.0, 0.0, 0.0),
    )

    def __init__(self, start_pose: tuple[float, ...], limits: ArmLimits) -> None:
        self.limits = limits
        self.home: Vec3 = (start_pose[0], start_pose[1], start_pose[2])
        self.orientation: Vec3 = (start_pose[3], start_pose[4], start_pose[5])
        self.p: Vec3 = self.home
        self.v: Vec3 = ZERO3
        self.mode = "idle"
        self.servo_target: Vec3 | None = None
        self.servo_tau = 0.1
        self.servo_gain = 300.0
        self.speed_target: Vec3 = ZERO3
        self.accel = 0.0
        self.linear_target: Vec3 | None = None
        self.linear_speed = 0.0
        self.stop_decel = limits.safety_stop_decel

    # --- commands -------------------------------------------------------------------
    def servo(self, target: Vec3, lookahead_time: float, gain: float) -> None:
        """Follow target with time constant lookahead_time (clamped to [0.002, 1] s)."""
        self.servo_target = target
        tau = self.limits.response_time_s or lookahead_time
        self.servo_tau = min(max(tau, 0.002), 1.0)
        self.servo_gain = gain
        self.mode = "servo"

    def speed(self, velocity: Vec3, accel: float) -> None:
        self.speed_target = _clamp_norm(velocity, self.limits.max_speed)
        self.accel = min(max(accel, 0.01), self.limits.max_accel)
        self.mode = "speed"

    def move_linear(self, target: Vec3, speed: float, accel: float) -> None:
        self.linear_target = target
        self.linear_speed = min(max(speed, 0.001), self.limits.max_speed)
        self.accel = min(max(accel, 0.01), self.limits.max_accel)
        self.mode = "linear"

    def stop(self, decel: float) -> None:
        """Decelerate to rest at decel m/s^2 (clamped to [0.1, 100]); the servo target
        stays recorded for the trace."""
        self.stop_decel = min(max(decel, 0.1), 100.0) if math.isfinite(decel) else 100.0
        self.mode = "stopping" if _norm(self.v) > 0.0 else "idle"

    @property
    def at_rest(self) -> bool:
        return self.mode in ("idle", "stopping") and self.v == ZERO3

    # --- integration ----------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance dt seconds."""
        lim = self.limits
        if self.mode == "servo" and self.servo_target is not None:
            v_des = _clamp_norm(
                _scale(_sub(self.servo_target, self.p), 1.0 / self.servo_tau), lim.max_speed
            )
            self.v = _add(self.v, _clamp_norm(_sub(v_des, self.v), lim.max_accel * dt))
        elif self.mode == "speed":
            self.v = _add(self.v, _clamp_norm(_sub(self.speed_target, self.v), self.accel * dt))
        elif self.mode == "linear" and self.linear_target is not None:
            to_go = _sub(self.linear_target, self.p)
            distance = _norm(to_go)
            # the fastest speed from which accel still stops at the target
            speed = min(self.linear_speed, math.sqrt(2.0 * self.accel * distance))
            v_des = _scale(to_go, speed / distance) if distance > 1e-9 else ZERO3
            self.v = _add(self.v, _clamp_norm(_sub(v_des, self.v), self.accel * dt))
            if distance < 1e-6 and _norm(self.v) < self.accel * dt:
                self.p, self.v, self.mode = self.linear_target, ZERO3, "idle"
                return
        elif self.mode == "stopping":
            speed = _norm(self.v)
            reduced = speed - self.stop_decel * dt
            if reduced <= 1e-12:  # (rounding would leave a residue of ~1e-17 m/s)
                # stop within this period: travel the remaining braking distance
                self.p = _add(self.p, _scale(self.v, 0.5 * speed / self.stop_decel))
                self.v, self.mode = ZERO3, "idle"
                return
            v_new = _scale(self.v, reduced / speed)
            self.p = _add(self.p, _scale(_add(self.v, v_new), 0.5 * dt))
            self.v = v_new
            return
        else:
            self.v = ZERO3
            return
        self.p = _add(self.p, _scale(self.v, dt))

    # --- derived outputs ------------------------------------------------------------
    def pose(self) -> tuple[float, ...]:
        return self.p + self.orientation

    def target_pose(self) -> tuple[float, ...]:
        target = self.servo_target if self.mode == "servo" and self.servo_target else self.p
        return target + self.orientation

    def joints(self) -> tuple[float, ...]:
        d = _sub(self.p, self.home)
        return tuple(
            q0 + row[0] * d[0] + row[1] * d[1] + row[2] * d[2]
            for q0, row in zip(self.Q_HOME, self.Q_PER_M, strict=True)
        )

    def joint_speeds(self) -> tuple[float, ...]:
        v = self.v
        return tuple(row[0] * v[0] + row[1] * v[1] + row[2] * v[2] for row in self.Q_PER_M)


@dataclass
class Person:
    """The force the person applies at the tool, in B (N). kind: "none", "constant",
    "ramp" (from -> to over duration_s starting at t0), "step" (before until t0, then
    after), "spring" (k (anchor - p) - damping v, limited to max_force). Gaussian noise of
    sigma N per axis from a seeded generator."""

    kind: str = "none"
    force: Vec3 = ZERO3
    force_to: Vec3 = ZERO3
    t0: float = 0.0
    duration_s: float = 0.0
    anchor: Vec3 = ZERO3
    k: float = 0.0
    damping: float = 0.0
    max_force: float = math.inf
    noise_sigma: float = 0.0
    rng: random.Random = field(default_factory=lambda: random.Random(0))

    def force_at(self, t: float, p: Vec3, v: Vec3) -> Vec3:
        if self.kind == "constant":
            f = self.force
        elif self.kind == "ramp":
            s = (
                1.0
                if self.duration_s <= 0.0
                else min(max((t - self.t0) / self.duration_s, 0.0), 1.0)
            )
            f = _add(self.force, _scale(_sub(self.force_to, self.force), s))
        elif self.kind == "step":
            f = self.force if t < self.t0 else self.force_to
        elif self.kind == "spring":
            f = _clamp_norm(
                _sub(_scale(_sub(self.anchor, p), self.k), _scale(v, self.damping)), self.max_force
            )
        else:
            f = ZERO3
        if self.noise_sigma > 0.0:
            g = self.rng.gauss
            f = (
                f[0] + g(0.0, self.noise_sigma),
                f[1] + g(0.0, self.noise_sigma),
                f[2] + g(0.0, self.noise_sigma),
            )
        return f


@dataclass
class ForceSensor:
    """A six-axis force-torque sensor: reading = applied + bias + drift_rate (t - t_drift)
    - zero_offset, per axis (3 forces N, 3 torques N m). zero() tares the current reading."""

    bias: list[float] = field(default_factory=lambda: [0.0] * 6)
    drift_rate: list[float] = field(default_factory=lambda: [0.0] * 6)
    drift_start: float = 0.0
    zero_offset: list[float] = field(default_factory=lambda: [0.0] * 6)

    def raw(self, applied: tuple[float, ...], t: float) -> list[float]:
        elapsed = max(t - self.drift_start, 0.0)
        return [applied[i] + self.bias[i] + self.drift_rate[i] * elapsed for i in range(6)]

    def reading(self, applied: tuple[float, ...], t: float) -> list[float]:
        raw = self.raw(applied, t)
        return [raw[i] - self.zero_offset[i] for i in range(6)]

    def zero(self, applied: tuple[float, ...], t: float) -> None:
        self.zero_offset = self.raw(applied, t)

    def start_drift(self, rate: list[float], t: float) -> None:
        """Fold the drift so far into the bias, then drift at rate (N/s, N m/s)."""
        elapsed = max(t - self.drift_start, 0.0)
        self.bias = [self.bias[i] + self.drift_rate[i] * elapsed for i in range(6)]
        self.drift_rate = list(rate)
        self.drift_start = t

    def jump(self, step: list[float]) -> None:
        self.bias = [self.bias[i] + step[i] for i in range(6)]

    def clear_faults(self, t: float) -> None:
        self.bias = [0.0] * 6
        self.drift_rate = [0.0] * 6
        self.drift_start = t
