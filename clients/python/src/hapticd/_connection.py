"""One control-channel connection: a TCP socket (TLS off loopback), the frame codec and
the matching of replies to requests.

Theory of operation. A request is sent whole, then its thread waits until the Reply
carrying its id has arrived:

    client ── Request{id=n, body} ──────────────▶ server
           ◀── Reply{id=s, telemetry} ────────── (s: an open subscription; queued)
           ◀── Reply{id=n, body | error} ─────── (the answer; an Error raises RemoteError)

Telemetry of open subscriptions can arrive at any time and is queued per subscription
(bounded; the oldest sample is dropped when full) until the subscriber asks for it. A
reply to a request that timed out is dropped when it arrives late. Everything blocks
with an explicit timeout.

Threads may share a connection. Frames go out whole, one at a time (the send lock).
Of the threads waiting for something, one at a time reads the socket and files every
reply it completes under its request or subscription, then wakes the others, who look
for theirs (the state condition guards the tables, the reading flag says a thread is
reading). Socket calls are never made concurrently (the I/O lock), so a TLS socket is
safe too.

When the connection fails (the server hangs up, garbage arrives), the failure is kept:
whoever waits, and every later call, gets a ConnectionClosed that says what happened.
LocalError is for close() having been called, which is the caller's doing.
"""

from __future__ import annotations

import collections
import ipaddress
import select
import socket
import ssl
import threading
import time
from collections.abc import Callable

from google.protobuf.message import DecodeError, Message

from hapticd._framing import MAX_FRAME_BYTES, FrameDecoder, encode_frame
from hapticd.errors import (
    ConnectionClosed,
    HapticdError,
    LocalError,
    ProtocolError,
    RemoteError,
    Timeout,
)
from hapticd.v1 import hapticd_pb2 as pb

RECEIVE_CHUNK_BYTES = 1 << 20
TELEMETRY_QUEUE_LENGTH = 1024
DEFAULT_PORT = 7460


def parse_address(address: str, name: str = "address") -> tuple[str, int]:
    """("host", port) from "host:port" or "[v6-host]:port"; LocalError naming the value."""
    if not isinstance(address, str) or ":" not in address:
        raise LocalError(
            f"{name} is {address!r}; it must be HOST:PORT, e.g. 127.0.0.1:{DEFAULT_PORT}"
        )
    host, _, port_text = address.rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    if not host:
        raise LocalError(f"{name} is {address!r}; the host before ':' is empty")
    try:
        port = int(port_text)
    except ValueError as exc:
        raise LocalError(f"{name} is {address!r}; the port {port_text!r} is not a number") from exc
    if not 0 < port < 65536:
        raise LocalError(f"{name} is {address!r}; the port must be in 1..65535")
    return host, port


def is_loopback(host: str) -> bool:
    """Whether host is a loopback IP address (names are not resolved here)."""
    try:
        return ipaddress.ip_address(host.split("%")[0]).is_loopback
    except ValueError:
        return False


def _socket_failure(exc: OSError, doing: str) -> ConnectionClosed:
    """A ConnectionClosed that says how the socket failed while doing something."""
    if isinstance(exc, (ConnectionResetError, BrokenPipeError, ConnectionAbortedError)):
        return ConnectionClosed(f"the server closed the connection ({doing}: {exc.strerror})")
    return ConnectionClosed(f"the connection failed ({doing}: {exc.strerror or exc})")


