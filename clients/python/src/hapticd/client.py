"""The control-channel client: build and edit the scene, query it, open device sessions
and watch them, with numpy arrays in and out.

    with hapticd.connect("127.0.0.1:7460") as client:
        client.add_sphere("ball", 0.05, position=(0, 0, 0.05), material={"stiffness": 2000})
        hit = client.ray_cast(origin=(0, 0, 1), direction=(0, 0, -1))
        nearest = client.closest_point_batch(np.random.rand(1000, 3))

Arguments are validated before anything is sent (LocalError naming the bad value, or
the unknown keyword); the server's refusals raise RemoteError with its code and
message. Every call takes an explicit timeout_s (default: the client's). Threads may
share a Client: each request waits for its own reply, and subscriptions get their own
samples (_connection.py says how). Closing a Client (or leaving its with block) closes
the device sessions it opened and has not closed.

Units are SI (m, N, s, kg); points, directions, normals and poses are in the scene's
world frame W; a rotation is a unit quaternion in the order (w, x, y, z) or a 3x3
rotation matrix. What each method asks and answers is written once (_calls.py) and
shared with AsyncClient (async_client.py), which awaits the same calls.
"""

from __future__ import annotations

import pathlib
import ssl
from collections.abc import Callable, Iterable, Iterator
from typing import TypedDict, TypeVar, Unpack

from google.protobuf.message import Message
from numpy.typing import ArrayLike

from hapticd import _calls as calls
from hapticd import _validate as check
from hapticd._closing import ClosesOnExit
from hapticd._connection import Connection
from hapticd.errors import LocalError, RemoteError
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

PROTOCOL_VERSION = calls.PROTOCOL_VERSION
MAX_BATCH_ROWS = calls.MAX_BATCH_ROWS

ResultT = TypeVar("ResultT")


class SessionOptions(TypedDict, total=False):
    """What Client.open_session and AsyncClient.open_session take besides device_type
    (all keywords; ranges are the server's, _validate.RANGES):

    - degrees_of_freedom: 3 or 6 (default 3; a 6-DOF device gets zero torque for now)
    - max_force: N, in (0, 1e4] (default 10); max_velocity: m/s, in (0, 100] (default 2)
    - rate_hz: the device's state rate, Hz, in [10, 10000] (default 1000)
    - max_force_rate: N/s (default 0: no limit)
    - avatar: "point" (default) or "sphere", with avatar_radius m in (0, 1]
    - method: "default" (god_object for a point, finger_proxy for a sphere), "penalty",
      "god_object" or "finger_proxy"; force_shading, passivity: bools (default False)
    - virtual_mass: kg in [1e-3, 1e3] and virtual_damping: N·s/m in [0, 1e5], for an
      admittance device (0: the server's 1 kg and 20 N·s/m)
    - start: the device's position now, m, (3,) in W (default the origin)
    - session_timeout_s: reclaim the session after this long without states, s, in
      [0.15, 3600] (default 0: the server's 2 s)
    - remote_mode: "direct" (default: the device renders each command's force) or
      "local_model" (impedance only: the commands carry models of the scene near the
      device, which renders its force itself: DeviceSession.render)
    - tdpa: two-port time-domain passivity across the channel (impedance only: the
      channel cannot generate energy; DeviceSession.limit_force is the device's end)
    - deadband: a perceptual deadband's Weber fraction (impedance only, in [0, 1), 0:
      off), with deadband_force_floor (N), deadband_position_floor (m) and
      deadband_velocity_floor (m/s) (0: the server's 0.02, 1e-4, 0.002) and keepalive_s
      (s, in (0, 0.025]; 0: 0.01); see hapticd.proto's OpenSession
    - timeout_s: this request's timeout, s
    """

    degrees_of_freedom: int
    max_force: float
    max_velocity: float
    rate_hz: float
    max_force_rate: float
    avatar: str
    avatar_radius: float
    method: str
    force_shading: bool
    passivity: bool
    virtual_mass: float
    virtual_damping: float
    start: ArrayLike
    session_timeout_s: float
    remote_mode: str
    tdpa: bool
    deadband: float
    deadband_force_floor: float
    deadband_position_floor: float
    deadband_velocity_floor: float
    keepalive_s: float
    timeout_s: float | None


