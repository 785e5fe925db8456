"""Readers for what a scene is built from: mesh files (OBJ, STL, PLY, through trimesh)
and JSON scene files in the scenario format's "scene" section
({"scene": {"objects": [...]}}, the object fields of ../shared/scenarios/FORMAT.md and
its extensions: "motion", a mesh's "representation" and "ray_backend", material
"force_shading", the scene's "tolerance"). A whole scenario file is accepted too; only
its "scene" is read.

A scene file is read as the server reads it (hapticd --scene FILE): strict JSON (no
NaN or Infinity, no key twice in one object), no field the format does not name,
numbers that are JSON numbers (not strings or true/false), rotations as 3x3 row-major
matrices, integer triangle indices, and mesh files that are OBJ or STL. The golden
files under tests/golden_scenes/ hold both readers to that. What the server checks
on the geometry itself (a hull that is a solid, a mesh with a triangle of non-zero
area, a representation a mesh can be pinned to) is left to the server.

Every problem raises LocalError naming the file and the field, e.g.
"scene.json: scene.objects[1].shape.radius is -1.0; it must be a finite number > 0".

The writer (write_scene_file, scene_document) writes what the readers read: meshes
inline, rotations as matrices, numbers as Python's shortest exact repr, so a file
written from a scene reads back to the same objects.
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
    MATERIAL_FIELDS,
    REPRESENTATIONS,
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
# The mesh files a scene file may name: those the server reads (server/scene/mesh_file.h).
SCENE_MESH_SUFFIXES = (".obj", ".stl")
# What may sit beside "scene" at the top: a whole scenario's sections.
TOP_FIELDS = {"scene", "rate_hz", "duration_s", "avatar", "device", "hand", "channel", "control"}
# A mesh's query backend as a scene file names it ("default" is not written there).
FILE_RAY_BACKENDS = ("native", "embree")
SHAPE_FIELDS = {
    "sphere": {"radius"},
    "box": {"half_extents"},
    "capsule": {"radius", "half_length"},
    "plane": set(),
    "convex": {"points"},
    "mesh": {"vertices", "triangles", "file"},
}
OBJECT_FIELDS = {
    "name",
    "shape",
    "position",
    "rotation",
    "material",
    "motion",
    "representation",
    "ray_backend",
}


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
        # JSON is UTF-8; bytes that are not are kept (as lone surrogates) to be named below
        text = file.read_bytes().decode("utf-8", errors="surrogateescape")
    except OSError as exc:
        raise LocalError(f"scene file {str(file)!r} cannot be read: {exc.strerror}") from exc
    try:
        document = json.loads(
            text, parse_constant=_refuse_constant, object_pairs_hook=_object_of_unique_keys
        )
    except json.JSONDecodeError as exc:
        raise LocalError(f"scene file {str(file)!r} is not JSON: {exc}") from exc
    except _NotStrictJson as exc:
        raise LocalError(f"scene file {str(file)!r} is not strict JSON: {exc}") from exc
    try:
        _refuse_strings_not_utf8(document, "")
        return parse_scene(document, file.parent)
    except LocalError as exc:
        raise LocalError(f"{file}: {exc}") from exc


def _refuse_strings_not_utf8(value: Any, where: str) -> None:
    """Refuses a key or string that is not UTF-8 (the server's reader does; a name that
    is not could not travel in a reply), naming where it is."""
    if isinstance(value, str):
        if any("\ud800" <= c <= "\udfff" for c in value):
            where = where or "the document"
            raise LocalError(f"{where} is not valid UTF-8; every string must be UTF-8")
    elif isinstance(value, dict):
        for key, item in value.items():
            inner = f"{where}.{key}" if where else key
            _refuse_strings_not_utf8(key, f"a key in {where or 'the document'}")
            _refuse_strings_not_utf8(item, inner)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _refuse_strings_not_utf8(item, f"{where}[{i}]")


class _NotStrictJson(Exception):
    """JSON that Python's reader takes and the server's does not."""


def _refuse_constant(name: str) -> Any:
    raise _NotStrictJson(f"{name} is not a JSON number")


def _object_of_unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise _NotStrictJson(f"the key {key!r} appears twice in one object")
        result[key] = value
    return result


def parse_scene(document: Any, base_dir: pathlib.Path) -> SceneFile:
    """The objects of a parsed scene document ({"scene": {"objects": [...]}})."""
    if not isinstance(document, dict) or "scene" not in document:
        raise LocalError(
            'the document has no "scene" section; it must be {"scene": {"objects": [...]}}'
        )
    _fields(document, "the document", TOP_FIELDS)
    scene = _fields(document["scene"], "scene", {"objects", "tolerance"})
    objects = scene.get("objects")
    if not isinstance(objects, list):
        raise LocalError(f"scene.objects is {objects!r}; it must be a list of objects")
    specs: list[ObjectSpec] = []
    for i, item in enumerate(objects):
        spec = _read_object(item, f"scene.objects[{i}]", base_dir)
        # names are unique in a scene
        for j, earlier in enumerate(specs):
            if earlier.name == spec.name:
                raise LocalError(
                    f"scene.objects[{i}].name is {spec.name!r}; scene.objects[{j}] has it already"
                )
        specs.append(spec)
    tolerance = scene.get("tolerance")
    return SceneFile(
        specs,
        None
        if tolerance is None
        else check.positive(_number(tolerance, "scene.tolerance"), "scene.tolerance"),
    )


def _fields(value: Any, where: str, allowed: set[str]) -> dict[str, Any]:
    """value as a JSON object with only allowed fields."""
    if not isinstance(value, dict):
        raise LocalError(f"{where} is {value!r}; it must be a JSON object")
    unknown = sorted(set(value) - allowed)
    if unknown:
        prefix = "" if where == "the document" else f"{where}."
        raise LocalError(
            f"{prefix}{unknown[0]} is not a field; {where} takes {', '.join(sorted(allowed))}"
        )
    return value


def _required(fields: dict[str, Any], where: str, name: str) -> Any:
    if name not in fields:
        raise LocalError(f"{where}.{name} is missing")
    return fields[name]


# ---- JSON values of the kinds the server's reader insists on ----


def _number(value: Any, where: str) -> float:
    """A JSON number (true and false are not numbers, nor is "0.1")."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise LocalError(f"{where} is {value!r}; it must be a number")
    return check.number(value, where)


