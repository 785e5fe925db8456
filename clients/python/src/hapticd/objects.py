"""Scene objects as the client describes them: shapes, materials, poses and whole object
specifications. Units SI (m, N/m, N·s/m); poses in the world frame W. Every constructor
validates its arguments and raises LocalError naming a bad one; arrays are stored as
float64 (points) or uint32 (triangle indices) numpy arrays.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import trimesh
from numpy.typing import ArrayLike

from hapticd import _validate as check
from hapticd._validate import FloatArray, IndexArray, RotationLike
from hapticd.errors import LocalError

REPRESENTATIONS = ("auto", "sphere", "box", "capsule", "convex", "mesh")
RAY_BACKENDS = ("default", "native", "embree")
# The stiffness (N/m) of a material that does not give one: the server's default
# (server/scene/material.h), for add_* and scene load alike.
DEFAULT_STIFFNESS = 1000.0


def _zeros() -> FloatArray:
    return np.zeros(3)


def _identity() -> FloatArray:
    return np.array([1.0, 0.0, 0.0, 0.0])


@dataclass(frozen=True)
class Material:
    """How an object feels: stiffness (N/m, in (0, 1e7]), damping along the normal
    (N·s/m, in [0, 1e5]), static and dynamic friction coefficients (in [0, 10], dynamic
    <= static), and force shading (None: the server's default, on)."""

    stiffness: float = DEFAULT_STIFFNESS
    damping: float = 0.0
    static_friction: float = 0.0
    dynamic_friction: float = 0.0
    force_shading: bool | None = None

    def __post_init__(self) -> None:
        checked = check_material_fields(
            {
                "stiffness": self.stiffness,
                "damping": self.damping,
                "static_friction": self.static_friction,
                "dynamic_friction": self.dynamic_friction,
            }
        )
        object.__setattr__(self, "stiffness", checked["stiffness"])
        object.__setattr__(self, "damping", checked["damping"])
        static, dynamic = checked["static_friction"], checked["dynamic_friction"]
        if dynamic > static:
            raise LocalError(
                f"material.dynamic_friction is {dynamic!r}; it must be <= "
                f"material.static_friction ({static!r})"
            )
        object.__setattr__(self, "static_friction", static)
        object.__setattr__(self, "dynamic_friction", dynamic)
        if self.force_shading is not None:
            object.__setattr__(
                self, "force_shading", check.flag(self.force_shading, "material.force_shading")
            )


@dataclass(frozen=True, eq=False)
class Pose:
    """A rigid pose in W: position (m, shape (3,)) and orientation as a unit quaternion
    (w, x, y, z). Build one with Pose.of(position, rotation)."""

    position: FloatArray = field(default_factory=_zeros)
    orientation: FloatArray = field(default_factory=_identity)

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", check.vector3(self.position, "position"))
        object.__setattr__(self, "orientation", check.quaternion(self.orientation, "rotation"))

    @classmethod
    def of(cls, position: ArrayLike = (0, 0, 0), rotation: RotationLike | None = None) -> Pose:
        """The pose at position with rotation: a quaternion (w, x, y, z), a 3x3 rotation
        matrix (columns the body's axes in W), a scipy.spatial.transform.Rotation or None
        (identity). A quaternion that may be in scipy's (x, y, z, w) order gets a
        QuaternionOrderWarning (the rule: _validate.hint_quaternion_order)."""
        return cls(
            check.vector3(position, "position"),
            _identity()
            if rotation is None
            else check.quaternion(rotation, "rotation", hint_order=True),
        )

    @property
    def rotation(self) -> FloatArray:
        """The orientation as a 3x3 rotation matrix (columns the body's axes in W)."""
        return check.quaternion_to_rotation(self.orientation)


@dataclass(frozen=True)
class Sphere:
    """A sphere of radius (m, in (0, 1e3]) centred at the body origin."""

    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", check.limited(self.radius, "radius", "size"))


@dataclass(frozen=True, eq=False)
class Box:
    """A box with half_extents (m, each in (0, 1e3]) along the body's axes, centred at
    its origin."""

    half_extents: FloatArray

    def __post_init__(self) -> None:
        half = check.vector3(self.half_extents, "half_extents")
        size = check.RANGES["size"]
        if not all(float(h) in size for h in half):
            raise LocalError(f"half_extents is {half.tolist()}; each must be in {size}")
        object.__setattr__(self, "half_extents", half)


@dataclass(frozen=True)
class Capsule:
    """A capsule: radius (m, in (0, 1e3]) around the segment of half_length (m, in
    [0, 1e3]) along the body's z axis."""

    radius: float
    half_length: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", check.limited(self.radius, "radius", "size"))
        half_length = check.limited(self.half_length, "half_length", "half_length")
        object.__setattr__(self, "half_length", half_length)


@dataclass(frozen=True)
class Plane:
    """The half-space below the body's xy plane: its z axis is the outward normal."""


@dataclass(frozen=True, eq=False)
class Convex:
    """The convex hull of points (m, shape (N, 3), N >= 4, in the body frame, each
    coordinate within 1e4 m)."""

    points: FloatArray

    def __post_init__(self) -> None:
        points = check.coordinates(check.points(self.points, "points", minimum=4), "points")
        object.__setattr__(self, "points", points)


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh in the body frame: vertices (m, shape (N, 3)), triangles (vertex
    indices, shape (M, 3), counter-clockwise seen from outside), the representation
    the server should render it as ("auto": the cheapest within the scene's tolerance)
    and, kept as a mesh, the backend of its queries ("default": the server's; "native"
    or "embree": the same answers)."""

    vertices: FloatArray
    triangles: IndexArray
    representation: str = "auto"
    ray_backend: str = "default"

    @classmethod
    def from_trimesh(
        cls, mesh: Any, representation: str = "auto", ray_backend: str = "default"
    ) -> Mesh:
        """The Mesh of a trimesh.Trimesh (its vertices and faces; a trimesh.Scene is
        refused: concatenate its geometry first, scene.to_mesh())."""
        vertices, triangles = trimesh_arrays(mesh, "mesh")
        return cls(vertices, triangles, representation, ray_backend)

    def __post_init__(self) -> None:
        vertices = check.coordinates(check.points(self.vertices, "vertices", minimum=3), "vertices")
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(
            self, "triangles", check.triangles(self.triangles, "triangles", len(vertices))
        )
        check.choice(self.representation, "representation", REPRESENTATIONS)
        check.choice(self.ray_backend, "ray_backend", RAY_BACKENDS)


def trimesh_arrays(mesh: Any, name: str) -> tuple[FloatArray, IndexArray]:
    """The vertices (N, 3) and faces (M, 3) of a trimesh.Trimesh; LocalError for anything
    else, a trimesh.Scene (several meshes) named as such."""
    if isinstance(mesh, trimesh.Scene):
        raise LocalError(
            f"{name} is a trimesh.Scene of {len(mesh.geometry)} geometries; give one "
            "trimesh.Trimesh (scene.to_mesh() concatenates them)"
        )
    if not isinstance(mesh, trimesh.Trimesh):
        raise LocalError(f"{name} is {type(mesh).__name__}; it must be a trimesh.Trimesh")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    triangles = np.asarray(mesh.faces, dtype=np.int64)
    return vertices, check.triangles(triangles, f"{name}.faces", len(vertices))


Shape = Sphere | Box | Capsule | Plane | Convex | Mesh
SHAPE_TYPES = (Sphere, Box, Capsule, Plane, Convex, Mesh)


@dataclass(frozen=True, eq=False)
class ObjectSpec:
    """One object to add to (or replace in) the scene: a unique name, a shape, its pose
    in W (each coordinate of its position within 1e4 m), its material, and for a
    kinematic object its velocity (m/s, at most 100) and angular velocity (rad/s, at
    most 1e3) in W. A static object has zero velocities."""

    name: str
    shape: Shape
    pose: Pose = field(default_factory=Pose)
    material: Material = field(default_factory=Material)
    kinematic: bool = False
    velocity: FloatArray = field(default_factory=_zeros)
    angular_velocity: FloatArray = field(default_factory=_zeros)

    def __post_init__(self) -> None:
        check.object_name(self.name)
        if not isinstance(self.shape, SHAPE_TYPES):
            raise LocalError(
                f"shape is {self.shape!r}; it must be a Sphere, Box, Capsule, Plane, Convex or Mesh"
            )
        if not isinstance(self.pose, Pose):
            raise LocalError(f"pose is {self.pose!r}; it must be a Pose")
        check.coordinates(self.pose.position, "position")
        if not isinstance(self.material, Material):
            raise LocalError(f"material is {self.material!r}; it must be a Material")
        velocity = check.norm_limited(check.vector3(self.velocity, "velocity"), "velocity", "speed")
        angular_velocity = check.vector3(self.angular_velocity, "angular_velocity")
        angular = check.norm_limited(angular_velocity, "angular_velocity", "angular_speed")
        if not self.kinematic and (np.any(velocity) or np.any(angular)):
            raise LocalError(
                f"object {self.name!r} is static but has velocity {velocity.tolist()} and "
                f"angular_velocity {angular.tolist()}; only a kinematic object moves"
            )
        object.__setattr__(self, "velocity", velocity)
        object.__setattr__(self, "angular_velocity", angular)


MATERIAL_FIELDS = tuple(f.name for f in dataclasses.fields(Material))
# Which of _validate.RANGES each numeric material field is within.
_MATERIAL_RANGES = {
    "stiffness": "stiffness",
    "damping": "damping",
    "static_friction": "friction",
    "dynamic_friction": "friction",
}


def check_material_fields(value: Mapping[str, Any]) -> dict[str, Any]:
    """value as a dict of Material fields, each checked on its own against the server's
    ranges (_validate.RANGES; force_shading a bool or None); LocalError naming the first
    unknown field or bad value. How the frictions compare is the Material's to check."""
    checked: dict[str, Any] = {}
    for key, item in value.items():
        if key not in MATERIAL_FIELDS:
            raise LocalError(
                f"material.{key} is not a material field; a material has "
                f"{', '.join(MATERIAL_FIELDS)}"
            )
        if key == "force_shading":
            checked[key] = None if item is None else check.flag(item, "material.force_shading")
        else:
            checked[key] = check.limited(item, f"material.{key}", _MATERIAL_RANGES[key])
    return checked


def material_from(value: Material | dict[str, Any] | None) -> Material:
    """A Material from a Material, a dict of its fields (the others their defaults),
    or None (the defaults)."""
    if value is None:
        return Material()
    if isinstance(value, Material):
        return value
    if isinstance(value, dict):
        return Material(**check_material_fields(value))
    raise LocalError(f"material is {value!r}; it must be a Material, a dict or None")
