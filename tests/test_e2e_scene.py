"""End to end, the control channel: a Python client builds a scene of every shape and a
mesh on a real hapticd process, queries it against analytic answers, edits and removes
objects; the server's refusals name the problem; and bad frames from a raw socket
(oversized, truncated, garbage, unknown fields) get an error reply or a clean close
while the server keeps serving other connections; the command line loads and shows
scenes."""

import json
import math
import pathlib
import socket
import ssl
import struct
import subprocess
import sys
import time

import hapticd
import numpy as np
import pytest
import trimesh
from hapticd._framing import FrameDecoder, encode_frame
from hapticd.v1 import hapticd_pb2 as pb
from server_process import running_server

STIFFNESS = 2000.0
MATERIAL = {"stiffness": STIFFNESS}
# how far behind the wall clock a kinematic pose read back may be (a stalled control thread)
KINEMATIC_LAG_S = 0.05
TETRA = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], dtype=np.float64)


@pytest.fixture
def client(server):
    with hapticd.connect(server.tcp, timeout_s=10) as connected:
        yield connected


@pytest.fixture
def shapes_scene(client):
    """Floor z = 0; box top z = 0.1 over (0, 0); sphere top 0.1 over (0.3, 0); capsule top
    0.14 over (-0.3, 0); tetrahedron x + y + z <= 0.1 at (0, 0.3, 0); a cube mesh (side
    0.06) pinned as a mesh, top 0.06 over (0, -0.3)."""
    client.clear_scene()
    client.add_plane("floor", normal=(0, 0, 1), material=MATERIAL)
    client.add_box("box", (0.05, 0.05, 0.05), position=(0, 0, 0.05), material=MATERIAL)
    client.add_sphere("ball", 0.05, position=(0.3, 0, 0.05), material=MATERIAL)
    client.add_capsule("pillar", 0.02, 0.05, position=(-0.3, 0, 0.07), material=MATERIAL)
    client.add_convex("tetra", TETRA, position=(0, 0.3, 0), material=MATERIAL)
    cube = trimesh.creation.box(extents=(0.06, 0.06, 0.06))
    client.add_mesh(
        "cube", cube.vertices, cube.faces, "mesh", position=(0, -0.3, 0.03), material=MATERIAL
    )
    return client


def test_the_scene_lists_every_shape(shapes_scene):
    scene = shapes_scene.scene()
    shapes = {info.name: info.shape for info in scene.objects}
    assert shapes == {
        "floor": "plane",
        "box": "box",
        "ball": "sphere",
        "pillar": "capsule",
        "tetra": "convex",
        "cube": "mesh",
    }
    cube = scene.object("cube")
    assert cube.representation == "mesh" and cube.triangles == 12
    assert np.allclose(cube.bounds_min, [-0.03, -0.33, 0]) and np.allclose(
        cube.bounds_max, [0.03, -0.27, 0.06]
    )
    assert scene.object("floor").bounds_max[2] == 0 and math.isinf(
        scene.object("floor").bounds_min[0]
    )
    assert scene.object("box").material.stiffness == STIFFNESS


@pytest.mark.parametrize(
    ("xy", "top", "name", "normal"),
    [
        ((0.01, 0.02), 0.1, "box", (0, 0, 1)),
        ((0.3, 0.0), 0.1, "ball", (0, 0, 1)),
        ((-0.3, 0.0), 0.14, "pillar", (0, 0, 1)),
        ((0.02, 0.32), 0.06, "tetra", np.ones(3) / math.sqrt(3)),
        ((0.01, -0.29), 0.06, "cube", (0, 0, 1)),
        ((0.15, 0.15), 0.0, "floor", (0, 0, 1)),
    ],
)
def test_a_ray_down_hits_each_top(shapes_scene, xy, top, name, normal):
    hit = shapes_scene.ray_cast((*xy, 1.0), (0, 0, -1), max_distance=2)
    assert hit.hit and hit.object == name
    assert hit.distance == pytest.approx(1 - top, abs=1e-9)
    assert np.allclose(hit.point, [*xy, top], atol=1e-9)
    assert np.allclose(hit.normal, normal, atol=1e-9)


