"""A Universal Robots arm as an admittance haptic device: `python -m hapticd ur-bridge`.

The person pushes the arm's tool; the bridge sends that force to a hapticd admittance
session, whose virtual mass–damper avatar moves under it against the scene; the bridge
servos the arm to where the avatar is. Touching a virtual wall, the avatar stops, and so
does the arm. It speaks to the robot with the ur_rtde library (RTDE for state and
servoL) and, where asked, to Modbus devices with pymodbus (ur_modbus.py).

Each cycle, paced by ur_rtde's initPeriod/waitPeriod at the robot's rate (500 Hz
e-Series, 125 Hz CB3):

    read the robot (TCP pose, speed, force, timestamp, safety)   ── safety checks
    filter the force (ur_force.py), into the scene's frame
    send an admittance state, take the command (up to half a period)
    limit speed and acceleration, clamp to the workspace (ur_motion.py)
    servoL the target, the tool's orientation held

servoL runs with lookahead_time 0.03 s and gain 500 by default: the lookahead is the
robot's lag (a 0.03 s lookahead trails its command by ~34 ms, URCL#86) and the lag is
what makes an admittance loop bounce on a hard wall (bench/results/admittance/), so the
least the controller takes; the targets are already smooth (the motion limiter), so a
middling gain follows them without exciting the arm.

Safety, always on: the arm is stopped (servoStop) and the bridge exits, with the reason,
when commands stop coming from the server for command_timeout_s (10 ms), when the
robot's RTDE data goes stale (its timestamp stops advancing for stale_s, 20 ms; ur_rtde
alone notices after 2.5 s), on a protective or emergency stop (reported; the bridge does
not resume, a person clears the robot and starts it again), when the control script
stops, when the Modbus sensor or enable input gives no reading for modbus_stale_s (50 ms),
and at the end (seconds, SIGINT, SIGTERM); an error from ur_rtde in the loop stops it
too, and the JSON line says so. When the robot closes an RTDE connection
(robot_disconnected, seen by the kernel before ur_rtde notices: ur_link.py) nothing more
is sent, since ur_rtde's own reconnect would race any call; the script's watchdog stops
the arm, as it does if the bridge itself dies (no command for 1/watchdog_hz, 0.1 s by default:
meanwhile the arm goes no further than its last target, which the speed cap keeps within
max_speed times the lookahead of where it is, 7.5 mm by default). It refuses to start
when the robot cannot be servoed, saying what to do.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hapticd.client import Client
from hapticd.device import DeviceSession
from hapticd.errors import ConnectionClosed, HapticdError, LocalError, SessionEnded
from hapticd.ur_force import ForceFilter, ForceFilterSettings
from hapticd.ur_link import RTDE_PORT, RtdeLinkWatch
from hapticd.ur_modbus import ROBOTIQ_FT300, EnableInput, ModbusForceSource, Poller, RegisterMap
from hapticd.ur_motion import BasePose, MotionLimiter, Workspace

ROBOT_MODE_RUNNING = 7
ROBOT_MODES = {
    -1: "NO_CONTROLLER",
    0: "DISCONNECTED",
    1: "CONFIRM_SAFETY",
    2: "BOOTING",
    3: "POWER_OFF",
    4: "POWER_ON",
    5: "IDLE",
    6: "BACKDRIVE",
    7: "RUNNING",
    8: "UPDATING_FIRMWARE",
}
RATES_HZ = (500.0, 125.0)
# the force a person may put into the avatar (N): a push harder than this is clipped
MAX_SENSED_FORCE_N = 150.0


@dataclass(frozen=True)
class BridgeOptions:
    """Every setting of the bridge; the command line's flags (build_parser) in full."""

    robot: str
    server: str
    seconds: float = math.inf
    rate_hz: float = 500.0
    virtual_mass: float = 5.0
    virtual_damping: float = 100.0
    max_speed: float = 0.25
    max_accel: float = 1.0
    lookahead_s: float = 0.03
    gain: float = 500.0
    force_source: str = "rtde"
    modbus: str = ""
    modbus_map: RegisterMap = ROBOTIQ_FT300
    enable_input: int | None = None
    ur_modbus: str = ""
    base_pose: BasePose = field(default_factory=BasePose)
    workspace: Workspace | None = None
    workspace_half_size: float = 0.25
    force: ForceFilterSettings = field(default_factory=ForceFilterSettings)
    command_timeout_s: float = 0.010
    stale_s: float = 0.020
    modbus_stale_s: float = 0.050
    watchdog_hz: float = 10.0
    stop_decel: float = 10.0


