"""Realtime-channel datagrams, sans I/O: the protobuf encoding of one DeviceState or
DeviceCommand followed by a 16-byte tag, keyed BLAKE2b (digest 16 bytes) of the encoded
message under the session's 32-byte key. A state (device to server) is at most 512 bytes;
a command (server to device) at most 1400, since it may carry a fragment of a local model.

encode_* raise LocalError (the caller built something unsendable); decode_* raise
ProtocolError naming what is wrong with what arrived (too short, too long, a tag that
does not verify, bytes that do not parse).
"""

from __future__ import annotations

import hashlib
import hmac
from typing import TypeVar

from google.protobuf.message import DecodeError, Message

from hapticd.errors import LocalError, ProtocolError
from hapticd.v1 import hapticd_pb2 as pb

TAG_BYTES = 16
KEY_BYTES = 32
# Whole datagrams, tag included. A command may carry a local model's fragment (up to
# 1024 bytes of it), so it gets the larger limit, still under Ethernet's 1472-byte UDP
# payload; the server drops a state over 512 bytes as oversized.
MAX_STATE_BYTES = 512
MAX_COMMAND_BYTES = 1400

MessageT = TypeVar("MessageT", bound=Message)


def max_datagram_bytes(message_type: type[Message]) -> int:
    """The size limit of a datagram carrying message_type: MAX_COMMAND_BYTES for a
    DeviceCommand, MAX_STATE_BYTES for anything else."""
    return MAX_COMMAND_BYTES if message_type is pb.DeviceCommand else MAX_STATE_BYTES


def compute_tag(key: bytes, payload: bytes) -> bytes:
    """The 16-byte keyed BLAKE2b tag of payload under key (32 bytes)."""
    return hashlib.blake2b(payload, digest_size=TAG_BYTES, key=key).digest()


def _check_key(key: bytes) -> None:
    if len(key) != KEY_BYTES:
        raise LocalError(f"session key is {len(key)} bytes; it must be {KEY_BYTES}")


def encode_datagram(message: Message, key: bytes) -> bytes:
    """message's encoding followed by its tag. Raises LocalError for a key that is not
    32 bytes or a datagram over its limit (max_datagram_bytes)."""
    _check_key(key)
    payload = message.SerializeToString()
    limit = max_datagram_bytes(type(message))
    if len(payload) + TAG_BYTES > limit:
        raise LocalError(
            f"{message.DESCRIPTOR.name} datagram would be {len(payload) + TAG_BYTES} bytes; "
            f"the limit is {limit}"
        )
    return payload + compute_tag(key, payload)


def decode_datagram(datagram: bytes, key: bytes, message_type: type[MessageT]) -> MessageT:
    """The message_type a datagram carries, after its tag verifies (constant-time
    compare). Raises ProtocolError naming the problem: under 16 bytes or over
    message_type's limit (max_datagram_bytes), a tag mismatch, bytes that do not parse
    as message_type."""
    _check_key(key)
    name = message_type.DESCRIPTOR.name
    limit = max_datagram_bytes(message_type)
    if len(datagram) > limit:
        raise ProtocolError(f"{name} datagram is {len(datagram)} bytes; the limit is {limit}")
    if len(datagram) < TAG_BYTES:
        raise ProtocolError(
            f"{name} datagram is {len(datagram)} bytes; it needs at least {TAG_BYTES} for its tag"
        )
    payload, tag = datagram[:-TAG_BYTES], datagram[-TAG_BYTES:]
    if not hmac.compare_digest(tag, compute_tag(key, payload)):
        raise ProtocolError(f"{name} datagram's tag does not verify under the session key")
    message = message_type()
    try:
        message.ParseFromString(payload)
    except DecodeError as exc:
        raise ProtocolError(f"{name} datagram does not parse: {exc}") from exc
    return message


def encode_state(state: pb.DeviceState, key: bytes) -> bytes:
    """A DeviceState datagram (device to server)."""
    return encode_datagram(state, key)


def decode_command(datagram: bytes, key: bytes) -> pb.DeviceCommand:
    """The DeviceCommand of a datagram from the server; see decode_datagram."""
    return decode_datagram(datagram, key, pb.DeviceCommand)


def decode_state(datagram: bytes, key: bytes) -> pb.DeviceState:
    """The DeviceState of a datagram (what the server decodes; for tests and tools)."""
    return decode_datagram(datagram, key, pb.DeviceState)


def encode_command(command: pb.DeviceCommand, key: bytes) -> bytes:
    """A DeviceCommand datagram (what the server sends; for tests and tools)."""
    return encode_datagram(command, key)
