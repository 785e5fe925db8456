"""What the UR bridge reads over Modbus (pymodbus): an external force–torque sensor's
force, and the UR controller's own Modbus server's digital inputs (an enable, dead-man,
input that must be held for the arm to move).

A sensor's registers are described by a RegisterMap, read from a small JSON file:

    {"function": "holding",            // or "input": read holding or input registers
     "device_id": 9,                   // the Modbus unit (slave) id
     "word_order": "big",              // for 32-bit types: which register comes first
     "frame": "tool",                  // the force's frame: the tool's or the base's
     "axes": [{"address": 180, "type": "int16", "scale": 0.01},   // Fx: N = raw * scale
              {"address": 181, "type": "int16", "scale": 0.01},   // Fy
              {"address": 182, "type": "int16", "scale": 0.01}]}  // Fz

The default, ROBOTIQ_FT300, is the layout of Robotiq's FT 300 sensor (holding registers
180–182, signed 16-bit, hundredths of a newton, unit 9). A sensor on the wrist reads in
the tool frame; the bridge turns its force into the base frame with the TCP's
orientation. Types: int16, uint16, int32, uint32, float32. The registers asked for must
span at most MAX_SPAN registers (one request a sample).

The bridge reads both through a Poller, a thread of its own that reads at the robot's
rate: the control loop takes the newest reading without waiting on the bus (a Modbus
RTU read at 19200 baud takes about 10 ms, longer than a 500 Hz period), and a device
that stops answering is noticed by the age of its newest reading.
"""

from __future__ import annotations

import json
import math
import pathlib
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np

from hapticd._validate import FloatArray
from hapticd.errors import HapticdError, LocalError

MAX_SPAN = 64
TYPE_REGISTERS = {"int16": 1, "uint16": 1, "int32": 2, "uint32": 2, "float32": 2}


@dataclass(frozen=True)
class Axis:
    address: int
    type: str
    scale: float