def test_a_ray_that_misses_says_so(shapes_scene):
    assert not shapes_scene.ray_cast((0, 0, 1), (0, 0, 1)).hit
    # too short to reach the box top 0.9 below
    assert not shapes_scene.ray_cast((0, 0, 1), (0, 0, -1), max_distance=0.5).hit


def test_closest_points_outside_and_inside(shapes_scene):
    above = shapes_scene.closest_point((0.01, 0, 0.2))
    assert above.found and above.object == "box"
    assert above.signed_distance == pytest.approx(0.1, abs=1e-12)
    assert np.allclose(above.point, [0.01, 0, 0.1]) and np.allclose(above.normal, [0, 0, 1])
    inside = shapes_scene.closest_point((0.045, 0, 0.05))
    assert inside.object == "box" and inside.signed_distance == pytest.approx(-0.005, abs=1e-12)
    assert np.allclose(inside.normal, [1, 0, 0])
    # 0.1 from the ball's centre along (0, 0.6, 0.8); the floor is 0.13 away
    ball = shapes_scene.closest_point((0.3, 0.06, 0.13), max_distance=0.5)
    assert ball.object == "ball" and ball.signed_distance == pytest.approx(0.05, abs=1e-12)
    assert np.allclose(ball.point, [0.3, 0.03, 0.09]) and np.allclose(ball.normal, [0, 0.6, 0.8])
    assert not shapes_scene.closest_point((0.15, 0.15, 0.5), max_distance=0.1).found


def test_contacts_of_a_sphere_in_a_corner(shapes_scene):
    # 1 cm sphere 5 mm into both the floor and the box's +x face
    contacts = shapes_scene.find_contacts((0.055, 0, 0.005), 0.01)
    by_object = {contact.object: contact for contact in contacts}
    assert set(by_object) == {"floor", "box"}
    assert by_object["floor"].depth == pytest.approx(0.005, abs=1e-12)
    assert np.allclose(by_object["floor"].normal, [0, 0, 1])
    assert by_object["box"].depth == pytest.approx(0.005, abs=1e-12)
    assert np.allclose(by_object["box"].normal, [1, 0, 0])
    assert shapes_scene.find_contacts((0.15, 0.15, 0.5), 0.01) == []


def test_edits_change_the_scene_and_bump_its_version(shapes_scene):
    client = shapes_scene
    version = client.scene().version
    # replace the ball by a bigger one elsewhere
    spec = hapticd.ObjectSpec("ball", hapticd.Sphere(0.08), pose=hapticd.Pose.of((0.3, 0.3, 0.08)))
    assert client.update_object(spec) == version + 1
    assert client.ray_cast((0.3, 0.3, 1), (0, 0, -1)).distance == pytest.approx(1 - 0.16)
    assert client.set_material("box", {"stiffness": 500, "damping": 1}) == version + 2
    assert client.scene().object("box").material.stiffness == 500
    # a kinematic object is moved, and then moves by its velocity until it is stopped:
    # after a pause it has gone v times the pause, within the times the calls took; the
    # server moves it every millisecond on its control thread, whose timer a loaded
    # machine may have kept waiting behind the read: up to KINEMATIC_LAG_S later
    client.add_sphere("puck", 0.01, position=(0.2, 0.2, 0.01), kinematic=True, material=MATERIAL)
    before_move = time.monotonic()
    client.move_kinematic("puck", (0.25, 0.2, 0.01), velocity=(0.1, 0, 0))
    after_move = time.monotonic()
    time.sleep(0.3)
    before_look = time.monotonic()
    x = client.scene().object("puck").pose.position[0]
    after_look = time.monotonic()
    lowest = 0.25 + 0.1 * (before_look - after_move - KINEMATIC_LAG_S)
    assert lowest - 2e-4 <= x <= 0.25 + 0.1 * (after_look - before_move) + 2e-4
    stopped = client.move_kinematic("puck", (0.3, 0.2, 0.01))
    time.sleep(0.05)
    assert np.allclose(client.scene().object("puck").pose.position, [0.3, 0.2, 0.01], atol=1e-12)
    assert client.remove_object("tetra") == stopped + 1
    assert "tetra" not in {info.name for info in client.scene().objects}
    assert not client.ray_cast((0.02, 0.32, 1), (0, 0, -1)).object == "tetra"
    client.clear_scene()
    assert client.scene().objects == []


