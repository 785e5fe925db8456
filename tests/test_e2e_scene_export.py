"""End to end, the scene read back and exported: a scene of every shape kind (meshes kept
as meshes, chosen as a primitive, pinned to a box and to a hull; an open mesh; a
kinematic object with its material) is exported with `python -m hapticd scene export`,
and a second server started on the file (hapticd --scene), as well as `scene load` into
the first one, hold the same scene: every field of every object, the mesh data and the
shape digests included. `scene show` prints strict JSON."""

import json
import subprocess
import sys
import time

import hapticd
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation
from server_process import running_server

# the moving object's speed (m/s) and spin (rad/s)
SPEED = np.array([0.002, 0.0, 0.0])
SPIN = np.array([0.0, 0.0, 0.05])
TOLERANCE = 2e-4


def cli(server, *args, timeout=60):
    done = subprocess.run(
        [sys.executable, "-m", "hapticd", *args, "--server", server.tcp, "--timeout", "20"],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def build_scene(client):
    """Every shape kind, as a researcher would bring them."""
    client.clear_scene()
    turn = Rotation.from_euler("xyz", [10, -20, 30], degrees=True)
    client.add_sphere("ball", 0.03, position=(0.3, 0, 0.03), material={"stiffness": 1500})
    client.add_box("crate", (0.05, 0.04, 0.03), position=(0, 0.3, 0.03), rotation=turn)
    client.add_capsule("pill", 0.02, 0.05, position=(-0.3, 0, 0.1))
    client.add_plane("floor", normal=(0, 0.1, 1), position=(0, 0, -0.01))
    client.add_convex("hull", np.random.default_rng(3).normal(size=(30, 3)) * 0.03,
                      position=(0, -0.3, 0.05))
    torus = trimesh.creation.torus(0.05, 0.015, major_sections=24, minor_sections=12)
    client.add_mesh("torus", torus, position=(0.2, 0.2, 0.02), material={
        "stiffness": 2500, "damping": 2.0, "static_friction": 0.6, "dynamic_friction": 0.4,
        "force_shading": False})
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.04)
    client.add_mesh("auto_ball", ball, position=(-0.2, 0.2, 0.04))
    off_centre = trimesh.creation.box(extents=(0.06, 0.04, 0.02))
    off_centre.apply_translation((0.03, 0, 0))
    client.add_mesh("boxed", off_centre, representation="box", position=(0.2, -0.2, 0.02),
                    rotation=turn)
    client.add_mesh("hulled", torus, representation="convex", position=(-0.2, -0.2, 0.02))
    sheet = trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0], [0, 0.1, 0]],
                            [[0, 1, 2], [0, 2, 3]], process=False)
    client.add_mesh("sheet", sheet, position=(0, 0, 0.3), ray_backend="embree")
    # kinematic: one at rest (compared exactly), one moving
    client.add_box("lift", (0.02, 0.02, 0.02), position=(0, 0, 0.5), kinematic=True,
                   material={"stiffness": 3000, "damping": 5.0})
    client.add_mesh("spinner", off_centre, representation="box", position=(0, 0, 0.7),
                    kinematic=True, velocity=SPEED, angular_velocity=SPIN,
                    material={"stiffness": 1200, "static_friction": 0.3,
                              "dynamic_friction": 0.2})


def same_array(a, b, atol=0.0):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and np.allclose(a, b, rtol=0, atol=atol, equal_nan=False) \
        if np.all(np.isfinite(a)) else np.array_equal(a, b)


def assert_same_object(got, want, moved_m=0.0, turned_rad=0.0):
    """Every field of an ObjectInfo; poses within rounding (a quaternion through a
    matrix and back), plus how far a moving object may have gone."""
    name = want.name
    for field in ("name", "shape", "representation", "kinematic", "triangles", "ray_backend",
                  "closed", "topology", "rewound_triangles", "warnings",
                  "pinned_representation", "shape_digest"):
        assert getattr(got, field) == getattr(want, field), (name, field)
    assert got.representation_error == pytest.approx(want.representation_error, rel=1e-12), name
    assert got.material == want.material, name
    assert same_array(got.velocity, want.velocity, 1e-15), name
    assert same_array(got.angular_velocity, want.angular_velocity, 1e-15), name
    # a pose, and what it turned: within the motion since and rounding
    poses = [(got.pose, want.pose)]
    if want.mesh_pose is not None:
        poses.append((got.mesh_pose, want.mesh_pose))
    else:
        assert got.mesh_pose is None, name
    for a, b in poses:
        assert np.linalg.norm(a.position - b.position) <= moved_m + 1e-12, name
        cos = (np.trace(a.rotation @ b.rotation.T) - 1) / 2
        assert np.arccos(min(1.0, cos)) <= turned_rad + 1e-7, name
    # the shape: parameters exactly, a mesh's data exactly
    assert type(got.represented) is type(want.represented), name
    if want.represented is not None:
        for key, value in vars(want.represented).items():
            assert same_array(getattr(got.represented, key), value) if isinstance(
                value, np.ndarray) else getattr(got.represented, key) == value, (name, key)
    assert (got.mesh is None) == (want.mesh is None), name
    if want.mesh is not None:
        assert np.array_equal(got.mesh.vertices, want.mesh.vertices), name
        assert np.array_equal(got.mesh.triangles, want.mesh.triangles), name
        assert got.mesh.representation == want.mesh.representation, name
    if not want.kinematic or not np.any(want.velocity) and not np.any(want.angular_velocity):
        assert same_array(got.bounds_min, want.bounds_min, 1e-12), name
        assert same_array(got.bounds_max, want.bounds_max, 1e-12), name