def _list(value: Any, where: str, length: int | None = None) -> list[Any]:
    """A JSON array, of the given length when one is given."""
    if not isinstance(value, list):
        raise LocalError(f"{where} is {value!r}; it must be an array")
    if length is not None and len(value) != length:
        raise LocalError(f"{where} has {len(value)} elements; it must have {length}")
    return value


def _vector3(value: Any, where: str) -> list[float]:
    """[x, y, z] of JSON numbers."""
    return [_number(v, f"{where}[{i}]") for i, v in enumerate(_list(value, where, 3))]


def _vectors(value: Any, where: str) -> list[list[float]]:
    """An array of [x, y, z]."""
    return [_vector3(v, f"{where}[{i}]") for i, v in enumerate(_list(value, where))]


def _rotation(value: Any, where: str) -> list[list[float]]:
    """A 3x3 row-major rotation matrix (a quaternion is not a scene file's rotation)."""
    rows = _list(value, where)
    if len(rows) != 3:
        raise LocalError(f"{where} has {len(rows)} rows; it must be a 3x3 matrix of 3 rows")
    return [_vector3(row, f"{where}[{i}]") for i, row in enumerate(rows)]


def _triangles(value: Any, where: str) -> list[list[int]]:
    """An array of [i, j, k] of JSON integers (1.0 and true are not indices)."""
    triangles = []
    for t, triangle in enumerate(_list(value, where)):
        corners = _list(triangle, f"{where}[{t}]", 3)
        for c, index in enumerate(corners):
            if isinstance(index, bool) or not isinstance(index, int):
                raise LocalError(f"{where}[{t}][{c}] is {index!r}; it must be an integer index")
        triangles.append(corners)
    return triangles


def _string(value: Any, where: str) -> str:
    if not isinstance(value, str):
        raise LocalError(f"{where} is {value!r}; it must be a string")
    return value


def _read_material(value: Any, where: str) -> Material:
    """A material: stiffness required, the rest optional."""
    fields = _fields(value, where, set(MATERIAL_FIELDS))
    _required(fields, where, "stiffness")
    values: dict[str, Any] = {}
    for name, item in fields.items():
        if name == "force_shading":
            if not isinstance(item, bool):
                raise LocalError(f"{where}.force_shading is {item!r}; it must be true or false")
            values[name] = item
        else:
            values[name] = _number(item, f"{where}.{name}")
    return Material(**values)


