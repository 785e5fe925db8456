"""Emulation of the URScript that ur_rtde 1.6.5 uploads (`def rtde_control():`, embedded in
librtde): one main-loop iteration per controller period, reading the command registers
ur_rtde writes over RTDE and answering through the output registers.

Register protocol (register numbers plus the script's reg_offset, 0 or 24):

    input_int_register_0       command code (0 = none; table below)
    input_int_register_1..7    integer arguments (async flag, selection vector, steps)
    input_double_register_0..  double arguments (pose, speed, acceleration, time, ...)
    output_int_register_0      script state: 1 ready for a command, 2 done with a command
    output_int_register_1      integer results (isSteady, is...WithinSafetyLimits)
    output_int_register_2      async progress: op id << 24 | write count << 16 | running << 15
                               | progress
    output_double_register_0.. double results (getStepTime, getTCPOffset, flange pose)

Handshake, as the script's main loop:

    real-time commands (servoL 24, servoJ 11, speedL 10, speedJ 9, forceMode 6, getters
    25 26 27 38 58, direct torque and newer 66-71): process every period while the
    register holds the code, then write ready (1). ur_rtde does not wait for them.

    other commands: process once (executing_cmd), then write done (2); ur_rtde then
    writes 0, and the script answers ready (1). A blocking motion (stopL, servoStop, a
    synchronous moveL) keeps the main loop inside process_cmd until the arm is at rest.

    255: stop the script; the program ends (runtime state stopped).

Supported here: moveL (3), forceModeStop (7, stops the arm), zeroFtSensor (8), speedL (10),
speedStop (15), servoStop (16), setPayload (17), servoL (24), getStepTime (26), setTcp (29),
triggerProtectiveStop (31), stopL (33), stopJ (34), setWatchdog (35), isPoseWithinSafety-
Limits (36), isJointsWithinSafetyLimits (37), getTCPOffset (40), isSteady (47),
getActualToolFlangePose (58), stop script (255). Any other code is logged, counted as
unknown and answered (ready or done) so that ur_rtde does not hang.
"""

from __future__ import annotations

import math

READY = 1
DONE = 2

REALTIME_COMMANDS = frozenset({24, 11, 9, 10, 6, 25, 26, 27, 38, 58, 66, 67, 68, 69, 70, 71})
STOP_SCRIPT = 255

COMMAND_NAMES = {
    1: "moveJ",
    2: "moveJ_IK",
    3: "moveL",
    4: "moveL_FK",
    6: "forceMode",
    7: "forceModeStop",
    8: "zeroFtSensor",
    9: "speedJ",
    10: "speedL",
    11: "servoJ",
    12: "servoC",
    15: "speedStop",
    16: "servoStop",
    17: "setPayload",
    18: "teachMode",
    19: "endTeachMode",
    24: "servoL",
    25: "toolContact",
    26: "getStepTime",
    27: "getActualJointPositionsHistory",
    29: "setTcp",
    30: "getInverseKinematics",
    31: "triggerProtectiveStop",
    33: "stopL",
    34: "stopJ",
    35: "setWatchdog",
    36: "isPoseWithinSafetyLimits",
    37: "isJointsWithinSafetyLimits",
    38: "getJointTorques",
    39: "poseTrans",
    40: "getTCPOffset",
    47: "isSteady",
    58: "getActualToolFlangePose",
    255: "stopScript",
}


