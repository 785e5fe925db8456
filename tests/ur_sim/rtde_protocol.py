"""RTDE protocol version 2, sans I/O: the packet framing, the message codes, the variable
type table and the packing of data packages (Universal Robots' "Real-Time Data Exchange
(RTDE) guide"). Nothing here touches a socket.

Wire format (all big-endian):

    +----------------+-----------+-------------------+
    | uint16 size    | uint8 type| payload           |   size counts the 3 header bytes
    +----------------+-----------+-------------------+

Controller replies, per request type:
    V  request_protocol_version  uint16 version          -> uint8 accepted
    v  get_urcontrol_version     (empty)                 -> uint32 major, minor, bugfix, build
    O  setup_outputs             double hz + "a,b,c"     -> uint8 recipe id + "TYPE,TYPE,..."
    I  setup_inputs              "a,b,c"                 -> uint8 recipe id (0 refused) + "TYPE,.."
    S  start / P pause           (empty)                 -> uint8 accepted
    U  data package              uint8 recipe id + values (both directions)
    M  text message              uint8 len, text, uint8 len, source, uint8 level
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

HEADER = struct.Struct(">HB")
HEADER_SIZE = HEADER.size
MAX_PACKET_SIZE = 4096  # the controller's limit on a setup request is 2048 bytes of names

REQUEST_PROTOCOL_VERSION = ord("V")
GET_URCONTROL_VERSION = ord("v")
TEXT_MESSAGE = ord("M")
DATA_PACKAGE = ord("U")
SETUP_OUTPUTS = ord("O")
SETUP_INPUTS = ord("I")
START = ord("S")
PAUSE = ord("P")

PROTOCOL_VERSION = 2

NOT_FOUND = "NOT_FOUND"
IN_USE = "IN_USE"

# struct format of each RTDE type name
TYPE_FORMATS = {
    "BOOL": "?",
    "UINT8": "B",
    "UINT32": "I",
    "UINT64": "Q",
    "INT32": "i",
    "DOUBLE": "d",
    "VECTOR3D": "3d",
    "VECTOR6D": "6d",
    "VECTOR6INT32": "6i",
    "VECTOR6UINT32": "6I",
}
# how many values a type unpacks to
TYPE_WIDTHS = {name: (int(fmt[:-1]) if len(fmt) > 1 else 1) for name, fmt in TYPE_FORMATS.items()}


def _output_types() -> dict[str, str]:
    """The controller's output variables and their types (RTDE guide, PolyScope 5.15)."""
    v6 = "VECTOR6D"
    types = {
        "timestamp": "DOUBLE",
        "target_q": v6,
        "target_qd": v6,
        "target_qdd": v6,
        "target_current": v6,
        "target_moment": v6,
        "actual_q": v6,
        "actual_qd": v6,
        "actual_qdd": v6,
        "actual_current": v6,
        "actual_current_window": v6,
        "actual_current_as_torque": v6,
        "actual_moment": v6,
        "joint_control_output": v6,
        "actual_TCP_pose": v6,
        "actual_TCP_speed": v6,
        "actual_TCP_force": v6,
        "target_TCP_pose": v6,
        "target_TCP_speed": v6,
        "actual_digital_input_bits": "UINT64",
        "joint_temperatures": v6,
        "actual_execution_time": "DOUBLE",
        "robot_mode": "INT32",
        "joint_mode": "VECTOR6INT32",
        "safety_mode": "INT32",
        "safety_status": "INT32",
        "actual_tool_accelerometer": "VECTOR3D",
        "speed_scaling": "DOUBLE",
        "target_speed_fraction": "DOUBLE",
        "actual_momentum": "DOUBLE",
        "actual_main_voltage": "DOUBLE",
        "actual_robot_voltage": "DOUBLE",
        "actual_robot_current": "DOUBLE",
        "actual_joint_voltage": v6,
        "actual_digital_output_bits": "UINT64",
        "runtime_state": "UINT32",
        "elbow_position": "VECTOR3D",
        "elbow_velocity": "VECTOR3D",
        "robot_status_bits": "UINT32",
        "safety_status_bits": "UINT32",
        "analog_io_types": "UINT32",
        "standard_analog_input0": "DOUBLE",
        "standard_analog_input1": "DOUBLE",
        "standard_analog_output0": "DOUBLE",
        "standard_analog_output1": "DOUBLE",
        "io_current": "DOUBLE",
        "euromap67_input_bits": "UINT32",
        "euromap67_output_bits": "UINT32",
        "euromap67_24V_voltage": "DOUBLE",
        "euromap67_24V_current": "DOUBLE",
        "tool_mode": "UINT32",
        "tool_analog_input_types": "UINT32",
        "tool_analog_input0": "DOUBLE",
        "tool_analog_input1": "DOUBLE",
        "tool_output_voltage": "INT32",
        "tool_output_current": "DOUBLE",
        "tool_temperature": "DOUBLE",
        "tcp_force_scalar": "DOUBLE",
        "output_bit_registers0_to_31": "UINT32",
        "output_bit_registers32_to_63": "UINT32",
        "input_bit_registers0_to_31": "UINT32",
        "input_bit_registers32_to_63": "UINT32",
        "tool_output_mode": "UINT8",
        "tool_digital_output0_mode": "UINT8",
        "tool_digital_output1_mode": "UINT8",
        "payload": "DOUBLE",
        "payload_cog": "VECTOR3D",
        "payload_inertia": v6,
        "script_control_line": "UINT32",
        "ft_raw_wrench": v6,
        "joint_position_deviation_ratio": "DOUBLE",
        "collision_detection_ratio": "DOUBLE",
        "time_scale_source": "UINT32",
    }
    for i in range(64, 128):
        types[f"output_bit_register_{i}"] = "BOOL"
        types[f"input_bit_register_{i}"] = "BOOL"
    for i in range(48):
        types[f"output_int_register_{i}"] = "INT32"
        types[f"output_double_register_{i}"] = "DOUBLE"
        types[f"input_int_register_{i}"] = "INT32"
        types[f"input_double_register_{i}"] = "DOUBLE"
    return types


