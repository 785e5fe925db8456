"""The simulated UR controller: robot, safety and program state, the RTDE registers, the
arm, the person and the sensors, stepped once per period by the clock.

Every server thread (RTDE, dashboard, script, Modbus, control channel) changes or reads
this state only while holding Controller.lock; tick() holds it for one period's work and
publishes the RTDE outputs after releasing it.

State machine (robot mode x safety mode x program):

    POWER_OFF --power on--> IDLE --brake release--> RUNNING --script arrives--> program PLAYING
    program PLAYING --stop / stop script / watchdog / protective stop / e-stop--> STOPPED
    safety NORMAL --protective stop--> PROTECTIVE_STOP --dashboard unlock (after the
        unlock delay)--> NORMAL
    safety NORMAL --emergency stop--> ROBOT_EMERGENCY_STOP, robot POWER_OFF --release-->
        NORMAL (robot stays POWER_OFF until power on, brake release)

A script is only run while the robot is RUNNING, safety NORMAL and in remote control.
"""

from __future__ import annotations

import math
import random
import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .arm import Arm, ArmLimits, ForceSensor, Person
from .control_script import COMMAND_NAMES, ControlScript
from .trace import Trace

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
POWER_OFF, IDLE, RUNNING = 3, 5, 7

SAFETY_MODES = {
    1: "NORMAL",
    2: "REDUCED",
    3: "PROTECTIVE_STOP",
    4: "RECOVERY",
    5: "SAFEGUARD_STOP",
    6: "SYSTEM_EMERGENCY_STOP",
    7: "ROBOT_EMERGENCY_STOP",
    8: "VIOLATION",
    9: "FAULT",
}
SAFETY_NORMAL, SAFETY_PROTECTIVE_STOP, SAFETY_ROBOT_EMERGENCY_STOP = 1, 3, 7

RUNTIME_STATES = {
    0: "STOPPING",
    1: "STOPPED",
    2: "PLAYING",
    3: "PAUSING",
    4: "PAUSED",
    5: "RESUMING",
}
STOPPED, PLAYING, PAUSED = 1, 2, 4

JOINT_RUNNING_MODE, JOINT_POWER_OFF_MODE = 253, 239

UNLOCK_TOO_EARLY = (
    "Cannot unlock protective stop until 5s after occurrence. "
    "Always inspect cause of protective stop before unlocking"
)

# bits of robot_status_bits and safety_status_bits (RTDE guide)
STATUS_POWER_ON, STATUS_PROGRAM_RUNNING = 1 << 0, 1 << 1
SAFETY_BIT_NORMAL, SAFETY_BIT_PROTECTIVE = 1 << 0, 1 << 2
SAFETY_BIT_ROBOT_ESTOP, SAFETY_BIT_ESTOP, SAFETY_BIT_STOPPED_BY_SAFETY = 1 << 6, 1 << 7, 1 << 10


@dataclass(frozen=True)
class ControllerConfig:
    """What does not change while the simulator runs."""

    rate_hz: int = 500
    version: tuple[int, int, int, int] = (5, 15, 0, 112233)
    serial_number: str = "20235500001"
    robot_model: str = "UR5"
    start_pose: tuple[float, ...] = (0.4, -0.1, 0.3, 0.0, 3.1416, 0.0)
    limits: ArmLimits = ArmLimits()
    unlock_delay_s: float = 5.0
    seed: int = 0
    trace_seconds: float = 60.0
    enable_input_bit: int = 0

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def polyscope_version(self) -> str:
        major, minor, bugfix, build = self.version
        return f"{major}.{minor}.{bugfix}.{build}"


