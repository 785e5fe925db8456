"""One control-channel connection: a TCP socket (TLS off loopback), the frame codec and
the matching of replies to requests.

Theory of operation. The client sends one Request at a time and reads frames until the
Reply carrying that request's id arrives:

    client ── Request{id=n, body} ──────────────▶ server
           ◀── Reply{id=s, telemetry} ────────── (s: an open subscription; queued)
           ◀── Reply{id=n, body | error} ─────── (the answer; an Error raises RemoteError)

Telemetry of open subscriptions can arrive at any time and is queued per subscription
(bounded; the oldest sample is dropped when full) until the subscriber asks for it. A
reply to a request that timed out is dropped when it arrives late. Everything blocks
with an explicit timeout; the connection is not thread-safe.
"""

from __future__ import annotations

import collections
import ipaddress
import socket
import ssl
import time

from google.protobuf.message import DecodeError, Message

from hapticd._framing import MAX_FRAME_BYTES, FrameDecoder, encode_frame
from hapticd.errors import ConnectionClosed, LocalError, ProtocolError, RemoteError, Timeout
from hapticd.v1 import hapticd_pb2 as pb

RECEIVE_CHUNK_BYTES = 1 << 20
TELEMETRY_QUEUE_LENGTH = 1024


def parse_address(address: str, name: str = "address") -> tuple[str, int]:
    """("host", port) from "host:port" or "[v6-host]:port"; LocalError naming the value."""
    if not isinstance(address, str) or ":" not in address:
        raise LocalError(f"{name} is {address!r}; it must be HOST:PORT, e.g. 127.0.0.1:7000")
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

    def close(self) -> None:
        """Closes the socket; further requests raise LocalError. Idempotent."""
        if self._socket is not None:
            self._socket.close()
            self._socket = None

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

    def send(self, body_name: str, body: Message, timeout_s: float) -> int:
        """Sends Request{body_name: body} without waiting; returns its request id."""
        request_id = self._next_id
        self._next_id += 1
        request = pb.Request(request_id=request_id)
        getattr(request, body_name).CopyFrom(body)
        frame = encode_frame(request.SerializeToString())
        sock = self._live_socket()
        try:
            sock.settimeout(timeout_s)
            sock.sendall(frame)
        except TimeoutError as exc:
            # a frame half sent cannot be taken back: the stream is lost
            self.close()
            raise Timeout(
                f"sending {body_name} took over {timeout_s} s; connection closed"
            ) from exc
        except OSError as exc:
            self.close()
            raise ConnectionClosed(f"sending {body_name} failed: {exc}") from exc
        return request_id

    # ---- subscriptions ----

    def start_subscription(self, subscription_id: int) -> None:
        """Queues telemetry replies carrying subscription_id (a Subscribe's request id)."""
        self._telemetry[subscription_id] = collections.deque(maxlen=TELEMETRY_QUEUE_LENGTH)

    def end_subscription(self, subscription_id: int) -> None:
        """Stops queueing that subscription's telemetry; late samples are dropped."""
        self._telemetry.pop(subscription_id, None)
        self._ended_subscriptions.add(subscription_id)

    def next_subscription_reply(self, subscription_id: int, timeout_s: float) -> pb.Reply:
        """The oldest queued reply of a subscription (telemetry or an error), waiting up
        to timeout_s for one; Timeout when none comes."""
        deadline = time.monotonic() + timeout_s
        queue = self._telemetry[subscription_id]
        while not queue:
            self._receive(deadline, f"telemetry within {timeout_s} s")
        return queue.popleft()

    # ---- receiving ----

    def _live_socket(self) -> socket.socket:
        if self._socket is None:
            raise LocalError("the connection is closed")
        return self._socket

    def _await_reply(
        self, request_id: int, what: str, deadline: float, timeout_s: float
    ) -> pb.Reply:
        """Receives until the reply to request_id is in; abandons it on timeout."""
        while request_id not in self._replies:
            try:
                self._receive(deadline, f"reply to {what} within {timeout_s} s")
            except Timeout:
                self._abandoned.add(request_id)
                raise
        return self._replies.pop(request_id)

    def _receive(self, deadline: float, waiting_for: str) -> None:
        """Reads once from the socket (until deadline) and routes the frames it completes."""
        sock = self._live_socket()
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise Timeout(f"no {waiting_for}")
        try:
            sock.settimeout(remaining)
            data = sock.recv(RECEIVE_CHUNK_BYTES)
        except TimeoutError as exc:
            raise Timeout(f"no {waiting_for}") from exc
        except OSError as exc:
            self.close()
            raise ConnectionClosed(f"the connection failed ({exc}); no {waiting_for}") from exc
        if not data:
            self.close()
            raise ConnectionClosed(f"the server closed the connection; no {waiting_for}")
        try:
            frames = self._decoder.feed(data)
        except ProtocolError:
            self.close()
            raise
        for frame in frames:
            self._route(frame)

    def _route(self, frame: bytes) -> None:
        """Files one reply frame under its request or subscription."""
        reply = pb.Reply()
        try:
            reply.ParseFromString(frame)
        except DecodeError as exc:
            self.close()
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
        self.close()
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