def _read_object(value: Any, where: str, base_dir: pathlib.Path) -> ObjectSpec:
    """One object of the scene section."""
    fields = _fields(value, where, OBJECT_FIELDS)
    try:
        name = _string(_required(fields, where, "name"), f"{where}.name")
        shape = _read_shape(
            _required(fields, where, "shape"),
            f"{where}.shape",
            base_dir,
            fields.get("representation"),
            fields.get("ray_backend"),
        )
        position = _vector3(_required(fields, where, "position"), f"{where}.position")
        rotation = fields.get("rotation")
        pose = Pose.of(
            position, None if rotation is None else _rotation(rotation, f"{where}.rotation")
        )
        material = _read_material(_required(fields, where, "material"), f"{where}.material")
        motion = fields.get("motion")
        velocities: dict[str, Any] = {}
        if motion is not None:
            motion_fields = _fields(motion, f"{where}.motion", {"velocity", "angular_velocity"})
            velocities = {
                key: _vector3(item, f"{where}.motion.{key}") for key, item in motion_fields.items()
            }
        return ObjectSpec(
            name=name,
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


def _read_shape(
    value: Any, where: str, base_dir: pathlib.Path, representation: Any, ray_backend: Any
) -> Shape:
    """The shape of an object; representation and ray_backend apply to meshes only."""
    kind = value.get("type") if isinstance(value, dict) else None
    if kind not in SHAPE_FIELDS:
        raise LocalError(f"{where}.type is {kind!r}; it must be one of {', '.join(SHAPE_FIELDS)}")
    fields = _fields(value, where, SHAPE_FIELDS[kind] | {"type"})
    for extension, given in (("representation", representation), ("ray_backend", ray_backend)):
        if given is not None and kind != "mesh":
            raise LocalError(f"{extension} is only for mesh shapes; this shape is a {kind}")
    if kind == "sphere":
        return Sphere(_number(_required(fields, where, "radius"), f"{where}.radius"))
    if kind == "box":
        half_extents = _vector3(_required(fields, where, "half_extents"), f"{where}.half_extents")
        return Box(np.array(half_extents))
    if kind == "capsule":
        return Capsule(
            _number(_required(fields, where, "radius"), f"{where}.radius"),
            _number(_required(fields, where, "half_length"), f"{where}.half_length"),
        )
    if kind == "plane":
        return Plane()
    if kind == "convex":
        return Convex(np.array(_vectors(_required(fields, where, "points"), f"{where}.points")))
    # a mesh: inline arrays or a file, not both
    if "file" in fields:
        if "vertices" in fields or "triangles" in fields:
            raise LocalError(f"{where} has a file and inline vertices or triangles; give one")
        file = _string(fields["file"], f"{where}.file")
        if pathlib.Path(file).suffix.lower() not in SCENE_MESH_SUFFIXES:
            raise LocalError(f"{where}.file is {file!r}; a scene file's mesh is an OBJ or STL file")
        vertices, triangles = read_mesh_file(base_dir / file)
    else:
        vertices = check.as_floats(
            _vectors(_required(fields, where, "vertices"), f"{where}.vertices"), "vertices"
        )
        triangles = check.as_indices(
            _triangles(_required(fields, where, "triangles"), f"{where}.triangles"), "triangles"
        )
    if representation is not None:
        check.choice(_string(representation, "representation"), "representation", REPRESENTATIONS)
    if ray_backend is not None:
        check.choice(_string(ray_backend, "ray_backend"), "ray_backend", FILE_RAY_BACKENDS)
    return Mesh(vertices, triangles, representation or "auto", ray_backend or "default")


# ---- writing ----


def _object_document(spec: ObjectSpec) -> dict[str, Any]:
    """One object of the scene section, as the readers read it back."""
    shape = spec.shape
    document: dict[str, Any] = {"name": spec.name}
    if isinstance(shape, Sphere):
        document["shape"] = {"type": "sphere", "radius": shape.radius}
    elif isinstance(shape, Box):
        document["shape"] = {"type": "box", "half_extents": shape.half_extents.tolist()}
    elif isinstance(shape, Capsule):
        document["shape"] = {
            "type": "capsule",
            "radius": shape.radius,
            "half_length": shape.half_length,
        }
    elif isinstance(shape, Plane):
        document["shape"] = {"type": "plane"}
    elif isinstance(shape, Convex):
        document["shape"] = {"type": "convex", "points": shape.points.tolist()}
    else:
        document["shape"] = {
            "type": "mesh",
            "vertices": shape.vertices.tolist(),
            "triangles": shape.triangles.astype(np.int64).tolist(),
        }
    document["position"] = spec.pose.position.tolist()
    document["rotation"] = spec.pose.rotation.tolist()
    material = spec.material
    document["material"] = {
        "stiffness": material.stiffness,
        "damping": material.damping,
        "static_friction": material.static_friction,
        "dynamic_friction": material.dynamic_friction,
    }
    if material.force_shading is not None:
        document["material"]["force_shading"] = material.force_shading
    if spec.kinematic:
        document["motion"] = {
            "velocity": spec.velocity.tolist(),
            "angular_velocity": spec.angular_velocity.tolist(),
        }
    if isinstance(shape, Mesh):
        if shape.representation != "auto":
            document["representation"] = shape.representation
        if shape.ray_backend != "default":
            document["ray_backend"] = shape.ray_backend
    return document


def scene_document(objects: list[ObjectSpec], tolerance: float | None = None) -> dict[str, Any]:
    """The JSON document of a scene file holding objects (and the scene's tolerance, m,
    when given)."""
    scene: dict[str, Any] = {"objects": [_object_document(spec) for spec in objects]}
    if tolerance is not None:
        scene["tolerance"] = check.positive(tolerance, "tolerance")
    return {"scene": scene}


def write_scene_file(
    path: str | pathlib.Path, objects: list[ObjectSpec], tolerance: float | None = None
) -> None:
    """Writes a scene file that read_scene_file and hapticd --scene read back to objects;
    atomically (a temporary file beside it, renamed), so a failed write leaves any
    earlier file as it was. LocalError when the file cannot be written."""
    file = pathlib.Path(path)
    text = json.dumps(scene_document(objects, tolerance), allow_nan=False)
    temporary = file.with_name(f".{file.name}.partial")
    try:
        temporary.write_text(text + "\n")
        temporary.replace(file)
    except OSError as exc:
        temporary.unlink(missing_ok=True)
        raise LocalError(f"scene file {str(file)!r} cannot be written: {exc.strerror}") from exc
