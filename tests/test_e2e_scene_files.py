"""End to end, the two readers of scene files agree: for every golden file under
golden_scenes/, the Python reader (hapticd.read_scene_file) and the real server
(hapticd --scene FILE) both accept it, or both refuse it naming the same field.

A file's name says what it is: valid-<what>.json, or invalid-<field>-<how>.json where
<field> is the field it breaks, which both refusals must name (the server exits with
status 2). A valid file must also give the same objects in both: the server's scene
lists the names, shapes, positions, materials and motion the Python reader read."""

import math
import pathlib
import subprocess
import time

import hapticd
import numpy as np
import pytest
from server_process import running_server

GOLDEN = pathlib.Path(__file__).resolve().parent / "golden_scenes"
VALID = sorted(GOLDEN.glob("valid-*.json"))
INVALID = sorted(GOLDEN.glob("invalid-*.json"))
SHAPE_NAMES = {
    hapticd.Sphere: "sphere",
    hapticd.Box: "box",
    hapticd.Capsule: "capsule",
    hapticd.Plane: "plane",
    hapticd.Convex: "convex",
    hapticd.Mesh: "mesh",
}
def field_of(path):
    """The field an invalid file breaks: the middle of invalid-<field>-<how>.json."""
    return path.stem.split("-")[1]


def test_the_golden_set_is_there():
    assert len(VALID) >= 5 and len(INVALID) >= 30
    assert all(len(path.stem.split("-")) == 3 for path in INVALID)


def server_refusal(bin_dir, path):
    """(exit status, log) of hapticd started on the file, when it exits within 20 s."""
    done = subprocess.run(
        [str(bin_dir / "hapticd"), "--scene", str(path), "--tcp-port", "0", "--udp-port", "0"],
        capture_output=True,
        text=True,
        timeout=20,
    )
    return done.returncode, done.stderr


@pytest.mark.parametrize("path", INVALID, ids=lambda path: path.name)
def test_both_readers_refuse_an_invalid_file_naming_its_field(bin_dir, path):
    field = field_of(path).lower()
    with pytest.raises(hapticd.LocalError) as refused:
        hapticd.read_scene_file(path)
    # the message names the field, not just the file (whose name holds it too)
    assert field in str(refused.value).replace(str(path), "FILE").lower()
    code, log = server_refusal(bin_dir, path)
    assert code == 2, f"hapticd exited {code} on {path.name}: {log}"
    assert f"--scene {path}: " in log
    assert field in log.replace(str(path), "FILE").lower(), log


@pytest.mark.parametrize("path", VALID, ids=lambda path: path.name)
def test_both_readers_accept_a_valid_file_alike(bin_dir, path):
    read = hapticd.read_scene_file(path)
    started = time.monotonic()
    with running_server(bin_dir, "--scene", str(path), "--log-level", "warning") as server:
        with hapticd.connect(server.tcp, timeout_s=10) as client:
            scene = client.scene()
    # a kinematic object moves by its velocity from the start: at most this long so far
    moving_s = time.monotonic() - started
    assert [info.name for info in scene.objects] == [spec.name for spec in read.objects]
    if read.tolerance is not None:
        assert scene.tolerance == read.tolerance
    for spec, info in zip(read.objects, scene.objects, strict=True):
        assert info.shape == SHAPE_NAMES[type(spec.shape)], spec.name
        speed = float(np.linalg.norm(spec.velocity)) if spec.kinematic else 0.0
        spin = float(np.linalg.norm(spec.angular_velocity)) if spec.kinematic else 0.0
        turned = info.pose.rotation @ spec.pose.rotation.T
        angle = math.acos(max(-1.0, min(1.0, (np.trace(turned) - 1) / 2)))
        assert angle <= spin * moving_s + 1e-9, spec.name
        assert info.kinematic == spec.kinematic, spec.name
        material, given = info.material, spec.material
        assert (material.stiffness, material.damping) == (given.stiffness, given.damping)
        assert (material.static_friction, material.dynamic_friction) == (
            given.static_friction,
            given.dynamic_friction,
        )
        # force shading is on unless the file says otherwise
        assert material.force_shading == (given.force_shading is not False), spec.name
        if isinstance(spec.shape, hapticd.Mesh):
            assert info.triangles == len(spec.shape.triangles), spec.name
            backend = {"default": "native"}.get(spec.shape.ray_backend, spec.shape.ray_backend)
            assert info.ray_backend == backend, spec.name
            if spec.shape.representation != "auto":
                assert info.representation == spec.shape.representation, spec.name
        else:
            # a mesh's pose is its representation's; a primitive's is the object's
            moved = float(np.linalg.norm(info.pose.position - spec.pose.position))
            assert moved <= speed * moving_s + 1e-12, spec.name


def test_inside_out_and_open_meshes_are_reported_and_answered_by_their_rule(bin_dir):
    """The inside-out tetrahedron is rewound (its info says so) and has its inside
    back: 2 cm inside it is -2 cm, and a contact; the open plate is a surface, whose
    distance is unsigned from either side; a ray from inside reports where it leaves."""
    path = GOLDEN / "valid-inside_out_and_open_meshes.json"
    with running_server(bin_dir, "--scene", str(path), "--log-level", "warning") as server:
        with hapticd.connect(server.tcp, timeout_s=10) as client:
            scene = client.scene()
            tetra, plate, ball = (scene.object(n) for n in ("inside_out", "plate", "ball"))
            assert (tetra.closed, tetra.topology, tetra.rewound_triangles) == (True, "closed", 4)
            assert tetra.warnings == (
                "rewound 4 of 4 triangles so that the mesh's normals point out of its solid",
            )
            assert (plate.closed, plate.topology, plate.rewound_triangles) == (False, "open", 0)
            assert len(plate.warnings) == 1 and "no inside" in plate.warnings[0]
            assert (ball.closed, ball.topology, ball.warnings) == (False, "", ())

            inside = (0.02, 0.02, 0.02)
            nearest = client.closest_point(inside, 0.5)
            assert nearest.object == "inside_out"
            assert nearest.signed_distance == pytest.approx(-0.02, abs=1e-12)
            contacts = client.find_contacts(inside, 0.0)
            assert [c.object for c in contacts] == ["inside_out"]
            assert contacts[0].depth == pytest.approx(0.02, abs=1e-12)

            for side in (1, -1):
                below = client.closest_point((0.5, 0.01, side * 0.03), 0.5)
                assert below.object == "plate"
                assert below.signed_distance == pytest.approx(0.03, abs=1e-12)
                assert np.allclose(below.normal, (0, 0, side), atol=1e-12)

            leaving = client.ray_cast(inside, (-1, 0, 0), 1.0)
            assert (leaving.hit, leaving.object) == (True, "inside_out")
            assert leaving.distance == pytest.approx(0.02, abs=1e-12)
            assert np.allclose(leaving.normal, (1, 0, 0), atol=1e-12)
