"""Argument checks at the API boundary: each converts a caller's value to the type the
package works with (float, numpy arrays) or raises LocalError naming the argument and
its bad value, e.g. "radius is -0.5; it must be a finite number > 0".
"""

from __future__ import annotations

import math
import os
import sys
import warnings
from dataclasses import dataclass
from types import FrameType
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hapticd.errors import LocalError, QuaternionOrderWarning

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.uint32]

# How far from unit a quaternion or orthonormal a rotation matrix may be, and be accepted.
ROTATION_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Range:
    """The documented range of one quantity: from low to high, each end closed unless
    marked open, in unit."""

    low: float
    high: float
    unit: str = ""
    low_open: bool = False
    high_open: bool = False

    def __contains__(self, value: float) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def __str__(self) -> str:
        text = (
            f"{'(' if self.low_open else '['}{_bound(self.low)}, "
            f"{_bound(self.high)}{')' if self.high_open else ']'}"
        )
        return f"{text} {self.unit}" if self.unit else text


def _bound(x: float) -> str:
    """A range's end as its documentation writes it: 10000, 0.001, 1e+07, inf."""
    return f"{x:g}"


# The server's documented ranges, the one table every check here reads (the server
# refuses the same values, naming the same field).
RANGES: dict[str, Range] = {
    # OpenSession: SessionLimits, server/force/session_settings.h
    "rate_hz": Range(10, 10_000, "Hz"),
    "max_force": Range(0, 1e4, "N", low_open=True),
    "max_velocity": Range(0, 100, "m/s", low_open=True),
    "avatar_radius": Range(0, 1, "m", low_open=True),  # a sphere avatar's; a point's is 0
    "virtual_mass": Range(1e-3, 1e3, "kg"),  # 0 on the wire: the server's 1 kg
    "virtual_damping": Range(0, 1e5, "N·s/m"),  # 0 on the wire: the server's 20 N·s/m
    "max_force_rate": Range(0, math.inf, "N/s", high_open=True),  # 0: no limit
    # OpenSession.timeout_s (0: the server's 2 s): after the watchdog's 0.05 s timeout
    # and 0.1 s ramp, within an hour (server/net/proto_convert.cc)
    "session_timeout_s": Range(0.15, 3600, "s"),
    # OpenSession's deadband (0 on the wire for a floor or the keep-alive: the server's
    # default): remote::ValidateDeadband, server/remote/deadband.h
    "deadband": Range(0, 1, high_open=True),
    "deadband_force_floor": Range(0, 10, "N", low_open=True),
    "deadband_position_floor": Range(0, 0.01, "m", low_open=True),
    "deadband_velocity_floor": Range(0, 1, "m/s", low_open=True),
    "keepalive_s": Range(0, 0.025, "s", low_open=True),
    # Scene objects: SceneLimits, server/scene/scene_limits.h
    "coordinate": Range(-1e4, 1e4, "m"),  # positions, vertices, hull points
    "size": Range(0, 1e3, "m", low_open=True),  # radii, half extents
    "half_length": Range(0, 1e3, "m"),
    "stiffness": Range(0, 1e7, "N/m", low_open=True),
    "damping": Range(0, 1e5, "N·s/m"),
    "friction": Range(0, 10),
    "speed": Range(0, 100, "m/s"),  # a kinematic object's velocity, its norm
    "angular_speed": Range(0, 1e3, "rad/s"),  # its angular velocity, the norm
    # Subscribe.rate_hz: server/net/control_service.cc
    "subscribe_rate_hz": Range(0.1, 1000, "Hz"),
}
# SceneBudgets::max_name_bytes, server/scene/scene_limits.h (a deployment's default).
MAX_NAME_BYTES = 128


def _shown(value: Any) -> str:
    """value as an error message shows it: arrays as nested lists, floats exactly."""
    if isinstance(value, np.ndarray):
        return str(value.tolist())
    return repr(value)


def _not_a_number(value: Any) -> bool:
    """Whether value is text or a truth value, which float() would take for a number."""
    return isinstance(value, (str, bytes, bool, np.bool_, np.str_, np.bytes_))


def number(value: Any, name: str) -> float:
    """value as a finite float: an int, a float or a numpy number, not text or a bool."""
    if _not_a_number(value):
        raise LocalError(f"{name} is {_shown(value)}; it must be a number")
    try:
        result = float(value)
    except (TypeError, ValueError) as exc:
        raise LocalError(f"{name} is {_shown(value)}; it must be a number") from exc
    if not math.isfinite(result):
        raise LocalError(f"{name} is {result!r}; it must be a finite number")
    return result