@dataclass
class StopEvent:
    """Why the arm was stopped, when the bridge noticed and when servoStop returned
    (time.monotonic_ns; stopped_ns 0: none sent, the robot's connection gone)."""

    reason: str
    noticed_ns: int
    stopped_ns: int = 0


class BridgeRefused(HapticdError):
    """The robot is not in a state to be servoed; the message says what to do."""


def _robot_ready(receive: Any, rate_hz: float, dashboard: Any) -> None:
    """BridgeRefused unless the arm can be servoed now."""
    if receive.isEmergencyStopped():
        raise BridgeRefused(
            "the robot is emergency-stopped: release the emergency stop, then power on and "
            "release the brakes in PolyScope"
        )
    if receive.isProtectiveStopped():
        raise BridgeRefused(
            "the robot is in a protective stop: find what caused it, then clear it (PolyScope, "
            "or the dashboard's 'unlock protective stop')"
        )
    mode = int(receive.getRobotMode())
    if mode != ROBOT_MODE_RUNNING:
        raise BridgeRefused(
            f"the robot's mode is {ROBOT_MODES.get(mode, mode)}, not RUNNING: power it on and "
            "release the brakes (PolyScope, or the dashboard's 'power on' then 'brake release')"
        )
    version = str(dashboard.polyscopeVersion())
    digits = [part for part in version.replace("-", ".").split() if part[:1].isdigit()]
    major = int(digits[0].split(".")[0]) if digits else 5
    if major >= 5 and not dashboard.isInRemoteControl():
        raise BridgeRefused(
            "the robot is in local control: switch it to remote control on the teach pendant"
        )
    if major < 5 and rate_hz != 125.0:
        raise BridgeRefused(
            f"the robot is a CB3 (PolyScope {version!r}), whose RTDE runs at 125 Hz: "
            "use --rate-hz 125"
        )


# ur_rtde 1.6.5's control interface reconnects from its own receive thread when its
# connection goes, and that reconnect races everything else that touches the interface:
# a call from the bridge, the destructor's disconnect, even the old receive thread, which
# keeps running beside the new one and reconnects again on every pass. A race there ends
# in a segmentation fault. So once a connection has gone, the bridge never calls either
# interface again, keeps both alive here, and leaves with os._exit: no destructor runs.
_abandoned_robot_links: list[Any] = []


def _abandon_robot_link(*interfaces: Any) -> None:
    _abandoned_robot_links.extend(i for i in interfaces if i is not None)


def exit_if_robot_link_abandoned(status: int) -> None:
    """Ends the process now (os._exit(status), output flushed) if a bridge lost its robot
    connection: ur_rtde's destructors would race its own reconnect."""
    if _abandoned_robot_links:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)


