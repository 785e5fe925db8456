"""Control-channel framing, sans I/O: each frame is a 4-byte big-endian length followed by
that many bytes (one protobuf Request or Reply). Frames over 64 MiB are refused.

The decoder never touches a socket: feed it whatever bytes arrived and it returns the
frames those bytes complete, keeping any partial frame for the next feed (need more).
A length over the limit is a ProtocolError and leaves the decoder broken: the stream
can no longer be resynchronised, so every later feed raises the same error.
"""

from __future__ import annotations

import struct

from hapticd.errors import LocalError, ProtocolError

MAX_FRAME_BYTES = 64 * 1024 * 1024
HEADER = struct.Struct(">I")


def encode_frame(payload: bytes, max_frame_bytes: int = MAX_FRAME_BYTES) -> bytes:
    """The frame carrying payload: its length (big-endian uint32) then the payload.
    Raises LocalError when the payload is over max_frame_bytes."""
    if len(payload) > max_frame_bytes:
        raise LocalError(
            f"message is {len(payload)} bytes; a control frame holds at most {max_frame_bytes}"
        )
    return HEADER.pack(len(payload)) + payload


class FrameDecoder:
    """Splits a byte stream into frames; bounded: it buffers at most one frame."""

    def __init__(self, max_frame_bytes: int = MAX_FRAME_BYTES) -> None:
        self._max_frame_bytes = max_frame_bytes
        self._buffer = bytearray()
        self._error: ProtocolError | None = None

    @property
    def buffered_bytes(self) -> int:
        """Bytes received that do not yet make a whole frame."""
        return len(self._buffer)

    def feed(self, data: bytes) -> list[bytes]:
        """Adds data and returns the payloads of the frames it completes, in order (an
        empty list: need more). Raises ProtocolError on a length over the limit."""
        if self._error is not None:
            raise self._error
        self._buffer += data
        frames: list[bytes] = []
        start = 0
        # take whole frames from the front; stop at a partial header or payload
        while len(self._buffer) - start >= HEADER.size:
            (length,) = HEADER.unpack_from(self._buffer, start)
            if length > self._max_frame_bytes:
                self._error = ProtocolError(
                    f"frame length {length} bytes is over the {self._max_frame_bytes}-byte limit"
                )
                self._buffer.clear()
                raise self._error
            end = start + HEADER.size + length
            if end > len(self._buffer):
                break
            frames.append(bytes(self._buffer[start + HEADER.size : end]))
            start = end
        # drop what was consumed once, not per frame
        if start:
            del self._buffer[:start]
        return frames
