"""End to end, the realtime channel: device sessions on a real hapticd process over real
UDP. A point pressed d into a box feels F = k d within 1%; an admittance device pushed
into a wall stops at it; two sessions share the scene; telemetry reports them; bad
datagrams are counted and dropped while the session carries on; a device that vanishes
has its force ramped to zero and its session reclaimed; a 10 MB upload and scene edits
during streaming leave every state answered; the command line's demo and latency
benchmark run against a fresh server."""

import json
import math
import os
import socket
import subprocess
import sys
import time
from dataclasses import dataclass

import hapticd
import numpy as np
import pytest
from hapticd._datagram import compute_tag, encode_state
from hapticd.demo import Ticker
from hapticd.v1 import hapticd_pb2 as pb
from server_process import running_server, wait_until

TOP = 0.1  # the box's top face, z (m)
ABOVE = (0.0, 0.0, 0.12)


@pytest.fixture
def client(server):
    """A client on a scene of two boxes: "box" (k 2000 N/m) centred at (0, 0, 0.05) and
    "soft" (k 500 N/m) at (0.3, 0, 0.05), both with tops at z = 0.1, and a floor."""
    with hapticd.connect(server.tcp, timeout_s=10) as connected:
        connected.clear_scene()
        connected.add_plane("floor", material={"stiffness": 2000})
        connected.add_box(
            "box", (0.05, 0.05, 0.05), position=(0, 0, 0.05), material={"stiffness": 2000}
        )
        connected.add_box(
            "soft", (0.05, 0.05, 0.05), position=(0.3, 0, 0.05), material={"stiffness": 500}
        )
        yield connected


def press(device, xy, depth, steps=100, hold=20):
    """Moves the device point from 2 cm above the top at xy down to depth below it, then
    holds; the last command."""
    command = None
    for z in np.linspace(TOP + 0.02, TOP - depth, steps).tolist() + [TOP - depth] * hold:
        command = device.exchange((*xy, z), timeout_s=1.0)
        assert command is not None, "no command within 1 s"
    return command


@pytest.mark.parametrize(
    ("box", "xy", "stiffness", "depth"),
    [
        ("box", (0.01, 0.02), 2000, 0.001),
        ("box", (0.0, 0.0), 2000, 0.003),
        ("soft", (0.3, 0.01), 500, 0.004),
    ],
)
def test_pressing_into_a_box_feels_k_times_d(client, box, xy, stiffness, depth):
    info = client.open_session("impedance", start=(*xy, TOP + 0.02))
    with hapticd.DeviceSession(info) as device:
        command = press(device, xy, depth)
    client.close_session(info.session_id)
    assert command.contact
    assert command.force[2] == pytest.approx(stiffness * depth, rel=0.01)
    assert abs(command.force[0]) < 1e-6 and abs(command.force[1]) < 1e-6
    # the god-object proxy stays on the surface above the device point
    assert np.allclose(command.avatar, [*xy, TOP], atol=1e-6)
    assert device.counters.lost == 0 and device.counters.bad == 0


def test_a_new_material_changes_the_force_at_once(client):
    info = client.open_session("impedance", start=(0, 0, TOP + 0.02))
    with hapticd.DeviceSession(info) as device:
        assert press(device, (0, 0), 0.002).force[2] == pytest.approx(4.0, rel=0.01)
        client.set_material("box", {"stiffness": 1000})
        # the next snapshot reaches the realtime thread within a few states
        forces = [device.exchange((0, 0, TOP - 0.002), timeout_s=1).force[2] for _ in range(50)]
    client.close_session(info.session_id)
    assert forces[-1] == pytest.approx(2.0, rel=0.01)


