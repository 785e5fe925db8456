"""The control channel's protocol, sans I/O: requests in, bytes out; bytes in, replies
filed under their request or subscription. It never touches a socket, a thread or an
event loop: the blocking Client (_connection.py) and the AsyncClient
(_async_connection.py) are thin transports that move its bytes and wait.

Theory of operation. Each request gets the next request id and leaves as one frame
(_framing.py). Whatever the transport reads goes to receive_data, which files each
reply it completes and says what arrived (events):

    send_request(body) ──▶ (request_id n, frame bytes)            ──▶ transport writes
    receive_data(bytes) ◀── Reply{id=n, body | error}              ◀── transport reads
        ├─ n awaited       ─▶ ReplyArrived(n)      take_reply(n) gives it (once)
        ├─ n a subscription ─▶ TelemetryArrived(n) next_telemetry(n) gives the oldest
        ├─ n abandoned (its caller timed out) or an ended subscription: dropped
        └─ n never sent    ─▶ ProtocolError (and the protocol has failed)

A subscription's queue is opened before its Subscribe leaves, so no sample is missed,
and holds at most telemetry_queue_length samples (the oldest dropped). A reply the
server could not attach to a request (an Error with id 0: a frame it could not read)
answers the latest request.

States: open, failed (fail(): the first reason is kept, and every later use raises
ConnectionClosed saying it) or closed by its owner (close(): LocalError, the caller's
doing). A ProtocolError from receive_data fails the protocol with itself.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass

from google.protobuf.message import DecodeError, Message

from hapticd._framing import MAX_FRAME_BYTES, FrameDecoder, encode_frame
from hapticd.errors import ConnectionClosed, HapticdError, LocalError, ProtocolError, RemoteError
from hapticd.v1 import hapticd_pb2 as pb

# Telemetry samples kept per subscription until read; the oldest is dropped beyond.
TELEMETRY_QUEUE_LENGTH = 1024


@dataclass(frozen=True)
class ReplyArrived:
    """The reply to request_id is in: take_reply(request_id) gives it."""

    request_id: int


@dataclass(frozen=True)
class TelemetryArrived:
    """A sample (or the error ending it) of subscription_id is queued."""

    subscription_id: int


Event = ReplyArrived | TelemetryArrived


class ControlProtocol:
    """One control connection's protocol state; see the module's theory of operation.
    Not thread-safe by itself: a transport shared by threads guards it with a lock."""

    def __init__(
        self,
        max_frame_bytes: int = MAX_FRAME_BYTES,
        telemetry_queue_length: int = TELEMETRY_QUEUE_LENGTH,
    ) -> None:
        self._max_frame_bytes = max_frame_bytes
        self._telemetry_queue_length = telemetry_queue_length
        self._decoder = FrameDecoder(max_frame_bytes)
        self._next_id = 1
        self._awaited: set[int] = set()
        self._replies: dict[int, pb.Reply] = {}
        self._abandoned: set[int] = set()
        self._telemetry: dict[int, collections.deque[pb.Reply]] = {}
        self._ended_subscriptions: set[int] = set()
        self._failure: HapticdError | None = None
        self._closed = False

    # ---- state ----

    @property
    def closed(self) -> bool:
        """Whether the connection is over: failed, or closed by its owner."""
        return self._closed or self._failure is not None

    @property
    def failure(self) -> HapticdError | None:
        """Why the connection failed (the first reason given); None while open or after
        close()."""
        return self._failure

    def check_open(self) -> None:
        """Raises ConnectionClosed (saying why) when the connection failed, LocalError
        when its owner closed it."""
        if self._failure is not None:
            raise ConnectionClosed(f"the connection is closed: {self._failure}")
        if self._closed:
            raise LocalError("the connection is closed (close() was called)")

    def fail(self, failure: HapticdError) -> None:
        """Records why the connection ended; the first reason stays. Nothing after a
        close() by the owner."""
        if self._failure is None and not self._closed:
            self._failure = failure

    def close(self) -> None:
        """The owner closed the connection; later use is LocalError. Idempotent."""
        self._closed = True

    # ---- sending ----

    def send_request(
        self, body_name: str, body: Message, *, subscription: bool = False
    ) -> tuple[int, bytes]:
        """The request id and the frame of Request{body_name: body}. With subscription
        its replies are queued as telemetry from now on (next_telemetry). Raises as
        check_open does, and LocalError when the frame is over the size limit."""
        self.check_open()
        request_id = self._next_id
        request = pb.Request(request_id=request_id)
        getattr(request, body_name).CopyFrom(body)
        frame = encode_frame(request.SerializeToString(), self._max_frame_bytes)
        self._next_id += 1
        if subscription:
            self._telemetry[request_id] = collections.deque(maxlen=self._telemetry_queue_length)
        else:
            self._awaited.add(request_id)
        return request_id, frame

    # ---- receiving ----

    def receive_data(self, data: bytes) -> list[Event]:
        """Files the replies data completes and says what arrived, in order. Raises
        ProtocolError (and fails the protocol with it) on garbage."""
        events: list[Event] = []
        try:
            for frame in self._decoder.feed(data):
                event = self._file(frame)
                if event is not None:
                    events.append(event)
        except ProtocolError as exc:
            self.fail(exc)
            raise
        return events

    def take_reply(self, request_id: int) -> pb.Reply | None:
        """The reply to request_id once it is in (given once), else None."""
        reply = self._replies.pop(request_id, None)
        if reply is not None:
            self._awaited.discard(request_id)
        return reply

    def abandon(self, request_id: int) -> pb.Reply | None:
        """Its caller gave up on request_id (a timeout, a cancellation): its reply is
        dropped when it comes. Returns the reply if it is in already."""
        reply = self.take_reply(request_id)
        if reply is None and request_id in self._awaited:
            self._awaited.discard(request_id)
            self._abandoned.add(request_id)
        return reply

    def next_telemetry(self, subscription_id: int) -> pb.Reply | None:
        """The oldest queued reply (telemetry or an error) of a subscription, or None."""
        queue = self._telemetry.get(subscription_id)
        if not queue:
            return None
        return queue.popleft()

    def end_subscription(self, subscription_id: int) -> None:
        """Stops queueing a subscription's telemetry; later samples are dropped."""
        self._telemetry.pop(subscription_id, None)
        self._ended_subscriptions.add(subscription_id)

    def _file(self, frame: bytes) -> Event | None:
        """Files one reply frame under its request or subscription."""
        reply = pb.Reply()
        try:
            reply.ParseFromString(frame)
        except DecodeError as exc:
            raise ProtocolError(f"a {len(frame)}-byte reply frame does not parse: {exc}") from exc
        request_id = reply.request_id
        # an error with id 0 answers a frame the server could not read: the latest request
        if request_id == 0 and reply.HasField("error"):
            request_id = self._next_id - 1
        # telemetry (or a refusal) for a subscription
        if request_id in self._telemetry:
            if reply.WhichOneof("body") in ("telemetry", "error"):
                self._telemetry[request_id].append(reply)
                return TelemetryArrived(request_id)
            return None
        # late: a request whose caller gave up, a subscription that ended
        if request_id in self._abandoned:
            self._abandoned.discard(request_id)
            return None
        if request_id in self._ended_subscriptions:
            return None
        if request_id in self._awaited:
            self._replies[request_id] = reply
            return ReplyArrived(request_id)
        if 0 < request_id < self._next_id:
            raise ProtocolError(
                f"the server replied to request_id {request_id} again "
                f"(body {reply.WhichOneof('body')})"
            )
        raise ProtocolError(
            f"the server replied to request_id {reply.request_id}, which was never sent "
            f"(body {reply.WhichOneof('body')})"
        )


def checked(reply: pb.Reply, request: str) -> pb.Reply:
    """reply itself, or the RemoteError its Error body says (request: what was asked)."""
    if reply.WhichOneof("body") == "error":
        raise remote_error(reply.error, request)
    return reply


def remote_error(error: pb.Error, request: str) -> RemoteError:
    """A RemoteError from an Error reply: the code's short name (e.g. NOT_FOUND)."""
    try:
        code = pb.Error.Code.Name(error.code).removeprefix("CODE_")
    except ValueError:
        code = f"CODE_{error.code}"
    return RemoteError(code, error.code, error.message, request)
