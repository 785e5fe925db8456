"""The UR bridge end to end: `python -m hapticd ur-bridge` with the real ur_rtde and
pymodbus libraries, against the protocol-level controller simulator (ur_sim/, its own
process) and a real hapticd server whose scene has a wall 3 cm under the tool.

The simulator's trace stamps every period and event with this machine's monotonic clock,
which the bridge's summary shares (its stop events), so "stopped within 10 ms of
noticing" is measured across the two processes. The simulator and the bridge run at a
real-time priority where the machine grants one (ur_sim/launcher.py says why)."""

import json
import pathlib
import signal
import subprocess
import sys
import time

import pytest
from server_process import ServerProcess, running_server
from ur_sim.launcher import realtime_prefix, rows_of, running_simulator

REPO = pathlib.Path(__file__).resolve().parent.parent
START = (0.4, -0.1, 0.3)  # the simulator's TCP at start (its default), m
WALL_TOP_Z = 0.27  # 3 cm under the tool
MAX_SPEED = 0.25  # the bridge's default, m/s
SCENE = {"scene": {"objects": [{
    "name": "wall", "shape": {"type": "box", "half_extents": [0.2, 0.2, 0.1]},
    "position": [START[0], START[1], WALL_TOP_Z - 0.1],
    "material": {"stiffness": 5000}}]}}  # fmt: skip
# the simulator's external sensor (ur_sim/modbus_servers.py): Fx Fy Fz as int32, mN, base frame
SIM_SENSOR_MAP = {"function": "holding", "device_id": 0, "frame": "base", "axes": [
    {"address": a, "type": "int32", "scale": 0.001} for a in (0, 2, 4)]}  # fmt: skip


@pytest.fixture
def sim():
    with running_simulator() as simulator:
        yield simulator


def wall_scene(tmp_path):
    scene = tmp_path / "wall.json"
    scene.write_text(json.dumps(SCENE))
    return str(scene)


@pytest.fixture
def wall_server(bin_dir, tmp_path):
    scene = wall_scene(tmp_path)
    with running_server(bin_dir, "--log-level", "warning", "--scene", scene) as process:
        yield process


@pytest.fixture
def doomed_server(bin_dir, tmp_path):
    """A server the test kills."""
    process = ServerProcess(bin_dir, "--log-level", "warning", "--scene", wall_scene(tmp_path))
    yield process
    process.stop()


# Looser stop timeouts for the tests that are not about them: a machine loaded by a whole
# test run can hold a process past 20 ms, which the bridge rightly takes for a fault
TOLERANT = ("--stale-ms", "200", "--command-timeout-ms", "100")