def positive(value: Any, name: str) -> float:
    """value as a finite float > 0."""
    result = number(value, name)
    if result <= 0:
        raise LocalError(f"{name} is {result!r}; it must be a finite number > 0")
    return result


def non_negative(value: Any, name: str) -> float:
    """value as a finite float >= 0."""
    result = number(value, name)
    if result < 0:
        raise LocalError(f"{name} is {result!r}; it must be a finite number >= 0")
    return result


def in_range(value: Any, name: str, low: float, high: float) -> float:
    """value as a finite float in [low, high]."""
    result = number(value, name)
    if not low <= result <= high:
        raise LocalError(f"{name} is {result!r}; it must be in [{low!r}, {high!r}]")
    return result


def limited(value: Any, name: str, quantity: str) -> float:
    """value as a finite float within RANGES[quantity]: "max_force is 0.0; it must be in
    (0, 10000] N"."""
    result = number(value, name)
    allowed = RANGES[quantity]
    if result not in allowed:
        raise LocalError(f"{name} is {result!r}; it must be in {allowed}")
    return result


def limited_or_zero(value: Any, name: str, quantity: str, zero_means: str) -> float:
    """limited(), except that 0 is also accepted: it asks for the server's default,
    which zero_means names in the message."""
    result = number(value, name)
    allowed = RANGES[quantity]
    if result != 0 and result not in allowed:
        raise LocalError(f"{name} is {result!r}; it must be in {allowed}, or 0 for {zero_means}")
    return result


def coordinates(array: FloatArray, name: str) -> FloatArray:
    """array (finite, any shape, the last axis x, y, z) with every coordinate within
    RANGES["coordinate"]: "vertices[4] is [...]; each coordinate must be in [-10000,
    10000] m"."""
    allowed = RANGES["coordinate"]
    outside = (array < allowed.low) | (array > allowed.high)
    if np.any(outside):
        bad = np.argwhere(outside)[0]
        where = "".join(f"[{i}]" for i in bad[:-1])
        row = array[tuple(bad[:-1])] if array.ndim > 1 else array
        raise LocalError(f"{name}{where} is {_shown(row)}; each coordinate must be in {allowed}")
    return array


def norm_limited(vector: FloatArray, name: str, quantity: str) -> FloatArray:
    """vector (finite) whose length is within RANGES[quantity]."""
    length = float(np.linalg.norm(vector))
    allowed = RANGES[quantity]
    if length not in allowed:
        raise LocalError(f"{name} is {_shown(vector)}; its norm {length!r} must be in {allowed}")
    return vector


