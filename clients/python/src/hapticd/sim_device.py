"""A simulated haptic device held by a simulated hand, the model of the scenario format
(../shared/scenarios/FORMAT.md) and of the server's simulator (server/sim/hand_device.h),
for demos and tests. World frame W, SI units.

The hand is a mass-spring-damper pulled towards a piecewise-linear path of [t, x, y, z]
points and rigidly coupled to the device handle.

Impedance: hand and handle move as one body of mass m = hand.mass + device.mass,
    m a = K_h (path(t) - x) + B_h (path'(t) - v) - b_d v + F,
with F the rendered force held constant over the tick (zero-order hold), integrated
with classical RK4 in substeps short enough (omega h <= 0.05, at least 20 per tick)
that the integrator's energy error is negligible.

Admittance: the hand's force at the handle is what the device senses and sends; the
device goes exactly where it is commanded, within the tick.

Each tick k the loop calls sample(t_k), accept(command) for a command that arrived, and
advance(t_k); energy_j sums the rendered force's work, sum F_k . (x_{k+1} - x_k).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hapticd import _validate as check
from hapticd._validate import FloatArray
from hapticd.errors import LocalError

Vec = tuple[float, float, float]
MIN_SUBSTEPS = 20
MAX_SUBSTEPS = 100_000
MAX_OMEGA_H = 0.05
ZERO: Vec = (0.0, 0.0, 0.0)


def _vec(value: ArrayLike, name: str) -> Vec:
    x, y, z = (float(c) for c in check.vector3(value, name))
    return (x, y, z)


class HandPath:
    """The hand's target: before the first point the first position, after the last the
    last, linear in between. points: [t, x, y, z] rows, times strictly increasing."""

    def __init__(self, points: Sequence[Sequence[float]]) -> None:
        rows = check.float_array(points, "path", (-1, 4))
        if len(rows) == 0:
            raise LocalError("path is empty; it needs at least one [t, x, y, z] point")
        if np.any(np.diff(rows[:, 0]) <= 0):
            i = int(np.argmax(np.diff(rows[:, 0]) <= 0)) + 1
            t, before = float(rows[i, 0]), float(rows[i - 1, 0])
            raise LocalError(
                f"path[{i}][0] is {t!r}; it must be > {before!r}, the time of path[{i - 1}]"
            )
        self._times = [float(t) for t in rows[:, 0]]
        self._points: list[Vec] = [(float(r[1]), float(r[2]), float(r[3])) for r in rows]

    def _segment(self, t: float) -> int:
        """i with t_i <= t < t_{i+1}; -1 before the first point; the last index after."""
        return bisect.bisect_right(self._times, t) - 1

    def position_at(self, t: float) -> Vec:
        """Where the hand wants to be at time t (s)."""
        i = self._segment(t)
        if i < 0:
            return self._points[0]
        if i + 1 >= len(self._points):
            return self._points[-1]
        a, b = self._points[i], self._points[i + 1]
        s = (t - self._times[i]) / (self._times[i + 1] - self._times[i])
        return (a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), a[2] + s * (b[2] - a[2]))

    def velocity_at(self, t: float) -> Vec:
        """The slope of the segment holding t ([t_i, t_{i+1})); zero outside the path."""
        i = self._segment(t)
        if i < 0 or i + 1 >= len(self._points):
            return ZERO
        a, b = self._points[i], self._points[i + 1]
        dt = self._times[i + 1] - self._times[i]
        return ((b[0] - a[0]) / dt, (b[1] - a[1]) / dt, (b[2] - a[2]) / dt)


@dataclass(frozen=True)
class HandSpec:
    """The person: mass (kg, >= 0), stiffness (N/m, >= 0) and damping (N·s/m, >= 0)
    towards the path ([t, x, y, z] rows)."""

    mass: float
    stiffness: float
    damping: float
    path: Sequence[Sequence[float]]


@dataclass(frozen=True)
class DeviceSpec:
    """The device: handle mass (kg, > 0), its own damping (N·s/m, >= 0), the largest force
    it renders (N, > 0), where it starts (m), and its position resolution (m; 0: exact)."""

    mass: float
    damping: float
    max_force: float
    start: ArrayLike
    position_resolution: float = 0.0


def calc_substeps(mass: float, stiffness: float, damping: float, dt: float) -> int:
    """Substeps per tick of dt: omega h <= 0.05 for both sqrt(K/m) and B/m, at least 20;
    LocalError when more than 100000 would be needed."""
    omega = max(math.sqrt(stiffness / mass), damping / mass)
    needed = math.ceil(omega * dt / MAX_OMEGA_H)
    if needed > MAX_SUBSTEPS:
        raise LocalError(
            f"the hand and device are too stiff for dt = {dt!r} s: {needed} substeps per tick "
            f"needed, at most {MAX_SUBSTEPS}"
        )
    return max(MIN_SUBSTEPS, needed)


@dataclass(frozen=True, eq=False)
class SimSample:
    """What the device senses at a tick: position (m), velocity (m/s), and the force
    it reports: the force held over the last tick (impedance) or the hand's force at the
    handle (admittance), N."""

    position: FloatArray
    velocity: FloatArray
    force: FloatArray


class _SimDeviceBase:
    """What both modes share: the hand, the tick, sensing and the energy account."""

    def __init__(self, hand: HandSpec, device: DeviceSpec, rate_hz: float) -> None:
        self.dt = 1 / check.positive(rate_hz, "rate_hz")
        self.hand_mass = check.non_negative(hand.mass, "hand.mass")
        self.hand_stiffness = check.non_negative(hand.stiffness, "hand.stiffness")
        self.hand_damping = check.non_negative(hand.damping, "hand.damping")
        self.path = HandPath(hand.path)
        self.device_mass = check.positive(device.mass, "device.mass")
        self.device_damping = check.non_negative(device.damping, "device.damping")
        self.max_force = check.positive(device.max_force, "device.max_force")
        self.resolution = check.non_negative(device.position_resolution, "position_resolution")
        self._p: Vec = _vec(device.start, "device.start")
        self._v: Vec = ZERO
        self._q_last = self._quantize(self._p)
        self.energy_j = 0.0

    @property
    def position(self) -> FloatArray:
        """The true handle position now (m)."""
        return np.array(self._p)

    @property
    def velocity(self) -> FloatArray:
        """The true handle velocity now (m/s)."""
        return np.array(self._v)

    def hand_force(self, t: float, p: Vec, v: Vec) -> Vec:
        """K_h (path(t) - p) + B_h (path'(t) - v): the hand's force on the handle (N)."""
        return self._hand_force(self._path_target(t), p, v)

    def _path_target(self, t: float) -> tuple[Vec, Vec]:
        """Where the hand wants the handle at t, and how fast."""
        return self.path.position_at(t), self.path.velocity_at(t)

    def _hand_force(self, target: tuple[Vec, Vec], p: Vec, v: Vec) -> Vec:
        """The hand's force towards target = (path position, path velocity)."""
        (x, y, z), (vx, vy, vz) = target
        k, b = self.hand_stiffness, self.hand_damping
        return (
            k * (x - p[0]) + b * (vx - v[0]),
            k * (y - p[1]) + b * (vy - v[1]),
            k * (z - p[2]) + b * (vz - v[2]),
        )

    def _quantize(self, p: Vec) -> Vec:
        if self.resolution == 0:
            return p
        r = self.resolution
        return (_round(p[0] / r) * r, _round(p[1] / r) * r, _round(p[2] / r) * r)

    def _sense(self) -> tuple[Vec, Vec]:
        """The sensed position, and the velocity: the true one for an exact sensor, a
        finite difference of quantized positions otherwise."""
        q = self._quantize(self._p)
        if self.resolution > 0:
            last = self._q_last
            v = ((q[0] - last[0]) / self.dt, (q[1] - last[1]) / self.dt, (q[2] - last[2]) / self.dt)
        else:
            v = self._v
        self._q_last = q
        return q, v


class SimImpedanceDevice(_SimDeviceBase):
    """An impedance device (position in, force out) and the hand holding it."""

    def __init__(self, hand: HandSpec, device: DeviceSpec, rate_hz: float = 1000.0) -> None:
        super().__init__(hand, device, rate_hz)
        self.mass = self.hand_mass + self.device_mass
        self.substeps = calc_substeps(
            self.mass, self.hand_stiffness, self.hand_damping + self.device_damping, self.dt
        )
        self._f_held: Vec = ZERO

    @property
    def held_force(self) -> FloatArray:
        """The force rendered over the current tick (N)."""
        return np.array(self._f_held)

    def sample(self, t: float) -> SimSample:
        """The state at t: the handle's position, velocity and the force held since the
        previous sample."""
        p, v = self._sense()
        return SimSample(np.array(p), np.array(v), np.array(self._f_held))

    def accept(self, force: ArrayLike) -> None:
        """Takes a commanded force (N): saturated at max_force; a non-finite one renders
        zero."""
        f = check.as_floats(force, "force").reshape(3)
        if not np.all(np.isfinite(f)):
            self._f_held = ZERO
            return
        norm = float(np.linalg.norm(f))
        scale = self.max_force / norm if norm > self.max_force else 1.0
        self._f_held = (float(f[0]) * scale, float(f[1]) * scale, float(f[2]) * scale)

    def _acceleration(self, target: tuple[Vec, Vec], p: Vec, v: Vec) -> Vec:
        h = self._hand_force(target, p, v)
        b, f, m = self.device_damping, self._f_held, self.mass
        return (
            (h[0] - b * v[0] + f[0]) / m,
            (h[1] - b * v[1] + f[1]) / m,
            (h[2] - b * v[2] + f[2]) / m,
        )

    def advance(self, t: float) -> None:
        """Moves hand and handle from t to t + dt under the held force (RK4 substeps)."""
        before = self._p
        h = self.dt / self.substeps
        p, v = self._p, self._v
        # classical RK4 on (p, v), the force held constant; the path's target at each
        # substep's start, middle and end
        start = self._path_target(t)
        for i in range(self.substeps):
            s = t + i * h
            middle = self._path_target(s + 0.5 * h)
            end = self._path_target(s + h)
            a1 = self._acceleration(start, p, v)
            p2 = _axpy(0.5 * h, v, p)
            v2 = _axpy(0.5 * h, a1, v)
            a2 = self._acceleration(middle, p2, v2)
            p3 = _axpy(0.5 * h, v2, p)
            v3 = _axpy(0.5 * h, a2, v)
            a3 = self._acceleration(middle, p3, v3)
            p4 = _axpy(h, v3, p)
            v4 = _axpy(h, a3, v)
            a4 = self._acceleration(end, p4, v4)
            p = _rk4_sum(p, h, v, v2, v3, v4)
            v = _rk4_sum(v, h, a1, a2, a3, a4)
            start = end
        self._p, self._v = p, v
        f = self._f_held
        self.energy_j += (
            f[0] * (p[0] - before[0]) + f[1] * (p[1] - before[1]) + f[2] * (p[2] - before[2])
        )


class SimAdmittanceDevice(_SimDeviceBase):
    """An admittance device (force in, pose out): it senses the hand's force at the
    handle and takes the commanded position exactly within the tick."""

    def __init__(self, hand: HandSpec, device: DeviceSpec, rate_hz: float = 1000.0) -> None:
        super().__init__(hand, device, rate_hz)
        self._target: Vec = self._p
        self._f_hand: Vec = ZERO

    @property
    def sensed_force(self) -> FloatArray:
        """The hand's force at the handle at the last sample (N)."""
        return np.array(self._f_hand)

    def sample(self, t: float) -> SimSample:
        """The state at t: position, velocity and the hand's force at the handle."""
        p, v = self._sense()
        self._f_hand = self.hand_force(t, self._p, self._v)
        return SimSample(np.array(p), np.array(v), np.array(self._f_hand))

    def accept(self, position: ArrayLike) -> None:
        """Takes a commanded position (m); a non-finite one is not followed."""
        target = check.as_floats(position, "position").reshape(3)
        if np.all(np.isfinite(target)):
            self._target = (float(target[0]), float(target[1]), float(target[2]))

    def advance(self, t: float) -> None:
        """Moves the handle to the commanded position over the tick [t, t + dt)."""
        before = self._p
        self._p = self._target
        p, dt = self._p, self.dt
        self._v = ((p[0] - before[0]) / dt, (p[1] - before[1]) / dt, (p[2] - before[2]) / dt)
        self.energy_j -= sum(self._f_hand[k] * (self._p[k] - before[k]) for k in range(3))


def _axpy(a: float, x: Vec, y: Vec) -> Vec:
    """a x + y."""
    return (a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2])


def _rk4_sum(x: Vec, h: float, k1: Vec, k2: Vec, k3: Vec, k4: Vec) -> Vec:
    """x + h/6 (k1 + 2 k2 + 2 k3 + k4): RK4's update from its four slopes."""
    c = h / 6
    return (
        x[0] + c * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
        x[1] + c * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]),
        x[2] + c * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]),
    )


def _round(x: float) -> float:
    """x to the nearest integer, halves away from zero (as std::round)."""
    return math.copysign(math.floor(abs(x) + 0.5), x)