def _input_types() -> dict[str, str]:
    """The controller's input variables (what a client may write) and their types."""
    types = {
        "speed_slider_mask": "UINT32",
        "speed_slider_fraction": "DOUBLE",
        "standard_digital_output_mask": "UINT8",
        "standard_digital_output": "UINT8",
        "configurable_digital_output_mask": "UINT8",
        "configurable_digital_output": "UINT8",
        "tool_digital_output_mask": "UINT8",
        "tool_digital_output": "UINT8",
        "standard_analog_output_mask": "UINT8",
        "standard_analog_output_type": "UINT8",
        "standard_analog_output_0": "DOUBLE",
        "standard_analog_output_1": "DOUBLE",
        "input_bit_registers0_to_31": "UINT32",
        "input_bit_registers32_to_63": "UINT32",
        "external_force_torque": "VECTOR6D",
    }
    for i in range(64, 128):
        types[f"input_bit_register_{i}"] = "BOOL"
    for i in range(48):
        types[f"input_int_register_{i}"] = "INT32"
        types[f"input_double_register_{i}"] = "DOUBLE"
    return types


OUTPUT_TYPES = _output_types()
INPUT_TYPES = _input_types()


class ProtocolError(Exception):
    """A peer sent bytes that are not RTDE: the connection should be closed."""


@dataclass(frozen=True)
class Packet:
    """One framed RTDE message: its type code and its payload (header stripped)."""

    kind: int
    payload: bytes


def encode(kind: int, payload: bytes = b"") -> bytes:
    """Frame a payload as one RTDE packet."""
    return HEADER.pack(HEADER_SIZE + len(payload), kind) + payload


