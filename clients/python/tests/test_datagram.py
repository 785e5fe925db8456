"""Realtime datagrams: protobuf bytes plus a 16-byte keyed BLAKE2b tag, at most 512
bytes; a wrong key, truncation, an oversized datagram and garbage are named errors."""

import hashlib

import pytest

from hapticd._datagram import (
    MAX_DATAGRAM_BYTES,
    TAG_BYTES,
    compute_tag,
    decode_command,
    decode_state,
    encode_command,
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
        ProtocolError, match="DeviceCommand datagram is 513 bytes; the limit is 512"
    ):
        decode_command(b"\x00" * (MAX_DATAGRAM_BYTES + 1), KEY)


def test_garbage_with_a_valid_tag_does_not_parse():
    payload = b"\xff\xff\xff"
    with pytest.raises(ProtocolError, match="DeviceCommand datagram does not parse"):
        decode_command(payload + compute_tag(KEY, payload), KEY)


def test_encoding_over_512_bytes_is_local_misuse():
    # a command with a long unknown-field tail: the state message has no big field
    big = pb.DeviceCommand(session_id=1)
    big.ParseFromString(big.SerializeToString() + b"\x9a\x05" + bytes([250, 3]) + b"x" * 506)
    with pytest.raises(
        LocalError, match=r"DeviceCommand datagram would be \d+ bytes; the limit is 512"
    ):
        encode_command(big, KEY)


def test_a_key_of_the_wrong_length_is_local_misuse():
    with pytest.raises(LocalError, match="session key is 31 bytes; it must be 32"):
        encode_state(make_state(), KEY[:31])