@pytest.mark.parametrize(
    ("call", "code", "words"),
    [
        (lambda c: c.add_sphere("box", 0.1), "ALREADY_EXISTS", ['"box"', "exists"]),
        (lambda c: c.remove_object("cup"), "NOT_FOUND", ['"cup"', "no object"]),
        (lambda c: c.set_material("cup", {"stiffness": 1}), "NOT_FOUND", ["cup"]),
        (lambda c: c.move_kinematic("box", (0, 0, 0)), "BAD_REQUEST", ["box", "static"]),
        (lambda c: c.close_session(4242), "NOT_FOUND", ["session"]),
        (
            lambda c: c.add_mesh("flat", [[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]]),
            "BAD_REQUEST",
            ["flat", "degenerate"],
        ),
    ],
)
def test_refusals_name_the_problem(shapes_scene, call, code, words):
    with pytest.raises(hapticd.RemoteError) as refused:
        call(shapes_scene)
    assert refused.value.code == code
    for word in words:
        assert word in refused.value.message
    # the connection carries on
    assert shapes_scene.scene().object("box")


# ---- raw frames ----


def raw_connect(server):
    host, port = server.tcp.rsplit(":", 1)
    sock = socket.create_connection((host, int(port)), timeout=10)
    return sock


def read_reply(sock, decoder):
    """The next reply frame, or None when the server closed the connection."""
    while True:
        data = sock.recv(65536)
        if not data:
            return None
        frames = decoder.feed(data)
        if frames:
            return pb.Reply.FromString(frames[0])


def request_frame(request_id, **body):
    return encode_frame(pb.Request(request_id=request_id, **body).SerializeToString())


def control_errors(server):
    """The server's count of control requests answered with an error, so far."""
    with hapticd.connect(server.tcp, timeout_s=10) as fresh:
        return fresh.stats().counters.control_errors


def assert_still_serving(server, errors_before, errors):
    """The server serves a new connection, and counted exactly `errors` more errors."""
    assert control_errors(server) == errors_before + errors
    assert server.alive


def test_an_oversized_length_gets_frame_too_large_and_a_close(server):
    errors_before = control_errors(server)
    with raw_connect(server) as sock:
        sock.sendall(struct.pack(">I", 64 * 1024 * 1024 + 1))
        decoder = FrameDecoder()
        reply = read_reply(sock, decoder)
        assert reply.error.code == pb.Error.CODE_FRAME_TOO_LARGE
        assert "67108865" in reply.error.message
        assert read_reply(sock, decoder) is None
    assert_still_serving(server, errors_before, 1)


def test_text_instead_of_frames_is_refused_the_same_way(server):
    errors_before = control_errors(server)
    with raw_connect(server) as sock:
        sock.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
        decoder = FrameDecoder()
        assert read_reply(sock, decoder).error.code == pb.Error.CODE_FRAME_TOO_LARGE
        assert read_reply(sock, decoder) is None
    assert_still_serving(server, errors_before, 1)


def test_a_truncated_frame_then_hanging_up_leaves_the_server_serving(server):
    errors_before = control_errors(server)
    with raw_connect(server) as sock:
        sock.sendall(struct.pack(">I", 100) + b"\x08\x01" * 5)
    with raw_connect(server) as sock:
        sock.sendall(struct.pack(">I", 100)[:2])
    # half a frame is no request: nothing to answer, nothing counted
    assert_still_serving(server, errors_before, 0)


def test_garbage_in_a_frame_is_a_bad_request_and_the_connection_goes_on(server):
    errors_before = control_errors(server)
    with raw_connect(server) as sock:
        decoder = FrameDecoder()
        sock.sendall(encode_frame(b"\xff\xff\xff\xff\xff\xff"))
        reply = read_reply(sock, decoder)
        assert reply.error.code == pb.Error.CODE_BAD_REQUEST
        assert "not a hapticd.v1.Request" in reply.error.message
        sock.sendall(request_frame(5, get_stats=pb.GetStats()))
        reply = read_reply(sock, decoder)
        assert reply.request_id == 5 and reply.HasField("stats")
    assert_still_serving(server, errors_before, 1)


