"""The control-channel client for asyncio programs: the blocking Client's methods, each
awaited, over one connection that many tasks may share.

    async with await hapticd.connect_async("127.0.0.1:7460") as client:
        await client.add_sphere("ball", 0.05, position=(0, 0, 0.05))
        async with await client.subscribe(60) as samples:
            async for sample in samples:
                ...

Every method asks and answers exactly what Client's method of the same name does (the
same code: _calls.py), so Client's documentation holds for both; only the waiting
differs. The scene edits (SceneEditor's methods) check their arguments when called and
return an awaitable of the new scene version. A connection belongs to the event loop
that opened it. Units SI, world frame W, quaternions (w, x, y, z).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import pathlib
import ssl
from collections.abc import AsyncIterator, Callable, Coroutine, Iterable
from typing import Any, TypeVar, Unpack

from google.protobuf.message import Message
from numpy.typing import ArrayLike

from hapticd import _calls as calls
from hapticd import _validate as check
from hapticd._async_connection import AsyncConnection
from hapticd.client import SessionOptions
from hapticd.errors import HapticdError, LocalError, RemoteError
from hapticd.results import (
    ClosestPoint,
    ClosestPoints,
    Contact,
    ContactsBatch,
    RayHit,
    RayHits,
    SceneInfo,
    SessionInfo,
    Stats,
    Telemetry,
)
from hapticd.scene_edits import SceneEditor, SceneEdits
from hapticd.v1 import hapticd_pb2 as pb

ResultT = TypeVar("ResultT")
Edit = Coroutine[Any, Any, int]


async def connect_async(
    address: str,
    *,
    timeout_s: float = 5.0,
    tls: ssl.SSLContext | None = None,
    access_token: str = "",
    client_name: str = "hapticd-python-asyncio",
    server_hostname: str | None = None,
) -> AsyncClient:
    """Connects as [connect][hapticd.connect] does (Hello; TLS and the access token off
    loopback), on the running event loop."""
    timeout_s = check.positive(timeout_s, "timeout_s")
    connection = await AsyncConnection.open(
        address, timeout_s=timeout_s, tls=tls, server_hostname=server_hostname
    )
    try:

        async def perform(request: calls.Request) -> pb.Reply:
            return await connection.request(request.body_name, request.body, timeout_s)

        greeting = await calls.run_async(calls.hello(access_token, client_name), perform)
    except BaseException:
        await connection.close()
        raise
    return AsyncClient(
        connection, timeout_s, greeting.server_name, greeting.udp_endpoint, greeting.role
    )


class AsyncClient(SceneEditor[Edit]):
    """A connection to the control channel for asyncio; made by connect_async(). Use
    with `async with` or await close(). Tasks may share it; each awaits its own reply.
    Every method is [Client][hapticd.Client]'s of the same name, awaited."""

    def __init__(
        self,
        connection: AsyncConnection,
        timeout_s: float,
        server_name: str,
        udp_endpoint: str,
        role: str = "operator",
    ) -> None:
        self._connection = connection
        self.timeout_s = timeout_s
        self.server_name = server_name
        self.udp_endpoint = udp_endpoint
        self.role = role
        self._sessions = calls.SessionBook()
        # CloseSessions that DeviceSession.close() started on this loop, not yet done
        self._closing: set[asyncio.Task[None]] = set()

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(self, exc_type: type[BaseException] | None, *exc_info: object) -> None:
        if exc_type is None:
            await self.close()
            return
        # an exception in flight says more than a failure to clean up
        try:
            await self.close()
        except HapticdError:
            pass

    async def _perform(self, request: calls.Request) -> pb.Reply:
        timeout_s = self.timeout_s if request.timeout_s is None else request.timeout_s
        return await self._connection.request(request.body_name, request.body, timeout_s)

    async def _run(self, call: calls.Call[ResultT]) -> ResultT:
        return await calls.run_async(call, self._perform)

    def _edit(self, body_name: str, body: Message, timeout_s: float | None) -> Edit:
        return self._run(calls.edit(body_name, body, timeout_s))

    async def close(self) -> None:
        """[Client.close][hapticd.Client.close]: closes the sessions this client opened,
        then the connection."""
        if self._closing:
            await asyncio.gather(*self._closing, return_exceptions=True)
        connection = self._connection
        failure = await self._run(calls.close_sessions(self._sessions, lambda: connection.closed))
        await connection.close()
        if failure is not None:
            raise failure

    @property
    def closed(self) -> bool:
        """Whether the connection is closed."""
        return self._connection.closed

    async def edit_scene(self, edits: SceneEdits, *, timeout_s: float | None = None) -> int:
        """[Client.edit_scene][hapticd.Client.edit_scene]."""
        if not isinstance(edits, SceneEdits):
            raise LocalError(f"edits is {edits!r}; it must be a SceneEdits")
        return await self._edit("edit_scene", edits.message(), timeout_s)

    async def clear_scene(self, *, timeout_s: float | None = None) -> int:
        """[Client.clear_scene][hapticd.Client.clear_scene]."""
        return await self._edit("clear_scene", pb.ClearScene(), timeout_s)

    async def scene(
        self,
        *,
        include_mesh_data: bool = False,
        mesh_data_for: Iterable[str] = (),
        timeout_s: float | None = None,
    ) -> SceneInfo:
        """[Client.scene][hapticd.Client.scene]."""
        return await self._run(calls.scene(timeout_s, include_mesh_data, mesh_data_for))

    async def export_scene(
        self, path: str | pathlib.Path, *, timeout_s: float | None = None
    ) -> SceneInfo:
        """[Client.export_scene][hapticd.Client.export_scene] (the file is written from
        the event loop's thread)."""
        return await self._run(calls.export_scene(path, timeout_s))

    # ---- queries ----

    async def ray_cast(
        self,
        origin: ArrayLike,
        direction: ArrayLike,
        max_distance: float = 10.0,
        *,
        timeout_s: float | None = None,
    ) -> RayHit:
        """[Client.ray_cast][hapticd.Client.ray_cast]."""
        return await self._run(calls.ray_cast(origin, direction, max_distance, timeout_s))

    async def ray_cast_batch(
        self,
        origins: ArrayLike,
        directions: ArrayLike,
        max_distance: float = 10.0,
        *,
        timeout_s: float | None = None,
    ) -> RayHits:
        """[Client.ray_cast_batch][hapticd.Client.ray_cast_batch]."""
        return await self._run(calls.ray_cast_batch(origins, directions, max_distance, timeout_s))

    async def closest_point(
        self, point: ArrayLike, max_distance: float = 1.0, *, timeout_s: float | None = None
    ) -> ClosestPoint:
        """[Client.closest_point][hapticd.Client.closest_point]."""
        return await self._run(calls.closest_point(point, max_distance, timeout_s))

    async def closest_point_batch(
        self, points: ArrayLike, max_distance: float = 1.0, *, timeout_s: float | None = None
    ) -> ClosestPoints:
        """[Client.closest_point_batch][hapticd.Client.closest_point_batch]."""
        return await self._run(calls.closest_point_batch(points, max_distance, timeout_s))

    async def find_contacts(
        self, center: ArrayLike, radius: float = 0.0, *, timeout_s: float | None = None
    ) -> list[Contact]:
        """[Client.find_contacts][hapticd.Client.find_contacts]."""
        return await self._run(calls.find_contacts(center, radius, timeout_s))

    async def find_contacts_batch(
        self, centers: ArrayLike, radius: ArrayLike = 0.0, *, timeout_s: float | None = None
    ) -> ContactsBatch:
        """[Client.find_contacts_batch][hapticd.Client.find_contacts_batch]."""
        return await self._run(calls.find_contacts_batch(centers, radius, timeout_s))

    # ---- sessions ----

    async def open_session(
        self, device_type: str = "impedance", **options: Unpack[SessionOptions]
    ) -> SessionInfo:
        """[Client.open_session][hapticd.Client.open_session]. Closing the
        DeviceSession made from the answer closes the session through this client (on
        its event loop, without waiting; close() waits for it)."""
        closer = self._session_closer(asyncio.get_running_loop())
        return await self._run(
            calls.open_session(
                self._sessions, self._connection.peer_host, closer, device_type, **options
            )
        )

    def _session_closer(
        self, loop: asyncio.AbstractEventLoop
    ) -> Callable[[int], Callable[[], None]]:
        """What closing the DeviceSession of a session opened here does: starts closing
        the session on loop, from the loop's thread or any other."""

        def closer(session_id: int) -> Callable[[], None]:
            def close() -> None:
                if self._connection.closed or loop.is_closed():
                    return
                call = self._run(calls.close_own_session(self._sessions, session_id))
                try:
                    on_loop = asyncio.get_running_loop() is loop
                except RuntimeError:
                    on_loop = False
                if on_loop:
                    task = loop.create_task(call)
                    self._closing.add(task)
                    task.add_done_callback(self._closing.discard)
                    task.add_done_callback(_retrieve)
                else:
                    asyncio.run_coroutine_threadsafe(call, loop).add_done_callback(_retrieve)

            return close

        return closer

    async def close_session(
        self, session_id: int, *, session_key: bytes = b"", timeout_s: float | None = None
    ) -> None:
        """[Client.close_session][hapticd.Client.close_session]."""
        await self._run(calls.close_session(self._sessions, session_id, session_key, timeout_s))

    # ---- telemetry ----

    async def subscribe(
        self,
        rate_hz: float,
        session_ids: Iterable[int] = (),
        *,
        timeout_s: float | None = None,
    ) -> AsyncSubscription:
        """[Client.subscribe][hapticd.Client.subscribe]: the samples as an async
        iterator (`async for sample in subscription`)."""
        message, wait_s = calls.subscribe_request(rate_hz, session_ids, self.timeout_s, timeout_s)
        connection = self._connection
        subscription_id = connection.send("subscribe", message, subscription=True)
        # the server answers a Subscribe at once: its first sample or an error
        try:
            reply = await connection.next_subscription_reply(subscription_id, self.timeout_s)
            first = calls.telemetry(reply)
        except BaseException:
            connection.end_subscription(subscription_id)
            raise
        return AsyncSubscription(self, subscription_id, wait_s, first)

    async def stats(self, *, timeout_s: float | None = None) -> Stats:
        """[Client.stats][hapticd.Client.stats]."""
        return await self._run(calls.stats(timeout_s))