def start_bridge(sim, server, *args, seconds=6.0, tolerant=True):
    command = [sys.executable, "-m", "hapticd", "ur-bridge", "--robot", sim.host,
               "--server", server.tcp, "--seconds", str(seconds),
               *(TOLERANT if tolerant else ()), *args]  # fmt: skip
    return subprocess.Popen(
        [*realtime_prefix(), *command], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def wait_servoing(sim, bridge, timeout_s=20.0):
    """Until the bridge servos the arm (its force zeroed first: hands off till then)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if sim.state()["counters"]["servoL"] > 10:
            return
        assert bridge.poll() is None, bridge.communicate()
        time.sleep(0.05)
    raise AssertionError("the bridge never servoed the arm")


def moving_sideways(sim, server, seconds=0.3, tolerant=True):
    """A bridge that servos the arm, pushed sideways through free space for seconds: the
    bridge, and the simulator's host time just before the push."""
    bridge = start_bridge(sim, server, seconds=20.0, tolerant=tolerant)
    wait_servoing(sim, bridge)
    since = sim.ask(cmd="ping")["host_time"]
    sim.ask(cmd="person", force=[20, 0, 0])
    time.sleep(seconds)
    return bridge, since


def finish(bridge, timeout_s=30.0):
    out, err = bridge.communicate(timeout=timeout_s)
    assert bridge.returncode == 0, err
    # stdout is the JSON line alone: ur_rtde's own prints go to stderr
    assert out.endswith("\n") and out.count("\n") == 1, out
    return json.loads(out)


def events_named(trace, name):
    return [e for e in trace["events"] if e["event"] == name]


def speed(row):
    return (row["vx"] ** 2 + row["vy"] ** 2 + row["vz"] ** 2) ** 0.5


def test_a_push_stops_on_the_virtual_wall_and_rests_there(sim, wall_server):
    bridge = start_bridge(sim, wall_server, seconds=5.0)
    wait_servoing(sim, bridge)
    pushed = sim.ask(cmd="ping")["host_time"]
    sim.ask(cmd="person", force=[0, 0, -20])
    summary = finish(bridge)
    assert summary["exit_reason"] == "seconds"
    rows = [r for r in rows_of(sim.trace(pushed)) if r["host_time"] >= pushed]
    lowest = min(r["z"] for r in rows)
    assert lowest >= WALL_TOP_Z - 0.002, f"the arm went {1e3 * (WALL_TOP_Z - lowest):.2f} mm in"
    # it got there and rests: the last second within a millimetre of the surface, still
    last_second = [r for r in rows if r["host_time"] >= rows[-1]["host_time"] - 1.0]
    assert all(abs(r["z"] - WALL_TOP_Z) <= 0.001 for r in last_second)
    assert max(speed(r) for r in last_second[len(last_second) // 2 :]) < 1e-3
    # the speed cap, on the arm and in the bridge's own reading
    assert max(speed(r) for r in rows) <= MAX_SPEED * 1.02
    assert summary["max_tcp_speed_m_s"] <= MAX_SPEED * 1.02
    assert summary["stops"] == 1 and summary["ticks"] > 0
    assert 0 < summary["command_latency_p50_us"] <= summary["command_latency_p99_us"]


def test_nobody_pushing_the_arm_stays_put_while_the_sensor_drifts(sim, wall_server):
    bridge = start_bridge(sim, wall_server, seconds=5.0)
    wait_servoing(sim, bridge)
    since = sim.ask(cmd="ping")["host_time"]
    # 0.5 N/s on y for 4 s: 2 N, inside the deadband only because the bias follows it
    sim.ask(cmd="fault", kind="drift", rate=[0, 0.5, 0], sensor="internal")
    summary = finish(bridge)
    assert summary["exit_reason"] == "seconds"
    rows = rows_of(sim.trace(since))
    axes = list(zip("xyz", START, strict=True))
    drift = max(abs(r[axis] - start) for r in rows for axis, start in axes)
    assert drift <= 0.0002, f"the arm moved {drift * 1e3:.3f} mm with nobody pushing"


def test_the_server_killed_while_the_arm_moves_stops_it(sim, doomed_server):
    bridge, since = moving_sideways(sim, doomed_server, seconds=0.5, tolerant=False)
    assert sim.state()["speed_norm"] > 0.05, "the arm should be moving"
    doomed_server.process.kill()
    summary = finish(bridge)
    assert summary["exit_reason"] == "server_lost"
    (event,) = summary["stop_events"]
    trace = sim.trace(since)
    stops = events_named(trace, "servoStop")
    assert stops, trace["events"][-10:]
    # the controller had servoStop within 10 ms of the bridge noticing
    assert stops[0]["host_time"] - event["noticed_ns"] / 1e9 <= 0.010
    rows = rows_of(trace)
    assert speed(rows[-1]) < 1e-3, "the arm is still moving"


def test_a_stalled_controller_is_noticed_and_the_arm_stopped(sim, wall_server):
    bridge, since = moving_sideways(sim, wall_server, seconds=0.5, tolerant=False)
    stalled = time.monotonic()
    sim.process.send_signal(signal.SIGSTOP)
    time.sleep(0.3)
    sim.process.send_signal(signal.SIGCONT)
    summary = finish(bridge)
    assert summary["exit_reason"] == "robot_stale"
    (event,) = summary["stop_events"]
    # the last data before the stall came up to a period before it: 20 ms plus a period
    # plus this test's own scheduling
    assert event["noticed_ns"] / 1e9 - stalled <= 0.020 + 0.002 + 0.010
    time.sleep(0.3)  # the controller, running again, takes the stop
    trace = sim.trace(since)
    # servoStop, or the script's own watchdog (it saw no input during the stall) first
    assert events_named(trace, "servoStop") or events_named(trace, "program_stopped")
    rows = rows_of(trace)
    assert speed(rows[-1]) < 1e-3
    # after the stall the arm went no further than its last target, a lookahead ahead
    resumed = [r for r in rows if r["host_time"] >= stalled + 0.3]
    assert max(abs(r["x"] - resumed[0]["x"]) for r in resumed) <= MAX_SPEED * 0.03 + 0.001


def test_a_protective_stop_is_reported_and_not_resumed(sim, wall_server):
    bridge, _ = moving_sideways(sim, wall_server)
    sim.ask(cmd="fault", kind="protective_stop")
    summary = finish(bridge)
    assert summary["exit_reason"] == "protective_stop"
    servoed = sim.state()["counters"]["servoL"]
    time.sleep(0.3)
    state = sim.state()
    assert state["counters"]["servoL"] == servoed, "servoing resumed"
    assert state["safety_mode_name"] == "PROTECTIVE_STOP" and state["speed_norm"] < 1e-3


@pytest.mark.parametrize(
    ("flags", "says"),
    [(["--robot-mode", "power_off"], "power it on"),
     (["--robot-mode", "protective_stop"], "protective stop"),
     (["--robot-mode", "emergency_stop"], "emergency"),
     (["--local-control"], "switch it to remote control")],
)  # fmt: skip
def test_it_refuses_a_robot_that_cannot_be_servoed(wall_server, flags, says):
    with running_simulator(*flags) as simulator:
        bridge = start_bridge(simulator, wall_server, seconds=2.0)
        out, err = bridge.communicate(timeout=30)
        assert bridge.returncode == 1 and says in err, err
        assert simulator.state()["counters"]["servoL"] == 0


def test_bad_flags_are_refused_by_name(wall_server, sim):
    for flags, named in (
        (["--rate-hz", "250"], "--rate-hz"),
        (["--max-speed", "5"], "--max-speed"),
        (["--force-source", "modbus"], "--modbus"),
        (["--frobnicate"], "--frobnicate"),
    ):
        bridge = start_bridge(sim, wall_server, *flags)
        _, err = bridge.communicate(timeout=30)
        assert bridge.returncode == 2 and named in err, err


def z_path(sim, wall_server, *flags):
    """Where the arm went (controller time from the push, z) under a 20 N push."""
    bridge = start_bridge(sim, wall_server, *flags, seconds=3.0)
    wait_servoing(sim, bridge)
    pushed = sim.ask(cmd="ping")
    sim.ask(cmd="person", force=[0, 0, -20])
    summary = finish(bridge)
    assert summary["exit_reason"] == "seconds"
    rows = [r for r in rows_of(sim.trace(pushed["host_time"])) if r["t"] >= pushed["t"]]
    return [(r["t"] - pushed["t"], r["z"]) for r in rows]


def test_the_modbus_force_source_moves_the_arm_like_rtde(wall_server, tmp_path):
    map_file = tmp_path / "sensor.json"
    map_file.write_text(json.dumps(SIM_SENSOR_MAP))
    paths = {}
    for source in ("rtde", "modbus"):
        with running_simulator() as simulator:
            flags = []
            if source == "modbus":
                modbus = f"{simulator.host}:{simulator.endpoints['ft_modbus']}"
                flags = ["--force-source", "modbus", "--modbus", modbus]
                flags += ["--modbus-map", str(map_file)]
            paths[source] = z_path(simulator, wall_server, *flags)
    # the same motion: both at the speed cap to the wall, there at the same time (within
    # the bridge's scheduling on a loaded machine), resting at the same height
    arrivals = [next(t for t, z in path if z <= WALL_TOP_Z + 0.001) for path in paths.values()]
    assert abs(arrivals[0] - arrivals[1]) <= 0.040, arrivals
    for t in (0.05, 0.1, 0.15):
        heights = [min(path, key=lambda p, t=t: abs(p[0] - t))[1] for path in paths.values()]
        assert abs(heights[0] - heights[1]) <= MAX_SPEED * 0.040, (t, heights)
    assert abs(paths["rtde"][-1][1] - paths["modbus"][-1][1]) <= 0.0005


def test_an_emergency_stop_while_the_arm_moves_is_reported_and_not_resumed(sim, wall_server):
    bridge, _ = moving_sideways(sim, wall_server)
    sim.ask(cmd="fault", kind="emergency_stop")
    summary = finish(bridge)
    assert summary["exit_reason"] == "emergency_stop", summary
    servoed = sim.state()["counters"]["servoL"]
    time.sleep(0.3)
    state = sim.state()
    assert state["counters"]["servoL"] == servoed, "servoing resumed"
    assert state["safety_mode_name"] == "ROBOT_EMERGENCY_STOP", state["safety_mode_name"]
    assert state["speed_norm"] < 1e-3 and state["program"] is None


@pytest.mark.parametrize("device", ["ft", "ur"])
def test_a_modbus_device_that_stops_answering_stops_the_arm(sim, wall_server, tmp_path, device):
    map_file = tmp_path / "sensor.json"
    map_file.write_text(json.dumps(SIM_SENSOR_MAP))
    ft = f"{sim.host}:{sim.endpoints['ft_modbus']}"
    ur = f"{sim.host}:{sim.endpoints['ur_modbus']}"
    bridge = start_bridge(sim, wall_server, "--force-source", "modbus", "--modbus", ft,
                          "--modbus-map", str(map_file), "--enable-input", "0",
                          "--ur-modbus", ur, seconds=20.0)  # fmt: skip
    sim.ask(cmd="enable", on=True)
    wait_servoing(sim, bridge)
    sim.ask(cmd="person", force=[20, 0, 0])
    time.sleep(0.3)
    assert sim.state()["speed_norm"] > 0.05, "the arm should be moving"
    silenced = time.monotonic()
    sim.ask(cmd="fault", kind="modbus_silence", device=device, on=True)
    summary = finish(bridge)
    lost = "force_source_lost" if device == "ft" else "enable_input_lost"
    assert summary["exit_reason"] == lost, summary
    # noticed once the newest reading is older than --modbus-stale-ms (50 ms): that
    # reading was taken up to a poll (2 ms) before the silence; later by the scheduling of
    # a loaded machine
    noticed = summary["stop_events"][0]["noticed_ns"] * 1e-9
    assert 0.05 - 0.005 <= noticed - silenced <= 0.05 + 0.2, noticed - silenced
    sim.wait_for(lambda s: s["speed_norm"] < 1e-3, timeout_s=2.0, what="the arm at rest")


def test_sigterm_stops_the_arm_and_the_bridge_exits_with_the_reason(sim, wall_server):
    bridge, _ = moving_sideways(sim, wall_server)
    bridge.send_signal(signal.SIGTERM)
    summary = finish(bridge)
    assert summary["exit_reason"] == "signal" and summary["stops"] == 1
    time.sleep(0.2)
    assert sim.state()["speed_norm"] < 1e-3


def test_a_killed_bridge_is_stopped_by_the_scripts_watchdog(sim, wall_server):
    bridge, _ = moving_sideways(sim, wall_server)
    killed = time.monotonic()
    bridge.kill()
    bridge.wait()
    # the watchdog's 0.1 s, then the arm at rest (it goes no further than its last target)
    state = sim.wait_for(lambda s: s["speed_norm"] < 1e-3, timeout_s=2.0, what="the arm at rest")
    trace = sim.trace(killed)
    assert state["counters"]["watchdog_trips"] == 1, trace["events"][-5:]
    trip = next(e for e in trace["events"] if "watchdog" in json.dumps(e))
    assert trip["host_time"] - killed <= 0.1 + 0.05


def test_the_arm_moves_only_while_the_enable_input_is_held(sim, wall_server):
    ur_modbus = f"{sim.host}:{sim.endpoints['ur_modbus']}"
    bridge = start_bridge(sim, wall_server, "--enable-input", "0", "--ur-modbus", ur_modbus,
                          seconds=6.0)  # fmt: skip
    wait_servoing(sim, bridge)
    since = sim.ask(cmd="ping")["host_time"]
    sim.ask(cmd="person", force=[20, 0, 0])
    time.sleep(1.0)
    held_from = sim.ask(cmd="ping")["host_time"]
    sim.ask(cmd="enable", on=True)
    summary = finish(bridge)
    assert summary["exit_reason"] == "seconds", summary
    rows = rows_of(sim.trace(since))
    before = [r for r in rows if r["host_time"] < held_from]
    assert max(abs(r["x"] - START[0]) for r in before) <= 0.0002, "moved without the enable"
    assert rows[-1]["x"] - START[0] > 0.05, "did not move with the enable held"
    assert summary["enable_released_ticks"] > 0


def test_a_cb3_runs_at_125_hz_and_is_refused_at_500(wall_server):
    with running_simulator("--rate-hz", "125") as cb3:
        bridge = start_bridge(cb3, wall_server, seconds=1.0)
        _, err = bridge.communicate(timeout=30)
        assert bridge.returncode == 1 and "--rate-hz 125" in err, err
        bridge = start_bridge(cb3, wall_server, "--rate-hz", "125", seconds=2.0)
        summary = finish(bridge)
        assert summary["exit_reason"] == "seconds" and summary["rate_hz"] == 125.0
        assert 150 <= summary["ticks"] <= 250  # 250 periods, fewer when cycles overrun


def test_a_dropped_rtde_connection_stops_the_arm(sim, wall_server):
    bridge, _ = moving_sideways(sim, wall_server)
    sim.ask(cmd="fault", kind="drop_connections")
    summary = finish(bridge)
    # seen on the socket before ur_rtde's reconnect: nothing more sent (no servoStop, so
    # no stop time), the control script's watchdog stops the arm
    assert summary["exit_reason"] == "robot_disconnected", summary
    assert summary["stop_events"][-1]["stopped_ns"] == 0, summary
    time.sleep(0.3)
    assert sim.state()["speed_norm"] < 1e-3
