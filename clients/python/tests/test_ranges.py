"""The client's ranges are the server's: one table (_validate.RANGES) that every check
reads, equal to the constants the server's headers document, and each entry point
refuses the value just past an end (naming the field, the value and the range) and
accepts the end itself."""

import math
import pathlib
import re

import numpy as np
import pytest

from hapticd import Box, Capsule, LocalError, Material, Mesh, ObjectSpec, Pose, Sphere
from hapticd import _validate as check

SERVER = pathlib.Path(__file__).resolve().parents[3] / "server"


def server_constant(header: str, name: str) -> float:
    """A `static constexpr double kName = <literal>;` of a server header."""
    text = (SERVER / header).read_text()
    found = re.search(rf"\b{name}\s*=\s*([0-9.e'+-]+)\s*;", text)
    assert found, f"{name} not in {header}"
    return float(found.group(1).replace("'", ""))


@pytest.mark.skipif(not SERVER.is_dir(), reason="the server's sources are not beside the package")
def test_the_deadbands_bounds_are_the_servers():
    deadband = "remote/deadband.h"
    ranges = check.RANGES
    assert ranges["deadband"].high == 1 and ranges["deadband"].high_open
    assert ranges["deadband_force_floor"].high == server_constant(deadband, "kMaxForceFloorN")
    assert ranges["deadband_position_floor"].high == server_constant(deadband, "kMaxPositionFloorM")
    velocity = server_constant(deadband, "kMaxVelocityFloorMps")
    assert ranges["deadband_velocity_floor"].high == velocity
    assert ranges["keepalive_s"].high == server_constant(deadband, "kMaxKeepaliveS")


@pytest.mark.skipif(not SERVER.is_dir(), reason="the server's sources are not beside the package")
def test_the_table_is_the_servers():
    session = "force/session_settings.h"
    scene = "scene/scene_limits.h"
    ranges = check.RANGES
    assert (ranges["rate_hz"].low, ranges["rate_hz"].high) == (
        server_constant(session, "kMinRateHz"),
        server_constant(session, "kMaxRateHz"),
    )
    assert ranges["max_force"].high == server_constant(session, "kMaxForce")
    assert ranges["max_velocity"].high == server_constant(session, "kMaxVelocity")
    assert ranges["avatar_radius"].high == server_constant(session, "kMaxAvatarRadius")
    assert (ranges["virtual_mass"].low, ranges["virtual_mass"].high) == (
        server_constant(session, "kMinVirtualMass"),
        server_constant(session, "kMaxVirtualMass"),
    )
    assert ranges["virtual_damping"].high == server_constant(session, "kMaxVirtualDamping")
    assert ranges["coordinate"].high == server_constant(scene, "kMaxCoordinate")
    assert ranges["coordinate"].low == -server_constant(scene, "kMaxCoordinate")
    assert ranges["size"].high == server_constant(scene, "kMaxSize")
    assert ranges["half_length"].high == server_constant(scene, "kMaxSize")
    assert ranges["stiffness"].high == server_constant(scene, "kMaxStiffness")
    assert ranges["damping"].high == server_constant(scene, "kMaxDamping")
    assert ranges["friction"].high == server_constant(scene, "kMaxFriction")
    assert ranges["speed"].high == server_constant(scene, "kMaxSpeed")
    assert ranges["angular_speed"].high == server_constant(scene, "kMaxAngularSpeed")
    service = (SERVER / "net/control_service.cc").read_text()
    low = float(re.search(r"kMinTelemetryRateHz = ([0-9.]+);", service).group(1))  # type: ignore[union-attr]
    high = float(re.search(r"kMaxTelemetryRateHz = ([0-9.]+);", service).group(1))  # type: ignore[union-attr]
    assert (ranges["subscribe_rate_hz"].low, ranges["subscribe_rate_hz"].high) == (low, high)
    budgets = (SERVER / scene).read_text()
    assert f"max_name_bytes = {check.MAX_NAME_BYTES};" in budgets


def test_ranges_print_as_documented():
    assert str(check.RANGES["max_force"]) == "(0, 10000] N"
    assert str(check.RANGES["rate_hz"]) == "[10, 10000] Hz"
    assert str(check.RANGES["friction"]) == "[0, 10]"
    assert str(check.RANGES["max_force_rate"]) == "[0, inf) N/s"