class AsyncSubscription(AsyncIterator[Telemetry]):
    """Telemetry samples of one Subscribe, in order, as an async iterator; close() (or
    leaving an `async with` block) unsubscribes. One task reads it at a time."""

    def __init__(
        self, client: AsyncClient, subscription_id: int, timeout_s: float, first: Telemetry
    ) -> None:
        self._client = client
        self.subscription_id = subscription_id
        self.timeout_s = timeout_s
        self._pending: Telemetry | None = first
        self._open = True

    async def __aenter__(self) -> AsyncSubscription:
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.close()

    def __aiter__(self) -> AsyncSubscription:
        return self

    async def __anext__(self) -> Telemetry:
        return await self.next()

    async def next(self, timeout_s: float | None = None) -> Telemetry:
        """The next sample, waiting up to timeout_s (default: the subscription's)."""
        if not self._open:
            raise LocalError("the subscription is closed")
        wait_s = self.timeout_s if timeout_s is None else check.positive(timeout_s, "timeout_s")
        if self._pending is not None:
            sample, self._pending = self._pending, None
            return sample
        connection = self._client._connection
        try:
            reply = await connection.next_subscription_reply(self.subscription_id, wait_s)
            return calls.telemetry(reply)
        except RemoteError:
            self._open = False
            connection.end_subscription(self.subscription_id)
            raise

    async def close(self) -> None:
        """Unsubscribes (when the connection is still open). Idempotent."""
        if not self._open:
            return
        self._open = False
        connection = self._client._connection
        connection.end_subscription(self.subscription_id)
        if not connection.closed:
            await self._client._run(calls.unsubscribe(self.subscription_id))


def _retrieve(done: asyncio.Future[None] | concurrent.futures.Future[None]) -> None:
    """Marks a background close's outcome as seen: a session that could not be closed
    is reclaimed by the server after its timeout."""
    if not done.cancelled():
        done.exception()
