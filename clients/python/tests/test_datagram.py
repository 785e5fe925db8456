"""Realtime datagrams: protobuf bytes plus a 16-byte keyed BLAKE2b tag, a state at most
512 bytes and a command (which may carry a model fragment) at most 1400; a wrong key,
truncation, an oversized datagram and garbage are named errors."""

import hashlib

import pytest

from hapticd._datagram import (
    MAX_COMMAND_BYTES,
    MAX_STATE_BYTES,
    TAG_BYTES,
    compute_tag,
    decode_command,
    decode_state,
    encode_command,
    encode_datagram,
    encode_state,
)
from hapticd.errors import LocalError, ProtocolError
from hapticd.v1 import hapticd_pb2 as pb

KEY = bytes(range(32))
OTHER_KEY = bytes(range(1, 33))


def make_state():
    return pb.DeviceState(
        session_id=7,
        sequence=42,
        send_time_ns=123456789,
        position=pb.Vec3(x=0.1, y=-0.2, z=0.3),
        velocity=pb.Vec3(x=1, y=2, z=3),
        buttons=5,
        held_force=pb.Vec3(z=1.5),
        rtt_us=80,
    )


def test_state_round_trip():
    state = make_state()
    datagram = encode_state(state, KEY)
    assert decode_state(datagram, KEY) == state


def test_command_round_trip():
    command = pb.DeviceCommand(
        session_id=7, sequence=42, echo_send_time_ns=99, force=pb.Vec3(z=2.5), contact=True
    )
    assert decode_command(encode_command(command, KEY), KEY) == command


def test_a_command_carrying_a_model_fragment_round_trips():
    data = bytes(range(256)) * 4
    command = pb.DeviceCommand(
        session_id=7,
        sequence=42,
        force=pb.Vec3(z=2.5),
        model=pb.ModelFragment(version=3, index=1, count=2, data=data),
    )
    datagram = encode_command(command, KEY)
    assert MAX_STATE_BYTES < len(datagram) <= MAX_COMMAND_BYTES
    back = decode_command(datagram, KEY)
    assert back == command and back.model.data == data


def test_the_tag_is_keyed_blake2b_16_of_the_payload():
    state = make_state()
    datagram = encode_state(state, KEY)
    payload = state.SerializeToString()
    assert datagram[:-TAG_BYTES] == payload
    assert datagram[-TAG_BYTES:] == hashlib.blake2b(payload, digest_size=16, key=KEY).digest()
    assert compute_tag(KEY, payload) == datagram[-TAG_BYTES:]


def test_a_wrong_key_does_not_verify():
    datagram = encode_state(make_state(), KEY)
    with pytest.raises(ProtocolError, match="DeviceState datagram's tag does not verify"):
        decode_state(datagram, OTHER_KEY)


def test_a_flipped_payload_bit_does_not_verify():
    datagram = bytearray(encode_state(make_state(), KEY))
    datagram[3] ^= 0x01
    with pytest.raises(ProtocolError, match="tag does not verify"):
        decode_state(bytes(datagram), KEY)


@pytest.mark.parametrize("length", [0, 1, TAG_BYTES - 1])
def test_a_datagram_shorter_than_the_tag_is_named(length):
    with pytest.raises(ProtocolError, match=f"is {length} bytes; it needs at least 16 for its tag"):
        decode_command(b"\x00" * length, KEY)


def test_a_truncated_datagram_does_not_verify():
    datagram = encode_state(make_state(), KEY)
    with pytest.raises(ProtocolError, match="tag does not verify"):
        decode_state(datagram[:-1], KEY)


def test_an_oversized_datagram_is_refused_before_the_tag():
    with pytest.raises(
        ProtocolError, match="DeviceCommand datagram is 1401 bytes; the limit is 1400"
    ):
        decode_command(b"\x00" * (MAX_COMMAND_BYTES + 1), KEY)
    with pytest.raises(ProtocolError, match="DeviceState datagram is 513 bytes; the limit is 512"):
        decode_state(b"\x00" * (MAX_STATE_BYTES + 1), KEY)


def test_a_command_over_the_state_limit_is_not_oversized():
    # 513 zero bytes: past a state's limit, so only the tag can refuse it
    with pytest.raises(ProtocolError, match="tag does not verify"):
        decode_command(b"\x00" * (MAX_STATE_BYTES + 1), KEY)


def test_garbage_with_a_valid_tag_does_not_parse():
    payload = b"\xff\xff\xff"
    with pytest.raises(ProtocolError, match="DeviceCommand datagram does not parse"):
        decode_command(payload + compute_tag(KEY, payload), KEY)


def padded(message, datagram_bytes):
    """message with an unknown field (number 99) appended, so that its datagram is
    datagram_bytes long."""
    head = message.SerializeToString()
    # key (2 bytes) and a 2-byte length before the padding
    padding = datagram_bytes - TAG_BYTES - len(head) - 4
    assert 128 <= padding < 2**14
    big = type(message)()
    length = bytes([padding & 0x7F | 0x80, padding >> 7])
    big.ParseFromString(head + b"\x9a\x06" + length + b"x" * padding)
    return big


def test_a_command_of_exactly_the_limit_encodes_and_decodes():
    command = padded(pb.DeviceCommand(session_id=1), MAX_COMMAND_BYTES)
    datagram = encode_command(command, KEY)
    assert len(datagram) == MAX_COMMAND_BYTES
    assert decode_command(datagram, KEY) == command


@pytest.mark.parametrize(
    ("message", "limit"),
    [
        (pb.DeviceCommand(session_id=1), MAX_COMMAND_BYTES),
        (pb.DeviceState(session_id=1), MAX_STATE_BYTES),
    ],
)
def test_encoding_over_the_limit_is_local_misuse(message, limit):
    # a long unknown-field tail: neither message has a field that big of its own
    name = message.DESCRIPTOR.name
    with pytest.raises(
        LocalError, match=rf"{name} datagram would be {limit + 1} bytes; the limit is {limit}"
    ):
        encode_datagram(padded(message, limit + 1), KEY)
    assert len(encode_datagram(padded(message, limit), KEY)) == limit


def test_a_key_of_the_wrong_length_is_local_misuse():
    with pytest.raises(LocalError, match="session key is 31 bytes; it must be 32"):
        encode_state(make_state(), KEY[:31])