class PacketParser:
    """Splits a byte stream into packets. feed() takes what recv() gave; packets() yields
    every complete packet; a partial one waits for more bytes. The buffer is bounded by
    MAX_PACKET_SIZE; a size field outside [3, MAX_PACKET_SIZE] raises ProtocolError."""

    def __init__(self) -> None:
        self._buffer = bytearray()

    def feed(self, data: bytes) -> list[Packet]:
        self._buffer += data
        packets = []
        while len(self._buffer) >= HEADER_SIZE:
            size, kind = HEADER.unpack_from(self._buffer)
            if size < HEADER_SIZE or size > MAX_PACKET_SIZE:
                raise ProtocolError(f"RTDE packet size {size} is outside [3, {MAX_PACKET_SIZE}]")
            if len(self._buffer) < size:
                break
            packets.append(Packet(kind, bytes(self._buffer[HEADER_SIZE:size])))
            del self._buffer[:size]
        return packets


def split_names(text: bytes) -> list[str]:
    """The comma-separated variable names of a setup request (a trailing comma, which
    ur_rtde sends, is ignored)."""
    try:
        decoded = text.decode("ascii")
    except UnicodeDecodeError as exc:
        raise ProtocolError("variable names are not ASCII") from exc
    return [name.strip() for name in decoded.split(",") if name.strip()]


class Recipe:
    """A set-up list of variables with their types and a precompiled struct.
    types holds NOT_FOUND / IN_USE entries as the controller reports them; valid is True
    only if every name was accepted."""

    def __init__(self, recipe_id: int, names: list[str], types: list[str]) -> None:
        self.recipe_id = recipe_id
        self.names = names
        self.types = types
        self.valid = all(t in TYPE_FORMATS for t in types)
        fmt = ">B" + "".join(TYPE_FORMATS[t] for t in types) if self.valid else ">B"
        self.struct = struct.Struct(fmt)
        self.widths = [TYPE_WIDTHS.get(t, 0) for t in types]

    def pack(self, values: list) -> bytes:
        """A data package body: recipe id then the flattened values, in recipe order."""
        return self.struct.pack(self.recipe_id, *values)

    def unpack(self, payload: bytes) -> dict[str, object]:
        """name -> value (a tuple for vectors) of an input data package; ProtocolError when
        its size does not match the recipe."""
        if len(payload) != self.struct.size:
            raise ProtocolError(
                f"data package for recipe {self.recipe_id} has {len(payload)} bytes, "
                f"the recipe needs {self.struct.size}"
            )
        flat = self.struct.unpack(payload)[1:]
        result: dict[str, object] = {}
        index = 0
        for name, width in zip(self.names, self.widths, strict=True):
            result[name] = flat[index] if width == 1 else flat[index : index + width]
            index += width
        return result


def decode_output_setup(payload: bytes) -> tuple[float, list[str]]:
    """(frequency in Hz, variable names) of a protocol-2 output setup request."""
    if len(payload) < 8:
        raise ProtocolError("output setup needs a frequency (8 bytes) before the names")
    (frequency,) = struct.unpack_from(">d", payload)
    return frequency, split_names(payload[8:])


def encode_setup_reply(kind: int, recipe: Recipe) -> bytes:
    """The controller's answer to a setup request: recipe id (0 when refused) and types."""
    recipe_id = recipe.recipe_id if recipe.valid else 0
    return encode(kind, bytes([recipe_id]) + ",".join(recipe.types).encode("ascii"))


def encode_version(major: int, minor: int, bugfix: int, build: int) -> bytes:
    return encode(GET_URCONTROL_VERSION, struct.pack(">IIII", major, minor, bugfix, build))


def encode_accepted(kind: int, accepted: bool) -> bytes:
    return encode(kind, bytes([1 if accepted else 0]))


def encode_text_message(text: str, source: str = "ur_sim", level: int = 1) -> bytes:
    """A protocol-2 text message (level 0 exception, 1 error, 2 warning, 3 info)."""
    message = text.encode("utf-8")[:255]
    src = source.encode("utf-8")[:255]
    return encode(
        TEXT_MESSAGE, bytes([len(message)]) + message + bytes([len(src)]) + src + bytes([level])
    )


def decode_text_message(payload: bytes) -> str:
    """The text of a client's text message (protocol 2 layout; garbage decodes leniently)."""
    if not payload:
        return ""
    length = payload[0]
    return payload[1 : 1 + length].decode("utf-8", errors="replace")