def connect(
    address: str,
    *,
    timeout_s: float = 5.0,
    tls: ssl.SSLContext | None = None,
    access_token: str = "",
    client_name: str = "hapticd-python",
    server_hostname: str | None = None,
) -> Client:
    """Connects to a hapticd server's control channel at address ("host:port") and
    introduces itself (Hello). Off loopback tls is required (an ssl.SSLContext that
    trusts the server's certificate; server_hostname: the name to check it for, default
    the host) and access_token is what the server was started with. timeout_s (s) is
    the default for every later request too."""
    timeout_s = check.positive(timeout_s, "timeout_s")
    connection = Connection.open(
        address, timeout_s=timeout_s, tls=tls, server_hostname=server_hostname
    )
    try:
        greeting = calls.run(
            calls.hello(access_token, client_name),
            lambda request: connection.request(request.body_name, request.body, timeout_s),
        )
    except BaseException:
        connection.close()
        raise
    return Client(connection, timeout_s, greeting.server_name, greeting.udp_endpoint, greeting.role)


class Client(ClosesOnExit, SceneEditor[int]):
    """A blocking connection to the control channel; made by connect(). Use as a
    context manager or call close(). Its scene edits (SceneEditor's methods) each
    return the new scene version. Safe to share between threads."""

    def __init__(
        self,
        connection: Connection,
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

    def __enter__(self) -> Client:
        return self

    def _perform(self, request: calls.Request) -> pb.Reply:
        timeout_s = self.timeout_s if request.timeout_s is None else request.timeout_s
        return self._connection.request(request.body_name, request.body, timeout_s)

    def _run(self, call: calls.Call[ResultT]) -> ResultT:
        return calls.run(call, self._perform)

    def _edit(self, body_name: str, body: Message, timeout_s: float | None) -> int:
        return self._run(calls.edit(body_name, body, timeout_s))

    def close(self) -> None:
        """Closes the device sessions this client opened and has not closed (one the
        server has already reclaimed is skipped), then the connection; the server ends
        the connection's subscriptions. Idempotent. When a session cannot be closed,
        the connection is closed all the same and the first such error raised."""
        connection = self._connection
        failure = self._run(calls.close_sessions(self._sessions, lambda: connection.closed))
        connection.close()
        if failure is not None:
            raise failure

    @property
    def closed(self) -> bool:
        """Whether the connection is closed."""
        return self._connection.closed

    def edit_scene(self, edits: SceneEdits, *, timeout_s: float | None = None) -> int:
        """Applies a batch of edits (SceneEdits) in one request, as one: all of them, as
        one new scene version (returned), or, when the server refuses one, none of them
        (RemoteError naming the edit, "edit_scene.edits[3]..."). At most
        MAX_EDITS_PER_BATCH edits."""
        if not isinstance(edits, SceneEdits):
            raise LocalError(f"edits is {edits!r}; it must be a SceneEdits")
        return self._edit("edit_scene", edits.message(), timeout_s)

    def clear_scene(self, *, timeout_s: float | None = None) -> int:
        """Removes every object; the new scene version."""
        return self._edit("clear_scene", pb.ClearScene(), timeout_s)

    def scene(
        self,
        *,
        include_mesh_data: bool = False,
        mesh_data_for: Iterable[str] = (),
        timeout_s: float | None = None,
    ) -> SceneInfo:
        """The scene as the server holds it now (ObjectInfo: each object's shape,
        representation, pose, material, motion). The vertices and triangles of the
        objects given as meshes come with include_mesh_data (all of them) or for the
        objects named in mesh_data_for, not both: at most 48 MiB of them per request
        (24 bytes a vertex, 12 a triangle; RemoteError RESOURCE_EXHAUSTED naming the
        bytes over it, NOT_FOUND for a name the scene lacks). export_scene reads any
        amount."""
        return self._run(calls.scene(timeout_s, include_mesh_data, mesh_data_for))

    def export_scene(
        self, path: str | pathlib.Path, *, timeout_s: float | None = None
    ) -> SceneInfo:
        """Writes the scene to a scene file (the format scene load and hapticd --scene
        read) that reads back to the same scene: every object as it was given (a mesh
        with its vertices and triangles, pinned as it was), its pose, material, motion,
        and the scene's tolerance. Returns the scene written."""
        return self._run(calls.export_scene(path, timeout_s))

    # ---- queries ----

    def ray_cast(
        self,
        origin: ArrayLike,
        direction: ArrayLike,
        max_distance: float = 10.0,
        *,
        timeout_s: float | None = None,
    ) -> RayHit:
        """The first surface the segment origin -> origin + max_distance * direction hits
        (origin m and direction (3,) in W, direction non-zero, normalised by the server;
        max_distance m, > 0): the first surface crossing from either side, alike for
        every representation. From inside a solid that is where the ray leaves it
        (normal turned back towards the origin); from a surface, distance 0 when the ray
        goes into the solid."""
        return self._run(calls.ray_cast(origin, direction, max_distance, timeout_s))

    def ray_cast_batch(
        self,
        origins: ArrayLike,
        directions: ArrayLike,
        max_distance: float = 10.0,
        *,
        timeout_s: float | None = None,
    ) -> RayHits:
        """The first hits of many segments at once, in one request (m, in W): origins
        and directions (N, 3), each direction non-zero; segment i runs origins[i] ->
        origins[i] + max_distance * directions[i] / |directions[i]|. One origin of shape
        (3,) with directions (N, 3) casts a fan of rays from that point (MuJoCo's
        mj_multiRay; the origin is sent once), and one direction (3,) with origins (N,
        3) casts parallel rays. Meshes on the Embree backend trace them in packets. A
        segment that only touches a surface counts as a hit. At most MAX_BATCH_ROWS
        (1,000,000) segments: LocalError beyond."""
        return self._run(calls.ray_cast_batch(origins, directions, max_distance, timeout_s))

    def closest_point(
        self, point: ArrayLike, max_distance: float = 1.0, *, timeout_s: float | None = None
    ) -> ClosestPoint:
        """The surface point nearest to point ((3,) m in W) within max_distance (m,
        > 0)."""
        return self._run(calls.closest_point(point, max_distance, timeout_s))

    def closest_point_batch(
        self, points: ArrayLike, max_distance: float = 1.0, *, timeout_s: float | None = None
    ) -> ClosestPoints:
        """closest_point for each row of points ((N, 3) m in W, finite) at once, in one
        request, against one scene version: arrays of N rows (ClosestPoints: found,
        signed_distance, point, normal, object_index). max_distance (m, > 0) is the same
        for every point. At most MAX_BATCH_ROWS (1,000,000) points: LocalError beyond."""
        return self._run(calls.closest_point_batch(points, max_distance, timeout_s))

    def find_contacts(
        self, center: ArrayLike, radius: float = 0.0, *, timeout_s: float | None = None
    ) -> list[Contact]:
        """The objects a sphere of radius (m, >= 0; 0: a point) at center ((3,) m in W)
        touches, in scene order."""
        return self._run(calls.find_contacts(center, radius, timeout_s))

    def find_contacts_batch(
        self, centers: ArrayLike, radius: ArrayLike = 0.0, *, timeout_s: float | None = None
    ) -> ContactsBatch:
        """find_contacts for the spheres at each row of centers ((N, 3) m in W) at once,
        in one request, against one scene version: radius (m, >= 0) one for all or (N,)
        one per center. The contacts come laid end to end with each center's count and
        offset (ContactsBatch; contacts_of(i) gives center i's as find_contacts would).
        At most MAX_BATCH_ROWS (1,000,000) centers, and the server answers at most
        1,000,000 contacts (RemoteError RESOURCE_EXHAUSTED beyond: fewer centers or a
        smaller radius)."""
        return self._run(calls.find_contacts_batch(centers, radius, timeout_s))

    # ---- sessions ----

    def open_session(
        self, device_type: str = "impedance", **options: Unpack[SessionOptions]
    ) -> SessionInfo:
        """Opens a device session (the capability handshake): device_type "impedance"
        (position in, force out) or "admittance" (force in, pose out), and the device's
        limits and how to render for it (SessionOptions). The SessionInfo is what
        DeviceSession(info) speaks the realtime channel with."""
        return self._run(
            calls.open_session(
                self._sessions,
                self._connection.peer_host,
                self._session_closer,
                device_type,
                **options,
            )
        )

    def _session_closer(self, session_id: int) -> Callable[[], None]:
        """What closing the DeviceSession of a session opened here does: closes the
        session, unless it is closed or gone already (or this client is closed)."""

        def close() -> None:
            if not self._connection.closed:
                self._run(calls.close_own_session(self._sessions, session_id))

        return close

    def close_session(
        self, session_id: int, *, session_key: bytes = b"", timeout_s: float | None = None
    ) -> None:
        """Closes a device session. A session belongs to the connection that opened it:
        from another one (this client after reconnecting, say) pass the session_key its
        SessionInfo holds (its key), else RemoteError PERMISSION_DENIED. Closing one this
        client has closed already does nothing; RemoteError NOT_FOUND when the server
        has no such session (never opened, or reclaimed after its timeout)."""
        self._run(calls.close_session(self._sessions, session_id, session_key, timeout_s))

    # ---- telemetry ----

    def subscribe(
        self,
        rate_hz: float,
        session_ids: Iterable[int] = (),
        *,
        timeout_s: float | None = None,
    ) -> Subscription:
        """Starts telemetry at rate_hz (in [0.1, 1000]) for session_ids (empty: every
        session) and waits for the server's first sample (RemoteError if it refuses).
        Iterate the result for samples; each waits up to timeout_s (default: the
        client's timeout plus two sample periods)."""
        message, wait_s = calls.subscribe_request(rate_hz, session_ids, self.timeout_s, timeout_s)
        connection = self._connection
        subscription_id = connection.send("subscribe", message, self.timeout_s, subscription=True)
        # the server answers a Subscribe at once: its first sample or an error
        try:
            reply = connection.next_subscription_reply(subscription_id, self.timeout_s)
            first = calls.telemetry(reply)
        except BaseException:
            connection.end_subscription(subscription_id)
            raise
        return Subscription(self, subscription_id, wait_s, first)

    def stats(self, *, timeout_s: float | None = None) -> Stats:
        """The server's counters and its sessions' statistics now."""
        return self._run(calls.stats(timeout_s))


class Subscription(Iterator[Telemetry]):
    """Telemetry samples of one Subscribe, in order; close() (or leaving a with block)
    unsubscribes."""

    def __init__(
        self, client: Client, subscription_id: int, timeout_s: float, first: Telemetry
    ) -> None:
        self._client = client
        self.subscription_id = subscription_id
        self.timeout_s = timeout_s
        self._pending: Telemetry | None = first
        self._open = True

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __next__(self) -> Telemetry:
        return self.next()

    def next(self, timeout_s: float | None = None) -> Telemetry:
        """The next sample, waiting up to timeout_s (default: the subscription's)."""
        if not self._open:
            raise LocalError("the subscription is closed")
        wait_s = self.timeout_s if timeout_s is None else check.positive(timeout_s, "timeout_s")
        if self._pending is not None:
            sample, self._pending = self._pending, None
            return sample
        connection = self._client._connection
        try:
            return calls.telemetry(connection.next_subscription_reply(self.subscription_id, wait_s))
        except RemoteError:
            self._open = False
            connection.end_subscription(self.subscription_id)
            raise

    def close(self) -> None:
        """Unsubscribes (when the connection is still open). Idempotent."""
        if not self._open:
            return
        self._open = False
        connection = self._client._connection
        connection.end_subscription(self.subscription_id)
        if not connection.closed:
            self._client._run(calls.unsubscribe(self.subscription_id))
