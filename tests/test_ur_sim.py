"""Tests of the UR controller simulator (tests/ur_sim) driven by the real ur_rtde library
and a real pymodbus client. Each test starts its own simulator process on a free loopback
address (ur_rtde's ports 30004/29999/30003 are fixed, so simulators differ by address).

Timing bounds: this machine has two cores shared with other work, so no test asserts a
timing tighter than tens of milliseconds; each bound says what it allows for."""

import json
import math
import os
import pathlib
import signal
import socket
import struct
import subprocess
import sys
import time

import dashboard_client
import pytest
import rtde_control
import rtde_io
import rtde_receive
from pymodbus.client import ModbusTcpClient

TESTS = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(TESTS))

from ur_sim import arm as sim_arm  # noqa: E402
from ur_sim import rtde_protocol as rp  # noqa: E402
from ur_sim.launcher import running_simulator as simulator  # noqa: E402
from ur_sim.script_server import ScriptAssembler  # noqa: E402

START_POSE = (0.4, -0.1, 0.3, 0.0, 3.1416, 0.0)


def _servo_for(control, target, seconds: float, lookahead: float = 0.1, kick: bool = False) -> int:
    """servoL toward target every period for `seconds` with initPeriod/waitPeriod."""
    cycles = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        t_start = control.initPeriod()
        assert control.servoL(list(target), 0.5, 0.5, 0.002, lookahead, 300)
        if kick:
            assert control.kickWatchdog()
        control.waitPeriod(t_start)
        cycles += 1
    return cycles