def as_floats(value: ArrayLike, name: str) -> FloatArray:
    """value as a float64 array of any shape (values unchecked); text and truth values
    are not numbers."""
    try:
        given = np.asarray(value)
        textual = given.dtype.kind in "USb" or (
            given.dtype.kind == "O" and any(_not_a_number(v) for v in given.ravel())
        )
        if not textual:
            return np.asarray(given, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise LocalError(f"{name} is {_shown(value)}; it must be numbers") from exc
    raise LocalError(f"{name} is {_shown(value)}; it must be numbers")


def as_indices(value: ArrayLike, name: str) -> NDArray[Any]:
    """value as an array of its own dtype (checked by triangles())."""
    try:
        return np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise LocalError(f"{name} is {_shown(value)}; it must be integer indices") from exc


def float_array(value: ArrayLike, name: str, shape: tuple[int, ...]) -> FloatArray:
    """value as a finite float64 array of the given shape (-1: any length on that axis)."""
    array = as_floats(value, name)
    fits = array.ndim == len(shape) and all(
        want in (-1, got) for want, got in zip(shape, array.shape, strict=True)
    )
    if not fits:
        wanted = str(tuple("N" if n == -1 else n for n in shape)).replace("'", "")
        raise LocalError(f"{name} has shape {array.shape}; it must be {wanted}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        where = "".join(f"[{i}]" for i in bad[:-1]) if array.ndim > 1 else ""
        row = array[tuple(bad[:-1])] if array.ndim > 1 else array
        raise LocalError(f"{name}{where} is {_shown(row)}; it must be finite")
    return array


def vector3(value: ArrayLike, name: str) -> FloatArray:
    """value as a finite float array of shape (3,)."""
    return float_array(value, name, (3,))


def nonzero_vector3(value: ArrayLike, name: str) -> FloatArray:
    """value as a finite, non-zero float array of shape (3,)."""
    vector = vector3(value, name)
    if not np.any(vector):
        raise LocalError(f"{name} is {_shown(vector)}; it must be non-zero")
    return vector


def points(value: ArrayLike, name: str, minimum: int = 1) -> FloatArray:
    """value as a finite (N, 3) float array with N >= minimum."""
    array = float_array(value, name, (-1, 3))
    if len(array) < minimum:
        raise LocalError(f"{name} has {len(array)} points; it needs at least {minimum}")
    return array


def triangles(value: ArrayLike, name: str, vertex_count: int) -> IndexArray:
    """value as an (M, 3) array of vertex indices in [0, vertex_count), M >= 1."""
    array = as_indices(value, name)
    if array.ndim != 2 or array.shape[1] != 3:
        raise LocalError(f"{name} has shape {array.shape}; it must be (M, 3)")
    if len(array) == 0:
        raise LocalError(f"{name} is empty; a mesh needs at least one triangle")
    if not np.issubdtype(array.dtype, np.integer):
        raise LocalError(f"{name} has dtype {array.dtype}; it must hold integer vertex indices")
    bad = np.argwhere((array < 0) | (array >= vertex_count))
    if len(bad):
        i, j = bad[0]
        raise LocalError(
            f"{name}[{i}][{j}] is {int(array[i, j])}; it must be a vertex index in "
            f"[0, {vertex_count})"
        )
    return array.astype(np.uint32)


class ScipyRotation(Protocol):
    """What hapticd uses of a scipy.spatial.transform.Rotation (scipy >= 1.14)."""

    @property
    def single(self) -> bool: ...

    def as_quat(self, canonical: bool = False, *, scalar_first: bool = False) -> Any: ...


# A rotation as the API takes it: a quaternion (w, x, y, z), a 3x3 matrix, or a scipy
# Rotation.
RotationLike = ArrayLike | ScipyRotation


def _is_scipy_rotation(value: object) -> bool:
    """Whether value is a scipy Rotation (told by its type's module: scipy is imported
    only by whoever made one)."""
    return type(value).__module__.startswith("scipy.spatial.transform") and hasattr(
        value, "as_quat"
    )


def quaternion(value: RotationLike, name: str, *, hint_order: bool = False) -> FloatArray:
    """An orientation as a unit quaternion (w, x, y, z): value is a quaternion (shape
    (4,), unit within 1e-6, in the order (w, x, y, z)), a rotation matrix (shape (3, 3),
    columns the body's axes in the world frame, orthonormal within 1e-6 and det +1) or
    a single scipy.spatial.transform.Rotation. With hint_order, a quaternion that may
    be in scipy's (x, y, z, w) order gets a QuaternionOrderWarning (see
    hint_quaternion_order); it is still read as (w, x, y, z)."""
    if _is_scipy_rotation(value):
        scipy_rotation = cast(ScipyRotation, value)
        if not scipy_rotation.single:
            raise LocalError(
                f"{name} is a scipy Rotation holding {len(cast(Any, scipy_rotation))} "
                "rotations; it must hold one"
            )
        q = float_array(scipy_rotation.as_quat(scalar_first=True), name, (4,))
        result: FloatArray = q / np.linalg.norm(q)
        return result
    array = as_floats(cast(ArrayLike, value), name)
    if array.shape == (4,):
        q = float_array(array, name, (4,))
        norm = float(np.linalg.norm(q))
        if abs(norm - 1) > ROTATION_TOLERANCE:
            raise LocalError(f"{name} is {_shown(q)}; a quaternion must have norm 1, not {norm!r}")
        q = q / norm
        if hint_order:
            hint_quaternion_order(q, name)
        return q
    if array.shape != (3, 3):
        raise LocalError(
            f"{name} has shape {array.shape}; it must be a quaternion (w, x, y, z) "
            "or a 3x3 rotation matrix"
        )
    rotation = float_array(array, name, (3, 3))
    error = float(np.max(np.abs(rotation.T @ rotation - np.eye(3))))
    if error > ROTATION_TOLERANCE or np.linalg.det(rotation) < 0:
        raise LocalError(
            f"{name} is {_shown(rotation)}; it is not a rotation (|R^T R - I| = {error:.3g}, "
            f"det R = {np.linalg.det(rotation):.3g})"
        )
    return rotation_to_quaternion(rotation)


def _turn(q: FloatArray) -> str:
    """The turn a unit quaternion (w, x, y, z) makes, in words: "a turn of 180 degrees
    about [0, 0, 1]"."""
    angle = math.degrees(2 * math.acos(min(1.0, abs(float(q[0])))))
    axis = q[1:] * (1 if q[0] >= 0 else -1)
    length = float(np.linalg.norm(axis))
    if length == 0:
        return "no turn"
    about = ", ".join(f"{c:.3g}" for c in axis / length)
    return f"a turn of {angle:.3g} degrees about [{about}]"


def hint_quaternion_order(q: FloatArray, name: str) -> None:
    """The rule for the order hint: a unit quaternion q given as (w, x, y, z) whose last
    component is larger in magnitude than its first (|q[3]| > |q[0]|) would be the
    smaller turn read in scipy's (x, y, z, w) order. So scipy's as_quat() of every turn
    under 90 degrees gets the hint (the identity, (0, 0, 0, 1), among them), and a
    (w, x, y, z) quaternion of a turn under 90 degrees never does (there |w| > 0.707 >
    |z|). Such a q gets a QuaternionOrderWarning naming both readings, pointing at the
    caller's line; q is used as (w, x, y, z) all the same. A matrix or a scipy Rotation
    never gets one."""
    if abs(float(q[3])) <= abs(float(q[0])):
        return
    scipy_order = np.array([q[3], q[0], q[1], q[2]])
    warnings.warn(
        f"{name} is {_shown(q)}, read as (w, x, y, z): {_turn(q)}; read in scipy's "
        f"(x, y, z, w) order it would be {_turn(scipy_order)}. hapticd's quaternions are "
        "(w, x, y, z): pass a scipy Rotation itself, or as_quat(scalar_first=True), or a "
        "3x3 matrix to say it unambiguously",
        QuaternionOrderWarning,
        stacklevel=_outside_the_package(),
    )


def _outside_the_package() -> int:
    """The warnings stacklevel, for the function that calls this one, of the first
    frame outside the hapticd package: the user's line that gave the value."""
    package = os.path.dirname(os.path.abspath(__file__))
    level = 1
    frame: FrameType | None = sys._getframe(1)
    while frame is not None and frame.f_code.co_filename.startswith(package):
        frame = frame.f_back
        level += 1
    return level


def rotation_to_quaternion(rotation: FloatArray) -> FloatArray:
    """The unit quaternion (w, x, y, z) of a rotation matrix, w >= 0 (Shepperd's method:
    divide by the largest of the four squared components)."""
    r = rotation
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    # pick the best-conditioned of the four formulas
    if trace > max(r[0, 0], r[1, 1], r[2, 2]):
        s = 2 * math.sqrt(1 + trace)
        q = [s / 4, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
    elif r[0, 0] >= r[1, 1] and r[0, 0] >= r[2, 2]:
        s = 2 * math.sqrt(1 + r[0, 0] - r[1, 1] - r[2, 2])
        q = [(r[2, 1] - r[1, 2]) / s, s / 4, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s]
    elif r[1, 1] >= r[2, 2]:
        s = 2 * math.sqrt(1 + r[1, 1] - r[0, 0] - r[2, 2])
        q = [(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, s / 4, (r[1, 2] + r[2, 1]) / s]
    else:
        s = 2 * math.sqrt(1 + r[2, 2] - r[0, 0] - r[1, 1])
        q = [(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, s / 4]
    result = np.array(q, dtype=np.float64)
    result /= np.linalg.norm(result)
    return -result if result[0] < 0 else result


def quaternion_to_rotation(q: FloatArray) -> FloatArray:
    """The rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(c) for c in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ],
        dtype=np.float64,
    )


def flag(value: Any, name: str) -> bool:
    """value as a bool: True or False (numpy's too), nothing else."""
    if not isinstance(value, (bool, np.bool_)):
        raise LocalError(f"{name} is {_shown(value)}; it must be True or False")
    return bool(value)


def choice(value: str, name: str, allowed: tuple[str, ...]) -> str:
    """value if it is one of allowed."""
    if value not in allowed:
        raise LocalError(f"{name} is {value!r}; it must be one of {', '.join(allowed)}")
    return value


def object_name(value: Any, name: str = "name") -> str:
    """A non-empty object name of at most MAX_NAME_BYTES bytes (UTF-8), without control
    characters (the server echoes names in errors and logs)."""
    if not isinstance(value, str) or not value:
        raise LocalError(f"{name} is {value!r}; it must be a non-empty string")
    size = len(value.encode("utf-8", errors="surrogatepass"))
    if size > MAX_NAME_BYTES:
        raise LocalError(
            f"{name} is {value[:32]!r}... ({size} bytes); it must be at most {MAX_NAME_BYTES} bytes"
        )
    control = next((c for c in value if ord(c) < 0x20 or ord(c) == 0x7F), None)
    if control is not None:
        raise LocalError(
            f"{name} is {value!r}; it has the control character {ord(control)} "
            "(names must be printable)"
        )
    return value