def test_an_admittance_device_pushed_into_a_wall_stops_at_it(client):
    # a simulated hand pulls the handle from 2 cm above the floor to 2 cm below it
    start = (-0.2, 0.0, 0.02)
    hand = hapticd.HandSpec(
        mass=0.3, stiffness=300, damping=5, path=[[0, *start], [0.3, -0.2, 0, -0.02]]
    )
    sim = hapticd.SimAdmittanceDevice(
        hand, hapticd.DeviceSpec(mass=0.05, damping=0, max_force=40, start=start)
    )
    info = client.open_session(
        "admittance", start=start, max_force=40, virtual_mass=1, virtual_damping=20
    )
    lowest = math.inf
    with hapticd.DeviceSession(info) as device:
        for k in range(1000):
            t = k / 1000
            sample = sim.sample(t)
            command = device.exchange(
                sample.position, sample.velocity, sensed_force=sample.force, timeout_s=1
            )
            assert command is not None
            sim.accept(command.position)
            sim.advance(t)
            lowest = min(lowest, sim.position[2])
    client.close_session(info.session_id)
    assert lowest > -1e-6, f"the device went {-lowest} m into the wall"
    assert sim.position[2] == pytest.approx(0, abs=1e-6) and command.contact
    # the hand still pushes down with K_h * 2 cm while the wall holds the device
    assert sample.force[2] == pytest.approx(-300 * 0.02, rel=0.01)


def test_two_sessions_at_once_each_feel_their_own_box(client):
    hard = client.open_session("impedance", start=(0, 0, TOP + 0.02))
    soft = client.open_session("impedance", start=(0.3, 0, TOP + 0.02))
    assert hard.session_id != soft.session_id and hard.key != soft.key
    with hapticd.DeviceSession(hard) as a, hapticd.DeviceSession(soft) as b:
        # interleaved, state by state
        for z in np.linspace(TOP + 0.02, TOP - 0.002, 60).tolist() + [TOP - 0.002] * 10:
            force_a = a.exchange((0, 0, z), timeout_s=1).force
            force_b = b.exchange((0.3, 0, TOP - 2 * (TOP - z)), timeout_s=1).force
        stats = client.stats()
    assert force_a[2] == pytest.approx(2000 * 0.002, rel=0.01)
    assert force_b[2] == pytest.approx(500 * 0.004, rel=0.01)
    # the stats may come after the 50 ms watchdog on a stalled machine (ramping, its
    # force scaled down): the commands above carry the forces
    for info in (hard, soft):
        session = stats.session(info.session_id)
        assert session.state in ("active", "ramping") and session.contact
        assert session.states_received == 70
    client.close_session(hard.session_id)
    client.close_session(soft.session_id)


def test_telemetry_reports_a_pressing_session(client, server):
    info = client.open_session("impedance", start=(0, 0, TOP + 0.02))
    with hapticd.connect(server.tcp) as watcher, hapticd.DeviceSession(info) as device:
        press(device, (0, 0), 0.002)
        with watcher.subscribe(200, [info.session_id]) as samples:
            sample = next(samples)
            assert [s.session_id for s in sample.sessions] == [info.session_id]
            # the session is idle now: a later sample shows the same held press
            device.exchange((0, 0, TOP - 0.002), timeout_s=1)
            later = samples.next(timeout_s=2)
    client.close_session(info.session_id)
    session = later.session(info.session_id)
    assert session.state in ("active", "ramping") and session.contact
    assert session.force[2] == pytest.approx(4.0, rel=0.01)
    assert np.allclose(session.device_position, [0, 0, TOP - 0.002])
    assert later.server_time_ns > sample.server_time_ns
    assert session.rtt_us > 0 and session.rtt_us < 1_000_000


def state_datagram(info, sequence, key=None, position=(0.0, 0.0, 0.15), session_id=None):
    state = pb.DeviceState(
        session_id=info.session_id if session_id is None else session_id,
        sequence=sequence,
        send_time_ns=sequence,
        position=pb.Vec3(x=position[0], y=position[1], z=position[2]),
    )
    return encode_state(state, info.key if key is None else key)


