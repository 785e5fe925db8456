"""Two Modbus TCP servers (pymodbus 3.16 server side, its SimDevice API), run on one asyncio
loop in a thread of their own. Every read fills the requested registers from the
controller's current state (pymodbus' SimDevice action hook), so values are never stale.

(a) The UR controller's own Modbus server (port 502 on a robot), a subset of UR's map.
    Registers are 16 bit; signed values are two's complement. Function codes 3 and 4 read
    the same registers; 6 and 16 write where marked W.

    address  content
    0        digital inputs, bits 0-15 (bit 0: the enable input, see --enable-input-bit)
    1        digital outputs, bits 0-15 (W)
    128-255  general purpose registers (W)
    256/257  controller major / minor version
    258      robot mode (3 power off, 5 idle, 7 running, ...)
    260      is power on robot          261  is protective ("security") stopped
    262      is emergency stopped       263  teach button pressed (0)
    264      power button pressed (0)   265  safety signal such that we should stop
    266      safety mode (1 normal, 3 protective stop, 7 robot emergency stop)
    270-275  joint positions, mrad      280-285  joint speeds, mrad/s
    400-402  TCP x, y, z in the base frame, 0.1 mm
    403-405  TCP rx, ry, rz, mrad
    410-412  TCP speed, mm/s            413-415  TCP angular speed, mrad/s

(b) An external force-torque sensor (a simulator convention, not a product's map):

    address  content
    0-11     Fx Fy Fz Tx Ty Tz, each a signed 32-bit integer in two registers, high word
             first (big-endian word order); FORCE_COUNTS_PER_N counts per N and
             TORQUE_COUNTS_PER_NM counts per N m (so 1 count = 1 mN / 1 mN m)
    12       tare: write 1 to zero the sensor at its current reading (W; reads 0)
    13       sample counter, +1 each controller period, wraps at 65536
    14       FORCE_COUNTS_PER_N         15  TORQUE_COUNTS_PER_NM
"""

from __future__ import annotations

import asyncio
import logging
import math
import threading

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from .controller import (
    SAFETY_NORMAL,
    SAFETY_PROTECTIVE_STOP,
    SAFETY_ROBOT_EMERGENCY_STOP,
    Controller,
)

log = logging.getLogger("ur_sim")

FORCE_COUNTS_PER_N = 1000
TORQUE_COUNTS_PER_NM = 1000
UR_REGISTER_COUNT = 512
FT_REGISTER_COUNT = 16
READ_CODES = (3, 4)


def _u16(value: float) -> int:
    """A value as an unsigned 16-bit register, two's complement, saturated to int16."""
    n = int(round(value)) if math.isfinite(value) else 0
    return max(-32768, min(32767, n)) & 0xFFFF


def ur_register_values(c: Controller) -> dict[int, int]:
    """The UR map's registers from the controller state (lock held)."""
    major, minor = c.config.version[:2]
    regs = {
        0: c.digital_inputs & 0xFFFF,
        1: c.digital_outputs & 0xFFFF,
        256: major,
        257: minor,
        258: _u16(c.robot_mode),
        260: int(c.robot_mode in (4, 5, 6, 7)),
        261: int(c.safety_mode == SAFETY_PROTECTIVE_STOP),
        262: int(c.safety_mode == SAFETY_ROBOT_EMERGENCY_STOP),
        263: 0,
        264: 0,
        265: int(c.safety_mode != SAFETY_NORMAL),
        266: _u16(c.safety_mode),
    }
    pose = c.arm.pose()
    for i, q in enumerate(c.arm.joints()):
        regs[270 + i] = _u16(q * 1000.0)
    for i, qd in enumerate(c.arm.joint_speeds()):
        regs[280 + i] = _u16(qd * 1000.0)
    for i in range(3):
        regs[400 + i] = _u16(pose[i] * 10000.0)
        regs[403 + i] = _u16(pose[3 + i] * 1000.0)
        regs[410 + i] = _u16(c.arm.v[i] * 1000.0)
        regs[413 + i] = 0
    return regs