def assert_same_scene(got, want, since_s):
    assert got.tolerance == want.tolerance
    assert [o.name for o in got.objects] == [o.name for o in want.objects]
    for a, b in zip(got.objects, want.objects, strict=True):
        moving = b.name == "spinner"
        # the spinner's frame moves at SPEED; where its box sits turns about it too
        reach = float(np.linalg.norm(SPEED) + np.linalg.norm(SPIN) * 0.05) * since_s
        assert_same_object(a, b, reach if moving else 0.0,
                           float(np.linalg.norm(SPIN)) * since_s if moving else 0.0)


@pytest.fixture(scope="module")
def first_server(bin_dir, tmp_path_factory):
    """A server whose scene tolerance is not the default, so that the file must carry it."""
    seed = tmp_path_factory.mktemp("seed") / "seed.json"
    seed.write_text(json.dumps({"scene": {"tolerance": TOLERANCE, "objects": []}}))
    with running_server(bin_dir, "--scene", str(seed), "--log-level", "warning") as server:
        yield server


def test_an_exported_scene_reads_back_the_same_in_a_new_server(bin_dir, first_server, tmp_path):
    with hapticd.connect(first_server.tcp, timeout_s=20) as client:
        build_scene(client)
        path = tmp_path / "exported.json"
        printed = json.loads(cli(first_server, "scene", "export", str(path)))
        exported_at = time.monotonic()
        assert printed["exported"] == str(path)
        assert len(printed["objects"]) == 12
        # what was written is the scene at printed["scene_version"]; read it the same way
        written = hapticd.read_scene_file(path)
        assert written.tolerance == TOLERANCE
        original = client.scene(include_mesh_data=True)
        read_at = time.monotonic()

    with (
        running_server(bin_dir, "--scene", str(path), "--log-level", "warning") as second,
        hapticd.connect(second.tcp, timeout_s=20) as client,
    ):
        reloaded = client.scene(include_mesh_data=True)
        since_s = max(time.monotonic() - exported_at, read_at - exported_at) + 1.0
    assert_same_scene(reloaded, original, since_s)
    # the moving object keeps moving, at the same velocities
    spinner = reloaded.object("spinner")
    assert np.allclose(spinner.velocity, SPEED, rtol=0, atol=1e-15)
    assert np.allclose(spinner.angular_velocity, SPIN, rtol=0, atol=1e-15)


def test_scene_load_of_an_export_rebuilds_the_same_scene(first_server, tmp_path):
    with hapticd.connect(first_server.tcp, timeout_s=20) as client:
        build_scene(client)
        path = tmp_path / "exported.json"
        exported = client.export_scene(path)
        exported_at = time.monotonic()
        loaded = json.loads(cli(first_server, "scene", "load", "--replace", str(path)))
        assert loaded["added"] == [o.name for o in exported.objects]
        reloaded = client.scene(include_mesh_data=True)
        assert_same_scene(reloaded, exported, time.monotonic() - exported_at + 1.0)


def test_an_inside_out_mesh_exports_as_the_server_wound_it(first_server, tmp_path):
    """The one field a round trip does not keep: rewound_triangles (and its warning) say
    what validation did to the upload; the exported mesh is the validated one, wound
    outwards, so reloading it has nothing to rewind and is otherwise the same."""
    tetra = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])
    inside_out = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]
    with hapticd.connect(first_server.tcp, timeout_s=20) as client:
        client.clear_scene()
        client.add_mesh("tetra", tetra, inside_out, representation="mesh")
        before = client.export_scene(tmp_path / "tetra.json").object("tetra")
        client.clear_scene()
        client.add_object(hapticd.read_scene_file(tmp_path / "tetra.json").objects[0])
        after = client.scene(include_mesh_data=True).object("tetra")
    assert (before.rewound_triangles, after.rewound_triangles) == (4, 0)
    assert np.array_equal(after.mesh.triangles, before.mesh.triangles)
    assert after.shape_digest == before.shape_digest
    assert after.warnings == ()


def test_scene_show_prints_strict_json(first_server):
    with hapticd.connect(first_server.tcp, timeout_s=20) as client:
        build_scene(client)

    def refuse(constant):
        raise AssertionError(f"scene show printed the bare constant {constant}")

    shown = json.loads(cli(first_server, "scene", "show"), parse_constant=refuse)
    objects = {o["name"]: o for o in shown["objects"]}
    # a plane's bounds are infinite: printed as text, not as a bare Infinity
    assert "-inf" in objects["floor"]["bounds_min"] and "inf" in objects["floor"]["bounds_max"]
    assert objects["ball"]["parameters"] == {"radius": 0.03}
    assert objects["spinner"]["velocity"] == SPEED.tolist()
    assert objects["boxed"]["pinned_representation"] == "box"
    assert objects["boxed"]["mesh_pose"]["position"] == pytest.approx([0.2, -0.2, 0.02])
