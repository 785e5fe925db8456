"""The control channel's sans-I/O framing: frames split anywhere, several in one feed,
need-more, and the 64 MiB limit."""

import struct

import pytest

from hapticd._framing import MAX_FRAME_BYTES, FrameDecoder, encode_frame
from hapticd.errors import LocalError, ProtocolError


def test_encode_frame_prefixes_the_big_endian_length():
    assert encode_frame(b"abc") == b"\x00\x00\x00\x03abc"
    assert encode_frame(b"") == b"\x00\x00\x00\x00"


def test_whole_frames_in_one_feed_come_out_in_order():
    decoder = FrameDecoder()
    stream = encode_frame(b"one") + encode_frame(b"") + encode_frame(b"three")
    assert decoder.feed(stream) == [b"one", b"", b"three"]
    assert decoder.buffered_bytes == 0


@pytest.mark.parametrize("split", range(1, 12))
def test_a_frame_split_anywhere_is_reassembled(split):
    stream = encode_frame(b"payload") + encode_frame(b"x")
    decoder = FrameDecoder()
    first = decoder.feed(stream[:split])
    second = decoder.feed(stream[split:])
    assert first + second == [b"payload", b"x"]
    # nothing comes out before a frame is complete
    assert len(first) == (1 if split >= 11 else 0)


def test_byte_by_byte_needs_more_until_the_last_byte():
    decoder = FrameDecoder()
    frame = encode_frame(b"hello")
    for byte in frame[:-1]:
        assert decoder.feed(bytes([byte])) == []
    assert decoder.buffered_bytes == len(frame) - 1
    assert decoder.feed(frame[-1:]) == [b"hello"]


def test_a_length_over_the_limit_is_refused_naming_it():
    decoder = FrameDecoder()
    with pytest.raises(
        ProtocolError, match=r"frame length 67108865 bytes is over the 67108864-byte limit"
    ):
        decoder.feed(struct.pack(">I", MAX_FRAME_BYTES + 1))


def test_the_limit_itself_is_allowed_and_waits_for_the_payload():
    decoder = FrameDecoder()
    assert decoder.feed(struct.pack(">I", MAX_FRAME_BYTES)) == []


def test_after_a_bad_length_the_decoder_stays_broken():
    decoder = FrameDecoder(max_frame_bytes=10)
    with pytest.raises(ProtocolError):
        decoder.feed(struct.pack(">I", 11))
    with pytest.raises(ProtocolError, match="over the 10-byte limit"):
        decoder.feed(encode_frame(b"ok"))


def test_frames_before_a_bad_length_are_not_returned_once_it_raises():
    decoder = FrameDecoder(max_frame_bytes=10)
    with pytest.raises(ProtocolError):
        decoder.feed(encode_frame(b"ok") + struct.pack(">I", 1000))


def test_encoding_over_the_limit_is_local_misuse():
    with pytest.raises(LocalError, match="message is 11 bytes; a control frame holds at most 10"):
        encode_frame(b"x" * 11, max_frame_bytes=10)