@dataclass
class Answer:
    """What a DeviceCommand commands: force (N) and avatar position (m), as arrays."""

    force: np.ndarray
    avatar: np.ndarray


def answer_of(command):
    vector = lambda v: np.array([v.x, v.y, v.z])  # noqa: E731
    return Answer(vector(command.force), vector(command.avatar))


def test_bad_datagrams_are_counted_and_dropped_and_the_session_goes_on(client, server):
    info = client.open_session("impedance", start=(0, 0, 0.15))
    before = client.stats().counters
    host, port = server.udp.rsplit(":", 1)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.connect((host, int(port)))
        sock.settimeout(1.0)

        commands = {}

        def answered(datagram):
            """The sequence of the command answering datagram (kept in commands); None if
            none comes. The watchdog's commands (sequence 0) of a silent session are
            skipped."""
            sock.send(datagram)
            try:
                while True:
                    command = pb.DeviceCommand.FromString(sock.recv(1024)[:-16])
                    if command.sequence:
                        commands[command.sequence] = answer_of(command)
                        return command.sequence
            except TimeoutError:
                return None

        assert answered(state_datagram(info, 1)) == 1
        assert answered(state_datagram(info, 3)) == 3
        sock.settimeout(0.2)
        assert answered(state_datagram(info, 2)) is None  # older than the newest
        assert answered(state_datagram(info, 3)) is None  # replayed
        assert answered(state_datagram(info, 4, key=bytes(32))) is None  # wrong key
        assert answered(os.urandom(60)) is None  # garbage
        assert answered(os.urandom(600)) is None  # oversized
        assert answered(state_datagram(info, 5, session_id=info.session_id ^ 1)) is None
        payload = pb.DeviceState(session_id=info.session_id, sequence=6).SerializeToString()
        assert answered(payload + compute_tag(info.key, payload)[:8]) is None  # truncated tag
        sock.settimeout(1.0)
        # pressing 2 mm into the box (k 2000 N/m): 4 N up
        pressing = (0.0, 0.0, TOP - 0.002)
        assert answered(state_datagram(info, 7, position=pressing)) == 7
        assert commands[7].force[2] == pytest.approx(4.0, rel=0.01)
        # a NaN position is counted, and answered with the last safe force
        assert answered(state_datagram(info, 8, position=(math.nan, 0, 0))) == 8
        assert np.array_equal(commands[8].force, commands[7].force)
        assert np.array_equal(commands[8].avatar, commands[7].avatar)
        assert answered(state_datagram(info, 9)) == 9
        assert np.array_equal(commands[9].force, [0, 0, 0])
    stats = client.stats()
    session = stats.session(info.session_id)
    after = stats.counters
    client.close_session(info.session_id)
    assert session.reordered == 1 and session.replayed == 1 and session.bad_mac == 1
    assert session.nonfinite_inputs == 1
    assert after.malformed > before.malformed
    assert after.oversized > before.oversized
    assert after.unknown_session > before.unknown_session

    # wrong key, garbage, oversized, another session, a truncated tag: each dropped once
    def dropped(counters):
        return counters.malformed + counters.oversized + counters.unknown_session + counters.bad_mac

    assert dropped(after) - dropped(before) == 5
    assert server.alive


def test_a_vanished_device_is_ramped_to_zero_and_reclaimed(client):
    timed_out = client.stats().counters.sessions_timed_out
    info = client.open_session("impedance", start=(0, 0, TOP + 0.02), session_timeout_s=0.4)
    with hapticd.DeviceSession(info) as device:
        assert press(device, (0, 0), 0.002).force[2] == pytest.approx(4.0, rel=0.01)
        # the device stops sending; the watchdog's commands keep coming, ramping down
        forces = []
        while (command := device.next_command(timeout_s=0.5)) is not None:
            assert command.watchdog and command.sequence == 0
            forces.append(command.force[2])
        # reclaimed after its timeout (the device is still open): closing it finds nothing
        assert wait_until(
            lambda: info.session_id not in {s.session_id for s in client.stats().sessions}, 3.0
        )
        with pytest.raises(hapticd.RemoteError, match="NOT_FOUND"):
            client.close_session(info.session_id)
    assert forces and forces[-1] == pytest.approx(0, abs=1e-9)
    assert all(later <= earlier + 1e-12 for earlier, later in zip(forces, forces[1:], strict=False))
    assert max(forces) <= forces[0]
    assert client.stats().counters.sessions_timed_out == timed_out + 1


