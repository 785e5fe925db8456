"""Scene files in the scenario format's "scene" section and mesh files through trimesh:
each shape, mesh files relative to the scene file, and errors that name the field."""

import json
import pathlib
import re

import numpy as np
import pytest
import trimesh

from hapticd import Box, Capsule, Convex, LocalError, Mesh, Plane, Sphere
from hapticd.scene_files import read_mesh_file, read_scene_file

GOLDEN = pathlib.Path(__file__).resolve().parents[3] / "tests" / "golden_scenes"
IDENTITY = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
MATERIAL = {"stiffness": 2000}


def write_scene(tmp_path, objects, **scene):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps({"scene": {"objects": objects, **scene}}))
    return path


def obj(name, shape, **fields):
    return {"name": name, "shape": shape, "position": [0, 0, 0], "material": MATERIAL, **fields}


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply"])
def test_mesh_files_of_each_kind_are_read(tmp_path, suffix):
    box = trimesh.creation.box(extents=(0.2, 0.4, 0.6))
    path = tmp_path / f"box{suffix}"
    box.export(path)
    vertices, triangles = read_mesh_file(path)
    # an STL repeats vertices per triangle; they are merged on reading
    assert vertices.shape == (8, 3) and triangles.shape == (12, 3)
    assert np.allclose(vertices.max(axis=0), [0.1, 0.2, 0.3])
    assert triangles.dtype == np.uint32


def test_a_broken_mesh_file_is_named(tmp_path):
    path = tmp_path / "empty.obj"
    path.write_text("# nothing here\n")
    with pytest.raises(LocalError, match=f"mesh file '{path}' holds no triangles"):
        read_mesh_file(path)


def test_every_shape_reads(tmp_path):
    box = trimesh.creation.box(extents=(1, 1, 1))
    box.export(tmp_path / "cube.stl")
    objects = [
        obj("s", {"type": "sphere", "radius": 0.1}),
        obj("b", {"type": "box", "half_extents": [0.1, 0.2, 0.3]}, rotation=IDENTITY),
        obj("c", {"type": "capsule", "radius": 0.1, "half_length": 0.2}),
        obj("p", {"type": "plane"}),
        obj("h", {"type": "convex", "points": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]}),
        obj(
            "m",
            {
                "type": "mesh",
                "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                "triangles": [[0, 1, 2]],
            },
        ),
        obj(
            "f",
            {"type": "mesh", "file": "cube.stl"},
            representation="mesh",
            motion={"velocity": [0.1, 0, 0]},
        ),
    ]
    scene = read_scene_file(write_scene(tmp_path, objects, tolerance=1e-3))
    kinds = [type(spec.shape) for spec in scene.objects]
    assert kinds == [Sphere, Box, Capsule, Plane, Convex, Mesh, Mesh]
    cube = scene.objects[-1]
    assert cube.kinematic and cube.velocity[0] == 0.1
    assert cube.shape.representation == "mesh" and len(cube.shape.triangles) == 12
    assert scene.tolerance == 1e-3 and scene.objects[0].material.stiffness == 2000


def test_a_whole_scenario_file_is_read_for_its_scene(tmp_path):
    path = tmp_path / "scenario.json"
    path.write_text(
        json.dumps(
            {
                "rate_hz": 1000,
                "scene": {"objects": [obj("s", {"type": "sphere", "radius": 1})]},
                "hand": {},
            }
        )
    )
    assert [spec.name for spec in read_scene_file(path).objects] == ["s"]


