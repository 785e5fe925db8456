"""Where a UR arm may go: the robot's base frame in the scene, and the limits every
target passes before servoL.

BasePose places the base frame in the scene (p_scene = R p_base + t); identity by
default, when the scene's world frame is the base frame. MotionLimiter turns the
avatar's position, which can jump (a new scene, a kinematic object's push), into a path
the arm can follow and a person next to it can expect: its speed at most max_speed, its
change of velocity at most max_accel·dt a step, never faster than it can still stop in
before the target (so the arm arrives at a virtual wall's surface without overshooting
it), and every point inside the workspace box.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hapticd._validate import FloatArray
from hapticd.errors import LocalError


def _rotation(quaternion: FloatArray) -> FloatArray:
    """The rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = quaternion
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


class BasePose:
    """The robot's base frame in the scene: a position (m) and a unit quaternion
    (w, x, y, z; normalized here, LocalError when it is not near unit length)."""

    def __init__(
        self, position: ArrayLike = (0.0, 0.0, 0.0), orientation: ArrayLike = (1.0, 0.0, 0.0, 0.0)
    ) -> None:
        t = np.asarray(position, dtype=float).reshape(3)
        q = np.asarray(orientation, dtype=float).reshape(4)
        norm = float(np.linalg.norm(q))
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q)) and abs(norm - 1) < 1e-3):
            raise LocalError(
                f"the base pose {t.tolist()!r} {q.tolist()!r} needs a finite position and a "
                "unit quaternion (w, x, y, z)"
            )
        self.translation = t
        self.rotation = _rotation(q / norm)

    def to_scene(self, p_base: ArrayLike) -> FloatArray:
        return np.asarray(
            self.rotation @ np.asarray(p_base, dtype=float) + self.translation, dtype=float
        )

    def to_base(self, p_scene: ArrayLike) -> FloatArray:
        return np.asarray(
            self.rotation.T @ (np.asarray(p_scene, dtype=float) - self.translation), dtype=float
        )

    def direction_to_scene(self, v_base: ArrayLike) -> FloatArray:
        """A velocity or a force, base frame to scene."""
        return np.asarray(self.rotation @ np.asarray(v_base, dtype=float), dtype=float)


@dataclass(frozen=True)
class Workspace:
    """An axis-aligned box in the base frame (m) that every target stays inside."""

    low: tuple[float, float, float]
    high: tuple[float, float, float]

    def __post_init__(self) -> None:
        for axis, (lo, hi) in enumerate(zip(self.low, self.high, strict=True)):
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise LocalError(
                    f"the workspace's axis {'xyz'[axis]} is [{lo!r}, {hi!r}]; it must be "
                    "finite with low < high"
                )

    @staticmethod
    def around(center: ArrayLike, half_size: float) -> Workspace:
        c = np.asarray(center, dtype=float).reshape(3)
        return Workspace(
            low=(float(c[0] - half_size), float(c[1] - half_size), float(c[2] - half_size)),
            high=(float(c[0] + half_size), float(c[1] + half_size), float(c[2] + half_size)),
        )

    def contains(self, p: ArrayLike) -> bool:
        q = np.asarray(p, dtype=float)
        return bool(np.all(q >= np.array(self.low)) and np.all(q <= np.array(self.high)))

    def clamp(self, p: ArrayLike) -> FloatArray:
        return np.asarray(np.clip(np.asarray(p, dtype=float), self.low, self.high), dtype=float)


class MotionLimiter:
    """The path of the module's docstring: step(target, dt) gives the next position to
    command, starting from start (which must be inside the workspace)."""

    def __init__(
        self, start: ArrayLike, max_speed: float, max_accel: float, workspace: Workspace
    ) -> None:
        if not (math.isfinite(max_speed) and max_speed > 0):
            raise LocalError(f"max_speed is {max_speed!r}; it must be finite and > 0")
        if not (math.isfinite(max_accel) and max_accel > 0):
            raise LocalError(f"max_accel is {max_accel!r}; it must be finite and > 0")
        self.position = np.asarray(start, dtype=float).reshape(3).copy()
        if not workspace.contains(self.position):
            raise LocalError(
                f"the arm's position {self.position.tolist()!r} is outside the workspace "
                f"{workspace.low!r}..{workspace.high!r}: move it inside first"
            )
        self.velocity = np.zeros(3)
        self.max_speed = max_speed
        self.max_accel = max_accel
        self.workspace = workspace

    def step(self, target: ArrayLike, dt: float) -> FloatArray:
        goal = self.workspace.clamp(target)
        offset = goal - self.position
        distance = float(np.linalg.norm(offset))
        # fast enough to get there this step, but no faster than the cap, or than lets
        # the arm stop at the goal under max_accel
        speed = min(distance / dt, self.max_speed, math.sqrt(2.0 * self.max_accel * distance))
        wanted = offset * (speed / distance) if distance > 0 else np.zeros(3)
        change = wanted - self.velocity
        allowed = self.max_accel * dt
        change_norm = float(np.linalg.norm(change))
        # slowing down along the way may take more than max_accel for a step (the goal
        # came nearer): stopping short of a wall wins over the limit; speeding up and
        # turning do not
        slowing = float(np.dot(wanted, self.velocity)) >= 0 and np.linalg.norm(
            wanted
        ) <= np.linalg.norm(self.velocity)
        if change_norm > allowed and not slowing:
            change *= allowed / change_norm
        moved = self.workspace.clamp(self.position + (self.velocity + change) * dt)
        # the workspace's wall stops what runs into it: the velocity is what it let through
        self.velocity = (moved - self.position) / dt
        self.position = moved
        return self.position.copy()
