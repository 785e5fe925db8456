"""The client refuses bad arguments before sending anything, with a LocalError that
names the argument and its value."""

import math

import numpy as np
import pytest

from hapticd import Box, LocalError, Material, Mesh, ObjectSpec, Pose, Sphere
from hapticd._connection import parse_address

CASES = [
    (lambda c: c.add_sphere("s", -0.5), r"radius is -0.5; it must be in \(0, 1000\] m"),
    (lambda c: c.add_sphere("s", math.nan), r"radius is nan; it must be a finite number"),
    (lambda c: c.add_sphere("", 1.0), r"name is ''; it must be a non-empty string"),
    (
        lambda c: c.add_sphere("s", 1.0, position=(0, math.nan, 0)),
        r"position is \[0.0, nan, 0.0\]; it must be finite",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, position=(0, 0)),
        r"position has shape \(2,\); it must be \(3,\)",
    ),
    (
        lambda c: c.add_box("b", (0.1, 0.0, 0.1)),
        r"half_extents is \[0.1, 0.0, 0.1\]; each must be in \(0, 1000\] m",
    ),
    (
        lambda c: c.add_capsule("c", 0.1, -1),
        r"half_length is -1.0; it must be in \[0, 1000\] m",
    ),
    (lambda c: c.add_convex("h", np.zeros((3, 3))), r"points has 3 points; it needs at least 4"),
    (
        lambda c: c.add_mesh("m", np.zeros((3, 3)), [[0, 1, 3]]),
        r"triangles\[0\]\[2\] is 3; it must be a vertex index in \[0, 3\)",
    ),
    (
        lambda c: c.add_mesh("m", np.zeros((3, 2)), [[0, 1, 2]]),
        r"vertices has shape \(3, 2\); it must be \(N, 3\)",
    ),
    (
        lambda c: c.add_mesh("m", [[0, 0, 0], [1, 0, 0], [0, math.inf, 0]], [[0, 1, 2]]),
        r"vertices\[2\] is \[0.0, inf, 0.0\]; it must be finite",
    ),
    (
        lambda c: c.add_mesh("m", np.zeros((3, 3)), [[0.0, 1.0, 2.0]]),
        r"triangles has dtype float64; it must hold integer vertex indices",
    ),
    (
        lambda c: c.add_mesh("m", np.zeros((3, 3)), [[0, 1, 2]], representation="blob"),
        r"representation is 'blob'; it must be one of auto, sphere, box, capsule, convex, mesh",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, rotation=(1, 0, 0, 0.5)),
        r"rotation is \[1.0, 0.0, 0.0, 0.5\]; a quaternion must have norm 1",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, rotation=np.diag([1.0, 1.0, -1.0])),
        r"it is not a rotation .*det R = -1",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, material={"stiffness": -5}),
        r"material.stiffness is -5.0; it must be in \(0, 1e\+07\] N/m",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, material={"stiffnes": 5}),
        r"^material.stiffnes is not a material field; a material has stiffness, damping, "
        r"static_friction, dynamic_friction, force_shading$",
    ),
    # unknown keywords are named, with the likely one meant
    (
        lambda c: c.add_sphere("s", 1.0, rotaton=(1, 0, 0, 0)),
        r"^add_sphere got an unknown keyword argument 'rotaton' \(did you mean 'rotation'\?\); "
        r"it takes position, rotation, material, kinematic, velocity, angular_velocity, "
        r"timeout_s$",
    ),
    (
        lambda c: c.add_box("b", (1, 1, 1), materail={"stiffness": 5}),
        r"^add_box got an unknown keyword argument 'materail' \(did you mean 'material'\?\)",
    ),
    (
        lambda c: c.add_capsule("c", 0.1, 0.1, orientation=(1, 0, 0, 0)),
        r"^add_capsule got an unknown keyword argument 'orientation' \(did you mean 'rotation'",
    ),
    (
        lambda c: c.add_convex("h", np.eye(4, 3), pos=(0, 0, 0)),
        r"^add_convex got an unknown keyword argument 'pos'; it takes position, rotation, "
        r"material, kinematic, velocity, angular_velocity, timeout_s$",
    ),
    (
        lambda c: c.add_plane("p", normals=(0, 0, 1)),
        r"^add_plane got an unknown keyword argument 'normals' \(did you mean 'normal'\?\); "
        r"it takes normal, position",
    ),
    (
        lambda c: c.add_mesh("m", np.eye(3), [[0, 1, 2]], represent="mesh"),
        r"^add_mesh got an unknown keyword argument 'represent' \(did you mean 'representation'",
    ),
    (
        lambda c: c.add_mesh_file("m", "/nonexistent/bunny.obj", scal=2),
        r"^add_mesh_file got an unknown keyword argument 'scal' \(did you mean 'scale'",
    ),
    # text and truth values are not numbers, nor is a number a flag
    (lambda c: c.add_sphere("s", "0.1"), r"^radius is '0.1'; it must be a number$"),
    (lambda c: c.add_sphere("s", True), r"^radius is True; it must be a number$"),
    (lambda c: c.add_sphere("s", np.True_), r"^radius is np.True_; it must be a number$"),
    (lambda c: c.add_capsule("c", 0.1, "1"), r"^half_length is '1'; it must be a number$"),
    (
        lambda c: c.add_sphere("s", 1.0, position=("0", 0, 0)),
        r"^position is \('0', 0, 0\); it must be numbers$",
    ),
    (
        lambda c: c.add_box("b", [True, True, True]),
        r"^half_extents is \[True, True, True\]; it must be numbers$",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, material={"stiffness": "2000"}),
        r"^material.stiffness is '2000'; it must be a number$",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, material={"stiffness": 1, "force_shading": 1}),
        r"^material.force_shading is 1; it must be True or False$",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, kinematic="no"),
        r"^kinematic is 'no'; it must be True or False$",
    ),
    (
        lambda c: c.set_material("s", {"dampin": 3}),
        r"^material.dampin is not a material field",
    ),
    (
        lambda c: c.set_material("s", {"damping": "3"}),
        r"^material.damping is '3'; it must be a number$",
    ),
    (lambda c: c.open_session(max_force="10"), r"^max_force is '10'; it must be a number$"),
    (lambda c: c.scene(timeout_s="1"), r"^timeout_s is '1'; it must be a number$"),
    (
        lambda c: c.add_sphere(
            "s", 1.0, material=Material(1000, static_friction=0.2, dynamic_friction=0.5)
        ),
        r"material.dynamic_friction is 0.5; it must be <= material.static_friction \(0.2\)",
    ),
    (
        lambda c: c.add_sphere("s", 1.0, velocity=(1, 0, 0)),
        r"object 's' is static but has velocity \[1.0, 0.0, 0.0\]",
    ),
    (
        lambda c: c.add_plane("p", normal=(0, 0, 0)),
        r"normal is \[0.0, 0.0, 0.0\]; it must be non-zero",
    ),
    (
        lambda c: c.add_mesh_file("m", "/nonexistent/bunny.obj"),
        r"mesh file '/nonexistent/bunny.obj' does not exist",
    ),
    (lambda c: c.add_mesh_file("m", "/tmp/bunny.xyz"), r"is not an OBJ, STL or PLY file"),
    (lambda c: c.remove_object(""), r"name is ''; it must be a non-empty string"),
    (
        lambda c: c.move_kinematic("k", (0, 0, math.nan)),
        r"position is \[0.0, 0.0, nan\]; it must be finite",
    ),
    (
        lambda c: c.ray_cast((0, 0, 0), (0, 0, 0)),
        r"direction is \[0.0, 0.0, 0.0\]; it must be non-zero",
    ),
    (
        lambda c: c.ray_cast((0, 0, 0), (0, 0, 1), -1),
        r"max_distance is -1.0; it must be a finite number > 0",
    ),
    (lambda c: c.closest_point((0, 0, math.nan)), r"point is \[0.0, 0.0, nan\]; it must be finite"),
    (
        lambda c: c.find_contacts((0, 0, 0), -0.1),
        r"radius is -0.1; it must be a finite number >= 0",
    ),
    (
        lambda c: c.open_session("haptic"),
        r"device_type is 'haptic'; it must be one of impedance, admittance",
    ),
    (lambda c: c.open_session(degrees_of_freedom=4), r"degrees_of_freedom is 4; it must be 3 or 6"),
    (lambda c: c.open_session(max_force=0), r"max_force is 0.0; it must be in \(0, 10000\] N"),
    (
        lambda c: c.open_session(rate_hz=20000),
        r"rate_hz is 20000.0; it must be in \[10, 10000\] Hz",
    ),
    (lambda c: c.open_session(avatar="sphere"), r"avatar_radius is 0.0; it must be in \(0, 1\] m"),
    (
        lambda c: c.open_session(method="magic"),
        r"method is 'magic'; it must be one of default, penalty",
    ),
    (
        lambda c: c.open_session(start=(0, 0, math.inf)),
        r"start is \[0.0, 0.0, inf\]; it must be finite",
    ),
    (lambda c: c.open_session(deadband=1), r"^deadband is 1.0; it must be in \[0, 1\)$"),
    (lambda c: c.open_session(deadband=-0.1), r"^deadband is -0.1; it must be in \[0, 1\)$"),
    (
        lambda c: c.open_session(deadband=0.1, keepalive_s=0.05),
        r"^keepalive_s is 0.05; it must be in \(0, 0.025\] s, or 0 for the server's 0.01 s$",
    ),
    (
        lambda c: c.open_session(deadband=0.1, deadband_position_floor=1),
        r"deadband_position_floor is 1.0; it must be in \(0, 0.01\] m",
    ),
    (lambda c: c.open_session(tdpa=1), r"^tdpa is 1; it must be True or False$"),
    (
        lambda c: c.open_session("admittance", tdpa=True),
        r"^tdpa is set for an admittance device; two-port passivity and the deadband are for "
        r"impedance",
    ),
    (
        lambda c: c.open_session("admittance", deadband=0.1),
        r"^deadband is set for an admittance device",
    ),
    (lambda c: c.subscribe(0), r"rate_hz is 0.0; it must be in \[0.1, 1000\] Hz"),
    (lambda c: c.subscribe(2000), r"rate_hz is 2000.0; it must be in \[0.1, 1000\] Hz"),
    (lambda c: c.scene(timeout_s=-1), r"timeout_s is -1.0; it must be a finite number > 0"),
    (lambda c: c.add_object("ball"), r"spec is 'ball'; it must be an ObjectSpec"),
]


