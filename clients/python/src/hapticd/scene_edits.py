"""The scene's edits as methods, shared by the Client (each edit its own request) and
SceneEdits (a batch of them, sent by Client.edit_scene as one request, applied as one).

    edits = hapticd.SceneEdits()
    for i in range(1000):
        edits.add_sphere(f"grain{i}", 0.002, position=(0.01 * (i % 10), 0.01 * (i // 10), 0))
    version = client.edit_scene(edits)

Every edit is validated as it is made (LocalError naming the bad value); the server
checks the batch again and refuses it whole, naming the edit.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from typing import Any, Generic, TypedDict, TypeVar, Unpack

import numpy as np
import trimesh
from google.protobuf.message import Message
from numpy.typing import ArrayLike

from hapticd import _codec as codec
from hapticd import _validate as check
from hapticd._validate import RotationLike
from hapticd.errors import LocalError
from hapticd.objects import (
    Box,
    Capsule,
    Convex,
    Material,
    Mesh,
    ObjectSpec,
    Plane,
    Pose,
    Shape,
    Sphere,
    check_material_fields,
    material_from,
)
from hapticd.scene_files import read_mesh_file
from hapticd.v1 import hapticd_pb2 as pb

# The most edits one Client.edit_scene may carry (the server's bound).
MAX_EDITS_PER_BATCH = 100_000

# What an edit returns: the new scene version (Client), an awaitable of it
# (AsyncClient), or the edit's index in a batch (SceneEdits).
EditT = TypeVar("EditT")


class Placement(TypedDict, total=False):
    """Where an added object goes and how it feels: position (m, (3,)), rotation (a
    quaternion (w, x, y, z), a 3x3 matrix or a scipy.spatial.transform.Rotation; None:
    identity; a quaternion that may be scipy's (x, y, z, w) gets a
    QuaternionOrderWarning), material (a Material or a
    dict of its fields; None: the server's default, stiffness DEFAULT_STIFFNESS =
    1000 N/m), kinematic (a bool) with its velocity (m/s) and angular_velocity (rad/s),
    and the request's timeout_s. Any other keyword is refused (LocalError naming it)."""

    position: ArrayLike
    rotation: RotationLike | None
    material: Material | dict[str, Any] | None
    kinematic: bool
    velocity: ArrayLike
    angular_velocity: ArrayLike
    timeout_s: float | None


PLACEMENT_KEYWORDS = tuple(Placement.__annotations__)


def _check_position(value: ArrayLike) -> check.FloatArray:
    """A position to send: finite, shape (3,), each coordinate within the server's range."""
    return check.coordinates(check.vector3(value, "position"), "position")


def _check_keywords(call: str, given: Mapping[str, object], own: tuple[str, ...] = ()) -> None:
    """LocalError naming the first keyword of given that is not a Placement's."""
    unknown = [key for key in given if key not in PLACEMENT_KEYWORDS]
    if not unknown:
        return
    takes = own + PLACEMENT_KEYWORDS
    guess = difflib.get_close_matches(unknown[0], takes, n=1)
    hint = f" (did you mean {guess[0]!r}?)" if guess else ""
    raise LocalError(
        f"{call} got an unknown keyword argument {unknown[0]!r}{hint}; it takes {', '.join(takes)}"
    )