def test_a_device_is_told_when_its_session_ends(client):
    # Closed by its client, or timed out: the device's next state is answered "ended"
    # (it used to get silence, which it could not tell from packet loss).
    info = client.open_session("impedance", start=(0, 0, TOP + 0.02), session_timeout_s=0.4)
    with hapticd.DeviceSession(info) as device:
        assert press(device, (0, 0), 0.002).force[2] == pytest.approx(4.0, rel=0.01)
        client.close_session(info.session_id)
        assert wait_until(
            lambda: info.session_id not in {s.session_id for s in client.stats().sessions}, 3.0
        )
        with pytest.raises(hapticd.SessionEnded) as ended:
            device.exchange((0, 0, TOP + 0.01), timeout_s=1.0)
        assert ended.value.reason == "closed" and ended.value.session_id == info.session_id
    quiet = client.open_session("impedance", start=(0, 0, TOP + 0.02), session_timeout_s=0.4)
    with hapticd.DeviceSession(quiet) as device:
        assert device.exchange((0, 0, TOP + 0.01), timeout_s=1.0) is not None
        assert wait_until(
            lambda: quiet.session_id not in {s.session_id for s in client.stats().sessions}, 3.0
        )
        with pytest.raises(hapticd.SessionEnded, match="timed_out"):
            device.exchange((0, 0, TOP + 0.01), timeout_s=1.0)


UPLOAD_SCRIPT = """
import sys, time
import numpy as np
import hapticd

# a 500 x 500 height field, about 10 MB on the wire, far from the device
n = 500
x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
vertices = np.stack([x.ravel() + 5, y.ravel(), 0.01 * np.sin(20 * x.ravel())], axis=1)
i = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
triangles = np.concatenate([np.stack([i, i + 1, i + n], 1), np.stack([i + 1, i + n + 1, i + n], 1)])
with hapticd.connect(sys.argv[1], timeout_s=60) as client:
    print("ready", flush=True)
    sys.stdin.readline()
    started = time.monotonic()
    client.add_mesh("terrain", vertices, triangles, "mesh")
    client.set_material("box", {"stiffness": 2000, "damping": 1})
    client.move_kinematic("puck", (0.2, 0.2, 0.01))
    print(time.monotonic() - started, flush=True)
"""


def stream(device, seconds, until=None):
    """The commands answering states at 1 kHz pressing 2 mm into the box, for seconds or
    until until() is true."""
    ticker = Ticker(1000)
    commands = []
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not (until and until()):
        command = device.exchange((0, 0, TOP - 0.002), timeout_s=1.0)
        assert command is not None, "a command was lost"
        commands.append(command)
        ticker.wait()
    return commands


def rtt_us(commands):
    return np.array([command.rtt_ns / 1000 for command in commands])


