"""Readers for what a scene is built from: mesh files (OBJ, STL, PLY, through trimesh)
and JSON scene files in the scenario format's "scene" section
({"scene": {"objects": [...]}}, the object fields of ../shared/scenarios/FORMAT.md and
its extensions: "motion", "representation", material "force_shading"). A whole
scenario file is accepted too; only its "scene" is read.

Every problem raises LocalError naming the file and the field, e.g.
"scene.json: scene.objects[1].shape.radius is -1.0; it must be a finite number > 0".
"""

from __future__ import annotations

import json
import pathlib
from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from hapticd import _validate as check
from hapticd._validate import FloatArray, IndexArray
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
)

MESH_SUFFIXES = (".obj", ".stl", ".ply")
SHAPE_FIELDS = {
    "sphere": {"radius"},
    "box": {"half_extents"},
    "capsule": {"radius", "half_length"},
    "plane": set(),
    "convex": {"points"},
    "mesh": {"vertices", "triangles", "file"},
}
OBJECT_FIELDS = {"name", "shape", "position", "rotation", "material", "motion", "representation"}
MATERIAL_FIELDS = {"stiffness", "damping", "static_friction", "dynamic_friction", "force_shading"}


@dataclass(frozen=True)
class SceneFile:
    """A scene file's objects, and its tolerance (m) when it gives one."""

    objects: list[ObjectSpec]
    tolerance: float | None


def read_mesh_file(path: str | pathlib.Path) -> tuple[FloatArray, IndexArray]:
    """The vertices (N, 3) and triangles (M, 3) of an OBJ, STL or PLY file, duplicate
    vertices merged. LocalError when the file is missing, of another kind, unreadable or
    holds no triangles."""
    file = pathlib.Path(path)
    if file.suffix.lower() not in MESH_SUFFIXES:
        raise LocalError(f"mesh file {str(file)!r} is not an OBJ, STL or PLY file (by its suffix)")
    if not file.is_file():
        raise LocalError(f"mesh file {str(file)!r} does not exist")
    try:
        mesh = trimesh.load(file, force="mesh")
    except Exception as exc:  # trimesh raises many kinds for a bad file
        raise LocalError(f"mesh file {str(file)!r} cannot be read: {exc}") from exc
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise LocalError(f"mesh file {str(file)!r} holds no triangles")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    triangles = np.asarray(mesh.faces, dtype=np.uint32)
    return vertices, triangles


def read_scene_file(path: str | pathlib.Path) -> SceneFile:
    """The objects of a JSON scene file; mesh "file" paths are relative to it."""
    file = pathlib.Path(path)
    try:
        document = json.loads(file.read_text())
    except OSError as exc:
        raise LocalError(f"scene file {str(file)!r} cannot be read: {exc.strerror}") from exc
    except json.JSONDecodeError as exc:
        raise LocalError(f"scene file {str(file)!r} is not JSON: {exc}") from exc
    try:
        return parse_scene(document, file.parent)
    except LocalError as exc:
        raise LocalError(f"{file}: {exc}") from exc


def parse_scene(document: Any, base_dir: pathlib.Path) -> SceneFile:
    """The objects of a parsed scene document ({"scene": {"objects": [...]}})."""
    if not isinstance(document, dict) or "scene" not in document:
        raise LocalError(
            'the document has no "scene" section; it must be {"scene": {"objects": [...]}}'
        )
    scene = _fields(document["scene"], "scene", {"objects", "tolerance"})
    objects = scene.get("objects")
    if not isinstance(objects, list):
        raise LocalError(f"scene.objects is {objects!r}; it must be a list of objects")
    specs = [_read_object(item, f"scene.objects[{i}]", base_dir) for i, item in enumerate(objects)]
    tolerance = scene.get("tolerance")
    return SceneFile(
        specs, None if tolerance is None else check.positive(tolerance, "scene.tolerance")
    )


def _fields(value: Any, where: str, allowed: set[str]) -> dict[str, Any]:
    """value as a JSON object with only allowed fields."""
    if not isinstance(value, dict):
        raise LocalError(f"{where} is {value!r}; it must be a JSON object")
    unknown = sorted(set(value) - allowed)
    if unknown:
        raise LocalError(
            f"{where}.{unknown[0]} is not a field; {where} takes {', '.join(sorted(allowed))}"
        )
    return value


def _required(fields: dict[str, Any], where: str, name: str) -> Any:
    if name not in fields:
        raise LocalError(f"{where}.{name} is missing")
    return fields[name]


def _read_object(value: Any, where: str, base_dir: pathlib.Path) -> ObjectSpec:
    """One object of the scene section."""
    fields = _fields(value, where, OBJECT_FIELDS)
    try:
        shape = _read_shape(
            _required(fields, where, "shape"),
            f"{where}.shape",
            base_dir,
            fields.get("representation"),
        )
        pose = Pose.of(_required(fields, where, "position"), fields.get("rotation"))
        material_fields = _fields(
            _required(fields, where, "material"), f"{where}.material", MATERIAL_FIELDS
        )
        _required(material_fields, f"{where}.material", "stiffness")
        material = Material(**material_fields)
        motion = fields.get("motion")
        velocities: dict[str, Any] = {}
        if motion is not None:
            velocities = dict(_fields(motion, f"{where}.motion", {"velocity", "angular_velocity"}))
        return ObjectSpec(
            name=_required(fields, where, "name"),
            shape=shape,
            pose=pose,
            material=material,
            kinematic=motion is not None,
            **velocities,
        )
    except LocalError as exc:
        # the object's own checks name the field; say which object it is
        if str(exc).startswith(where):
            raise
        raise LocalError(f"{where}: {exc}") from exc


def _read_shape(value: Any, where: str, base_dir: pathlib.Path, representation: Any) -> Shape:
    """The shape of an object; representation applies to meshes only."""
    kind = value.get("type") if isinstance(value, dict) else None
    if kind not in SHAPE_FIELDS:
        raise LocalError(f"{where}.type is {kind!r}; it must be one of {', '.join(SHAPE_FIELDS)}")
    fields = _fields(value, where, SHAPE_FIELDS[kind] | {"type"})
    if representation is not None and kind != "mesh":
        raise LocalError(f"representation is only for mesh shapes; this shape is a {kind}")
    if kind == "sphere":
        return Sphere(_required(fields, where, "radius"))
    if kind == "box":
        return Box(_required(fields, where, "half_extents"))
    if kind == "capsule":
        return Capsule(_required(fields, where, "radius"), _required(fields, where, "half_length"))
    if kind == "plane":
        return Plane()
    if kind == "convex":
        return Convex(_required(fields, where, "points"))
    # a mesh: inline arrays or a file, not both
    if "file" in fields:
        if "vertices" in fields or "triangles" in fields:
            raise LocalError(f"{where} has a file and inline vertices or triangles; give one")
        vertices, triangles = read_mesh_file(base_dir / str(fields["file"]))
    else:
        vertices = check.as_floats(_required(fields, where, "vertices"), "vertices")
        triangles = check.as_indices(_required(fields, where, "triangles"), "triangles")
    return Mesh(vertices, triangles, representation or "auto")
