"""The asyncio transport of the control channel: a stream (TLS off loopback) that moves
the bytes of the sans-I/O protocol core (_protocol.py), for AsyncClient.

Theory of operation. One reader task reads the stream and feeds the core; each event
it gets back wakes the one task waiting for that reply or that subscription's next
sample (a future per waiter). A request writes its frame whole (asyncio's writer
buffers it; frames never interleave) and awaits its reply:

    task ── core.send_request ── writer.write(frame) ──────────────▶ server
    reader task ── reader.read ── core.receive_data ── ReplyArrived(n) ──▶ wakes task n

A timeout or a cancellation abandons the request (its reply is dropped when it comes).
When the stream ends or fails, the reader keeps what happened and wakes every waiter;
the first to notice says what it was waiting for ("the server closed the connection
(awaiting the reply to get_scene)"), that becomes the connection's failure, and every
later call raises ConnectionClosed saying it. Everything runs on the event loop that
opened the connection; nothing here is for other threads.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import ssl
from collections.abc import Callable

from google.protobuf.message import Message

from hapticd._connection import (
    RECEIVE_CHUNK_BYTES,
    is_loopback,
    parse_address,
    plain_peer_refused,
    socket_failure,
)
from hapticd._protocol import ControlProtocol, ReplyArrived, checked
from hapticd.errors import ConnectionClosed, LocalError, ProtocolError, Timeout
from hapticd.v1 import hapticd_pb2 as pb

# A waiter's key: ("reply", request_id) or ("telemetry", subscription_id).
WaiterKey = tuple[str, int]
# How long close() waits for a TLS stream to shut down, s.
CLOSE_TIMEOUT_S = 1.0


class AsyncConnection:
    """A connected control channel on an event loop; see the module's theory."""

    def __init__(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, peer_host: str
    ) -> None:
        self._reader = reader
        self._writer = writer
        self.peer_host = peer_host
        self._protocol = ControlProtocol()
        self._waiters: dict[WaiterKey, asyncio.Future[None]] = {}
        # how the stream ended, given what a caller was doing then (None: it has not)
        self._lost: Callable[[str], ConnectionClosed] | None = None
        # whether a caller was told of the server's garbage (a ProtocolError) yet
        self._protocol_error_told = False
        self._reader_task = asyncio.get_running_loop().create_task(self._read_loop())

    @classmethod
    async def open(
        cls,
        address: str,
        *,
        timeout_s: float,
        tls: ssl.SSLContext | None,
        server_hostname: str | None = None,
    ) -> AsyncConnection:
        """Connects to address ("host:port") within timeout_s; the same rules and errors
        as the blocking Connection.open (TLS required off loopback)."""
        host, port = parse_address(address)
        try:
            async with asyncio.timeout(timeout_s):
                reader, writer = await asyncio.open_connection(host, port)
        except TimeoutError as exc:
            raise Timeout(f"connecting to {address} took over {timeout_s} s") from exc
        except OSError as exc:
            raise ConnectionClosed(f"cannot connect to {address}: {exc.strerror or exc}") from exc
        peer = str(writer.get_extra_info("peername")[0])
        if tls is None and not is_loopback(peer):
            writer.close()
            raise plain_peer_refused(address, peer)
        sock = writer.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        if tls is not None:
            try:
                async with asyncio.timeout(timeout_s):
                    await writer.start_tls(tls, server_hostname=server_hostname or host)
            except TimeoutError as exc:
                writer.close()
                raise Timeout(f"the TLS handshake with {address} took over {timeout_s} s") from exc
            except (OSError, ssl.SSLError) as exc:
                writer.close()
                raise ConnectionClosed(f"TLS handshake with {address} failed: {exc}") from exc
        return cls(reader, writer, peer)

    @classmethod
    async def adopt(cls, sock: socket.socket, peer_host: str) -> AsyncConnection:
        """A connection over a socket already connected (and greeted, if need be)."""
        reader, writer = await asyncio.open_connection(sock=sock)
        return cls(reader, writer, peer_host)

    @property
    def closed(self) -> bool:
        """Whether the connection is closed (by close() or because it failed)."""
        return self._protocol.closed or self._lost is not None

    async def close(self) -> None:
        """Closes the stream; further requests raise LocalError. Idempotent."""
        if self._protocol.closed and self._reader_task.done():
            return
        self._protocol.close()
        self._reader_task.cancel()
        self._writer.close()
        with contextlib.suppress(Exception, asyncio.CancelledError):
            await self._reader_task
        with contextlib.suppress(OSError, ssl.SSLError, TimeoutError):
            async with asyncio.timeout(CLOSE_TIMEOUT_S):
                await self._writer.wait_closed()
        self._wake_all()

    async def request(self, body_name: str, body: Message, timeout_s: float) -> pb.Reply:
        """Sends Request{body_name: body} and returns its Reply; the errors of the
        blocking Connection.request."""
        request_id = self.send(body_name, body)
        try:
            async with asyncio.timeout(timeout_s):
                await self._drain(f"sending {body_name}")
                reply = await self._wait(
                    ("reply", request_id),
                    lambda: self._protocol.take_reply(request_id),
                    f"reply to {body_name}",
                )
        except TimeoutError as exc:
            late = self._protocol.abandon(request_id)
            if late is None:
                raise Timeout(f"no reply to {body_name} within {timeout_s} s") from exc
            reply = late
        except BaseException:
            self._protocol.abandon(request_id)
            raise
        return checked(reply, body_name)

    def send(self, body_name: str, body: Message, *, subscription: bool = False) -> int:
        """Queues Request{body_name: body} on the stream; its request id. With
        subscription, replies carrying that id are queued as telemetry."""
        self._raise_if_ended(f"sending {body_name}")
        request_id, frame = self._protocol.send_request(body_name, body, subscription=subscription)
        self._writer.write(frame)
        return request_id

    # ---- subscriptions ----

    def end_subscription(self, subscription_id: int) -> None:
        """Stops queueing that subscription's telemetry; late samples are dropped."""
        self._protocol.end_subscription(subscription_id)

    async def next_subscription_reply(self, subscription_id: int, timeout_s: float) -> pb.Reply:
        """The oldest queued reply of a subscription (telemetry or an error), waiting up
        to timeout_s; Timeout when none comes. One task at a time per subscription."""
        what = f"telemetry of subscription {subscription_id}"
        try:
            async with asyncio.timeout(timeout_s):
                return await self._wait(
                    ("telemetry", subscription_id),
                    lambda: self._protocol.next_telemetry(subscription_id),
                    what,
                )
        except TimeoutError as exc:
            raise Timeout(f"no {what} within {timeout_s} s") from exc

    # ---- receiving ----

    def _raise_if_ended(self, doing: str) -> None:
        """Raises when the connection is over: the first caller to see a lost stream
        gets ConnectionClosed saying what it was doing (which becomes the failure every
        later call names); otherwise as the core's check_open."""
        if self._lost is not None and not self._protocol.closed:
            failure = self._lost(doing)
            self._protocol.fail(failure)
            raise failure
        # the reader may have met the garbage before anyone asked: the first caller
        # then gets the ProtocolError itself, as a blocking Client's reader would
        garbage = self._protocol.failure
        if isinstance(garbage, ProtocolError) and not self._protocol_error_told:
            self._protocol_error_told = True
            raise garbage
        self._protocol.check_open()

    async def _drain(self, doing: str) -> None:
        """Waits until the stream has taken what was written (flow control)."""
        self._raise_if_ended(doing)
        try:
            await self._writer.drain()
        except (OSError, ssl.SSLError) as exc:
            # the reader may know better why the stream ended
            self._raise_if_ended(doing)
            failure = (
                socket_failure(exc, doing)
                if isinstance(exc, OSError)
                else ConnectionClosed(f"the connection failed ({doing}: {exc})")
            )
            self._protocol.fail(failure)
            raise failure from exc

    async def _wait(
        self, key: WaiterKey, take: Callable[[], pb.Reply | None], waiting_for: str
    ) -> pb.Reply:
        """The reply take() gives, once the reader has filed one. Garbage from the
        server while this caller waits raises its ProtocolError here."""
        loop = asyncio.get_running_loop()
        while (reply := take()) is None:
            self._raise_if_ended(f"awaiting the {waiting_for}")
            if key in self._waiters:
                raise LocalError(f"another task is already awaiting the {waiting_for}")
            waiter: asyncio.Future[None] = loop.create_future()
            self._waiters[key] = waiter
            try:
                await waiter
            finally:
                self._waiters.pop(key, None)
            failure = self._protocol.failure
            if isinstance(failure, ProtocolError):
                self._protocol_error_told = True
                raise failure
        return reply

    async def _read_loop(self) -> None:
        """Reads the stream into the core and wakes whoever an event concerns."""
        try:
            while True:
                try:
                    data = await self._reader.read(RECEIVE_CHUNK_BYTES)
                except OSError as exc:
                    self._lost = lambda doing, exc=exc: socket_failure(exc, doing)
                    return
                except ssl.SSLError as exc:
                    self._lost = lambda doing, exc=exc: ConnectionClosed(
                        f"the connection failed ({doing}: {exc})"
                    )
                    return
                if not data:
                    self._lost = lambda doing: ConnectionClosed(
                        f"the server closed the connection ({doing})"
                    )
                    return
                try:
                    events = self._protocol.receive_data(data)
                except ProtocolError:
                    return
                for event in events:
                    key = (
                        ("reply", event.request_id)
                        if isinstance(event, ReplyArrived)
                        else ("telemetry", event.subscription_id)
                    )
                    waiter = self._waiters.get(key)
                    if waiter is not None and not waiter.done():
                        waiter.set_result(None)
        finally:
            if self._protocol.closed or self._lost is not None:
                self._writer.close()
            self._wake_all()

    def _wake_all(self) -> None:
        """Wakes every waiter (the stream ended): each looks again and raises."""
        for waiter in self._waiters.values():
            if not waiter.done():
                waiter.set_result(None)