class ControlScript:
    """The running `rtde_control` program. host is the controller: it owns the registers
    (in_int, in_double, out_int, out_double), the arm, and the actions the script calls
    (zero_ft_sensor, set_watchdog, raise_protective_stop, event, count_unknown)."""

    def __init__(self, host, reg_offset_int: int, reg_offset_float: int) -> None:
        self.host = host
        self.off_i = reg_offset_int
        self.off_f = reg_offset_float
        self.running = True
        self.executing_cmd = False
        self.blocking_cmd: int | None = None  # a command waiting for the arm to stop
        self.is_servoing = False
        self.is_speeding = False
        self.async_stop_running = False
        self.async_move_running = False
        self.async_wr_count = 0
        self.async_op_id = 0
        self.tcp_offset = [0.0] * 6
        # the main loop's preamble: reset_async_progress(); signal_ready()
        self._write_async_progress(-1)
        self._out_i(0, READY)

    # --- register access, with the script's offsets ----------------------------------
    def _in_i(self, index: int) -> int:
        return self.host.in_int[index + self.off_i]

    def _in_f(self, index: int) -> float:
        return self.host.in_double[index + self.off_f]

    def _out_i(self, index: int, value: int) -> None:
        self.host.out_int[index + self.off_i] = value

    def _out_f(self, index: int, value: float) -> None:
        self.host.out_double[index + self.off_f] = value

    def _pose_in(self, index: int) -> list[float]:
        return [self._in_f(index + i) for i in range(6)]

    def _pose_out(self, index: int, values) -> None:
        for i, value in enumerate(values):
            self._out_f(index + i, float(value))

    def _write_async_progress(self, value: int) -> None:
        """write_async_progress_register() of the script, bit for bit."""
        self.async_wr_count = 0 if self.async_wr_count + 1 > 127 else self.async_wr_count + 1
        if value == 0:
            self.async_op_id = 0 if self.async_op_id + 1 > 127 else self.async_op_id + 1
        reg = self.async_wr_count * 65536 + self.async_op_id * 16777216
        if value >= 0:
            reg += min(value, 32767) + 32768
        self._out_i(2, reg)

    # --- one period of the main loop ----------------------------------------------
    def step(self) -> None:
        """One iteration of `while keep_running: ... sync()`."""
        if not self.running:
            return
        arm = self.host.arm
        if self.async_stop_running and arm.at_rest:
            self.async_stop_running = False
            self._write_async_progress(-1)
        if self.async_move_running and arm.mode != "linear":
            self.async_move_running = False
            self._write_async_progress(-1)
        if self.blocking_cmd is not None:
            # still inside process_cmd: the motion it started must finish first
            if not arm.at_rest:
                return
            self.host.event("command_done", command=COMMAND_NAMES.get(self.blocking_cmd))
            self.blocking_cmd = None
            self._out_i(0, DONE)
            return
        cmd = self._in_i(0)
        if cmd in REALTIME_COMMANDS:
            self._process(cmd)
            self._out_i(0, READY)
        elif cmd == 0:
            self.executing_cmd = False
            self._out_i(0, READY)
        elif not self.executing_cmd:
            self.executing_cmd = True
            if not self._process(cmd):
                self.running = False
                self.host.event("script_stopped", reason="stop script command")
                self.host.program_ended("stop script command")

    def _finish(self, cmd: int, blocking: bool) -> None:
        """End of process_cmd: signal done now, or once the arm is at rest."""
        if blocking and not self.host.arm.at_rest:
            self.blocking_cmd = cmd
        else:
            self._out_i(0, DONE)

    def _process(self, cmd: int) -> bool:
        """process_cmd(cmd); False when the script must end (255)."""
        host = self.host
        arm = host.arm
        if cmd == 24:  # servoL
            target = self._pose_in(0)
            lookahead = self._in_f(9)
            gain = self._in_f(10)
            if all(math.isfinite(x) for x in target[:3]):
                arm.servo((target[0], target[1], target[2]), lookahead, gain)
                self.is_servoing = True
            host.servo_processed(target, lookahead, gain)
        elif cmd == 10:  # speedL
            xd = self._pose_in(0)
            arm.speed((xd[0], xd[1], xd[2]), self._in_f(6))
            self.is_speeding = True
        elif cmd == 26:  # getStepTime
            self._out_f(0, host.period_s)
        elif cmd == 58:  # getActualToolFlangePose (the tool offset is zero)
            self._pose_out(0, arm.pose())
        elif cmd in REALTIME_COMMANDS:
            host.count_unknown(cmd)
        elif cmd == 16:  # servoStop
            decel = self._in_f(0)
            self.is_servoing = False
            arm.stop(decel)
            host.command_seen("servoStop", deceleration=decel)
            self._finish(cmd, blocking=True)
        elif cmd == 15:  # speedStop
            decel = self._in_f(0)
            self.is_speeding = False
            arm.stop(decel)
            host.command_seen("speedStop", deceleration=decel)
            self._finish(cmd, blocking=True)
        elif cmd in (33, 34):  # stopL, stopJ; a stopJ deceleration (rad/s^2) is used as m/s^2
            decel = self._in_f(0)
            asynchronous = self._in_i(1) == 1
            arm.stop(decel)
            host.command_seen(
                "stopL" if cmd == 33 else "stopJ", deceleration=decel, asynchronous=asynchronous
            )
            if asynchronous:
                self.async_stop_running = True
                self._write_async_progress(0)
            self._finish(cmd, blocking=not asynchronous)
        elif cmd == 7:  # forceModeStop: end_force_mode(); stopl(10)
            arm.stop(10.0)
            self._finish(cmd, blocking=True)
        elif cmd == 3:  # moveL
            pose = self._pose_in(0)
            asynchronous = self._in_i(1) == 1
            arm.move_linear((pose[0], pose[1], pose[2]), self._in_f(6), self._in_f(7))
            host.command_seen("moveL", target=pose[:3], asynchronous=asynchronous)
            if asynchronous:
                self.async_move_running = True
                self._write_async_progress(0)
            self._finish(cmd, blocking=not asynchronous)
        elif cmd == 8:  # zeroFtSensor
            host.zero_ft_sensor()
            self._finish(cmd, blocking=False)
        elif cmd == 17:  # setPayload
            host.set_payload(self._in_f(0), [self._in_f(1), self._in_f(2), self._in_f(3)])
            self._finish(cmd, blocking=False)
        elif cmd == 29:  # setTcp: recorded; poses stay those of the TCP
            self.tcp_offset = self._pose_in(0)
            self._finish(cmd, blocking=False)
        elif cmd == 31:  # triggerProtectiveStop
            host.raise_protective_stop("triggerProtectiveStop")
            self._finish(cmd, blocking=False)
        elif cmd == 35:  # setWatchdog
            host.set_watchdog(f"input_int_register_{self.off_i}", self._in_f(0))
            self._finish(cmd, blocking=False)
        elif cmd in (36, 37):  # is...WithinSafetyLimits: everything is within limits
            self._out_i(1, 1)
            self._finish(cmd, blocking=False)
        elif cmd == 40:  # getTCPOffset
            self._pose_out(0, self.tcp_offset)
            self._finish(cmd, blocking=False)
        elif cmd == 47:  # isSteady
            self._out_i(1, 1 if arm.at_rest else 0)
            self._finish(cmd, blocking=False)
        elif cmd == STOP_SCRIPT:
            arm.stop(host.arm.limits.safety_stop_decel)
            return False
        else:
            host.count_unknown(cmd)
            self._finish(cmd, blocking=False)
        return True