def test_unknown_fields_are_named_and_the_connection_goes_on(server):
    errors_before = control_errors(server)
    with raw_connect(server) as sock:
        decoder = FrameDecoder()
        # field 99, a varint: not part of hapticd.v1
        payload = pb.Request(request_id=6, get_scene=pb.GetScene()).SerializeToString()
        sock.sendall(encode_frame(payload + b"\x98\x06\x01"))
        reply = read_reply(sock, decoder)
        assert reply.request_id == 6 and reply.error.code == pb.Error.CODE_BAD_REQUEST
        assert "not part of hapticd.v1" in reply.error.message
        sock.sendall(request_frame(7, get_scene=pb.GetScene()))
        assert read_reply(sock, decoder).HasField("scene")
    assert_still_serving(server, errors_before, 1)


def test_an_empty_request_and_values_the_client_would_refuse(server):
    errors_before = control_errors(server)
    with raw_connect(server) as sock:
        decoder = FrameDecoder()
        sock.sendall(encode_frame(b""))
        assert read_reply(sock, decoder).error.code == pb.Error.CODE_BAD_REQUEST
        # NaN radius and an out-of-range triangle index, bypassing the client's checks
        nan_ball = pb.Object(
            name="nan",
            shape=pb.Shape(sphere=pb.Sphere(radius=math.nan)),
            material=pb.Material(stiffness=1),
        )
        sock.sendall(request_frame(8, add_object=pb.AddObject(object=nan_ball)))
        reply = read_reply(sock, decoder)
        assert reply.request_id == 8 and reply.error.code == pb.Error.CODE_BAD_REQUEST
        assert "radius" in reply.error.message and "nan" in reply.error.message
        mesh = pb.Mesh(vertices=[0, 0, 0, 1, 0, 0, 0, 1, 0], triangles=[0, 1, 7])
        bad_mesh = pb.Object(name="m", shape=pb.Shape(mesh=mesh), material=pb.Material(stiffness=1))
        sock.sendall(request_frame(9, add_object=pb.AddObject(object=bad_mesh)))
        reply = read_reply(sock, decoder)
        assert reply.error.code == pb.Error.CODE_BAD_REQUEST
        assert "triangles[2] is 7" in reply.error.message
    assert_still_serving(server, errors_before, 3)


def run_cli(*args):
    done = subprocess.run(
        [sys.executable, "-m", "hapticd", *args], capture_output=True, text=True, timeout=60
    )
    return done.returncode, done.stdout, done.stderr


def test_the_command_line_loads_and_shows_scenes(server, tmp_path):
    trimesh.creation.box(extents=(0.02, 0.02, 0.02)).export(tmp_path / "cube.stl")
    trimesh.creation.icosphere(subdivisions=1, radius=0.03).export(tmp_path / "ico.ply")
    scene_file = tmp_path / "scene.json"
    scene_file.write_text(
        json.dumps(
            {
                "scene": {
                    "objects": [
                        {
                            "name": "ball",
                            "shape": {"type": "sphere", "radius": 0.05},
                            "position": [0, 0, 0.05],
                            "material": {"stiffness": 1500},
                        },
                        {
                            "name": "cube",
                            "shape": {"type": "mesh", "file": "cube.stl"},
                            "position": [0.2, 0, 0.01],
                            "representation": "mesh",
                            "material": {"stiffness": 800, "static_friction": 0.3},
                        },
                    ]
                }
            }
        )
    )
    code, out, err = run_cli("scene", "load", str(scene_file), "--replace", "--server", server.tcp)
    assert code == 0, err
    assert json.loads(out)["added"] == ["ball", "cube"]
    code, out, err = run_cli(
        "scene",
        "load",
        str(tmp_path / "ico.ply"),
        "--position",
        "0",
        "0.3",
        "0.03",
        "--server",
        server.tcp,
    )
    assert code == 0, err
    code, out, err = run_cli("scene", "show", "--server", server.tcp)
    assert code == 0, err
    shown = {obj["name"]: obj for obj in json.loads(out)["objects"]}
    assert set(shown) == {"ball", "cube", "ico"}
    assert shown["ball"]["shape"] == "sphere" and shown["ball"]["material"]["stiffness"] == 1500
    assert shown["cube"]["representation"] == "mesh" and shown["cube"]["triangles"] == 12
    # a mesh file's stiffness is the package's one default, the server's
    assert shown["ico"]["position"] == [0, 0.3, 0.03]
    assert shown["ico"]["material"]["stiffness"] == hapticd.objects.DEFAULT_STIFFNESS == 1000
    # the server's refusal is a failure (1) that names the problem
    code, out, err = run_cli("scene", "load", str(scene_file), "--server", server.tcp)
    assert code == 1 and "ALREADY_EXISTS" in err and '"ball"' in err


