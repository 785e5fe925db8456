"""The control-channel client: build and edit the scene, query it, open device sessions
and watch them, with numpy arrays in and out.

    with hapticd.connect("127.0.0.1:7460") as client:
        client.add_sphere("ball", 0.05, position=(0, 0, 0.05), material={"stiffness": 2000})
        hit = client.ray_cast(origin=(0, 0, 1), direction=(0, 0, -1))

Arguments are validated before anything is sent (LocalError naming the bad value, or
the unknown keyword); the server's refusals raise RemoteError with its code and
message. Every call takes an explicit timeout_s (default: the client's). Threads may
share a Client: each request waits for its own reply, and subscriptions get their own
samples. Closing a Client (or leaving its with block) closes the device sessions it
opened and has not closed.
"""

from __future__ import annotations

import collections
import functools
import ssl
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar, cast

import numpy as np
from google.protobuf.message import Message
from numpy.typing import ArrayLike

from hapticd import _codec as codec
from hapticd import _validate as check
from hapticd._closing import ClosesOnExit
from hapticd._connection import Connection, parse_address, remote_error
from hapticd.errors import HapticdError, LocalError, ProtocolError, RemoteError
from hapticd.objects import (
    Material,
)
from hapticd.results import (
    ClosestPoint,
    Contact,
    RayHit,
    RayHits,
    SceneInfo,
    SessionInfo,
    Stats,
    Telemetry,
)
from hapticd.scene_edits import SceneEditor, SceneEdits
from hapticd.v1 import hapticd_pb2 as pb

PROTOCOL_VERSION = 1
DEVICE_TYPES = {"impedance": pb.DEVICE_TYPE_IMPEDANCE, "admittance": pb.DEVICE_TYPE_ADMITTANCE}
AVATARS = {"point": pb.AVATAR_TYPE_POINT, "sphere": pb.AVATAR_TYPE_SPHERE}
REMOTE_MODES = {"direct": pb.REMOTE_MODE_DIRECT, "local_model": pb.REMOTE_MODE_LOCAL_MODEL}
FORCE_METHODS = {
    "default": pb.FORCE_METHOD_DEFAULT,
    "penalty": pb.FORCE_METHOD_PENALTY,
    "god_object": pb.FORCE_METHOD_GOD_OBJECT,
    "finger_proxy": pb.FORCE_METHOD_FINGER_PROXY,
}
# How many closed session ids a client remembers, so that closing one twice is quiet.
CLOSED_SESSIONS_REMEMBERED = 1024

ResultT = TypeVar("ResultT")
BodyT = TypeVar("BodyT", bound=Message)


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
    introduces itself (Hello). Off loopback tls is required and access_token is what the
    server was started with. timeout_s is the default for every later request too."""
    timeout_s = check.positive(timeout_s, "timeout_s")
    connection = Connection.open(
        address, timeout_s=timeout_s, tls=tls, server_hostname=server_hostname
    )
    try:
        hello = pb.Hello(
            protocol_version=PROTOCOL_VERSION, access_token=access_token, client_name=client_name
        )
        reply = connection.request("hello", hello, timeout_s)
        answer = _body(reply, "hello", pb.HelloReply)
        if answer.protocol_version != PROTOCOL_VERSION:
            raise ProtocolError(
                f"server speaks protocol version {answer.protocol_version}; this client "
                f"speaks {PROTOCOL_VERSION}"
            )
    except BaseException:
        connection.close()
        raise
    return Client(connection, timeout_s, answer.server_name, answer.udp_endpoint)


def _body(reply: pb.Reply, name: str, kind: type[BodyT]) -> BodyT:
    """The reply's body, which must be `name`; ProtocolError otherwise."""
    got = reply.WhichOneof("body")
    if got != name:
        raise ProtocolError(f"expected a {name} reply, got {got or 'an empty one'}")
    return cast(BodyT, getattr(reply, name))


def _decoded(convert: Callable[[BodyT], ResultT], body: BodyT) -> ResultT:
    """convert(body); a value the package's own types refuse is the server's fault."""
    try:
        return convert(body)
    except LocalError as exc:
        raise ProtocolError(f"the server sent an invalid {body.DESCRIPTOR.name}: {exc}") from exc