def test_a_10_mb_mesh_upload_and_edits_during_streaming(client, server):
    """Every state is answered while a 10 MB mesh is uploaded and the scene edited, and
    the commands pick up the new scene versions. The mesh is parsed and its BVH built on
    the control thread: a realtime channel that waited for that would stall for the
    whole upload (about a second here), so no round trip may come near that: a quarter
    of the upload's time at most (the upload, the server and this test share two cores,
    so the bound grows with the upload on a loaded machine). Finer percentiles depend on
    the load of this shared machine; bench/ measures them."""
    client.add_sphere("puck", 0.01, position=(0.2, 0.3, 0.01), kinematic=True)
    info = client.open_session("impedance", start=(0, 0, TOP + 0.02))
    upload = subprocess.Popen(
        [sys.executable, "-c", UPLOAD_SCRIPT, server.tcp],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert upload.stdout.readline().strip() == "ready"
        with hapticd.DeviceSession(info) as device:
            press(device, (0, 0), 0.002)
            quiet = stream(device, 1.0)
            upload.stdin.write("go\n")
            upload.stdin.flush()
            during = stream(device, 30.0, until=lambda: upload.poll() is not None)
            after = stream(device, 0.1)
        upload_s = float(upload.stdout.read())
    finally:
        upload.kill()
        upload.wait()
    client.close_session(info.session_id)
    assert upload.returncode == 0
    assert client.scene().object("terrain").triangles == 2 * 499 * 499
    assert len(during) > 0.5 * upload_s * 1000
    # the realtime channel kept rendering through the edits, and picked them up
    assert after[-1].scene_version == quiet[-1].scene_version + 3
    assert all(command.force[2] == pytest.approx(4.0, rel=0.01) for command in during + after)
    quiet_p, during_p = (np.percentile(rtt_us(c), [50, 99, 99.9]) for c in (quiet, during))
    print(
        f"\nrtt p50/p99/p99.9 us: quiet {quiet_p.round(1)}, during a {upload_s:.2f} s upload "
        f"{during_p.round(1)}"
    )
    assert rtt_us(during).max() < max(50_000, upload_s * 1e6 / 4)
    assert during_p[1] < quiet_p[1] + 5_000


def run_cli(*args, timeout=60):
    done = subprocess.run(
        [sys.executable, "-m", "hapticd", *args], capture_output=True, text=True, timeout=timeout
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 1, done.stdout
    return json.loads(lines[0])


def test_the_demo_renders_from_the_local_model(bin_dir):
    with running_server(bin_dir, "--log-level", "warning") as fresh:
        summary = run_cli("demo", "--server", fresh.tcp, "--seconds", "2", "--remote-mode", "local_model")
    assert summary["remote_mode"] == "local_model" and summary["model_version"] > 0
    # the same stroke as the direct demo: into the floor and the box, a few newtons, and
    # (on loopback, the same renderer on the same positions) the direct demo's energy, about
    # +0.0006 J in the runs of 2026-12-04
    assert 500 < summary["contacts"] < 2000
    assert 1.0 < summary["max_force_n"] <= 10.0
    assert abs(summary["energy_j"]) < 0.01


def test_the_demo_strokes_the_default_scene_and_plots(bin_dir, tmp_path):
    plot = tmp_path / "demo.png"
    with running_server(bin_dir, "--log-level", "warning") as fresh:
        summary = run_cli("demo", "--server", fresh.tcp, "--seconds", "2", "--plot", str(plot))
        latency = run_cli("bench", "latency", "--server", fresh.tcp, "--seconds", "0.5")
    for key in (
        "rtt_p50_us",
        "rtt_p99_us",
        "rtt_p999_us",
        "max_force_n",
        "contacts",
        "packets_sent",
        "packets_lost",
    ):
        assert key in summary
    # lost: a command not back within the demo's 20 ms, which a stalled CI machine can
    # cause on loopback (CI saw 1 of 2000); every state is answered or lost, few lost
    sent, lost = summary["packets_sent"], summary["packets_lost"]
    assert sent == 2000 and summary["packets_received"] + lost == sent and lost <= sent // 100
    # pressing 5 mm into the floor and 2 cm into the box's side: contact, a few newtons
    assert 500 < summary["contacts"] < 2000
    assert 1.0 < summary["max_force_n"] <= 10.0
    assert 0 < summary["rtt_p50_us"] <= summary["rtt_p99_us"] <= summary["rtt_p999_us"]
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert latency["samples"] + latency["packets_lost"] == 500 and latency["packets_lost"] <= 500 // 100