class SceneEditor(Generic[EditT]):
    """The scene edits: add_* (from a shape's parameters, a spec or a mesh file),
    update_object, remove_object, set_material, move_kinematic. Each returns EditT:
    the new scene version for a Client, an awaitable of it for an AsyncClient, the
    edit's index for SceneEdits. Subclasses say what an edit does (_edit)."""

    def _edit(self, body_name: str, body: Message, timeout_s: float | None) -> EditT:
        raise NotImplementedError

    def add_object(self, spec: ObjectSpec, *, timeout_s: float | None = None) -> EditT:
        """Adds an object; RemoteError ALREADY_EXISTS when the name is taken."""
        if not isinstance(spec, ObjectSpec):
            raise LocalError(f"spec is {spec!r}; it must be an ObjectSpec")
        message = pb.AddObject()
        codec.fill_object(message.object, spec)
        return self._edit("add_object", message, timeout_s)

    def _add(self, name: str, shape: Shape, placement: Placement) -> EditT:
        timeout_s = placement.pop("timeout_s", None)
        return self.add_object(_spec(name, shape, placement), timeout_s=timeout_s)

    def add_sphere(self, name: str, radius: float, **placement: Unpack[Placement]) -> EditT:
        """Adds a sphere of radius (m) centred at position."""
        _check_keywords("add_sphere", placement)
        return self._add(name, Sphere(radius), placement)

    def add_box(self, name: str, half_extents: ArrayLike, **placement: Unpack[Placement]) -> EditT:
        """Adds a box of half_extents (m, (3,), along its axes) centred at position."""
        _check_keywords("add_box", placement)
        return self._add(name, Box(check.as_floats(half_extents, "half_extents")), placement)

    def add_capsule(
        self, name: str, radius: float, half_length: float, **placement: Unpack[Placement]
    ) -> EditT:
        """Adds a capsule: radius (m) around a segment of half_length (m) along its z axis."""
        _check_keywords("add_capsule", placement)
        return self._add(name, Capsule(radius, half_length), placement)

    def add_plane(
        self, name: str, normal: ArrayLike | None = None, **placement: Unpack[Placement]
    ) -> EditT:
        """Adds the half-space behind a plane through position: its outward normal is the
        body's z axis, or `normal` (non-zero, (3,)) when given instead of a rotation."""
        _check_keywords("add_plane", placement, ("normal",))
        if normal is not None:
            if placement.get("rotation") is not None:
                raise LocalError("give add_plane a normal or a rotation, not both")
            placement["rotation"] = _rotation_to_z(check.nonzero_vector3(normal, "normal"))
        return self._add(name, Plane(), placement)

    def add_convex(self, name: str, points: ArrayLike, **placement: Unpack[Placement]) -> EditT:
        """Adds the convex hull of points (m, (N, 3), N >= 4, in the body frame)."""
        _check_keywords("add_convex", placement)
        return self._add(name, Convex(check.as_floats(points, "points")), placement)

    def add_mesh(
        self,
        name: str,
        vertices: ArrayLike | trimesh.Trimesh,
        triangles: ArrayLike | None = None,
        representation: str = "auto",
        ray_backend: str = "default",
        **placement: Unpack[Placement],
    ) -> EditT:
        """Adds a triangle mesh: vertices (m, (N, 3)) and triangles ((M, 3) integer vertex
        indices, counter-clockwise seen from outside), or a trimesh.Trimesh in place of
        vertices (and no triangles: its faces are), rendered as `representation`
        ("auto": the cheapest within the scene's tolerance, or sphere, box, capsule,
        convex, mesh); kept as a mesh, its queries run on `ray_backend` ("default": the
        server's, "native" or "embree")."""
        _check_keywords("add_mesh", placement, ("representation", "ray_backend"))
        if isinstance(vertices, (trimesh.Trimesh, trimesh.Scene)):
            if triangles is not None:
                raise LocalError(
                    "add_mesh got a trimesh.Trimesh and triangles; the Trimesh's faces are "
                    "its triangles, so give no triangles"
                )
            mesh = Mesh.from_trimesh(vertices, representation, ray_backend)
        else:
            if triangles is None:
                raise LocalError(
                    "add_mesh got vertices and no triangles; give both, or a trimesh.Trimesh"
                )
            mesh = Mesh(
                check.as_floats(vertices, "vertices"),
                check.as_indices(triangles, "triangles"),
                representation,
                ray_backend,
            )
        return self._add(name, mesh, placement)

    def add_mesh_file(
        self,
        name: str,
        path: str,
        representation: str = "auto",
        scale: float = 1.0,
        **placement: Unpack[Placement],
    ) -> EditT:
        """Adds the mesh of an OBJ, STL or PLY file, its coordinates times scale (e.g.
        0.001 for a file in millimetres)."""
        _check_keywords("add_mesh_file", placement, ("representation", "scale"))
        scale = check.positive(scale, "scale")
        vertices, triangles = read_mesh_file(path)
        return self._add(name, Mesh(vertices * scale, triangles, representation), placement)

    def update_object(self, spec: ObjectSpec, *, timeout_s: float | None = None) -> EditT:
        """Replaces the object of spec's name with spec; RemoteError NOT_FOUND if none."""
        if not isinstance(spec, ObjectSpec):
            raise LocalError(f"spec is {spec!r}; it must be an ObjectSpec")
        message = pb.UpdateObject()
        codec.fill_object(message.object, spec)
        return self._edit("update_object", message, timeout_s)

    def remove_object(self, name: str, *, timeout_s: float | None = None) -> EditT:
        """Removes the object called name; RemoteError NOT_FOUND if there is none."""
        message = pb.RemoveObject(name=check.object_name(name))
        return self._edit("remove_object", message, timeout_s)

    def set_material(
        self, name: str, material: Material | dict[str, Any], *, timeout_s: float | None = None
    ) -> EditT:
        """Changes the material of the object called name. A dict changes only the
        fields it names, e.g. {"damping": 3}: the others keep the object's values (the
        server reads and writes them in one step, so no other client's edit comes in
        between). A Material replaces the whole material. LocalError for a field that is
        not a Material's or a bad value (named); RemoteError NOT_FOUND when there is no
        such object, BAD_REQUEST when the result is not a material (e.g. a dynamic
        friction above the static one)."""
        check.object_name(name)
        if isinstance(material, dict):
            change = codec.material_change_message(check_material_fields(material))
            return self._edit("set_material", pb.SetMaterial(name=name, change=change), timeout_s)
        whole = codec.material_message(material_from(material))
        message = pb.SetMaterial(name=name, material=whole)
        return self._edit("set_material", message, timeout_s)

    def move_kinematic(
        self,
        name: str,
        position: ArrayLike,
        rotation: RotationLike | None = None,
        velocity: ArrayLike = (0, 0, 0),
        angular_velocity: ArrayLike = (0, 0, 0),
        *,
        timeout_s: float | None = None,
    ) -> EditT:
        """Moves a kinematic object to a pose (rotation as in Placement), with its
        velocities from now on (m/s, rad/s); RemoteError if it is static."""
        message = pb.MoveKinematic(
            name=check.object_name(name),
            pose=codec.pose_message(Pose.of(_check_position(position), rotation)),
            velocity=codec.vec3(
                check.norm_limited(check.vector3(velocity, "velocity"), "velocity", "speed")
            ),
            angular_velocity=codec.vec3(
                check.norm_limited(
                    check.vector3(angular_velocity, "angular_velocity"),
                    "angular_velocity",
                    "angular_speed",
                )
            ),
        )
        return self._edit("move_kinematic", message, timeout_s)