def _rotation_of(rotvec: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
    """The matrix of a rotation vector (UR's rx, ry, rz: axis times angle)."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return np.eye(3)
    k = rotvec / angle
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.asarray(np.eye(3) + math.sin(angle) * skew + (1 - math.cos(angle)) * skew @ skew)


class UrBridge:
    """One run of the bridge (the module's theory of operation): connect(), then run()."""

    def __init__(self, options: BridgeOptions, client: Client) -> None:
        self.options = options
        self.client = client
        self.stops: list[StopEvent] = []
        self.stale_states = 0
        self.ticks = 0
        self.commands_lost = 0
        self.overruns = 0
        self.enable_released_ticks = 0
        self.max_tcp_speed = 0.0
        self.max_force = 0.0
        self.latency_ns: list[int] = []
        self._receive: Any = None
        self._control: Any = None
        self._sensor: ModbusForceSource | None = None
        self._enable: EnableInput | None = None
        self._force_poll: Poller[Any] | None = None
        self._enable_poll: Poller[bool] | None = None
        self._sensor_bias = np.zeros(3)
        self.error = ""
        self._device: DeviceSession | None = None
        self._robot_link_lost = False
        self._link: RtdeLinkWatch | None = None

    def connect(self) -> None:
        """Reaches the robot and the Modbus devices, checks the robot can be servoed,
        uploads the control script and zeroes the force. BridgeRefused or HapticdError
        (nothing left moving) when it cannot."""
        import dashboard_client
        import rtde_control
        import rtde_receive

        o = self.options
        robot = o.robot
        try:
            self._receive = rtde_receive.RTDEReceiveInterface(robot, o.rate_hz)
        except RuntimeError as exc:
            raise HapticdError(f"the robot's RTDE interface at {robot}:30004: {exc}") from exc
        dashboard = dashboard_client.DashboardClient(robot)
        try:
            dashboard.connect()
        except RuntimeError as exc:
            raise HapticdError(f"the robot's dashboard server at {robot}:29999: {exc}") from exc
        try:
            _robot_ready(self._receive, o.rate_hz, dashboard)
        finally:
            dashboard.disconnect()
        period_s = 1.0 / o.rate_hz
        if o.force_source == "modbus":
            sensor = self._sensor = ModbusForceSource(o.modbus, o.modbus_map)
            # its reading at rest (hands off while the bridge starts), in its own frame
            self._sensor_bias = np.mean([sensor.read() for _ in range(25)], axis=0)
            self._force_poll = Poller(sensor.read, period_s, f"the sensor at {o.modbus}")
        if o.enable_input is not None:
            enable = self._enable = EnableInput(o.ur_modbus, o.enable_input)
            self._enable_poll = Poller(enable.held, period_s, f"the enable input at {o.ur_modbus}")
        try:
            self._control = rtde_control.RTDEControlInterface(robot, o.rate_hz)
        except RuntimeError as exc:
            raise HapticdError(f"the robot's control interface at {robot}: {exc}") from exc
        # the script stops the arm by itself when the bridge stops sending: its watchdog
        # (rtde_set_watchdog) watches the command register, which every servoL writes, so
        # the loop needs no kickWatchdog, whose own write of that register would replace
        # a servoL before the script read it
        self._control.setWatchdog(o.watchdog_hz)
        self._link = RtdeLinkWatch(robot)
        if self._link.watched != 2:
            raise HapticdError(
                f"found {self._link.watched} RTDE connections to {robot}:{RTDE_PORT}, not "
                "the 2 the receive and control interfaces opened: cannot watch them"
            )
        if o.force_source == "rtde":
            self._control.zeroFtSensor()

    def _in_base(self, force: np.ndarray[Any, Any], rotation: np.ndarray[Any, Any]) -> Any:
        """An external sensor's force (its map's frame) in the base frame."""
        assert self._sensor is not None
        return rotation @ force if self._sensor.map.frame == "tool" else force

    def _read_force(self, rotation: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
        """The person's force (N, base frame) as the force source reads it; HapticdError
        when an external sensor's newest reading is older than modbus_stale_s."""
        if self._force_poll is None:
            return np.asarray(self._receive.getActualTCPForce()[:3], dtype=float)
        newest = self._force_poll.latest(self.options.modbus_stale_s)
        return np.asarray(self._in_base(newest, rotation))

    def _modbus_bias(self, rotation: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
        """An external sensor's reading at rest (the tool untouched), in the base frame."""
        if self._sensor is None:
            return np.zeros(3)
        return np.asarray(self._in_base(self._sensor_bias, rotation))

    def _link_lost(self) -> bool:
        """Whether either RTDE connection has gone; once true, the control interface is
        never called again (see _abandon_robot_link)."""
        if not self._robot_link_lost:
            # the socket first: once it shows the loss, not even isConnected is called
            closed = self._link is not None and self._link.lost()
            self._robot_link_lost = closed or not self._both_connected()
        return self._robot_link_lost

    def _both_connected(self) -> bool:
        return bool(self._receive.isConnected() and self._control.isConnected())

    def _stop(self, reason: str, noticed_ns: int) -> None:
        """servoStop, recorded; an arm already stopped by the controller (a protective
        stop) refuses it, which is fine. With the connection gone nothing can be sent:
        the control script's watchdog stops the arm, and stopped_ns stays 0."""
        event = StopEvent(reason, noticed_ns)
        if not self._link_lost():
            try:
                self._control.servoStop(self.options.stop_decel)
            except RuntimeError:
                self._robot_link_lost = True
            event.stopped_ns = time.monotonic_ns()
        self.stops.append(event)

    def _robot_fault(self) -> str:
        """Why the robot can no longer be servoed ('' while it can)."""
        receive = self._receive
        if receive.isEmergencyStopped():
            return "emergency_stop"
        if receive.isProtectiveStopped():
            return "protective_stop"
        if int(receive.getRobotMode()) != ROBOT_MODE_RUNNING:
            return "robot_not_running"
        if not self._control.isProgramRunning():
            return "control_script_stopped"
        return ""

    def run(self, stop: threading.Event) -> str:
        """Servos the arm until the end or a fault; returns the exit reason. The arm is
        stopped when it returns, also after an error in the loop (reason "error", the
        message in self.error)."""
        try:
            return self._servo(stop)
        except (RuntimeError, HapticdError) as exc:
            # ur_rtde raises RuntimeError when its connection goes; nothing else should
            self.error = f"{type(exc).__name__}: {exc}"
            self._robot_link_lost |= isinstance(exc, RuntimeError)
            return self._finish("error", time.monotonic_ns())

    def _servo(self, stop: threading.Event) -> str:
        o = self.options
        period = 1.0 / o.rate_hz
        pose = np.asarray(self._receive.getActualTCPPose(), dtype=float)
        orientation = pose[3:6].tolist()
        rotation = _rotation_of(pose[3:6])
        start = pose[:3]
        workspace = o.workspace or Workspace.around(start, o.workspace_half_size)
        limiter = MotionLimiter(start, o.max_speed, o.max_accel, workspace)
        filtered = ForceFilter(o.force, self._modbus_bias(rotation))
        base = o.base_pose
        info = self.client.open_session(
            "admittance",
            rate_hz=o.rate_hz,
            max_velocity=o.max_speed,
            max_force=MAX_SENSED_FORCE_N,
            virtual_mass=o.virtual_mass,
            virtual_damping=o.virtual_damping,
            start=base.to_scene(start),
            session_timeout_s=1.0,
        )
        self._device = DeviceSession(info)
        target = base.to_scene(start)
        started_ns = time.monotonic_ns()
        last_command_ns = started_ns
        last_step_ns = started_ns
        last_timestamp = -1.0
        timestamp_changed_ns = started_ns
        end_ns = started_ns + (int(o.seconds * 1e9) if math.isfinite(o.seconds) else 2**62)
        while True:
            cycle = self._control.initPeriod()
            read_ns = time.monotonic_ns()
            if stop.is_set():
                return self._finish("signal", read_ns)
            if read_ns >= end_ns:
                return self._finish("seconds", read_ns)
            if self._link_lost():
                return self._finish("robot_disconnected", read_ns)
            timestamp = float(self._receive.getTimestamp())
            if timestamp != last_timestamp:
                last_timestamp, timestamp_changed_ns = timestamp, read_ns
            elif self.ticks > 0:
                self.stale_states += 1
                if read_ns - timestamp_changed_ns > o.stale_s * 1e9:
                    return self._finish("robot_stale", read_ns)
            fault = self._robot_fault()
            if fault == "control_script_stopped":
                return self._script_stopped(read_ns)
            if fault:
                return self._finish(fault, read_ns)
            pose = np.asarray(self._receive.getActualTCPPose(), dtype=float)
            speed = np.asarray(self._receive.getActualTCPSpeed(), dtype=float)
            self.max_tcp_speed = max(self.max_tcp_speed, float(np.linalg.norm(speed[:3])))
            try:
                force = filtered.update(self._read_force(rotation), period)
            except HapticdError:
                return self._finish("force_source_lost", time.monotonic_ns())
            try:
                enabled = self._enable_poll is None or self._enable_poll.latest(o.modbus_stale_s)
            except HapticdError:
                return self._finish("enable_input_lost", time.monotonic_ns())
            if not enabled:
                self.enable_released_ticks += 1
                force = np.zeros(3)
            self.max_force = max(self.max_force, float(np.linalg.norm(force)))
            try:
                command = self._device.exchange(
                    base.to_scene(pose[:3]),
                    base.direction_to_scene(speed[:3]),
                    sensed_force=base.direction_to_scene(force),
                    timeout_s=period / 2,
                )
            except (ConnectionClosed, SessionEnded):
                return self._finish("server_lost", time.monotonic_ns())
            now_ns = time.monotonic_ns()
            if command is None:
                self.commands_lost += 1
                if now_ns - last_command_ns > o.command_timeout_s * 1e9:
                    return self._finish("server_lost", now_ns)
            else:
                last_command_ns = now_ns
                target = command.position
            goal = base.to_base(target) if enabled else limiter.position
            # the time since the last target, at most a period: a late cycle followed by
            # one without a wait must not add up to more than the speed cap in real time
            step_s = min((read_ns - last_step_ns) * 1e-9, period) if self.ticks else period
            last_step_ns = read_ns
            position = limiter.step(goal, max(step_s, 1e-6))
            if self._link_lost():  # it may have gone during the exchange
                return self._finish("robot_disconnected", time.monotonic_ns())
            self._control.servoL(
                [*position.tolist(), *orientation], 0.0, 0.0, period, o.lookahead_s, o.gain
            )
            self.latency_ns.append(time.monotonic_ns() - read_ns)
            self.ticks += 1
            if time.monotonic_ns() - read_ns > period * 1e9:
                self.overruns += 1
            self._control.waitPeriod(cycle)

    def _script_stopped(self, noticed_ns: int, wait_s: float = 0.05) -> str:
        """The control script stopped: stop, then tell why. A protective or emergency
        stop ends the script too, and the control interface's connection can show the
        script gone a period or two before the receive interface shows the stop."""
        self._stop("control_script_stopped", noticed_ns)
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            if self._receive.isEmergencyStopped():
                self.stops[-1].reason = "emergency_stop"
                break
            if self._receive.isProtectiveStopped():
                self.stops[-1].reason = "protective_stop"
                break
            time.sleep(0.002)
        return self.stops[-1].reason

    def _finish(self, reason: str, noticed_ns: int) -> str:
        self._stop(reason, noticed_ns)
        return reason

    def close(self) -> None:
        """Ends the session and lets go of the robot (the arm already stopped)."""
        if self._device is not None:
            try:
                self._device.close()
            except HapticdError:
                pass  # the server is gone: nothing to close there
        if self._robot_link_lost:
            _abandon_robot_link(self._control, self._receive)
        else:
            if self._link is not None:
                self._link.close()
            if self._control is not None:
                try:
                    self._control.stopScript()
                    self._control.disconnect()
                except RuntimeError:
                    pass
            if self._receive is not None:
                try:
                    self._receive.disconnect()
                except RuntimeError:
                    pass
        for poller in (self._force_poll, self._enable_poll):
            if poller is not None:
                poller.close()
        for device in (self._sensor, self._enable):
            if device is not None:
                device.close()

    def summary(self, exit_reason: str) -> dict[str, Any]:
        """The JSON line printed at exit."""
        latency = np.array(self.latency_ns, dtype=float) / 1e3
        o = self.options

        def percentile(q: float) -> float:
            return float(np.percentile(latency, q)) if latency.size else 0.0

        return {
            "exit_reason": exit_reason,
            "error": self.error,
            "ticks": self.ticks,
            "rate_hz": o.rate_hz,
            "command_latency_p50_us": percentile(50),
            "command_latency_p99_us": percentile(99),
            "command_latency_max_us": float(latency.max()) if latency.size else 0.0,
            "max_tcp_speed_m_s": self.max_tcp_speed,
            "max_force_n": self.max_force,
            "stops": len(self.stops),
            "stop_events": [
                {"reason": e.reason, "noticed_ns": e.noticed_ns, "stopped_ns": e.stopped_ns}
                for e in self.stops
            ],
            "stale_states": self.stale_states,
            "commands_lost": self.commands_lost,
            "overruns": self.overruns,
            "enable_released_ticks": self.enable_released_ticks,
            "force_source": o.force_source,
            "virtual_mass_kg": o.virtual_mass,
            "virtual_damping_ns_per_m": o.virtual_damping,
            "max_speed_m_s": o.max_speed,
            "lookahead_s": o.lookahead_s,
            "gain": o.gain,
            "session_id": self._device.info.session_id if self._device else 0,
        }


def _stdout_for_the_summary_only() -> None:
    """Sends whatever else writes to file descriptor 1 to stderr; sys.stdout keeps the
    real stdout. ur_rtde prints to std::cout from its own threads ("Reconnecting..."),
    at any time, even into the middle of the JSON line."""
    sys.stdout.flush()
    real_stdout = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = os.fdopen(real_stdout, "w", encoding="utf-8")


def run_bridge(options: BridgeOptions, client: Client) -> dict[str, Any]:
    """Connects, servos until the end, stops; the summary. SIGINT and SIGTERM end the
    run (the arm stopped) instead of killing it. From the call on, only sys.stdout
    writes to the process's stdout (see _stdout_for_the_summary_only)."""
    _stdout_for_the_summary_only()
    stop = threading.Event()
    previous: dict[signal.Signals, Any] = {}

    def ask_to_stop(signum: int, _frame: Any) -> None:
        stop.set()

    for signum in (signal.SIGINT, signal.SIGTERM):
        previous[signum] = signal.signal(signum, ask_to_stop)
    bridge = UrBridge(options, client)
    try:
        bridge.connect()
        reason = bridge.run(stop)
    finally:
        bridge.close()
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return bridge.summary(reason)


def _number(low: float, high: float, *, low_open: bool = False) -> Callable[[str], float]:
    """An argparse type: a number in [low, high] ((low, high] with low_open)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        inside = (value > low if low_open else value >= low) and value <= high
        if not inside:
            bracket = "(" if low_open else "["
            raise argparse.ArgumentTypeError(f"{text!r} is not in {bracket}{low}, {high}]")
        return value

    return parse


def _floats(count: int) -> Callable[[str], tuple[float, ...]]:
    def parse(text: str) -> tuple[float, ...]:
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {count} numbers") from None
        if len(values) != count or not all(math.isfinite(v) for v in values):
            raise argparse.ArgumentTypeError(f"{text!r} must be {count} finite numbers, a,b,...")
        return values

    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ur-bridge command's flags (the connection flags are cli.py's)."""
    d = BridgeOptions(robot="", server="")
    f = d.force
    add = parser.add_argument
    add("--robot", required=True, metavar="HOST", help="the robot controller's address")
    add(
        "--seconds",
        type=_number(0, 1e6, low_open=True),
        default=math.inf,
        help="stop after this long (s; default: until SIGINT or SIGTERM)",
    )
    add(
        "--rate-hz",
        type=float,
        choices=RATES_HZ,
        default=d.rate_hz,
        help="the robot's RTDE rate: 500 (e-Series, default) or 125 (CB3)",
    )
    add(
        "--virtual-mass",
        type=_number(1e-3, 1e3),
        default=d.virtual_mass,
        metavar="KG",
        help="the avatar's mass (kg, default %(default)s)",
    )
    add(
        "--virtual-damping",
        type=_number(0, 1e5),
        default=d.virtual_damping,
        metavar="NS_PER_M",
        help="the avatar's damping (N·s/m, default %(default)s)",
    )
    add(
        "--max-speed",
        type=_number(0, 1.0, low_open=True),
        default=d.max_speed,
        metavar="M_PER_S",
        help="the arm's and the avatar's top speed (m/s, default %(default)s)",
    )
    add(
        "--max-accel",
        type=_number(0, 10.0, low_open=True),
        default=d.max_accel,
        metavar="M_PER_S2",
        help="the arm's acceleration limit (m/s², default %(default)s)",
    )
    add(
        "--lookahead",
        type=_number(0.03, 0.2),
        default=d.lookahead_s,
        metavar="S",
        help="servoL's lookahead_time (s, in [0.03, 0.2], default %(default)s: the least lag)",
    )
    add(
        "--gain",
        type=_number(100, 2000),
        default=d.gain,
        help="servoL's gain (in [100, 2000], default %(default)s)",
    )
    add(
        "--force-source",
        choices=("rtde", "modbus"),
        default=d.force_source,
        help="the person's force: RTDE's actual_TCP_force (default) or a Modbus F/T sensor",
    )
    add(
        "--modbus",
        metavar="HOST:PORT|/dev/DEVICE",
        default="",
        help="the F/T sensor: Modbus TCP HOST:PORT, or a serial device for Modbus RTU",
    )
    add(
        "--modbus-map",
        metavar="FILE.json",
        help="the sensor's register map (hapticd.ur_modbus; default: a Robotiq FT 300's)",
    )
    add(
        "--enable-input",
        type=int,
        metavar="N",
        help="the arm moves only while the controller's digital input N is held (read over "
        "the UR Modbus server)",
    )
    add(
        "--ur-modbus",
        metavar="HOST:PORT",
        default="",
        help="the controller's Modbus server (default ROBOT:502)",
    )
    add(
        "--base-pose",
        type=_floats(7),
        metavar="X,Y,Z,QW,QX,QY,QZ",
        help="the robot's base frame in the scene (m; unit quaternion); default identity",
    )
    add(
        "--workspace",
        type=_floats(6),
        metavar="XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX",
        help="the box (m, base frame) the TCP stays in; default ±0.25 m around the start",
    )
    add(
        "--force-deadband",
        type=_number(0, 50),
        default=f.deadband_n,
        metavar="N",
        help="forces below this (N) do not move the arm (default %(default)s)",
    )
    add(
        "--force-cutoff-hz",
        type=_number(0, 500, low_open=True),
        default=f.cutoff_hz,
        metavar="HZ",
        help="the force's low-pass cutoff (Hz, default %(default)s)",
    )
    add(
        "--bias-time-constant",
        type=_number(0, 3600, low_open=True),
        default=f.bias_time_constant_s,
        metavar="S",
        help="how slowly (s) the bias follows the sensor while nobody pushes (default %(default)s)",
    )
    add(
        "--command-timeout-ms",
        type=_number(1, 1000),
        default=d.command_timeout_s * 1e3,
        metavar="MS",
        help="stop when no command came from the server for this long (default %(default)s)",
    )
    add(
        "--stale-ms",
        type=_number(1, 1000),
        default=d.stale_s * 1e3,
        metavar="MS",
        help="stop when the robot's data stopped advancing for this long (default %(default)s)",
    )
    add(
        "--modbus-stale-ms",
        type=_number(1, 1000),
        default=d.modbus_stale_s * 1e3,
        metavar="MS",
        help="stop when the Modbus sensor or enable input gave no reading for this long "
        "(default %(default)s)",
    )
    add(
        "--watchdog-hz",
        type=_number(1, 500),
        default=d.watchdog_hz,
        metavar="HZ",
        help="the control script stops the arm unless commanded this often (default %(default)s)",
    )


def options_from(args: argparse.Namespace) -> BridgeOptions:
    """BridgeOptions from the parsed flags; LocalError naming a flag that does not fit."""
    if args.force_source == "modbus" and not args.modbus:
        raise LocalError("--force-source modbus needs --modbus HOST:PORT or a serial device")
    if args.force_source != "modbus" and (args.modbus or args.modbus_map):
        raise LocalError("--modbus and --modbus-map are for --force-source modbus")
    if args.enable_input is not None and not 0 <= args.enable_input <= 15:
        raise LocalError(f"--enable-input is {args.enable_input}; it must be in [0, 15]")
    if args.ur_modbus and args.enable_input is None:
        raise LocalError("--ur-modbus is for --enable-input")
    base = BasePose()
    if args.base_pose is not None:
        base = BasePose(args.base_pose[:3], args.base_pose[3:])
    workspace = None
    if args.workspace is not None:
        workspace = Workspace(low=args.workspace[:3], high=args.workspace[3:])
    return BridgeOptions(
        robot=args.robot,
        server=args.server,
        seconds=args.seconds,
        rate_hz=args.rate_hz,
        virtual_mass=args.virtual_mass,
        virtual_damping=args.virtual_damping,
        max_speed=args.max_speed,
        max_accel=args.max_accel,
        lookahead_s=args.lookahead,
        gain=args.gain,
        force_source=args.force_source,
        modbus=args.modbus,
        modbus_map=RegisterMap.read(args.modbus_map) if args.modbus_map else ROBOTIQ_FT300,
        enable_input=args.enable_input,
        ur_modbus=args.ur_modbus or f"{args.robot}:502",
        base_pose=base,
        workspace=workspace,
        force=ForceFilterSettings(
            deadband_n=args.force_deadband,
            cutoff_hz=args.force_cutoff_hz,
            bias_time_constant_s=args.bias_time_constant,
        ),
        command_timeout_s=args.command_timeout_ms / 1e3,
        stale_s=args.stale_ms / 1e3,
        modbus_stale_s=args.modbus_stale_ms / 1e3,
        watchdog_hz=args.watchdog_hz,
    )