@dataclass(frozen=True)
class RegisterMap:
    """Where a sensor keeps Fx, Fy, Fz (see the module's docstring)."""

    axes: tuple[Axis, Axis, Axis]
    function: str = "holding"
    device_id: int = 1
    word_order: str = "big"
    frame: str = "tool"

    def __post_init__(self) -> None:
        if self.function not in ("holding", "input"):
            raise LocalError(f"function is {self.function!r}; it must be 'holding' or 'input'")
        if not 0 <= self.device_id <= 247:
            raise LocalError(f"device_id is {self.device_id!r}; it must be in [0, 247]")
        if self.word_order not in ("big", "little"):
            raise LocalError(f"word_order is {self.word_order!r}; it must be 'big' or 'little'")
        if self.frame not in ("tool", "base"):
            raise LocalError(f"frame is {self.frame!r}; it must be 'tool' or 'base'")
        for name, axis in zip(("Fx", "Fy", "Fz"), self.axes, strict=True):
            if axis.type not in TYPE_REGISTERS:
                raise LocalError(
                    f"{name}'s type is {axis.type!r}; it must be one of {sorted(TYPE_REGISTERS)}"
                )
            if not 0 <= axis.address <= 65535:
                raise LocalError(f"{name}'s address is {axis.address!r}; it must be in [0, 65535]")
            if not (math.isfinite(axis.scale) and axis.scale != 0):
                raise LocalError(f"{name}'s scale is {axis.scale!r}; it must be finite and not 0")
        if self.span[1] > MAX_SPAN:
            raise LocalError(
                f"the axes span {self.span[1]} registers from {self.span[0]}; at most {MAX_SPAN}"
            )

    @property
    def span(self) -> tuple[int, int]:
        """The first register and how many to read, to get every axis in one request."""
        first = min(axis.address for axis in self.axes)
        end = max(axis.address + TYPE_REGISTERS[axis.type] for axis in self.axes)
        return first, end - first

    def decode(self, registers: list[int]) -> FloatArray:
        """Fx, Fy, Fz (N) from the registers of span."""
        first, count = self.span
        if len(registers) != count:
            raise HapticdError(f"the sensor answered {len(registers)} registers; asked {count}")
        force = np.empty(3)
        for i, axis in enumerate(self.axes):
            words = registers[
                axis.address - first : axis.address - first + TYPE_REGISTERS[axis.type]
            ]
            force[i] = _value(words, axis.type, self.word_order) * axis.scale
        return force

    @staticmethod
    def from_json(data: Any, source: str) -> RegisterMap:
        """A map from parsed JSON (source names it in errors)."""
        known = {"function", "device_id", "word_order", "frame", "axes"}
        if not isinstance(data, dict):
            raise LocalError(f"{source}: a register map is a JSON object")
        unknown = sorted(set(data) - known)
        if unknown:
            raise LocalError(f"{source}: unknown key(s) {unknown}; known: {sorted(known)}")
        axes = data.get("axes")
        if not (isinstance(axes, list) and len(axes) == 3):
            raise LocalError(f"{source}: 'axes' must list three axes (Fx, Fy, Fz)")
        try:
            parsed = tuple(
                Axis(address=int(a["address"]), type=str(a["type"]), scale=float(a["scale"]))
                for a in axes
            )
            return RegisterMap(
                axes=(parsed[0], parsed[1], parsed[2]),
                function=str(data.get("function", "holding")),
                device_id=int(data.get("device_id", 1)),
                word_order=str(data.get("word_order", "big")),
                frame=str(data.get("frame", "tool")),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise LocalError(f"{source}: each axis needs address, type and scale ({exc})") from exc

    @staticmethod
    def read(path: str) -> RegisterMap:
        try:
            data = json.loads(pathlib.Path(path).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise LocalError(f"--modbus-map {path!r}: {exc}") from exc
        return RegisterMap.from_json(data, f"--modbus-map {path!r}")


def _value(words: list[int], kind: str, word_order: str) -> float:
    """One register value (a word or two) as a number."""
    if kind == "uint16":
        return float(words[0])
    if kind == "int16":
        return float(words[0] - 65536 if words[0] >= 32768 else words[0])
    high, low = (words[0], words[1]) if word_order == "big" else (words[1], words[0])
    raw = (high << 16) | low
    if kind == "uint32":
        return float(raw)
    if kind == "int32":
        return float(raw - 2**32 if raw >= 2**31 else raw)
    return float(np.frombuffer(raw.to_bytes(4, "big"), dtype=">f4")[0])


ROBOTIQ_FT300 = RegisterMap(
    axes=(Axis(180, "int16", 0.01), Axis(181, "int16", 0.01), Axis(182, "int16", 0.01)),
    function="holding",
    device_id=9,
)


def modbus_client(endpoint: str, timeout_s: float) -> Any:
    """A connected pymodbus client: HOST:PORT for Modbus TCP, or a serial device path
    (starting with /) for Modbus RTU at 19200 8N1 (the FT 300's). HapticdError when it
    does not connect."""
    from pymodbus.client import ModbusSerialClient, ModbusTcpClient

    from hapticd._connection import parse_address

    client: Any
    if endpoint.startswith("/"):
        client = ModbusSerialClient(endpoint, baudrate=19200, timeout=timeout_s, retries=0)
    else:
        host, port = parse_address(endpoint, "the Modbus endpoint")
        client = ModbusTcpClient(host, port=port, timeout=timeout_s, retries=0)
    if not client.connect():
        raise HapticdError(f"the Modbus device at {endpoint} did not answer")
    return client


class ModbusForceSource:
    """An external force–torque sensor: read() gives Fx, Fy, Fz (N, the map's frame)."""

    def __init__(self, endpoint: str, register_map: RegisterMap, timeout_s: float = 0.05) -> None:
        self.map = register_map
        self.endpoint = endpoint
        self._client = modbus_client(endpoint, timeout_s)
        self._first, self._count = register_map.span

    def read(self) -> FloatArray:
        read = (
            self._client.read_holding_registers
            if self.map.function == "holding"
            else self._client.read_input_registers
        )
        try:
            answer = read(self._first, count=self._count, device_id=self.map.device_id)
        except Exception as exc:  # pymodbus raises its own ModbusException family
            raise HapticdError(f"reading the sensor at {self.endpoint} failed: {exc}") from exc
        if answer.isError():
            raise HapticdError(f"the sensor at {self.endpoint} refused the read: {answer}")
        return self.map.decode(list(answer.registers))

    def close(self) -> None:
        self._client.close()


class EnableInput:
    """A digital input of the UR controller's Modbus server (register 0: the control
    box's inputs, bit i: input i) that a person holds for the arm to move."""

    def __init__(self, endpoint: str, bit: int, timeout_s: float = 0.05) -> None:
        if not 0 <= bit <= 15:
            raise LocalError(f"--enable-input is {bit!r}; it must be a digital input in [0, 15]")
        self.bit = bit
        self.endpoint = endpoint
        self._client = modbus_client(endpoint, timeout_s)

    def held(self) -> bool:
        try:
            answer = self._client.read_holding_registers(0, count=1, device_id=255)
        except Exception as exc:  # pymodbus raises its own ModbusException family
            raise HapticdError(
                f"reading the enable input at {self.endpoint} failed: {exc}"
            ) from exc
        if answer.isError():
            raise HapticdError(f"the robot's Modbus server refused the read: {answer}")
        return bool((answer.registers[0] >> self.bit) & 1)

    def close(self) -> None:
        self._client.close()


T = TypeVar("T")


class Poller(Generic[T]):
    """Reads a device in a thread of its own every period_s (or as fast as it answers,
    when slower) and keeps the newest reading. latest(max_age_s) gives it, or raises
    HapticdError naming the device when no reading is that recent: it stopped answering
    (the last error is in the message) or answers too slowly."""

    def __init__(self, read: Callable[[], T], period_s: float, name: str) -> None:
        self.name = name
        self._read = read
        self._period_s = period_s
        self._lock = threading.Lock()
        self._value: T | None = None
        self._stamp_ns = 0
        self._error = ""
        self._stopping = threading.Event()
        # the first reading in the caller's thread: a device that cannot be read at all
        # is refused before anything moves
        self._store(read())
        self._thread = threading.Thread(target=self._run, name=f"poll {name}", daemon=True)
        self._thread.start()

    def _store(self, value: T) -> None:
        with self._lock:
            self._value, self._stamp_ns, self._error = value, time.monotonic_ns(), ""

    def _run(self) -> None:
        next_ns = time.monotonic_ns()
        while not self._stopping.is_set():
            try:
                self._store(self._read())
            except HapticdError as exc:
                with self._lock:
                    self._error = str(exc)
            # paced against absolute deadlines; one late read does not bunch the next
            next_ns = max(next_ns + int(self._period_s * 1e9), time.monotonic_ns())
            self._stopping.wait(max(0.0, (next_ns - time.monotonic_ns()) * 1e-9))

    def latest(self, max_age_s: float) -> T:
        with self._lock:
            value, stamp_ns, error = self._value, self._stamp_ns, self._error
        age_s = (time.monotonic_ns() - stamp_ns) * 1e-9
        if value is None or age_s > max_age_s:
            why = f": {error}" if error else ""
            raise HapticdError(
                f"no reading from {self.name} for {age_s * 1e3:.0f} ms "
                f"(at most {max_age_s * 1e3:.0f} ms){why}"
            )
        return value

    def close(self) -> None:
        """Stops the thread (it ends within one read's timeout)."""
        self._stopping.set()
        self._thread.join(timeout=1.0)