def _until(condition, what, timeout_s: float = 5.0) -> None:
    """Until condition() holds: what ur_rtde's interfaces read trails the simulator by a
    period or more (more on a loaded machine), so a read right after the simulator changed
    can still see the old state. what: a text, or a function giving one at the timeout."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out waiting for " + (
            what() if callable(what) else what
        )
        time.sleep(0.01)


def _reading_becomes(read, expected, tolerance: float) -> None:
    """Until read() (an interface's getter) returns expected within tolerance."""
    _until(
        lambda: read() == pytest.approx(expected, abs=tolerance),
        lambda: f"{expected} within {tolerance} (last read {read()})",
    )


def _rows_after(trace: dict, host_time: float) -> list[dict]:
    fields = trace["fields"]
    return [dict(zip(fields, row, strict=True)) for row in trace["rows"] if row[1] >= host_time]


# --- the sans-I/O pieces -------------------------------------------------------------


def test_recipe_packs_and_unpacks_in_recipe_order():
    names = ["input_int_register_0", "input_double_register_0", "external_force_torque"]
    recipe = rp.Recipe(3, names, [rp.INPUT_TYPES[n] for n in names])
    payload = recipe.pack([24, 0.5, 1, 2, 3, 4, 5, 6])
    assert payload == struct.pack(">Bid6d", 3, 24, 0.5, 1, 2, 3, 4, 5, 6)
    assert recipe.unpack(payload) == {
        "input_int_register_0": 24,
        "input_double_register_0": 0.5,
        "external_force_torque": (1, 2, 3, 4, 5, 6),
    }
    with pytest.raises(rp.ProtocolError, match="has 5 bytes, the recipe needs 61"):
        recipe.unpack(payload[:5])


def test_unknown_and_taken_names_make_a_recipe_invalid():
    recipe = rp.Recipe(1, ["timestamp", "no_such_thing"], ["DOUBLE", rp.NOT_FOUND])
    assert not recipe.valid
    assert rp.encode_setup_reply(rp.SETUP_OUTPUTS, recipe) == rp.encode(
        rp.SETUP_OUTPUTS, b"\x00DOUBLE,NOT_FOUND"
    )


def test_packet_parser_waits_for_whole_packets_and_rejects_bad_sizes():
    parser = rp.PacketParser()
    data = rp.encode(rp.START) + rp.encode(rp.TEXT_MESSAGE, b"\x02hi")
    assert parser.feed(data[:4]) == [rp.Packet(rp.START, b"")]
    assert parser.feed(data[4:6]) == []
    assert parser.feed(data[6:]) == [rp.Packet(rp.TEXT_MESSAGE, b"\x02hi")]
    with pytest.raises(rp.ProtocolError, match="size 2 is outside"):
        parser.feed(b"\x00\x02U")


def test_script_assembler_finds_programs_and_one_line_scripts():
    assembler = ScriptAssembler()
    assert assembler.feed("def rtde_control():\n    def inner():\n    end\n") == []
    assert assembler.feed("    x = 1\nend\ntextmsg(1)\n") == [
        "def rtde_control():\n    def inner():\n    end\n    x = 1\nend\n",
        "textmsg(1)\n",
    ]


def test_arm_stop_brakes_at_the_deceleration_and_stays_put():
    arm = sim_arm.Arm(START_POSE, sim_arm.ArmLimits(max_speed=1.0, max_accel=1e9))
    arm.speed((0.2, 0.0, 0.0), 1e9)
    arm.step(0.002)
    x_moving = arm.p[0]
    arm.stop(10.0)
    steps = 0
    while not arm.at_rest:
        arm.step(0.002)
        steps += 1
    # v / a = 20 ms = 10 periods; braking distance v^2 / (2 a) = 2 mm
    assert steps == 10
    assert arm.p[0] - x_moving == pytest.approx(0.002, abs=1e-12)
    arm.step(0.002)
    assert arm.v == (0.0, 0.0, 0.0)


def test_force_sensor_zero_tares_the_current_reading_and_drift_adds_up():
    sensor = sim_arm.ForceSensor()
    applied = (0.0, 0.0, -20.0, 0.0, 0.0, 0.0)
    sensor.jump([1.0, 0, 0, 0, 0, 0])
    assert sensor.reading(applied, 0.0)[:3] == [1.0, 0.0, -20.0]
    sensor.zero(applied, 0.0)
    assert sensor.reading(applied, 0.0) == [0.0] * 6
    sensor.start_drift([0, 0, 2.0, 0, 0, 0], 1.0)
    assert sensor.reading(applied, 3.0)[2] == pytest.approx(4.0)


# --- RTDE, dashboard and script ports with the real ur_rtde ------------------------


def _rtde_timestamps(host: str, count: int, frequency: float = 500.0) -> list[float]:
    """The timestamps of `count` consecutive output packages, read with a bare RTDE
    client (ur_rtde keeps only the latest state, so it cannot show every package)."""
    with socket.create_connection((host, 30004), timeout=5) as sock:
        parser = rp.PacketParser()

        def request(kind: int, payload: bytes = b"") -> rp.Packet:
            sock.sendall(rp.encode(kind, payload))
            while True:
                for packet in parser.feed(sock.recv(4096)):
                    if packet.kind == kind:
                        return packet

        assert request(rp.REQUEST_PROTOCOL_VERSION, b"\x00\x02").payload == b"\x01"
        reply = request(rp.SETUP_OUTPUTS, struct.pack(">d", frequency) + b"timestamp,no_such_name")
        assert reply.payload == b"\x00DOUBLE,NOT_FOUND"  # refused, as the controller does
        reply = request(rp.SETUP_OUTPUTS, struct.pack(">d", frequency) + b"timestamp")
        assert reply.payload == b"\x01DOUBLE"
        assert request(rp.START).payload == b"\x01"
        stamps: list[float] = []
        while len(stamps) < count:
            for packet in parser.feed(sock.recv(4096)):
                if packet.kind == rp.DATA_PACKAGE:
                    stamps.append(struct.unpack(">Bd", packet.payload)[1])
        return stamps[:count]


def test_receive_interface_reads_start_pose_and_timestamps_advance_one_period_at_a_time():
    pose = (0.35, 0.12, 0.42, 0.1, 3.0, -0.2)
    with simulator("--start-pose", ",".join(map(str, pose))) as sim:
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            assert receive.getActualTCPPose() == pytest.approx(pose)
            assert receive.getRobotMode() == 7 and receive.getSafetyMode() == 1
            host_start = time.monotonic()
            first = receive.getTimestamp()
            stamps = _rtde_timestamps(sim.host, 250)
            host_elapsed = time.monotonic() - host_start
            last = receive.getTimestamp()
            # package to package, exactly one 2 ms period, unless the simulator stalled
            stalls = sim.state()["counters"]["stalls"]
            steps = [round((b - a) / 0.002, 9) for a, b in zip(stamps, stamps[1:], strict=False)]
            assert steps.count(1.0) >= len(steps) - stalls
            # controller time keeps host time (10 % and 50 ms for a loaded machine)
            assert last - first == pytest.approx(host_elapsed, rel=0.1, abs=0.05)
            # at a lower asked frequency, every fifth period
            slow = _rtde_timestamps(sim.host, 20, frequency=100.0)
            assert {round((b - a) / 0.002, 9) for a, b in zip(slow, slow[1:], strict=False)} == {
                5.0
            }
        finally:
            receive.disconnect()


def test_cb3_simulator_at_125_hz_works_with_the_receive_interface():
    with simulator("--rate-hz", "125") as sim:
        assert sim.endpoints["controller_version"].startswith("3.15.")
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            assert receive.getActualTCPPose() == pytest.approx(START_POSE)
            started = time.monotonic()
            t0 = receive.getTimestamp()
            time.sleep(0.3)
            t1 = receive.getTimestamp()
            slept = time.monotonic() - started
            assert round(t0 / 0.008, 6) == int(round(t0 / 0.008, 6))
            assert round((t1 - t0) / 0.008, 6) == int(round((t1 - t0) / 0.008, 6))
            # host pace, to a period or two of what ur_rtde reads trailing
            assert 0.3 - 0.05 <= t1 - t0 <= slept + 0.05
        finally:
            receive.disconnect()
        assert sim.dashboard("PolyscopeVersion")[0].startswith("URSoftware 3.15.")


def _forces_from(sim, since_t: float, enough) -> dict[float, list[float]]:
    """The simulator's tcp_force by its controller time, for the periods after since_t,
    read until enough(samples) holds. Each state carries the time its force is of, so a
    sample is checked against the profile at that time, however late this reads it."""
    samples: dict[float, list[float]] = {}

    def record(state: dict) -> bool:
        if state["t"] > since_t:
            samples[state["t"]] = state["tcp_force"]
        return enough(samples)

    sim.wait_for(record, timeout_s=5.0, what=f"enough samples after t = {since_t}")
    return samples


def test_person_profiles_spring_ramp_step_and_seeded_noise():
    with simulator() as sim:
        anchor = [START_POSE[0], START_POSE[1], START_POSE[2] + 0.01]
        spring = sim.ctl(cmd="person", spring={"anchor": anchor, "k": 500.0})
        assert spring["kind"] == "spring"
        # the arm at rest 1 cm below the anchor: 5 N up
        forces = _forces_from(sim, spring["t"], lambda s: len(s) >= 3)
        assert all(f == pytest.approx([0, 0, 5.0, 0, 0, 0]) for f in forces.values())

        ramp = sim.ctl(cmd="person", ramp={"from": [0, 0, 0], "to": [0, 0, -10], "duration_s": 0.4})
        forces = _forces_from(sim, ramp["t"], lambda s: max(s, default=0) > ramp["t"] + 0.45)
        for t, f in forces.items():
            assert f[2] == pytest.approx(-10.0 * min((t - ramp["t"]) / 0.4, 1.0)), t - ramp["t"]
        assert any(-8.0 < f[2] < -2.0 for f in forces.values())  # read mid-ramp too

        step = sim.ctl(cmd="person", step={"before": [1, 0, 0], "after": [0, 2, 0], "at_s": 0.2})
        forces = _forces_from(sim, step["t"], lambda s: max(s, default=0) > step["t"] + 0.25)
        for t, f in forces.items():
            assert f[:3] == pytest.approx([1, 0, 0] if t < step["t"] + 0.2 else [0, 2, 0]), t - step["t"]
        assert {tuple(f[:3]) for f in forces.values()} == {(1, 0, 0), (0, 2, 0)}

        noisy = sim.ctl(cmd="person", force=[0, 0, -20], noise={"sigma": 0.5, "seed": 3})
        # each period a new draw
        forces = _forces_from(sim, noisy["t"], lambda s: len(s) >= 40)
        draws = [f[2] for f in forces.values()]
        assert len(set(draws)) == len(draws) and all(-23 < f < -17 for f in draws)
        assert sim.ctl(cmd="person", force=[0, 1]) == {
            "ok": False,
            "error": "force must be a list of 3 finite numbers, got [0, 1]",
        }
        assert sim.ctl(cmd="fault", kind="meteor") == {
            "ok": False,
            "error": "unknown fault kind 'meteor'",
        }


def test_control_interface_uploads_the_script_and_completes_the_handshake():
    with simulator() as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        try:
            state = sim.state()
            assert state["program"] == "rtde_control" and state["runtime_state_name"] == "PLAYING"
            assert state["out_int"][0] == 1  # ready for a command
            assert control.isProgramRunning()
            # getStepTime is a real-time command: ur_rtde reads the register without
            # waiting, so the first call can see the old value, as on a robot
            control.getStepTime()
            time.sleep(0.01)
            assert control.getStepTime() == pytest.approx(0.002)
            assert control.isSteady()
            assert control.isPoseWithinSafetyLimits(list(START_POSE))
            assert control.getTCPOffset() == [0.0] * 6
            assert sim.dashboard("programState", "running") == [
                "PLAYING rtde_control",
                "Program running: true",
            ]
            # an unsupported command is answered, not hung on, and counted
            assert control.moveJ([0.0, -1.57, 1.57, -1.57, -1.57, 0.0], 0.5, 0.5)
            state = sim.state()
            assert state["counters"]["unknown_commands"] == 1 and state["unknown_codes"] == {"1": 1}
        finally:
            control.stopScript()
            control.disconnect()
        assert sim.state()["runtime_state_name"] == "STOPPED"


def test_servoL_trails_its_target_converges_and_never_exceeds_the_speed_cap():
    with simulator("--max-tcp-speed", "0.2") as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            target = list(START_POSE)
            target[0] += 0.05
            started = time.monotonic()
            _servo_for(control, target, 0.5)
            # the servo keeps its last target: the arm converges without more calls
            sim.wait_for(
                lambda s: abs(s["pose"][0] - target[0]) < 1e-4, timeout_s=3, what="convergence"
            )
            _reading_becomes(lambda: receive.getActualTCPPose()[:3], target[:3], 1e-4)
            rows = _rows_after(sim.ctl(cmd="trace", since_host_time=started), started)
            moving = [r for r in rows if r["target"] is not None]
            # controller time, so load on this machine does not matter: 5 cm at 0.2 m/s
            # takes at least 0.25 s, so 0.1 s after the first servoL the arm trails
            after_100ms = next(r for r in moving if r["t"] >= moving[0]["t"] + 0.1)
            assert 0.005 < after_100ms["x"] - START_POSE[0] <= 0.2 * 0.102
            speeds = [math.hypot(r["vx"], r["vy"], r["vz"]) for r in rows]
            assert max(speeds) <= 0.2 + 1e-12
            assert max(speeds) == pytest.approx(0.2)  # the cap did bind
            assert all(b["x"] >= a["x"] - 1e-12 for a, b in zip(rows, rows[1:], strict=False))
            assert sim.state()["last_servo"]["lookahead_time"] == pytest.approx(0.1)
        finally:
            control.disconnect()
            receive.disconnect()


def test_servo_time_constant_is_the_lookahead_time():
    with simulator() as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        try:
            target = list(START_POSE)
            target[2] -= 0.05
            _servo_for(control, target, 0.6, lookahead=0.1)
            events = sim.ctl(cmd="trace")
            rows = [dict(zip(events["fields"], r, strict=True)) for r in events["rows"]]
            moving = [r for r in rows if r["target"] is not None]
            t0 = moving[0]["t"] - 0.002
            at_tau = next(r for r in moving if r["t"] >= t0 + 0.1)
            fraction = (START_POSE[2] - at_tau["z"]) / 0.05
            # a first-order lag covers 1 - 1/e = 63 % in one time constant; the
            # acceleration limit (20 m/s^2) costs a few per cent of that
            assert 0.5 < fraction < 0.64
        finally:
            control.disconnect()


def test_servoStop_brings_the_arm_to_rest_quickly():
    with simulator("--max-tcp-speed", "0.25") as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        try:
            target = list(START_POSE)
            target[1] += 0.3
            _servo_for(control, target, 0.3)
            assert sim.state()["speed_norm"] == pytest.approx(0.25, rel=0.01)
            called = time.monotonic()
            assert control.servoStop(10.0)
            returned = time.monotonic()
            state = sim.state()
            assert state["at_rest"] and state["counters"]["servoStop"] == 1
            trace = sim.ctl(cmd="trace", since_host_time=called)
            stop_event = next(e for e in trace["events"] if e["event"] == "servoStop")
            assert stop_event["deceleration"] == 10.0
            rest = next(r for r in _rows_after(trace, stop_event["host_time"]) if r["stopped"])
            # 0.25 m/s at 10 m/s^2 is 25 ms; allow 25 ms more for ticks late under load
            assert rest["host_time"] - stop_event["host_time"] < 0.05
            # servoStop is synchronous: it returns once the script reports done, after rest
            assert returned >= rest["host_time"] and returned - called < 1.0
        finally:
            control.disconnect()


def test_zeroFtSensor_zeroes_the_persons_force_like_the_real_one():
    with simulator() as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            assert sim.ctl(cmd="person", force=[0, 0, -20])["ok"]
            _reading_becomes(receive.getActualTCPForce, [0, 0, -20, 0, 0, 0], 1e-9)
            assert control.zeroFtSensor()
            _reading_becomes(receive.getActualTCPForce, [0] * 6, 1e-9)
            sim.ctl(cmd="person", force=[5, 0, -20])
            sim.ctl(cmd="fault", kind="jump", bias=[0, 0, 3])
            _reading_becomes(receive.getActualTCPForce, [5, 0, 3, 0, 0, 0], 1e-9)
            assert sim.state()["counters"]["zeroFtSensor"] == 1
        finally:
            control.disconnect()
            receive.disconnect()


def test_script_watchdog_stops_the_arm_when_not_kicked():
    with simulator() as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        try:
            # at least every 100 ms: a loaded machine can hold this process 20 ms
            assert control.setWatchdog(10.0)
            target = list(START_POSE)
            target[0] += 0.2
            _servo_for(control, target, 0.3, kick=True)
            quiet_since = time.monotonic()
            # (not checked here that it has not tripped yet: a loaded machine can take the
            # watchdog's 100 ms to answer; the trip's time is checked below)
            state = sim.wait_for(
                lambda s: s["counters"]["watchdog_trips"] == 1, what="a watchdog trip"
            )
            state = sim.wait_for(lambda s: s["at_rest"], what="the arm at rest")
            assert state["runtime_state_name"] == "STOPPED"
            # ur_rtde sees it in its next data package, which a loaded machine delays
            deadline = time.monotonic() + 5.0
            while control.isProgramRunning():
                assert time.monotonic() < deadline, "ur_rtde still sees the program running"
                time.sleep(0.01)
            trip = next(e for e in sim.ctl(cmd="trace")["events"] if e["event"] == "watchdog_trip")
            # tripped after 100 ms of silence, within 400 ms of the last kick (a loaded machine)
            assert trip["silent_s"] > 0.1
            assert 0.09 <= trip["host_time"] - quiet_since < 0.4
            assert not control.servoL(target, 0.5, 0.5, 0.002, 0.1, 300)
        finally:
            control.disconnect()


def test_init_and_wait_period_pace_servoL_at_500_hz_and_every_call_arrives():
    with simulator() as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        try:
            before = sim.state()["counters"]["servoL"]
            started = time.monotonic()
            for _ in range(250):
                t_start = control.initPeriod()
                control.servoL(list(START_POSE), 0.5, 0.5, 0.002, 0.1, 300)
                control.waitPeriod(t_start)
            elapsed = time.monotonic() - started
            assert 0.49 < elapsed < 0.75  # 250 periods of 2 ms, plus a loaded machine's slack
            assert sim.state()["counters"]["servoL"] - before == 250
        finally:
            control.disconnect()


def test_moveL_speedL_and_stopL_move_and_stop_the_arm():
    with simulator() as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            target = list(START_POSE)
            target[2] += 0.02
            assert control.moveL(target, 0.25, 1.2)  # synchronous: returns at the target
            assert sim.state()["pose"][:3] == pytest.approx(target[:3], abs=1e-6)
            _reading_becomes(lambda: receive.getActualTCPPose()[:3], target[:3], 1e-6)
            assert control.speedL([0.0, 0.05, 0.0, 0.0, 0.0, 0.0], 0.5, 0.0)
            time.sleep(0.3)
            assert receive.getActualTCPSpeed()[1] == pytest.approx(0.05)
            control.stopL(2.0)  # synchronous (returns nothing): the arm is at rest after it
            _reading_becomes(lambda: receive.getActualTCPSpeed()[:3], [0.0, 0.0, 0.0], 0.0)
            counters = sim.state()["counters"]
            assert (counters["moveL"], counters["stopL"], counters["unknown_commands"]) == (1, 1, 0)
        finally:
            control.disconnect()
            receive.disconnect()


def test_io_interface_upper_registers_and_inputs_in_use():
    with simulator() as sim:
        flags = (
            rtde_control.RTDEControlInterface.FLAG_UPLOAD_SCRIPT
            | rtde_control.RTDEControlInterface.FLAG_UPPER_RANGE_REGISTERS
        )
        control = rtde_control.RTDEControlInterface(sim.host, 500.0, flags)
        io = rtde_io.RTDEIOInterface(sim.host)
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            target = list(START_POSE)
            target[0] += 0.01
            _servo_for(control, target, 0.2)
            state = sim.state()
            assert state["counters"]["servoL"] > 50 and state["pose"][0] > START_POSE[0] + 0.005
            assert control.setWatchdog(20.0)
            assert sim.state()["watchdog"] == ["input_int_register_24", 20.0]
            assert io.setStandardDigitalOut(2, True)
            sim.wait_for(lambda s: s["digital_outputs"] == 4, what="digital output 2")
            _until(
                lambda: receive.getDigitalOutState(2) and receive.getActualDigitalOutputBits() == 4,
                "digital output 2 through the receive interface",
            )
            # a second control interface asks for the same input registers
            with pytest.raises(RuntimeError, match="already in use"):
                rtde_control.RTDEControlInterface(sim.host, 500.0, flags)
        finally:
            control.disconnect()
            io.disconnect()
            receive.disconnect()


def test_protective_stop_stops_the_arm_until_the_dashboard_unlocks_it():
    with simulator("--protective-stop-unlock-delay-s", "0.5") as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            target = list(START_POSE)
            target[0] += 0.2
            _servo_for(control, target, 0.2)
            assert sim.ctl(cmd="fault", kind="protective_stop")["ok"]
            sim.wait_for(lambda s: s["at_rest"], timeout_s=0.5, what="the arm at rest")
            _until(
                lambda: receive.isProtectiveStopped() and not control.isProgramRunning(),
                "the protective stop through both interfaces",
            )
            assert receive.getSafetyMode() == 3 and receive.getSafetyStatusBits() & 0b100
            assert not control.servoL(target, 0.5, 0.5, 0.002, 0.1, 300)
            assert sim.dashboard("safetystatus", "unlock protective stop") == [
                "Safetystatus: PROTECTIVE_STOP",
                "Cannot unlock protective stop until 5s after occurrence. "
                "Always inspect cause of protective stop before unlocking",
            ]
            assert receive.isProtectiveStopped()
            time.sleep(0.5)
            dashboard = dashboard_client.DashboardClient(sim.host)
            dashboard.connect()
            dashboard.unlockProtectiveStop()  # raises unless "Protective stop releasing"
            dashboard.disconnect()
            _until(
                lambda: not receive.isProtectiveStopped() and receive.getSafetyMode() == 1,
                "the unlock through the receive interface",
            )
            # reuploadScript returns once the script is sent; the program starts a period later
            assert control.reuploadScript()
            sim.wait_for(lambda s: s["runtime_state_name"] == "PLAYING", what="the program")
            _until(control.isProgramRunning, "the program through the control interface")
            assert control.servoL(target, 0.5, 0.5, 0.002, 0.1, 300)
        finally:
            control.disconnect()
            receive.disconnect()


def test_emergency_stop_powers_off_until_released_powered_and_braked():
    with simulator() as sim:
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            sim.ctl(cmd="fault", kind="emergency_stop")
            _until(
                lambda: receive.isEmergencyStopped() and receive.getSafetyMode() == 7,
                "the emergency stop through the receive interface",
            )
            assert sim.dashboard("robotmode", "power on", "robotmode") == [
                "Robotmode: POWER_OFF",
                "Powering on",
                "Robotmode: POWER_OFF",
            ]
            sim.ctl(cmd="fault", kind="release_emergency_stop")
            assert sim.dashboard(
                "power on", "robotmode", "brake release", "robotmode", "safetymode"
            ) == [
                "Powering on",
                "Robotmode: IDLE",
                "Brake releasing",
                "Robotmode: RUNNING",
                "Safetymode: NORMAL",
            ]
        finally:
            receive.disconnect()


def test_dashboard_answers_like_the_controller():
    with simulator() as sim:
        client = dashboard_client.DashboardClient(sim.host)
        client.connect()
        try:
            assert client.polyscopeVersion() == "5.15.0.112233"
            assert client.isInRemoteControl()
            assert client.robotmode() == "Robotmode: RUNNING"
            assert client.safetystatus() == "Safetystatus: NORMAL"
            assert client.getSerialNumber() == "20235500001"
            assert not client.running()
            client.closeSafetyPopup()
        finally:
            client.disconnect()
        assert sim.dashboard("frobnicate", "quit") == [
            "could not understand: 'frobnicate'",
            "Disconnected",
        ]


def test_a_powered_off_robot_refuses_the_script_until_powered_and_braked():
    with simulator("--robot-mode", "power_off") as sim:
        with socket.create_connection((sim.host, 30003)) as sock:
            sock.sendall(b"def rtde_control():\n  textmsg(1)\nend\n")
        state = sim.wait_for(lambda s: s["counters"]["scripts_refused"] == 1, what="the refusal")
        assert state["runtime_state_name"] == "STOPPED" and state["robot_mode_name"] == "POWER_OFF"
        assert sim.dashboard("power on", "brake release") == ["Powering on", "Brake releasing"]
        control = rtde_control.RTDEControlInterface(sim.host)
        try:
            assert control.isProgramRunning()
        finally:
            control.disconnect()


def test_local_control_makes_ur_rtde_refuse_to_start():
    with simulator("--local-control") as sim:
        with pytest.raises(RuntimeError, match="remote control"):
            rtde_control.RTDEControlInterface(sim.host)


# --- Modbus ------------------------------------------------------------------------


def _int32s(registers: list[int]) -> list[int]:
    return [
        struct.unpack(">i", struct.pack(">HH", registers[i], registers[i + 1]))[0]
        for i in range(0, len(registers), 2)
    ]


def test_ft_sensor_registers_carry_the_persons_force_and_the_sensor_faults():
    with simulator() as sim:
        sim.ctl(cmd="person", force=[1.5, -2.0, -20.25])
        client = ModbusTcpClient(sim.host, port=sim.endpoints["ft_modbus"])
        assert client.connect()

        def fz() -> float:
            return _int32s(client.read_holding_registers(4, count=2).registers)[0] / 1000.0

        try:
            # the registers hold the latest period's reading (mN), from the next period on
            _until(lambda: fz() == -20.25, "the person's force in the registers")
            regs = client.read_holding_registers(0, count=16).registers
            assert _int32s(regs[:12]) == [1500, -2000, -20250, 0, 0, 0]
            assert regs[14:16] == [1000, 1000]
            _until(lambda: client.read_holding_registers(13, count=1).registers[0] != regs[13], "a new sample")
            drift = sim.ctl(cmd="fault", kind="drift", rate=[0, 0, 10], sensor="external")
            time.sleep(0.3)
            # 10 N/s since the fault, read at a period between these two states
            before = sim.state()["t"]
            drifted = fz()
            after = sim.state()["t"]
            assert before - drift["t"] >= 0.2  # long enough to tell the rate from none
            assert -20.25 + 10 * (before - drift["t"]) - 1e-3 <= drifted <= -20.25 + 10 * (after - drift["t"]) + 1e-3
            tare_from = sim.state()["t"]
            client.write_register(12, 1)  # tare: zero from now, drifting on
            _until(lambda: fz() > -1.0, "the tare in the registers")
            tared = fz()
            after = sim.state()["t"]
            assert -1e-3 <= tared <= 10 * (after - tare_from) + 1e-3
            # the robot's own sensor has no drift
            assert sim.state()["tcp_force"][2] == pytest.approx(-20.25)
        finally:
            client.close()


def test_ur_modbus_server_enable_bit_pose_and_safety_registers():
    with simulator() as sim:
        client = ModbusTcpClient(sim.host, port=sim.endpoints["ur_modbus"])
        assert client.connect()
        try:
            assert client.read_holding_registers(0, count=1).registers[0] & 1 == 0
            sim.ctl(cmd="enable", on=True)
            assert client.read_holding_registers(0, count=1).registers[0] & 1 == 1
            pose = client.read_holding_registers(400, count=6).registers
            signed = [r - 65536 if r >= 32768 else r for r in pose]
            assert signed == [4000, -1000, 3000, 0, 3142, 0]
            assert client.read_holding_registers(258, count=1).registers[0] == 7
            assert client.read_holding_registers(261, count=1).registers[0] == 0
            sim.ctl(cmd="fault", kind="protective_stop")
            assert client.read_holding_registers(261, count=6).registers == [1, 0, 0, 0, 1, 3]
            sim.ctl(cmd="enable", on=False)
            assert client.read_holding_registers(0, count=1).registers[0] & 1 == 0
        finally:
            client.close()


# --- faults of the process and the network -----------------------------------------


def test_a_stalled_simulator_resumes_with_its_timestamp_keeping_real_time():
    with simulator() as sim:
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            before = sim.state()
            stopped = time.monotonic()
            sim.process.send_signal(signal.SIGSTOP)
            time.sleep(0.4)
            sim.process.send_signal(signal.SIGCONT)
            continued = time.monotonic()
            time.sleep(0.05)
            after = sim.state()
            # controller time kept host time through the stall (to a late tick or two)
            assert after["t"] - before["t"] == pytest.approx(after["host_time"] - before["host_time"], abs=0.03)
            assert after["t"] - before["t"] >= 0.4
            stall = next(e for e in sim.ctl(cmd="trace")["events"] if e["event"] == "stall")
            assert 0.4 - 0.005 <= stall["skipped_s"] <= continued - stopped + 0.005
            # and goes on at host pace (what ur_rtde reads trails by a period or more)
            started = time.monotonic()
            t0 = receive.getTimestamp()
            time.sleep(0.1)
            t1 = receive.getTimestamp()
            assert 0.1 - 0.04 <= t1 - t0 <= time.monotonic() - started + 0.04
        finally:
            receive.disconnect()


def test_dropped_rtde_connections_can_be_reconnected():
    with simulator() as sim:
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            assert sim.ctl(cmd="fault", kind="drop_connections")["dropped"] == 1
            deadline = time.monotonic() + 3
            while receive.isConnected():
                assert time.monotonic() < deadline, "ur_rtde did not notice the dropped connection"
                time.sleep(0.01)
            # ur_rtde's receive interface leaves reconnecting to its user
            assert receive.reconnect()
            t0 = receive.getTimestamp()
            time.sleep(0.1)
            assert receive.getTimestamp() > t0 and sim.state()["counters"]["input_packages"] == 0
        finally:
            receive.disconnect()


def test_trace_file_is_written_on_sigterm_and_bad_flags_are_refused(tmp_path):
    trace_file = tmp_path / "trace.jsonl"
    with simulator("--trace-file", str(trace_file)) as sim:
        sim.ctl(cmd="person", force=[0, 0, -5])
        time.sleep(0.05)
    lines = [json.loads(line) for line in trace_file.read_text().splitlines()]
    rows = [line["row"] for line in lines if "row" in line]
    assert len(rows) > 20 and set(rows[0]) == {
        "t",
        "host_time",
        "x",
        "y",
        "z",
        "vx",
        "vy",
        "vz",
        "target",
        "stopped",
        "mode",
    }
    assert any(line.get("event", {}).get("event") == "person" for line in lines)
    bad = subprocess.run(
        [sys.executable, "-m", "ur_sim", "--rate-hz", "250"],
        capture_output=True,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(TESTS)),
        timeout=20,
    )
    assert bad.returncode == 2 and "--rate-hz" in bad.stderr