class Connection:
    """A connected control channel; see the module's theory of operation."""

    def __init__(self, sock: socket.socket, peer_host: str) -> None:
        self._socket: socket.socket | None = sock
        self.peer_host = peer_host
        self._decoder = FrameDecoder(MAX_FRAME_BYTES)
        self._next_id = 1
        self._replies: dict[int, pb.Reply] = {}
        self._abandoned: set[int] = set()
        self._telemetry: dict[int, collections.deque[pb.Reply]] = {}
        self._ended_subscriptions: set[int] = set()
        # why the connection ended, when it failed (None: open, or closed by close())
        self._failure: HapticdError | None = None
        self._state = threading.Condition(threading.Lock())
        self._reading = False
        self._send_lock = threading.Lock()
        self._io_lock = threading.Lock()

    @classmethod
    def open(
        cls,
        address: str,
        *,
        timeout_s: float,
        tls: ssl.SSLContext | None,
        server_hostname: str | None = None,
    ) -> Connection:
        """Connects to address ("host:port") within timeout_s. Without tls the peer must
        be loopback (the server refuses plain connections elsewhere, and an access token
        would travel in clear): LocalError otherwise. ConnectionClosed when the
        connection or the TLS handshake fails, Timeout when it takes too long."""
        host, port = parse_address(address)
        try:
            sock = socket.create_connection((host, port), timeout=timeout_s)
        except TimeoutError as exc:
            raise Timeout(f"connecting to {address} took over {timeout_s} s") from exc
        except OSError as exc:
            raise ConnectionClosed(f"cannot connect to {address}: {exc.strerror or exc}") from exc
        peer = str(sock.getpeername()[0])
        if tls is None and not is_loopback(peer):
            sock.close()
            raise LocalError(
                f"address {address} is not loopback ({peer}); the control channel needs TLS "
                "there: pass tls=ssl.create_default_context(...)"
            )
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        if tls is not None:
            try:
                sock = tls.wrap_socket(sock, server_hostname=server_hostname or host)
            except (OSError, ssl.SSLError) as exc:
                sock.close()
                raise ConnectionClosed(f"TLS handshake with {address} failed: {exc}") from exc
        return cls(sock, peer)

    @property
    def closed(self) -> bool:
        """Whether the connection is closed (by close() or because it failed)."""
        return self._socket is None

    @property
    def failure(self) -> HapticdError | None:
        """Why the connection ended, when it failed; None while open or after close()."""
        return self._failure

    def close(self) -> None:
        """Closes the socket; further requests raise LocalError. Idempotent."""
        with self._state:
            self._close_socket()
            self._state.notify_all()

    def request(self, body_name: str, body: Message, timeout_s: float) -> pb.Reply:
        """Sends Request{body_name: body} and returns its Reply. Raises RemoteError for an
        Error reply, Timeout when sending and the reply take over timeout_s,
        ConnectionClosed when the connection ends, ProtocolError when the server sends
        garbage."""
        deadline = time.monotonic() + timeout_s
        request_id = self.send(body_name, body, timeout_s)
        reply = self._await_reply(request_id, body_name, deadline, timeout_s)
        if reply.WhichOneof("body") == "error":
            raise remote_error(reply.error, body_name)
        return reply

    def send(
        self, body_name: str, body: Message, timeout_s: float, *, subscription: bool = False
    ) -> int:
        """Sends Request{body_name: body} without waiting; returns its request id. With
        subscription, replies carrying that id are queued as telemetry from before the
        request leaves (see next_subscription_reply)."""
        with self._send_lock:
            with self._state:
                sock = self._live_socket()
                request_id = self._next_id
                self._next_id += 1
                if subscription:
                    self._telemetry[request_id] = collections.deque(
                        maxlen=TELEMETRY_QUEUE_LENGTH
                    )
            request = pb.Request(request_id=request_id)
            getattr(request, body_name).CopyFrom(body)
            frame = encode_frame(request.SerializeToString())
            try:
                with self._io_lock:
                    sock.settimeout(timeout_s)
                    sock.sendall(frame)
            except TimeoutError as exc:
                # a frame half sent cannot be taken back: the stream is lost
                failure: HapticdError = Timeout(
                    f"sending {body_name} took over {timeout_s} s; connection closed"
                )
                self._fail(ConnectionClosed(f"sending {body_name} took over {timeout_s} s"))
                raise failure from exc
            except OSError as exc:
                failure = _socket_failure(exc, f"sending {body_name}")
                self._fail(failure)
                raise failure from exc
        return request_id

    # ---- subscriptions ----

    def end_subscription(self, subscription_id: int) -> None:
        """Stops queueing that subscription's telemetry; late samples are dropped."""
        with self._state:
            self._telemetry.pop(subscription_id, None)
            self._ended_subscriptions.add(subscription_id)

    def next_subscription_reply(self, subscription_id: int, timeout_s: float) -> pb.Reply:
        """The oldest queued reply of a subscription (telemetry or an error), waiting up
        to timeout_s for one; Timeout when none comes."""
        deadline = time.monotonic() + timeout_s
        with self._state:
            queue = self._telemetry[subscription_id]
        self._wait_for(
            lambda: bool(queue), f"telemetry of subscription {subscription_id}", deadline, timeout_s
        )
        with self._state:
            return queue.popleft()

    # ---- receiving ----

    def _live_socket(self) -> socket.socket:
        """The socket; ConnectionClosed (why) when the connection failed, LocalError when
        close() closed it. Called with the state lock held."""
        if self._socket is None:
            if self._failure is not None:
                raise ConnectionClosed(f"the connection is closed: {self._failure}")
            raise LocalError("the connection is closed (close() was called)")
        return self._socket

    def _close_socket(self) -> None:
        """Closes the socket, if open. Called with the state lock held."""
        if self._socket is not None:
            self._socket.close()
            self._socket = None

    def _fail(self, failure: HapticdError) -> None:
        """Records why the connection ended (the first reason) and closes it."""
        with self._state:
            if self._socket is not None and self._failure is None:
                self._failure = failure
            self._close_socket()
            self._state.notify_all()

    def _await_reply(
        self, request_id: int, what: str, deadline: float, timeout_s: float
    ) -> pb.Reply:
        """Waits until the reply to request_id is in; abandons it on timeout."""
        try:
            self._wait_for(
                lambda: request_id in self._replies, f"reply to {what}", deadline, timeout_s
            )
        except Timeout:
            with self._state:
                if request_id in self._replies:
                    return self._replies.pop(request_id)
                self._abandoned.add(request_id)
            raise
        with self._state:
            return self._replies.pop(request_id)

    def _wait_for(
        self, ready: Callable[[], bool], waiting_for: str, deadline: float, timeout_s: float
    ) -> None:
        """Returns once ready() (called with the state lock held) is true. Meanwhile this
        thread reads the socket unless another one is reading already."""
        with self._state:
            while not ready():
                sock = self._live_socket()
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise Timeout(f"no {waiting_for} within {timeout_s} s")
                if self._reading:
                    self._state.wait(remaining)
                    continue
                self._reading = True
                self._state.release()
                try:
                    data = self._read(sock, remaining, waiting_for)
                finally:
                    self._state.acquire()
                    self._reading = False
                    self._state.notify_all()
                if data:
                    self._route_data(data)

    def _read(self, sock: socket.socket, timeout_s: float, waiting_for: str) -> bytes | None:
        """What one read of the socket returns within timeout_s (None: nothing came).
        Called without the state lock; ConnectionClosed when the connection ends."""
        try:
            # TLS may hold a decrypted record that select cannot see
            pending = sock.pending() if isinstance(sock, ssl.SSLSocket) else 0
            if not pending and not select.select([sock], [], [], timeout_s)[0]:
                return None
            with self._io_lock:
                sock.settimeout(timeout_s)
                data = sock.recv(RECEIVE_CHUNK_BYTES)
        except TimeoutError:
            return None
        except (OSError, ValueError) as exc:
            if self._socket is not sock:
                # close() in another thread: the next check says so
                return None
            failure = (
                _socket_failure(exc, f"awaiting the {waiting_for}")
                if isinstance(exc, OSError)
                else ConnectionClosed(f"the connection failed: {exc}")
            )
            self._fail(failure)
            raise failure from exc
        if not data:
            failure = ConnectionClosed(
                f"the server closed the connection (awaiting the {waiting_for})"
            )
            self._fail(failure)
            raise failure
        return data

    def _route_data(self, data: bytes) -> None:
        """Decodes data and files the replies it completes. Called with the state lock
        held; a ProtocolError closes the connection."""
        try:
            for frame in self._decoder.feed(data):
                self._route(frame)
        except ProtocolError as exc:
            if self._socket is not None and self._failure is None:
                self._failure = exc
            self._close_socket()
            raise

    def _route(self, frame: bytes) -> None:
        """Files one reply frame under its request or subscription."""
        reply = pb.Reply()
        try:
            reply.ParseFromString(frame)
        except DecodeError as exc:
            raise ProtocolError(f"a {len(frame)}-byte reply frame does not parse: {exc}") from exc
        request_id = reply.request_id
        # telemetry (or a refusal) for a subscription
        if request_id in self._telemetry:
            if reply.WhichOneof("body") in ("telemetry", "error"):
                self._telemetry[request_id].append(reply)
            return
        # late: a request that timed out, a subscription that ended
        if request_id in self._abandoned:
            self._abandoned.discard(request_id)
            return
        if request_id in self._ended_subscriptions:
            return
        # an error with id 0 answers a frame the server could not read: the latest request
        if 0 < request_id < self._next_id or (request_id == 0 and reply.HasField("error")):
            self._replies[request_id or self._next_id - 1] = reply
            return
        raise ProtocolError(
            f"the server replied to request_id {request_id}, which was never sent "
            f"(body {reply.WhichOneof('body')})"
        )


def remote_error(error: pb.Error, request: str) -> RemoteError:
    """A RemoteError from an Error reply: the code's short name (e.g. NOT_FOUND)."""
    try:
        code = pb.Error.Code.Name(error.code).removeprefix("CODE_")
    except ValueError:
        code = f"CODE_{error.code}"
    return RemoteError(code, error.code, error.message, request)