def refuse_constant(name):
    raise AssertionError(f"{name} is not JSON")


def test_scene_show_prints_strict_json_for_infinite_values(client, server):
    """A plane's bounds are infinite: JSON has no infinity, so they print as "inf". (A
    flat mesh pinned as a sphere, whose error has no bound, is refused, naming the pin.)"""
    client.clear_scene()
    client.add_plane("floor")
    flat = [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]]
    with pytest.raises(hapticd.RemoteError, match=r"shape\.pin"):
        client.add_mesh("flat", flat, [[0, 1, 2]], "sphere", position=(0, 0, 0.5))
    code, out, err = run_cli("scene", "show", "--server", server.tcp)
    assert code == 0, err
    shown = json.loads(out, parse_constant=refuse_constant)
    objects = {obj["name"]: obj for obj in shown["objects"]}
    assert set(objects) == {"floor"}
    assert objects["floor"]["bounds_min"] == ["-inf", "-inf", "-inf"]
    assert objects["floor"]["bounds_max"] == ["inf", "inf", 0.0]


def test_tls_on_the_control_channel(bin_dir, tmp_path):
    """With --tls-cert the control channel speaks TLS: a client trusting the certificate
    works; a plain client is cut off at the handshake."""
    cert, key, token = tmp_path / "cert.pem", tmp_path / "key.pem", tmp_path / "token"
    subprocess.run(
        [
            "openssl",
            "req",
            "-x509",
            "-newkey",
            "ec",
            "-pkeyopt",
            "ec_paramgen_curve:prime256v1",
            "-nodes",
            "-keyout",
            str(key),
            "-out",
            str(cert),
            "-days",
            "1",
            "-subj",
            "/CN=127.0.0.1",
            "-addext",
            "subjectAltName=IP:127.0.0.1",
        ],
        check=True,
        capture_output=True,
        timeout=30,
    )
    token.write_text("a-token-of-24-characters\n")
    args = ["--tls-cert", str(cert), "--tls-key", str(key), "--access-token-file", str(token)]
    with running_server(bin_dir, "--log-level", "error", *args) as tls_server:
        context = ssl.create_default_context(cafile=str(cert))
        with hapticd.connect(tls_server.tcp, tls=context, access_token="a-token-of-24-characters") as client:
            assert client.scene().object("floor").shape == "plane"
        with pytest.raises((hapticd.ConnectionClosed, hapticd.ProtocolError, hapticd.Timeout)):
            hapticd.connect(tls_server.tcp, timeout_s=2)
        assert tls_server.alive


def main_thread_wakeups(pid):
    """Voluntary context switches of the server's main (control) thread so far."""
    status = pathlib.Path(f"/proc/{pid}/task/{pid}/status").read_text()
    return int(status.split("voluntary_ctxt_switches:")[1].split()[0])


def test_a_scene_at_rest_does_not_wake_the_control_thread(bin_dir):
    # the kinematics timer runs only while something moves: at rest the control thread
    # wakes for its 50 ms housekeeping and little else (the timer alone was 1,000 a second)
    with running_server(bin_dir, "--log-level", "warning") as server:
        with hapticd.connect(server.tcp, timeout_s=10) as client:
            client.add_sphere("puck", 0.01, position=(0.2, 0.2, 0.01), kinematic=True)
            time.sleep(0.2)
            before = main_thread_wakeups(server.process.pid)
            time.sleep(1.0)
            assert main_thread_wakeups(server.process.pid) - before < 300
            # set moving, the puck moves; stopped, the thread rests again
            client.move_kinematic("puck", (0.2, 0.2, 0.01), velocity=(0.1, 0, 0))
            time.sleep(0.2)
            assert client.scene().object("puck").pose.position[0] > 0.205
            client.move_kinematic("puck", (0.3, 0.2, 0.01))
            version = client.scene().version
            time.sleep(0.2)
            before = main_thread_wakeups(server.process.pid)
            time.sleep(1.0)
            assert main_thread_wakeups(server.process.pid) - before < 300
            assert client.scene().version == version