# (a value at the end of a range, accepted; one just past it, refused; the message)
ENDS = [
    (lambda v: Sphere(v), 1e3, 1000.5, r"^radius is 1000.5; it must be in \(0, 1000\] m$"),
    (
        lambda v: Capsule(0.1, v),
        0.0,
        -1e-300,
        r"^half_length is -1e-300; it must be in \[0, 1000\] m$",
    ),
    (
        lambda v: Box((0.1, v, 0.1)),
        1e3,
        1001.0,
        r"^half_extents is \[0.1, 1001.0, 0.1\]; each must be in \(0, 1000\] m$",
    ),
    (
        lambda v: Material(stiffness=v),
        1e7,
        2e7,
        r"^material.stiffness is 20000000.0; it must be in \(0, 1e\+07\] N/m$",
    ),
    (
        lambda v: Material(damping=v),
        1e5,
        1e5 + 1,
        r"^material.damping is 100001.0; it must be in \[0, 100000\] N·s/m$",
    ),
    (
        lambda v: Material(static_friction=v),
        10.0,
        10.5,
        r"^material.static_friction is 10.5; it must be in \[0, 10\]$",
    ),
    (
        lambda v: ObjectSpec("s", Sphere(1), pose=Pose.of((0, v, 0))),
        -1e4,
        -1e4 - 1,
        r"^position is \[0.0, -10001.0, 0.0\]; each coordinate must be in \[-10000, 10000\] m$",
    ),
    (
        lambda v: Mesh([[0, 0, 0], [1, 0, 0], [0, 1, v]], [[0, 1, 2]]),
        1e4,
        2e4,
        r"^vertices\[2\] is \[0.0, 1.0, 20000.0\]; each coordinate must be in \[-10000, 10000\] m$",
    ),
    (
        lambda v: ObjectSpec("s", Sphere(1), kinematic=True, velocity=(v, 0, 0)),
        100.0,
        100.5,
        r"^velocity is \[100.5, 0.0, 0.0\]; its norm 100.5 must be in \[0, 100\] m/s$",
    ),
    (
        lambda v: ObjectSpec("s", Sphere(1), kinematic=True, angular_velocity=(0, 0, v)),
        1e3,
        1001.0,
        r"^angular_velocity is \[0.0, 0.0, 1001.0\]; its norm 1001.0 must be in \[0, 1000\] rad/s$",
    ),
    (
        lambda v: ObjectSpec(v, Sphere(1)),
        "n" * 128,
        "n" * 129,
        r"\(129 bytes\); it must be at most 128 bytes$",
    ),
]


@pytest.mark.parametrize(("make", "end", "past", "message"), ENDS)
def test_an_end_is_accepted_and_just_past_it_refused(make, end, past, message):
    make(end)
    with pytest.raises(LocalError, match=message):
        make(past)


def test_names_without_control_characters():
    with pytest.raises(LocalError, match=r"the control character 10 \(names must be printable\)"):
        ObjectSpec("a\nb", Sphere(1))
    # bytes, not characters: 64 two-byte characters are 128 bytes
    ObjectSpec("é" * 64, Sphere(1))
    with pytest.raises(LocalError, match="130 bytes"):
        ObjectSpec("é" * 65, Sphere(1))


# Session and subscription arguments: (keyword arguments, message) for values just past
# an end; the ends themselves are checked through the same function below.
SESSION_CASES = [
    ({"rate_hz": 9.99}, r"^rate_hz is 9.99; it must be in \[10, 10000\] Hz$"),
    ({"max_force": 10_000.5}, r"^max_force is 10000.5; it must be in \(0, 10000\] N$"),
    ({"max_velocity": 0}, r"^max_velocity is 0.0; it must be in \(0, 100\] m/s$"),
    (
        {"avatar": "sphere", "avatar_radius": 1.5},
        r"^avatar_radius is 1.5; it must be in \(0, 1\] m$",
    ),
    ({"avatar_radius": 0.1}, r"^avatar_radius is 0.1; a point avatar has radius 0$"),
    (
        {"virtual_mass": 1e-4},
        r"^virtual_mass is 0.0001; it must be in \[0.001, 1000\] kg, or 0 for the server's 1 kg$",
    ),
    ({"virtual_damping": -1}, r"^virtual_damping is -1.0; it must be in \[0, 100000\] N·s/m$"),
    (
        {"session_timeout_s": 0.1},
        r"^session_timeout_s is 0.1; it must be in \[0.15, 3600\] s, or 0 for the server's 2 s$",
    ),
    ({"max_force_rate": -1}, r"^max_force_rate is -1.0; it must be in \[0, inf\) N/s$"),
]


@pytest.mark.parametrize(("arguments", "message"), SESSION_CASES)
def test_session_arguments_past_their_ranges_are_refused(offline, arguments, message):
    with pytest.raises(LocalError, match=message):
        offline.client.open_session(**arguments)
    assert offline.nothing_sent()


def test_subscriptions_past_their_range_are_refused(offline):
    for rate, shown in ((0.09, "0.09"), (1000.5, "1000.5"), (math.inf, "inf")):
        with pytest.raises(LocalError, match=rf"^rate_hz is {shown}; it must be"):
            offline.client.subscribe(rate)
    assert offline.nothing_sent()


@pytest.mark.parametrize("quantity", sorted(check.RANGES))
def test_every_range_takes_its_closed_ends_and_refuses_beyond(quantity):
    allowed = check.RANGES[quantity]
    for end, is_open, outward in (
        (allowed.low, allowed.low_open, -1),
        (allowed.high, allowed.high_open, 1),
    ):
        if math.isinf(end):
            continue
        if is_open:
            with pytest.raises(LocalError, match=quantity):
                check.limited(end, quantity, quantity)
        else:
            assert check.limited(end, quantity, quantity) == end
        beyond = end + outward * max(abs(end), 1) * 1e-9
        with pytest.raises(
            LocalError, match=rf"^{quantity} is .*; it must be in {re.escape(str(allowed))}$"
        ):
            check.limited(beyond, quantity, quantity)


def test_a_move_beyond_the_ranges_is_refused(offline):
    with pytest.raises(LocalError, match=r"^position is \[20000.0, 0.0, 0.0\]; each coordinate"):
        offline.client.move_kinematic("k", (2e4, 0, 0))
    with pytest.raises(
        LocalError, match=r"^velocity is .*; its norm .* must be in \[0, 100\] m/s$"
    ):
        offline.client.move_kinematic("k", (0, 0, 0), velocity=np.array([60.0, 60.0, 60.0]))
    assert offline.nothing_sent()
