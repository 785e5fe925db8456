"""The blocking transport of the control channel: a TCP socket (TLS off loopback) that
moves the bytes of the sans-I/O protocol core (_protocol.py) and waits for its replies.

Theory of operation. A request is sent whole, then its thread waits until the Reply
carrying its id has been filed:

    thread ── core.send_request ── frame ──▶ socket ──▶ server
    thread ◀── core.take_reply(n) ◀── core.receive_data ◀── socket ◀── Reply{id=n}

Threads may share a connection. Frames go out whole, one at a time, in request-id
order (the send lock). Of the threads waiting for something, one at a time reads the
socket and feeds the core, which files every reply under its request or subscription;
then it wakes the others, who look for theirs (the state condition guards the core,
the reading flag says a thread is reading). Socket calls are never made concurrently
(the I/O lock), so a TLS socket is safe too. Everything blocks with an explicit
timeout; a reply to a request that timed out is dropped when it arrives.

When the connection fails (the server hangs up, garbage arrives), the core keeps why:
whoever waits, and every later call, gets a ConnectionClosed that says what happened.
LocalError is for close() having been called, which is the caller's doing.
"""

from __future__ import annotations

import ipaddress
import select
import socket
import ssl
import threading
import time
from collections.abc import Callable

from google.protobuf.message import Message

from hapticd._protocol import ControlProtocol, checked
from hapticd.errors import ConnectionClosed, HapticdError, LocalError, ProtocolError, Timeout
from hapticd.v1 import hapticd_pb2 as pb

RECEIVE_CHUNK_BYTES = 1 << 20
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


def plain_peer_refused(address: str, peer: str) -> LocalError:
    """The error for a connection without TLS to a peer that is not loopback."""
    return LocalError(
        f"address {address} is not loopback ({peer}); the control channel needs TLS "
        "there: pass tls=ssl.create_default_context(...)"
    )


def socket_failure(exc: OSError, doing: str) -> ConnectionClosed:
    """A ConnectionClosed that says how the socket failed while doing something."""
    if isinstance(exc, (ConnectionResetError, BrokenPipeError, ConnectionAbortedError)):
        return ConnectionClosed(
            f"the server closed the connection ({doing}: {exc.strerror or exc})"
        )
    return ConnectionClosed(f"the connection failed ({doing}: {exc.strerror or exc})")


class Connection:
    """A connected control channel; see the module's theory of operation."""

    def __init__(self, sock: socket.socket, peer_host: str) -> None:
        self._socket: socket.socket | None = sock
        self.peer_host = peer_host
        self._protocol = ControlProtocol()
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
            raise plain_peer_refused(address, peer)
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
        return self._protocol.failure

    def close(self) -> None:
        """Closes the socket; further requests raise LocalError. Idempotent."""
        with self._state:
            self._protocol.close()
            self._close_socket()
            self._state.notify_all()

    def request(self, body_name: str, body: Message, timeout_s: float) -> pb.Reply:
        """Sends Request{body_name: body} and returns its Reply. Raises RemoteError for an
        Error reply, Timeout when sending and the reply take over timeout_s,
        ConnectionClosed when the connection ends, ProtocolError when the server sends
        garbage."""
        deadline = time.monotonic() + timeout_s
        request_id = self.send(body_name, body, timeout_s)
        try:
            reply = self._wait_for(
                lambda: self._protocol.take_reply(request_id),
                f"reply to {body_name}",
                deadline,
                timeout_s,
            )
        except Timeout:
            with self._state:
                late = self._protocol.abandon(request_id)
            if late is None:
                raise
            reply = late
        return checked(reply, body_name)

    def send(
        self, body_name: str, body: Message, timeout_s: float, *, subscription: bool = False
    ) -> int:
        """Sends Request{body_name: body} without waiting; returns its request id. With
        subscription, replies carrying that id are queued as telemetry from before the
        request leaves (see next_subscription_reply)."""
        with self._send_lock:
            with self._state:
                sock = self._live_socket()
                request_id, frame = self._protocol.send_request(
                    body_name, body, subscription=subscription
                )
            try:
                with self._io_lock:
                    sock.settimeout(timeout_s)
                    sock.sendall(frame)
            except TimeoutError as exc:
                # a frame half sent cannot be taken back: the stream is lost
                self._fail(ConnectionClosed(f"sending {body_name} took over {timeout_s} s"))
                raise Timeout(
                    f"sending {body_name} took over {timeout_s} s; connection closed"
                ) from exc
            except OSError as exc:
                failure = socket_failure(exc, f"sending {body_name}")
                self._fail(failure)
                raise failure from exc
        return request_id

    # ---- subscriptions ----

    def end_subscription(self, subscription_id: int) -> None:
        """Stops queueing that subscription's telemetry; late samples are dropped."""
        with self._state:
            self._protocol.end_subscription(subscription_id)

    def next_subscription_reply(self, subscription_id: int, timeout_s: float) -> pb.Reply:
        """The oldest queued reply of a subscription (telemetry or an error), waiting up
        to timeout_s for one; Timeout when none comes."""
        deadline = time.monotonic() + timeout_s
        return self._wait_for(
            lambda: self._protocol.next_telemetry(subscription_id),
            f"telemetry of subscription {subscription_id}",
            deadline,
            timeout_s,
        )

    # ---- receiving ----

    def _live_socket(self) -> socket.socket:
        """The socket; ConnectionClosed (why) when the connection failed, LocalError when
        close() closed it. Called with the state lock held."""
        self._protocol.check_open()
        assert self._socket is not None
        return self._socket

    def _close_socket(self) -> None:
        """Closes the socket, if open. Called with the state lock held."""
        if self._socket is not None:
            self._socket.close()
            self._socket = None

    def _fail(self, failure: HapticdError) -> None:
        """Records why the connection ended (the first reason) and closes it."""
        with self._state:
            self._protocol.fail(failure)
            self._close_socket()
            self._state.notify_all()

    def _wait_for(
        self,
        take: Callable[[], pb.Reply | None],
        waiting_for: str,
        deadline: float,
        timeout_s: float,
    ) -> pb.Reply:
        """The reply take() (called with the state lock held) gives, once it gives one.
        Meanwhile this thread reads the socket unless another one is reading already."""
        with self._state:
            while (reply := take()) is None:
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
                    self._feed(data)
            return reply

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
                socket_failure(exc, f"awaiting the {waiting_for}")
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

    def _feed(self, data: bytes) -> None:
        """Hands data to the core, which files the replies it completes. Called with the
        state lock held; a ProtocolError closes the connection."""
        try:
            self._protocol.receive_data(data)
        except ProtocolError:
            self._close_socket()
            raise