class SceneEdits(SceneEditor[int]):
    """A batch of scene edits, applied in order as one by Client.edit_scene. Each edit
    method returns the edit's index in the batch (the index the server's errors name).
    set_material needs a whole Material here (a batch cannot read the server's scene),
    and no edit takes a timeout_s (edit_scene does)."""

    def __init__(self) -> None:
        self._edits: list[pb.SceneEdit] = []

    def __len__(self) -> int:
        return len(self._edits)

    def _edit(self, body_name: str, body: Message, timeout_s: float | None) -> int:
        if timeout_s is not None:
            raise LocalError(
                f"a batched {body_name} takes no timeout_s; give it to Client.edit_scene"
            )
        if len(self._edits) >= MAX_EDITS_PER_BATCH:
            raise LocalError(
                f"this batch holds {len(self._edits)} edits, the most one edit_scene may carry"
            )
        edit = pb.SceneEdit()
        getattr(edit, body_name).CopyFrom(body)
        self._edits.append(edit)
        return len(self._edits) - 1

    def message(self) -> pb.EditScene:
        """The EditScene request these edits make."""
        return pb.EditScene(edits=self._edits)


def _spec(name: str, shape: Shape, placement: Placement) -> ObjectSpec:
    """The ObjectSpec an add_* call describes."""
    return ObjectSpec(
        name=name,
        shape=shape,
        pose=Pose.of(placement.get("position", (0, 0, 0)), placement.get("rotation")),
        material=material_from(placement.get("material")),
        kinematic=check.flag(placement.get("kinematic", False), "kinematic"),
        velocity=check.as_floats(placement.get("velocity", (0, 0, 0)), "velocity"),
        angular_velocity=check.as_floats(
            placement.get("angular_velocity", (0, 0, 0)), "angular_velocity"
        ),
    )


def _rotation_to_z(normal: check.FloatArray) -> check.FloatArray:
    """A rotation (quaternion w, x, y, z) taking the z axis onto normal's direction (the
    shortest arc; for normal along -z, half a turn about x)."""
    n = normal / np.linalg.norm(normal)
    w = 1.0 + n[2]
    if w < 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([w, -n[1], n[0], 0.0])
    result: check.FloatArray = q / np.linalg.norm(q)
    return result