class Client(ClosesOnExit, SceneEditor):
    """A connection to the control channel; made by connect(). Use as a context manager
    or call close(). Its scene edits (SceneEditor's methods) each return the new scene
    version."""

    def __init__(
        self, connection: Connection, timeout_s: float, server_name: str, udp_endpoint: str
    ) -> None:
        self._connection = connection
        self.timeout_s = timeout_s
        self.server_name = server_name
        self.udp_endpoint = udp_endpoint
        # device sessions opened here and not closed yet, and the latest ones closed
        self._sessions: set[int] = set()
        self._closed_sessions: collections.OrderedDict[int, None] = collections.OrderedDict()
        self._sessions_lock = threading.Lock()

    def __enter__(self) -> Client:
        return self

    def close(self) -> None:
        """Closes the device sessions this client opened and has not closed (one the
        server has already reclaimed is skipped), then the connection; the server ends
        the connection's subscriptions. Idempotent. When a session cannot be closed,
        the connection is closed all the same and the first such error raised."""
        failure: HapticdError | None = None
        with self._sessions_lock:
            open_sessions = sorted(self._sessions)
        for session_id in open_sessions:
            if self._connection.closed:
                break
            try:
                self.close_session(session_id)
            except RemoteError as exc:
                if exc.code != "NOT_FOUND" and failure is None:
                    failure = exc
            except HapticdError as exc:
                failure = failure or exc
        self._connection.close()
        if failure is not None:
            raise failure

    @property
    def closed(self) -> bool:
        """Whether the connection is closed."""
        return self._connection.closed

    def _call(self, body_name: str, body: Message, timeout_s: float | None) -> pb.Reply:
        timeout = self.timeout_s if timeout_s is None else check.positive(timeout_s, "timeout_s")
        return self._connection.request(body_name, body, timeout)

    def _edit(self, body_name: str, body: Message, timeout_s: float | None) -> int:
        return _body(self._call(body_name, body, timeout_s), "done", pb.Done).scene_version

    def _current_material(self, name: str, timeout_s: float | None) -> Material | None:
        """The material of the object called name as the server holds it (None: none)."""
        for info in self.scene(timeout_s=timeout_s).objects:
            if info.name == name:
                return info.material
        return None

    def edit_scene(self, edits: SceneEdits, *, timeout_s: float | None = None) -> int:
        """Applies a batch of edits (SceneEdits) in one request, as one: all of them, as
        one new scene version (returned), or, when the server refuses one, none of them
        (RemoteError naming the edit, "edit_scene.edits[3]..."). At most
        MAX_EDITS_PER_BATCH edits."""
        if not isinstance(edits, SceneEdits):
            raise LocalError(f"edits is {edits!r}; it must be a SceneEdits")
        return self._edit("edit_scene", edits.message(), timeout_s)

    def clear_scene(self, *, timeout_s: float | None = None) -> int:
        """Removes every object."""
        return self._edit("clear_scene", pb.ClearScene(), timeout_s)

    def scene(self, *, timeout_s: float | None = None) -> SceneInfo:
        """The scene as the server holds it now."""
        reply = self._call("get_scene", pb.GetScene(), timeout_s)
        return _decoded(codec.scene_from, _body(reply, "scene", pb.SceneDescription))

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
        (direction non-zero, normalised by the server; max_distance m, > 0): the first
        surface crossing from either side, alike for every representation. From inside
        a solid that is where the ray leaves it (normal turned back towards the origin);
        from a surface, distance 0 when the ray goes into the solid."""
        message = pb.RayCast(
            origin=codec.vec3(check.vector3(origin, "origin")),
            direction=codec.vec3(check.nonzero_vector3(direction, "direction")),
            max_distance=check.positive(max_distance, "max_distance"),
        )
        reply = self._call("ray_cast", message, timeout_s)
        return _decoded(codec.ray_hit_from, _body(reply, "ray_hit", pb.RayHit))

    def ray_cast_batch(
        self,
        origins: ArrayLike,
        directions: ArrayLike,
        max_distance: float = 10.0,
        *,
        timeout_s: float | None = None,
    ) -> RayHits:
        """The first hits of many segments at once: origins and directions (N, 3), each
        direction non-zero; segment i runs origins[i] -> origins[i] + max_distance *
        directions[i] / |directions[i]|. Meshes on the Embree backend trace them in
        packets. A segment that only touches a surface counts as a hit."""
        origins = check.points(origins, "origins")
        directions = check.points(directions, "directions")
        if directions.shape != origins.shape:
            raise LocalError(
                f"directions has {len(directions)} rows and origins {len(origins)}; "
                "one direction per origin"
            )
        if np.any(np.linalg.norm(directions, axis=1) == 0):
            row = int(np.argmax(np.linalg.norm(directions, axis=1) == 0))
            raise LocalError(f"directions[{row}] is zero; every segment needs a direction")
        message = pb.RayCastBatch(max_distance=check.positive(max_distance, "max_distance"))
        message.origins.extend(origins.ravel().tolist())
        message.directions.extend(directions.ravel().tolist())
        reply = self._call("ray_cast_batch", message, timeout_s)
        return _decoded(codec.ray_hits_from, _body(reply, "ray_hits", pb.RayHits))

    def closest_point(
        self, point: ArrayLike, max_distance: float = 1.0, *, timeout_s: float | None = None
    ) -> ClosestPoint:
        """The surface point nearest to point within max_distance (m, > 0)."""
        message = pb.ClosestPoint(
            point=codec.vec3(check.vector3(point, "point")),
            max_distance=check.positive(max_distance, "max_distance"),
        )
        reply = self._call("closest_point", message, timeout_s)
        return _decoded(
            codec.closest_point_from, _body(reply, "closest_point", pb.ClosestPointResult)
        )

    def find_contacts(
        self, center: ArrayLike, radius: float = 0.0, *, timeout_s: float | None = None
    ) -> list[Contact]:
        """The objects a sphere of radius (m, >= 0; 0: a point) at center touches."""
        message = pb.FindContacts(
            center=codec.vec3(check.vector3(center, "center")),
            radius=check.non_negative(radius, "radius"),
        )
        reply = self._call("find_contacts", message, timeout_s)
        return _decoded(codec.contacts_from, _body(reply, "contacts", pb.ContactsResult))

    # ---- sessions ----

    def open_session(
        self,
        device_type: str = "impedance",
        *,
        degrees_of_freedom: int = 3,
        max_force: float = 10.0,
        max_velocity: float = 2.0,
        rate_hz: float = 1000.0,
        max_force_rate: float = 0.0,
        avatar: str = "point",
        avatar_radius: float = 0.0,
        method: str = "default",
        force_shading: bool = False,
        passivity: bool = False,
        virtual_mass: float = 0.0,
        virtual_damping: float = 0.0,
        start: ArrayLike = (0, 0, 0),
        session_timeout_s: float = 0.0,
        remote_mode: str = "direct",
        tdpa: bool = False,
        deadband: float = 0.0,
        deadband_force_floor: float = 0.0,
        deadband_position_floor: float = 0.0,
        deadband_velocity_floor: float = 0.0,
        keepalive_s: float = 0.0,
        timeout_s: float | None = None,
    ) -> SessionInfo:
        """Opens a device session (the capability handshake). device_type "impedance"
        (position in, force out) or "admittance" (force in, pose out); max_force (N, in
        (0, 1e4]) and max_velocity (m/s, in (0, 100]) the device's limits; rate_hz its
        state rate (in [10, 10000]); max_force_rate N/s (0: none); avatar "point" or
        "sphere" (avatar_radius m in (0, 1]); method "default", "penalty", "god_object"
        or "finger_proxy"; virtual_mass (kg, in [1e-3, 1e3]) and virtual_damping (N·s/m,
        in [0, 1e5]) for admittance (0: the server's 1 kg, 20 N·s/m); start: the
        device's position now; session_timeout_s: reclaim after this long without states
        (in [0.15, 3600]; 0: 2 s); remote_mode "direct" (the device renders each
        command's force) or "local_model" (impedance only: the commands carry models of
        the scene near the device, which renders its force itself: DeviceSession.render).
        tdpa: two-port time-domain passivity across the channel (impedance only: the
        channel cannot generate energy; DeviceSession.limit_force is the device's end);
        deadband: a perceptual deadband's Weber fraction (impedance only, in [0, 1), 0:
        off) with its floors (N, m, m/s; 0: the server's 0.02, 1e-4, 0.002) and keep-alive
        (s, in (0, 0.025]; 0: 0.01); see hapticd.proto's OpenSession.
        The ranges are _validate.RANGES, the server's."""
        if degrees_of_freedom not in (3, 6):
            raise LocalError(f"degrees_of_freedom is {degrees_of_freedom!r}; it must be 3 or 6")
        check.choice(device_type, "device_type", tuple(DEVICE_TYPES))
        check.choice(avatar, "avatar", tuple(AVATARS))
        check.choice(method, "method", tuple(FORCE_METHODS))
        check.choice(remote_mode, "remote_mode", tuple(REMOTE_MODES))
        if not isinstance(tdpa, bool):
            raise LocalError(f"tdpa is {tdpa!r}; it must be True or False")
        weber = check.limited(deadband, "deadband", "deadband")
        if (tdpa or weber > 0) and device_type != "impedance":
            raise LocalError(
                f"{'tdpa' if tdpa else 'deadband'} is set for an admittance device; two-port "
                "passivity and the deadband are for impedance devices"
            )
        if remote_mode == "local_model" and device_type != "impedance":
            raise LocalError(
                "remote_mode is 'local_model' for an admittance device; a local model is for "
                "impedance devices"
            )
        if avatar == "sphere":
            radius = check.limited(avatar_radius, "avatar_radius", "avatar_radius")
        else:
            radius = check.number(avatar_radius, "avatar_radius")
            if radius != 0:
                raise LocalError(f"avatar_radius is {radius!r}; a point avatar has radius 0")
        rate = check.limited(rate_hz, "rate_hz", "rate_hz")
        message = pb.OpenSession(
            device_type=DEVICE_TYPES[device_type],
            degrees_of_freedom=degrees_of_freedom,
            max_force=check.limited(max_force, "max_force", "max_force"),
            max_velocity=check.limited(max_velocity, "max_velocity", "max_velocity"),
            rate_hz=rate,
            max_force_rate=check.limited(max_force_rate, "max_force_rate", "max_force_rate"),
            avatar=AVATARS[avatar],
            avatar_radius=radius,
            method=FORCE_METHODS[method],
            force_shading=force_shading,
            passivity=passivity,
            virtual_mass=check.limited_or_zero(
                virtual_mass, "virtual_mass", "virtual_mass", "the server's 1 kg"
            ),
            virtual_damping=check.limited(virtual_damping, "virtual_damping", "virtual_damping"),
            start=codec.vec3(check.vector3(start, "start")),
            timeout_s=check.limited_or_zero(
                session_timeout_s, "session_timeout_s", "session_timeout_s", "the server's 2 s"
            ),
            remote_mode=REMOTE_MODES[remote_mode],
            tdpa=tdpa,
            deadband=weber,
            deadband_force_floor=check.limited_or_zero(
                deadband_force_floor,
                "deadband_force_floor",
                "deadband_force_floor",
                "the server's 0.02 N",
            ),
            deadband_position_floor=check.limited_or_zero(
                deadband_position_floor,
                "deadband_position_floor",
                "deadband_position_floor",
                "the server's 1e-4 m",
            ),
            deadband_velocity_floor=check.limited_or_zero(
                deadband_velocity_floor,
                "deadband_velocity_floor",
                "deadband_velocity_floor",
                "the server's 0.002 m/s",
            ),
            keepalive_s=check.limited_or_zero(
                keepalive_s, "keepalive_s", "keepalive_s", "the server's 0.01 s"
            ),
        )
        opened = _body(
            self._call("open_session", message, timeout_s), "session_opened", pb.SessionOpened
        )
        if len(opened.session_key) != 32:
            raise ProtocolError(f"session key is {len(opened.session_key)} bytes; it must be 32")
        try:
            udp_host, udp_port = parse_address(opened.udp_endpoint, "udp_endpoint")
        except LocalError as exc:
            raise ProtocolError(f"the server's {exc}") from exc
        # a wildcard bind is reached where the control channel is
        if udp_host in ("0.0.0.0", "::"):
            udp_host = self._connection.peer_host
        with self._sessions_lock:
            self._sessions.add(opened.session_id)
        return SessionInfo(
            session_id=opened.session_id,
            key=opened.session_key,
            udp_host=udp_host,
            udp_port=udp_port,
            max_datagram=opened.max_datagram,
            device_type=device_type,
            rate_hz=rate,
            close_session=functools.partial(self._close_own_session, opened.session_id),
            remote_mode=remote_mode,
            open_request=message.SerializeToString(),
        )

    def close_session(
        self, session_id: int, *, session_key: bytes = b"", timeout_s: float | None = None
    ) -> None:
        """Closes a device session. A session belongs to the connection that opened it:
        from another one (this client after reconnecting, say) pass the session_key its
        SessionInfo holds (its key), else RemoteError PERMISSION_DENIED. Closing one this client
        has closed already does nothing; RemoteError NOT_FOUND when the server has no
        such session (never opened, or reclaimed after its timeout)."""
        with self._sessions_lock:
            if session_id in self._closed_sessions:
                return
        if not isinstance(session_key, bytes):
            raise LocalError(f"session_key is {session_key!r}; it must be bytes")
        try:
            _body(
                self._call(
                    "close_session",
                    pb.CloseSession(session_id=session_id, session_key=session_key),
                    timeout_s,
                ),
                "done",
                pb.Done,
            )
        except RemoteError as exc:
            # the server has none: nothing of ours to close later
            if exc.code == "NOT_FOUND":
                with self._sessions_lock:
                    self._sessions.discard(session_id)
            raise
        with self._sessions_lock:
            self._sessions.discard(session_id)
            self._closed_sessions[session_id] = None
            while len(self._closed_sessions) > CLOSED_SESSIONS_REMEMBERED:
                self._closed_sessions.popitem(last=False)

    def _close_own_session(self, session_id: int) -> None:
        """Closes a session this client opened, unless it is closed or gone already (the
        client closed, the session closed, or the server reclaimed it)."""
        with self._sessions_lock:
            if session_id not in self._sessions or self._connection.closed:
                return
        try:
            self.close_session(session_id)
        except RemoteError as exc:
            if exc.code != "NOT_FOUND":
                raise

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
        rate = check.limited(rate_hz, "rate_hz", "subscribe_rate_hz")
        wait_s = (
            self.timeout_s + 2 / rate
            if timeout_s is None
            else check.positive(timeout_s, "timeout_s")
        )
        message = pb.Subscribe(rate_hz=rate, session_ids=list(session_ids))
        connection = self._connection
        subscription_id = connection.send("subscribe", message, self.timeout_s, subscription=True)
        # the server answers a Subscribe at once: its first sample or an error
        try:
            first = _telemetry(connection.next_subscription_reply(subscription_id, self.timeout_s))
        except BaseException:
            connection.end_subscription(subscription_id)
            raise
        return Subscription(self, subscription_id, wait_s, first)

    def stats(self, *, timeout_s: float | None = None) -> Stats:
        """The server's counters and its sessions' statistics now."""
        reply = self._call("get_stats", pb.GetStats(), timeout_s)
        return _decoded(codec.stats_from, _body(reply, "stats", pb.Stats))


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
            return _telemetry(connection.next_subscription_reply(self.subscription_id, wait_s))
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
            message = pb.Unsubscribe(subscription_id=self.subscription_id)
            connection.request("unsubscribe", message, self._client.timeout_s)


def _telemetry(reply: pb.Reply) -> Telemetry:
    """The sample a subscription's reply carries; RemoteError for an Error reply."""
    if reply.WhichOneof("body") == "error":
        raise remote_error(reply.error, "subscribe")
    return _decoded(codec.telemetry_from, _body(reply, "telemetry", pb.Telemetry))