def ft_register_values(c: Controller) -> dict[int, int]:
    """The force-torque sensor's registers from the controller state (lock held)."""
    regs = {12: 0, 13: c.external_samples, 14: FORCE_COUNTS_PER_N, 15: TORQUE_COUNTS_PER_NM}
    for i, value in enumerate(c.external_force):
        scale = FORCE_COUNTS_PER_N if i < 3 else TORQUE_COUNTS_PER_NM
        n = int(round(value * scale)) if math.isfinite(value) else 0
        n = max(-(1 << 31), min((1 << 31) - 1, n)) & 0xFFFFFFFF
        regs[2 * i] = n >> 16
        regs[2 * i + 1] = n & 0xFFFF
    return regs


async def _while_silent(controller: Controller, device: str) -> None:
    """Holds a request unanswered while the device is silenced (fault modbus_silence)."""
    while device in controller.silent_modbus:
        await asyncio.sleep(0.005)


def _ur_action(controller: Controller):
    async def action(function_code, start_address, address, count, registers, set_values):
        await _while_silent(controller, "ur")
        with controller.lock:
            if set_values is not None:
                for offset in range(count):
                    a = address + offset
                    if not (a == 1 or 128 <= a <= 255):
                        return ExcCodes.ILLEGAL_ADDRESS
                if address <= 1 < address + count:
                    controller.digital_outputs = int(set_values[1 - address])
                return None
            values = ur_register_values(controller)
            for a in range(address, address + count):
                if a in values:
                    registers[a - start_address] = values[a]
        return None

    return action


def _ft_action(controller: Controller):
    async def action(function_code, start_address, address, count, registers, set_values):
        await _while_silent(controller, "ft")
        with controller.lock:
            if set_values is not None:
                if address != 12 or count != 1:
                    return ExcCodes.ILLEGAL_ADDRESS
                if int(set_values[0]) == 1:
                    controller.external_sensor.zero(controller.applied_wrench, controller.t)
                    controller.event("external_sensor_tare")
                set_values[0] = 0
                return None
            values = ft_register_values(controller)
            for a in range(address, address + count):
                if a in values:
                    registers[a - start_address] = values[a]
        return None

    return action


class ModbusServers:
    """Both servers on one event loop thread. start() blocks until both listen and
    returns their ports (a port of 0 picks a free one)."""

    def __init__(self, controller: Controller, host: str, ur_port: int, ft_port: int) -> None:
        self._controller = controller
        self._host = host
        self._wanted = (ur_port, ft_port)
        self._loop = asyncio.new_event_loop()
        self._servers: list[ModbusTcpServer] = []
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self.ports: tuple[int, int] = (0, 0)
        self._thread = threading.Thread(target=self._run, name="modbus", daemon=True)

    def start(self, timeout_s: float = 10.0) -> tuple[int, int]:
        self._thread.start()
        if not self._ready.wait(timeout_s):
            raise RuntimeError("the Modbus servers did not start listening in time")
        if self._error is not None:
            raise RuntimeError(
                f"the Modbus servers could not start: {self._error}"
            ) from self._error
        return self.ports

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._listen())
        except BaseException as exc:  # reported to start()
            self._error = exc
            self._ready.set()
            return
        self._ready.set()
        self._loop.run_forever()

    async def _listen(self) -> None:
        c = self._controller
        devices = (
            SimDevice(
                0,
                simdata=[
                    SimData(0, count=UR_REGISTER_COUNT, values=0, datatype=DataType.REGISTERS)
                ],
                action=_ur_action(c),
            ),
            SimDevice(
                0,
                simdata=[
                    SimData(0, count=FT_REGISTER_COUNT, values=0, datatype=DataType.REGISTERS)
                ],
                action=_ft_action(c),
            ),
        )
        ports = []
        for device, port in zip(devices, self._wanted, strict=True):
            server = ModbusTcpServer(device, address=(self._host, port))
            await server.serve_forever(background=True)
            self._servers.append(server)
            listening = server.transport.sockets  # type: ignore[attr-defined]  # an asyncio.Server
            ports.append(listening[0].getsockname()[1])
        self.ports = (ports[0], ports[1])

    def stop(self) -> None:
        async def shutdown() -> None:
            for server in self._servers:
                await server.shutdown()

        if self._loop.is_running():
            future = asyncio.run_coroutine_threadsafe(shutdown(), self._loop)
            try:
                future.result(timeout=5.0)
            except Exception:  # closing anyway
                log.warning("Modbus servers did not shut down cleanly")
            self._loop.call_soon_threadsafe(self._loop.stop)