@pytest.mark.parametrize(("call", "message"), CASES)
def test_bad_arguments_are_named_and_nothing_is_sent(offline, call, message):
    with pytest.raises(LocalError, match=message):
        call(offline.client)
    assert offline.nothing_sent()


def test_local_errors_are_value_errors():
    with pytest.raises(ValueError):
        Sphere(-1)


def test_object_spec_checks_its_parts():
    with pytest.raises(LocalError, match="shape is 3; it must be a Sphere"):
        ObjectSpec("x", 3)  # type: ignore[arg-type]
    with pytest.raises(LocalError, match="pose is"):
        ObjectSpec("x", Box((1, 1, 1)), pose=(0, 0, 0))  # type: ignore[arg-type]


def test_a_rotation_matrix_becomes_its_quaternion():
    quarter_turn_z = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    pose = Pose.of((1, 2, 3), quarter_turn_z)
    assert np.allclose(pose.orientation, [math.sqrt(0.5), 0, 0, math.sqrt(0.5)])
    assert np.allclose(pose.rotation, quarter_turn_z)


def test_mesh_indices_are_stored_as_uint32():
    mesh = Mesh(np.zeros((3, 3)), np.array([[0, 1, 2]], dtype=np.int64))
    assert mesh.triangles.dtype == np.uint32


@pytest.mark.parametrize(
    ("address", "message"),
    [
        ("localhost", r"address is 'localhost'; it must be HOST:PORT"),
        (":7000", r"the host before ':' is empty"),
        ("host:port", r"the port 'port' is not a number"),
        ("host:0", r"the port must be in 1..65535"),
        ("host:70000", r"the port must be in 1..65535"),
    ],
)
def test_bad_addresses_are_named(address, message):
    with pytest.raises(LocalError, match=message):
        parse_address(address)


def test_ipv6_addresses_parse():
    assert parse_address("[::1]:7460") == ("::1", 7460)


def test_values_that_are_not_numbers_are_named(offline):
    client = offline.client
    with pytest.raises(LocalError, match=r"position is \[0, 0, 'x'\]; it must be numbers"):
        client.add_sphere("s", 1.0, position=[0, 0, "x"])
    with pytest.raises(LocalError, match=r"radius is 'big'; it must be a number"):
        client.add_sphere("s", "big")  # type: ignore[arg-type]
    with pytest.raises(LocalError, match=r"triangles is .*; it must be integer indices"):
        client.add_mesh("m", np.zeros((3, 3)), [[0, 1], [2]])
    assert offline.nothing_sent()