@pytest.mark.parametrize(
    ("objects", "message"),
    [
        ([obj("s", {"type": "sphere", "radius": -1})], r"scene.objects\[0\]: radius is -1.0"),
        (
            [obj("s", {"type": "cone"})],
            r"scene.objects\[0\].shape.type is 'cone'; it must be one of",
        ),
        (
            [obj("s", {"type": "sphere", "radius": 1, "colour": 2})],
            r"scene.objects\[0\].shape.colour is not a field",
        ),
        (
            [obj("s", {"type": "sphere", "radius": 1}, spin=1)],
            r"scene.objects\[0\].spin is not a field",
        ),
        (
            [{"name": "s", "shape": {"type": "plane"}, "position": [0, 0, 0]}],
            r"scene.objects\[0\].material is missing",
        ),
        (
            [obj("s", {"type": "plane"}, material={"damping": 1})],
            r"scene.objects\[0\].material.stiffness is missing",
        ),
        (
            [obj("s", {"type": "sphere", "radius": 1}, representation="mesh")],
            r"representation is only for mesh shapes; this shape is a sphere",
        ),
        (
            [obj("m", {"type": "mesh", "file": "missing.obj"})],
            r"mesh file '.*missing.obj' does not exist",
        ),
        (
            [obj("s", {"type": "plane"}, rotation=[[1, 0, 0], [0, 1, 0], [0, 0, -1]])],
            r"it is not a rotation",
        ),
    ],
)
def test_bad_scene_files_name_the_field(tmp_path, objects, message):
    with pytest.raises(LocalError, match=message):
        read_scene_file(write_scene(tmp_path, objects))


def test_a_file_that_is_not_json_or_has_no_scene_is_named(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text("{")
    with pytest.raises(LocalError, match="is not JSON"):
        read_scene_file(path)
    path.write_text("{}")
    with pytest.raises(LocalError, match='has no "scene" section'):
        read_scene_file(path)


# ---- the golden scene files (tests/golden_scenes/README.md), the Python reader alone ----


@pytest.mark.parametrize("path", sorted(GOLDEN.glob("valid-*.json")), ids=lambda p: p.name)
def test_every_valid_golden_file_reads(path):
    assert isinstance(read_scene_file(path).objects, list)


@pytest.mark.parametrize("path", sorted(GOLDEN.glob("invalid-*.json")), ids=lambda p: p.name)
def test_every_invalid_golden_file_is_refused_naming_its_field(path):
    field = path.stem.split("-")[1].lower()
    with pytest.raises(LocalError) as refused:
        read_scene_file(path)
    assert field in str(refused.value).replace(str(path), "FILE").lower()


def test_the_golden_files_are_there():
    assert len(list(GOLDEN.glob("valid-*.json"))) >= 5
    assert len(list(GOLDEN.glob("invalid-*.json"))) >= 30


def test_a_meshs_ray_backend_is_read(tmp_path):
    mesh = {"type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 2]]}
    scene = read_scene_file(write_scene(tmp_path, [obj("m", mesh, ray_backend="embree")]))
    assert scene.objects[0].shape.ray_backend == "embree"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"scene": {"objects": [], "tolerance": NaN}}', "NaN is not a JSON number"),
        ('{"scene": {"objects": []}, "scene": {"objects": []}}', "the key 'scene' appears twice"),
    ],
)
def test_json_the_server_would_not_read_is_refused(tmp_path, text, message):
    path = tmp_path / "scene.json"
    path.write_text(text)
    with pytest.raises(LocalError, match=f"^scene file '{path}' is not strict JSON: {message}"):
        read_scene_file(path)


@pytest.mark.parametrize(
    ("objects", "message"),
    [
        (
            [obj("s", {"type": "sphere", "radius": "0.1"})],
            r"^scene.objects\[0\].shape.radius is '0.1'; it must be a number$",
        ),
        (
            [obj("s", {"type": "plane"}, rotation=[1, 0, 0, 0])],
            r"^scene.objects\[0\].rotation has 4 rows; it must be a 3x3 matrix of 3 rows$",
        ),
        (
            [obj("s", {"type": "plane"}), obj("s", {"type": "plane"})],
            r"^scene.objects\[1\].name is 's'; scene.objects\[0\] has it already$",
        ),
        (
            [obj("m", {"type": "mesh", "file": "part.ply"})],
            r"^scene.objects\[0\].shape.file is 'part.ply'; a scene file's mesh is an OBJ or STL",
        ),
    ],
)
def test_what_the_server_refuses_the_reader_refuses(tmp_path, objects, message):
    with pytest.raises(LocalError) as refused:
        read_scene_file(write_scene(tmp_path, objects))
    text = str(refused.value)
    assert text.startswith(f"{tmp_path / 'scene.json'}: ")
    assert re.match(message, text.split(": ", 1)[1])