class Controller:
    """Mutable controller state (see the module docstring). Methods whose name does not
    start with "locked_" take the lock themselves; the others expect the caller to hold it."""

    def __init__(
        self, config: ControllerConfig, robot_mode: int, safety_mode: int, remote_control: bool
    ) -> None:
        self.config = config
        self.period_s = config.period_s
        self.lock = threading.Lock()
        self.start_host_time = time.monotonic()
        # registers and other RTDE inputs
        self.in_int = [0] * 48
        self.in_double = [0.0] * 48
        self.in_bits = 0  # input bit registers 0..127
        self.out_int = [0] * 48
        self.out_double = [0.0] * 48
        self.out_bits = 0
        self.other_inputs: dict[str, object] = {}
        self.input_update_host_time: dict[str, float] = {}
        self.input_seq = 0
        # robot, safety, program
        self.robot_mode = robot_mode
        self.safety_mode = safety_mode
        self.remote_control = remote_control
        self.runtime_state = STOPPED
        self.program: ControlScript | None = None
        self.program_name = "<unnamed>"
        self.last_script: str | None = None
        self.protective_stop_host_time = (
            time.monotonic() if safety_mode == SAFETY_PROTECTIVE_STOP else 0.0
        )
        self.watchdog: tuple[str, float, float] | None = None  # (variable, min Hz, armed at)
        # the physical world
        self.arm = Arm(config.start_pose, config.limits)
        self.person = Person(rng=random.Random(config.seed))
        self.tcp_sensor = ForceSensor()
        self.external_sensor = ForceSensor()
        self.silent_modbus: frozenset[str] = frozenset()  # "ft", "ur": servers not answering
        self.applied_wrench: tuple[float, ...] = (0.0,) * 6
        self.tcp_force = [0.0] * 6
        self.external_force = [0.0] * 6
        self.external_samples = 0
        self.digital_inputs = 0
        self.digital_outputs = 0
        self.payload_mass = 0.0
        self.payload_cog = [0.0, 0.0, 0.0]
        # time and bookkeeping
        self.k = 0
        self.t = 0.0
        self.host_time = self.start_host_time
        self.counters = {
            "servoL": 0,
            "servoL_processed": 0,
            "servoStop": 0,
            "stopL": 0,
            "stopJ": 0,
            "speedStop": 0,
            "zeroFtSensor": 0,
            "unknown_commands": 0,
            "watchdog_trips": 0,
            "protective_stops": 0,
            "emergency_stops": 0,
            "scripts_received": 0,
            "scripts_refused": 0,
            "stalls": 0,
            "input_packages": 0,
            "bad_packages": 0,
        }
        self.unknown_codes: dict[int, int] = {}
        self._unknown_seq = -1
        self.last_servo: dict | None = None
        self.trace = Trace(int(config.trace_seconds * config.rate_hz))
        self.frame: dict[str, object] = {}
        self.publish: Callable[[int, dict], None] | None = None
        self._build_frame()

    # --- the period ------------------------------------------------------------
    def tick(self, k: int, nominal_host_time: float, skipped: int) -> None:
        """One controller period (clock.run_periodic's callback)."""
        with self.lock:
            self.host_time = time.monotonic()
            if skipped:
                self._catch_up(skipped)
            self.k = k
            self.t = k * self.period_s
            self._check_watchdog()
            if self.program is not None and self.runtime_state == PLAYING:
                self.program.step()
            self.arm.step(self.period_s)
            self._update_sensors()
            arm = self.arm
            target = arm.servo_target if arm.mode == "servo" else None
            self.trace.add_row(
                (self.t, self.host_time, *arm.p, *arm.v, target, arm.at_rest, arm.mode)
            )
            self._build_frame()
            frame = self.frame
        if self.publish is not None:
            self.publish(k, frame)

    def _catch_up(self, skipped: int) -> None:
        """The process was stalled for `skipped` periods: move the world on by that much,
        without outputs, the way a real controller keeps running while its client stalls."""
        self.counters["stalls"] += 1
        self.event("stall", skipped_periods=skipped, skipped_s=round(skipped * self.period_s, 6))
        steps = min(skipped, 60 * self.config.rate_hz)
        dt = skipped * self.period_s / steps
        for _ in range(steps):
            self.arm.step(dt)

    def _check_watchdog(self) -> None:
        """rtde_set_watchdog(variable, min_frequency, "stop"): stop the program when the
        variable was not written for longer than 1 / min_frequency."""
        if self.watchdog is None or self.runtime_state != PLAYING:
            return
        variable, min_hz, armed_at = self.watchdog
        last = max(self.input_update_host_time.get(variable, armed_at), armed_at)
        if self.host_time - last > 1.0 / min_hz:
            self.counters["watchdog_trips"] += 1
            self.event(
                "watchdog_trip",
                variable=variable,
                min_frequency=min_hz,
                silent_s=round(self.host_time - last, 6),
            )
            self.program_ended("RTDE watchdog")

    def _update_sensors(self) -> None:
        force = self.person.force_at(self.t, self.arm.p, self.arm.v)
        self.applied_wrench = (force[0], force[1], force[2], 0.0, 0.0, 0.0)
        self.tcp_force = self.tcp_sensor.reading(self.applied_wrench, self.t)
        self.external_force = self.external_sensor.reading(self.applied_wrench, self.t)
        self.external_samples = (self.external_samples + 1) & 0xFFFF

    # --- outputs -----------------------------------------------------------------
    def robot_status_bits(self) -> int:
        bits = STATUS_POWER_ON if self.robot_mode in (4, 5, 6, 7) else 0
        return bits | (STATUS_PROGRAM_RUNNING if self.runtime_state == PLAYING else 0)

    def safety_status_bits(self) -> int:
        if self.safety_mode == SAFETY_NORMAL:
            return SAFETY_BIT_NORMAL
        if self.safety_mode == SAFETY_PROTECTIVE_STOP:
            return SAFETY_BIT_PROTECTIVE | SAFETY_BIT_STOPPED_BY_SAFETY
        return SAFETY_BIT_ROBOT_ESTOP | SAFETY_BIT_ESTOP | SAFETY_BIT_STOPPED_BY_SAFETY

    def _build_frame(self) -> None:
        """Every output variable's value this period (vectors as tuples); registers are
        copied under the keys _out_int, _out_double, _in_int, _in_double."""
        arm = self.arm
        q = arm.joints()
        qd = arm.joint_speeds()
        speed = arm.v + (0.0, 0.0, 0.0)
        zeros6 = (0.0,) * 6
        running = self.robot_mode == RUNNING
        f = self.tcp_force
        self.frame = {
            "timestamp": self.t,
            "actual_TCP_pose": arm.pose(),
            "target_TCP_pose": arm.target_pose(),
            "actual_TCP_speed": speed,
            "target_TCP_speed": speed,
            "actual_TCP_force": tuple(f),
            "ft_raw_wrench": tuple(self.tcp_sensor.raw(self.applied_wrench, self.t)),
            "tcp_force_scalar": math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]),
            "actual_q": q,
            "target_q": q,
            "actual_qd": qd,
            "target_qd": qd,
            "target_qdd": zeros6,
            "actual_qdd": zeros6,
            "target_current": zeros6,
            "target_moment": zeros6,
            "actual_current": zeros6,
            "actual_current_window": zeros6,
            "actual_current_as_torque": zeros6,
            "actual_moment": zeros6,
            "joint_control_output": zeros6,
            "actual_digital_input_bits": self.digital_inputs,
            "actual_digital_output_bits": self.digital_outputs,
            "joint_temperatures": (30.0,) * 6,
            "actual_execution_time": 0.25,
            "robot_mode": self.robot_mode,
            "joint_mode": ((JOINT_RUNNING_MODE if running else JOINT_POWER_OFF_MODE),) * 6,
            "safety_mode": self.safety_mode,
            "safety_status": self.safety_mode,
            "actual_tool_accelerometer": (0.0, 0.0, 9.81),
            "speed_scaling": 1.0,
            "target_speed_fraction": 1.0,
            "actual_momentum": 0.0,
            "actual_main_voltage": 48.0,
            "actual_robot_voltage": 48.0 if running else 0.0,
            "actual_robot_current": 0.5 if running else 0.0,
            "actual_joint_voltage": (48.0 if running else 0.0,) * 6,
            "runtime_state": self.runtime_state,
            "elbow_position": (0.1, 0.1, 0.4),
            "elbow_velocity": (0.0, 0.0, 0.0),
            "robot_status_bits": self.robot_status_bits(),
            "safety_status_bits": self.safety_status_bits(),
            "payload": self.payload_mass,
            "payload_cog": tuple(self.payload_cog),
            "payload_inertia": zeros6,
            "output_bit_registers0_to_31": self.out_bits & 0xFFFFFFFF,
            "output_bit_registers32_to_63": (self.out_bits >> 32) & 0xFFFFFFFF,
            "input_bit_registers0_to_31": self.in_bits & 0xFFFFFFFF,
            "input_bit_registers32_to_63": (self.in_bits >> 32) & 0xFFFFFFFF,
            "_out_int": tuple(self.out_int),
            "_out_double": tuple(self.out_double),
            "_in_int": tuple(self.in_int),
            "_in_double": tuple(self.in_double),
            "_out_bits": self.out_bits,
            "_in_bits": self.in_bits,
        }

    # --- RTDE inputs ---------------------------------------------------------------
    def apply_inputs(self, values: dict[str, Any], host_time: float) -> None:
        """One input data package from an RTDE client (takes the lock)."""
        with self.lock:
            self.input_seq += 1
            self.counters["input_packages"] += 1
            offset = self.program.off_i if self.program is not None else 0
            for name, value in values.items():
                self.input_update_host_time[name] = host_time
                if name.startswith("input_int_register_"):
                    index = int(name[19:])
                    self.in_int[index] = int(value)
                    if index == offset and value == 24:
                        self.counters["servoL"] += 1
                elif name.startswith("input_double_register_"):
                    self.in_double[int(name[22:])] = float(value)
                elif name.startswith("input_bit_register_"):
                    bit = int(name[19:])
                    self.in_bits = (
                        (self.in_bits | (1 << bit)) if value else (self.in_bits & ~(1 << bit))
                    )
                elif name == "input_bit_registers0_to_31":
                    self.in_bits = (self.in_bits & ~0xFFFFFFFF) | int(value)
                elif name == "input_bit_registers32_to_63":
                    self.in_bits = (self.in_bits & ~(0xFFFFFFFF << 32)) | (int(value) << 32)
                else:
                    self.other_inputs[name] = value
            mask = self.other_inputs.pop("standard_digital_output_mask", None)
            if isinstance(mask, int) and "standard_digital_output" in values:
                out = int(values["standard_digital_output"])
                self.digital_outputs = (self.digital_outputs & ~mask) | (out & mask)

    # --- called by the control script (lock held) ------------------------------------
    def event(self, kind: str, /, **details) -> None:
        """Record an event of this period, stamped with the host time now."""
        self.trace.add_event(self.t, time.monotonic(), kind, **details)

    def command_seen(self, command: str, /, **details) -> None:
        """Count and record a command the control script carried out."""
        self.counters[command] = self.counters.get(command, 0) + 1
        self.event(command, **details)

    def count_unknown(self, cmd: int) -> None:
        """An unsupported command code; counted once per input package that carries it."""
        if self._unknown_seq == self.input_seq:
            return
        self._unknown_seq = self.input_seq
        self.counters["unknown_commands"] += 1
        self.unknown_codes[cmd] = self.unknown_codes.get(cmd, 0) + 1
        self.event("unknown_command", code=cmd, name=COMMAND_NAMES.get(cmd, "?"))

    def servo_processed(self, target: list[float], lookahead: float, gain: float) -> None:
        self.counters["servoL_processed"] += 1
        self.last_servo = {"target": target, "lookahead_time": lookahead, "gain": gain}

    def zero_ft_sensor(self) -> None:
        self.counters["zeroFtSensor"] += 1
        self.tcp_sensor.zero(self.applied_wrench, self.t)
        self.event("zeroFtSensor")

    def set_payload(self, mass: float, cog: list[float]) -> None:
        self.payload_mass, self.payload_cog = mass, cog

    def set_watchdog(self, variable: str, min_frequency: float) -> None:
        if not (math.isfinite(min_frequency) and min_frequency > 0.0):
            self.event("watchdog_refused", min_frequency=min_frequency)
            return
        self.watchdog = (variable, min_frequency, time.monotonic())
        self.event("watchdog_set", variable=variable, min_frequency=min_frequency)

    def program_ended(self, reason: str) -> None:
        """The program stops (any reason): the arm stops at the safety deceleration."""
        if self.runtime_state == STOPPED and self.program is None:
            return
        self.program = None
        self.runtime_state = STOPPED
        self.watchdog = None
        self.arm.stop(self.arm.limits.safety_stop_decel)
        self.event("program_stopped", reason=reason)

    def raise_protective_stop(self, reason: str) -> None:
        self.counters["protective_stops"] += 1
        self.safety_mode = SAFETY_PROTECTIVE_STOP
        self.protective_stop_host_time = time.monotonic()
        self.event("protective_stop", reason=reason)
        self.program_ended("protective stop")

    # --- faults and dashboard actions (lock held) ------------------------------------
    def emergency_stop(self) -> None:
        self.counters["emergency_stops"] += 1
        self.safety_mode = SAFETY_ROBOT_EMERGENCY_STOP
        self.event("emergency_stop")
        self.program_ended("emergency stop")
        self.robot_mode = POWER_OFF

    def release_emergency_stop(self) -> None:
        if self.safety_mode == SAFETY_ROBOT_EMERGENCY_STOP:
            self.safety_mode = SAFETY_NORMAL
            self.event("emergency_stop_released")

    def unlock_protective_stop(self) -> str:
        if self.safety_mode != SAFETY_PROTECTIVE_STOP:
            return "Protective stop releasing"
        if time.monotonic() - self.protective_stop_host_time < self.config.unlock_delay_s:
            return UNLOCK_TOO_EARLY
        self.safety_mode = SAFETY_NORMAL
        self.event("protective_stop_unlocked")
        return "Protective stop releasing"

    def load_script(self, text: str) -> None:
        """A script arrived on the script port: run it as the program, if allowed."""
        self.counters["scripts_received"] += 1
        if text.startswith("sec "):
            self.event("secondary_program_ignored")  # secondary programs do not replace the program
            return
        match = re.search(r"^def\s+(\w+)\s*\(\s*\)\s*:", text, re.MULTILINE)
        name = match.group(1) if match else "<unnamed>"
        refusal = None
        if not self.remote_control:
            refusal = "robot is in local control"
        elif self.robot_mode != RUNNING:
            refusal = f"robot mode is {ROBOT_MODES.get(self.robot_mode)}"
        elif self.safety_mode != SAFETY_NORMAL:
            refusal = f"safety mode is {SAFETY_MODES.get(self.safety_mode)}"
        if refusal:
            self.counters["scripts_refused"] += 1
            self.event("script_refused", name=name, reason=refusal)
            return
        if self.program is not None or self.runtime_state != STOPPED:
            self.program_ended("replaced by a new script")
        self.last_script = text
        self._start_program(text, name)

    def _start_program(self, text: str, name: str) -> None:
        self.program_name = name
        # ur_rtde injects the offsets after the line's comment: the value is the first
        # number after "=", on the next line ("= # int register offset\n24    global ...")
        offsets = [
            int(m) if m else 0
            for m in (
                _first(r"global\s+reg_offset_int\s*=\s*(?:#[^\n]*\n)?\s*(\d+)", text),
                _first(r"global\s+reg_offset_float\s*=\s*(?:#[^\n]*\n)?\s*(\d+)", text),
            )
        ]
        if name == "rtde_control":
            self.program = ControlScript(self, offsets[0], offsets[1])
        else:
            self.program = None  # any other script: accepted and ends at once
        self.runtime_state = PLAYING if self.program is not None else STOPPED
        self.event(
            "program_started" if self.program else "script_ignored",
            name=name,
            reg_offset_int=offsets[0],
            reg_offset_float=offsets[1],
        )

    def replay(self) -> bool:
        """Dashboard play: rerun the last script (or resume a paused one)."""
        if self.robot_mode != RUNNING or self.safety_mode != SAFETY_NORMAL:
            return False
        if self.runtime_state == PAUSED and self.program is not None:
            self.runtime_state = PLAYING
            return True
        if self.runtime_state == PLAYING or self.last_script is None:
            return False
        self._start_program(self.last_script, self.program_name)
        return self.program is not None

    def pause(self) -> bool:
        if self.runtime_state != PLAYING:
            return False
        self.runtime_state = PAUSED
        self.arm.stop(self.arm.limits.safety_stop_decel)
        self.event("program_paused")
        return True

    def power_on(self) -> None:
        if self.robot_mode == POWER_OFF and self.safety_mode != SAFETY_ROBOT_EMERGENCY_STOP:
            self.robot_mode = IDLE
            self.event("power_on")

    def power_off(self) -> None:
        self.program_ended("power off")
        self.robot_mode = POWER_OFF
        self.event("power_off")

    def brake_release(self) -> None:
        if self.robot_mode == IDLE:
            self.robot_mode = RUNNING
            self.event("brake_release")

    # --- state for the control channel (lock held) -----------------------------------
    def state(self) -> dict:
        arm = self.arm
        return {
            "t": self.t,
            "host_time": self.host_time,
            "k": self.k,
            "pose": list(arm.pose()),
            "speed": list(arm.v),
            "speed_norm": math.sqrt(sum(x * x for x in arm.v)),
            "arm_mode": arm.mode,
            "at_rest": arm.at_rest,
            "servo_target": list(arm.servo_target) if arm.servo_target else None,
            "servo_time_constant": arm.servo_tau,
            "last_servo": self.last_servo,
            "robot_mode": self.robot_mode,
            "robot_mode_name": ROBOT_MODES.get(self.robot_mode),
            "safety_mode": self.safety_mode,
            "safety_mode_name": SAFETY_MODES.get(self.safety_mode),
            "runtime_state": self.runtime_state,
            "runtime_state_name": RUNTIME_STATES.get(self.runtime_state),
            "program": self.program_name if self.program is not None else None,
            "remote_control": self.remote_control,
            "watchdog": list(self.watchdog[:2]) if self.watchdog else None,
            "applied_force": list(self.applied_wrench),
            "tcp_force": list(self.tcp_force),
            "external_force": list(self.external_force),
            "digital_inputs": self.digital_inputs,
            "digital_outputs": self.digital_outputs,
            "counters": dict(self.counters),
            "unknown_codes": dict(self.unknown_codes),
            "out_int": self.out_int[:3],
            "in_int": self.in_int[:2],
        }


def _first(pattern: str, text: str) -> str | None:
    match = re.search(pattern, text)
    return match.group(1) if match else None


def output_accessor(name: str, width: int) -> Callable[[dict], object]:
    """A function frame -> value for one RTDE output variable of `width` values (the name
    must be in rtde_protocol.OUTPUT_TYPES). Variables with nothing simulated behind them
    read as zeros."""
    registers = {
        "output_int_register_": "_out_int",
        "output_double_register_": "_out_double",
        "input_int_register_": "_in_int",
        "input_double_register_": "_in_double",
    }
    bit_registers = {"output_bit_register_": "_out_bits", "input_bit_register_": "_in_bits"}
    for prefix, key in registers.items():
        if name.startswith(prefix):
            index = int(name[len(prefix) :])

            def register(frame: dict, key: str = key, index: int = index) -> object:
                return frame[key][index]

            return register
    for prefix, key in bit_registers.items():
        if name.startswith(prefix):
            bit = int(name[len(prefix) :])

            def bit_register(frame: dict, key: str = key, bit: int = bit) -> object:
                return bool((frame[key] >> bit) & 1)

            return bit_register
    default: object = 0 if width == 1 else (0,) * width

    def variable(frame: dict) -> object:
        return frame.get(name, default)

    return variable
