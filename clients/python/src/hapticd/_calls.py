"""What each method of Client and AsyncClient asks and answers, written once and sans
I/O: argument checks, the request messages, and the decoding of the replies.

A call is a generator. It checks its arguments (LocalError, before anything is sent),
yields each Request it needs answered, is sent back each Reply (or has the error the
transport met thrown into it, so that it can react, e.g. forget a session the server
no longer has), and returns its result:

    call = calls.ray_cast(origin, direction, 10.0, None)
    request = next(call)                 # Request("ray_cast", pb.RayCast(...), None)
    result = call.send(reply)            # StopIteration(RayHit(...))

run() drives a call over a blocking transport, run_async() over an asyncio one; those
two loops are all that the two clients do differently.
"""

from __future__ import annotations

import collections
import pathlib
import threading
from collections.abc import Awaitable, Callable, Generator, Iterable
from dataclasses import dataclass
from typing import TypeAlias, TypeVar, cast

import numpy as np
from google.protobuf.message import Message
from numpy.typing import ArrayLike

from hapticd import _codec as codec
from hapticd import _validate as check
from hapticd._connection import parse_address
from hapticd._protocol import remote_error
from hapticd.errors import HapticdError, LocalError, ProtocolError, RemoteError
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
from hapticd.scene_files import write_scene_file
from hapticd.scene_readback import read_whole_scene
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
# The most rays, points or query spheres one batch request may hold (the server's
# bound: kMaxRaySegments, kMaxBatchPoints), and the most contacts one contact batch may
# answer with (kMaxBatchContacts; beyond, the server refuses RESOURCE_EXHAUSTED).
MAX_BATCH_ROWS = 1_000_000
MAX_BATCH_CONTACTS = 1_000_000
# How many closed session ids a client remembers, so that closing one twice is quiet.
CLOSED_SESSIONS_REMEMBERED = 1024

T = TypeVar("T")
BodyT = TypeVar("BodyT", bound=Message)


@dataclass(frozen=True)
class Request:
    """One request a call needs answered: Request{body_name: body}, within timeout_s
    (None: the client's default)."""

    body_name: str
    body: Message
    timeout_s: float | None = None

    def __post_init__(self) -> None:
        if self.timeout_s is not None:
            object.__setattr__(self, "timeout_s", check.positive(self.timeout_s, "timeout_s"))


Call: TypeAlias = Generator[Request, pb.Reply, T]


def run(call: Call[T], perform: Callable[[Request], pb.Reply]) -> T:
    """Drives call over a blocking transport: perform(request) returns its Reply or
    raises; a HapticdError goes into the call, which may handle it."""
    try:
        request = next(call)
        while True:
            try:
                reply = perform(request)
            except HapticdError as exc:
                request = call.throw(exc)
            else:
                request = call.send(reply)
    except StopIteration as done:
        return cast(T, done.value)


async def run_async(call: Call[T], perform: Callable[[Request], Awaitable[pb.Reply]]) -> T:
    """Drives call over an asyncio transport, as run() does."""
    try:
        request = next(call)
        while True:
            try:
                reply = await perform(request)
            except HapticdError as exc:
                request = call.throw(exc)
            else:
                request = call.send(reply)
    except StopIteration as done:
        return cast(T, done.value)


def body(reply: pb.Reply, name: str, kind: type[BodyT]) -> BodyT:
    """The reply's body, which must be `name`; ProtocolError otherwise."""
    got = reply.WhichOneof("body")
    if got != name:
        raise ProtocolError(f"expected a {name} reply, got {got or 'an empty one'}")
    return cast(BodyT, getattr(reply, name))


def decoded(convert: Callable[[BodyT], T], message: BodyT) -> T:
    """convert(message); a value the package's own types refuse is the server's fault."""
    try:
        return convert(message)
    except LocalError as exc:
        raise ProtocolError(f"the server sent an invalid {message.DESCRIPTOR.name}: {exc}") from exc


# ---- the connection ----


@dataclass(frozen=True)
class Greeting:
    """What the server said to Hello: its name, its UDP endpoint and this connection's
    role ("operator" or "observer")."""

    server_name: str
    udp_endpoint: str
    role: str


def hello(access_token: str, client_name: str) -> Call[Greeting]:
    """The first request of a connection: the protocol version and the access token."""
    if not isinstance(access_token, str):
        raise LocalError(f"access_token is {access_token!r}; it must be a str")
    message = pb.Hello(
        protocol_version=PROTOCOL_VERSION, access_token=access_token, client_name=client_name
    )
    answer = body((yield Request("hello", message)), "hello", pb.HelloReply)
    if answer.protocol_version != PROTOCOL_VERSION:
        raise ProtocolError(
            f"server speaks protocol version {answer.protocol_version}; this client "
            f"speaks {PROTOCOL_VERSION}"
        )
    return Greeting(answer.server_name, answer.udp_endpoint, answer.role)


# ---- the scene ----


def edit(body_name: str, message: Message, timeout_s: float | None) -> Call[int]:
    """One scene edit; the new scene version."""
    reply = yield Request(body_name, message, timeout_s)
    return body(reply, "done", pb.Done).scene_version


def scene(
    timeout_s: float | None, include_mesh_data: bool = False, mesh_data_for: Iterable[str] = ()
) -> Call[SceneInfo]:
    """The scene as the server holds it now; the meshes' data with include_mesh_data
    (all of them) or for the objects named in mesh_data_for, not both."""
    names = [check.object_name(name, "mesh_data_for[]") for name in mesh_data_for]
    if include_mesh_data and names:
        raise LocalError("give include_mesh_data or mesh_data_for, not both")
    message = codec.get_scene_message(check.flag(include_mesh_data, "include_mesh_data"), names)
    reply = yield Request("get_scene", message, timeout_s)
    return decoded(codec.scene_from, body(reply, "scene", pb.SceneDescription))


def export_scene(path: str | pathlib.Path, timeout_s: float | None) -> Call[SceneInfo]:
    """Reads the whole scene (read_whole_scene) and writes it to a scene file."""
    whole = yield from read_whole_scene(lambda **mesh_data: scene(timeout_s, **mesh_data))
    write_scene_file(path, [info.spec() for info in whole.objects], whole.tolerance)
    return whole


# ---- queries ----


def ray_cast(
    origin: ArrayLike, direction: ArrayLike, max_distance: float, timeout_s: float | None
) -> Call[RayHit]:
    """Client.ray_cast."""
    message = pb.RayCast(
        origin=codec.vec3(check.vector3(origin, "origin")),
        direction=codec.vec3(check.nonzero_vector3(direction, "direction")),
        max_distance=check.positive(max_distance, "max_distance"),
    )
    reply = yield Request("ray_cast", message, timeout_s)
    return decoded(codec.ray_hit_from, body(reply, "ray_hit", pb.RayHit))


def _batch_rows(array: check.FloatArray, name: str) -> check.FloatArray:
    """array itself when it holds at most MAX_BATCH_ROWS rows; LocalError otherwise."""
    if len(array) > MAX_BATCH_ROWS:
        raise LocalError(
            f"{name} has {len(array)} rows; at most {MAX_BATCH_ROWS} are served in one request"
        )
    return array


def ray_cast_batch(
    origins: ArrayLike, directions: ArrayLike, max_distance: float, timeout_s: float | None
) -> Call[RayHits]:
    """Client.ray_cast_batch: origins (N, 3) or one origin (3,) for every direction
    (sent once: the wire carries a single origin), directions (N, 3) or one (3,) for
    every origin (repeated here)."""
    one_origin = np.ndim(check.as_floats(origins, "origins")) == 1
    starts = (
        check.vector3(origins, "origins").reshape(1, 3)
        if one_origin
        else check.points(origins, "origins")
    )
    if np.ndim(check.as_floats(directions, "directions")) == 1:
        ways = np.tile(check.nonzero_vector3(directions, "directions"), (len(starts), 1))
    else:
        ways = check.points(directions, "directions")
    if not one_origin and len(ways) != len(starts):
        raise LocalError(
            f"directions has {len(ways)} rows and origins {len(starts)}; one direction per "
            "origin (or one origin of shape (3,) for every direction)"
        )
    _batch_rows(ways, "directions")
    zero = np.linalg.norm(ways, axis=1) == 0
    if np.any(zero):
        row = int(np.argmax(zero))
        raise LocalError(f"directions[{row}] is zero; every segment needs a direction")
    message = pb.RayCastBatch()
    message.ParseFromString(codec.packed_doubles(1, starts) + codec.packed_doubles(2, ways))
    message.max_distance = check.positive(max_distance, "max_distance")
    reply = yield Request("ray_cast_batch", message, timeout_s)
    hits = decoded(codec.ray_hits_from, body(reply, "ray_hits", pb.RayHits))
    if len(hits.hit) != len(ways):
        raise ProtocolError(f"{len(ways)} segments were cast and {len(hits.hit)} answered")
    return hits


def closest_point(
    point: ArrayLike, max_distance: float, timeout_s: float | None
) -> Call[ClosestPoint]:
    """Client.closest_point."""
    message = pb.ClosestPoint(
        point=codec.vec3(check.vector3(point, "point")),
        max_distance=check.positive(max_distance, "max_distance"),
    )
    reply = yield Request("closest_point", message, timeout_s)
    return decoded(codec.closest_point_from, body(reply, "closest_point", pb.ClosestPointResult))


def closest_point_batch(
    points: ArrayLike, max_distance: float, timeout_s: float | None
) -> Call[ClosestPoints]:
    """Client.closest_point_batch."""
    rows = _batch_rows(check.points(points, "points", minimum=0), "points")
    message = pb.ClosestPointBatch()
    message.ParseFromString(codec.packed_doubles(1, rows))
    message.max_distance = check.positive(max_distance, "max_distance")
    reply = yield Request("closest_point_batch", message, timeout_s)
    nearest = decoded(codec.closest_points_from, body(reply, "closest_points", pb.ClosestPoints))
    if len(nearest) != len(rows):
        raise ProtocolError(f"{len(rows)} points were asked and {len(nearest)} answered")
    return nearest


def find_contacts(center: ArrayLike, radius: float, timeout_s: float | None) -> Call[list[Contact]]:
    """Client.find_contacts."""
    message = pb.FindContacts(
        center=codec.vec3(check.vector3(center, "center")),
        radius=check.non_negative(radius, "radius"),
    )
    reply = yield Request("find_contacts", message, timeout_s)
    return decoded(codec.contacts_from, body(reply, "contacts", pb.ContactsResult))


def find_contacts_batch(
    centers: ArrayLike, radius: ArrayLike, timeout_s: float | None
) -> Call[ContactsBatch]:
    """Client.find_contacts_batch: one radius for every center is sent once."""
    rows = _batch_rows(check.points(centers, "centers", minimum=0), "centers")
    if np.ndim(check.as_floats(radius, "radius")) == 0:
        radii = np.array([check.non_negative(radius, "radius")])
    else:
        radii = check.float_array(radius, "radius", (len(rows),))
        if np.any(radii < 0):
            bad = int(np.argmax(radii < 0))
            raise LocalError(
                f"radius[{bad}] is {float(radii[bad])!r}; it must be a finite number >= 0"
            )
    message = pb.FindContactsBatch()
    message.ParseFromString(codec.packed_doubles(1, rows) + codec.packed_doubles(2, radii))
    reply = yield Request("find_contacts_batch", message, timeout_s)
    found = decoded(codec.contacts_batch_from, body(reply, "contacts_batch", pb.ContactsBatch))
    if len(found) != len(rows):
        raise ProtocolError(f"{len(rows)} spheres were asked and {len(found)} answered")
    return found


def stats(timeout_s: float | None) -> Call[Stats]:
    """The server's counters and its sessions' statistics now."""
    reply = yield Request("get_stats", pb.GetStats(), timeout_s)
    return decoded(codec.stats_from, body(reply, "stats", pb.Stats))


# ---- sessions ----


class SessionBook:
    """The device sessions one client opened and has not closed, and the latest ones it
    closed (so that closing one twice is quiet). Thread-safe."""

    def __init__(self) -> None:
        self._open: set[int] = set()
        self._closed: collections.OrderedDict[int, None] = collections.OrderedDict()
        self._lock = threading.Lock()

    def opened(self, session_id: int) -> None:
        with self._lock:
            self._open.add(session_id)

    def closed(self, session_id: int) -> None:
        with self._lock:
            self._open.discard(session_id)
            self._closed[session_id] = None
            while len(self._closed) > CLOSED_SESSIONS_REMEMBERED:
                self._closed.popitem(last=False)

    def forget(self, session_id: int) -> None:
        """The server has no such session: nothing of ours to close later."""
        with self._lock:
            self._open.discard(session_id)

    def is_open(self, session_id: int) -> bool:
        with self._lock:
            return session_id in self._open

    def was_closed(self, session_id: int) -> bool:
        with self._lock:
            return session_id in self._closed

    def open_ids(self) -> list[int]:
        with self._lock:
            return sorted(self._open)


def open_session(
    book: SessionBook,
    peer_host: str,
    closer: Callable[[int], Callable[[], None]],
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
) -> Call[SessionInfo]:
    """Client.open_session (see SessionOptions). peer_host: where a wildcard UDP
    endpoint is reached; closer(session_id): what the SessionInfo's close_session does."""
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
    reply = yield Request("open_session", message, timeout_s)
    opened = body(reply, "session_opened", pb.SessionOpened)
    if len(opened.session_key) != 32:
        raise ProtocolError(f"session key is {len(opened.session_key)} bytes; it must be 32")
    try:
        udp_host, udp_port = parse_address(opened.udp_endpoint, "udp_endpoint")
    except LocalError as exc:
        raise ProtocolError(f"the server's {exc}") from exc
    # a wildcard bind is reached where the control channel is
    if udp_host in ("0.0.0.0", "::"):
        udp_host = peer_host
    book.opened(opened.session_id)
    return SessionInfo(
        session_id=opened.session_id,
        key=opened.session_key,
        udp_host=udp_host,
        udp_port=udp_port,
        max_datagram=opened.max_datagram,
        device_type=device_type,
        rate_hz=rate,
        close_session=closer(opened.session_id),
        remote_mode=remote_mode,
        open_request=message.SerializeToString(),
    )


def close_session(
    book: SessionBook, session_id: int, session_key: bytes, timeout_s: float | None
) -> Call[None]:
    """Client.close_session."""
    if book.was_closed(session_id):
        return
    if not isinstance(session_key, bytes):
        raise LocalError(f"session_key is {session_key!r}; it must be bytes")
    message = pb.CloseSession(session_id=session_id, session_key=session_key)
    try:
        body((yield Request("close_session", message, timeout_s)), "done", pb.Done)
    except RemoteError as exc:
        if exc.code == "NOT_FOUND":
            book.forget(session_id)
        raise
    book.closed(session_id)


def close_own_session(book: SessionBook, session_id: int) -> Call[None]:
    """Closes a session the client opened, unless it is closed or gone already (closed,
    or reclaimed by the server after its timeout)."""
    if not book.is_open(session_id):
        return
    try:
        yield from close_session(book, session_id, b"", None)
    except RemoteError as exc:
        if exc.code != "NOT_FOUND":
            raise


def close_sessions(
    book: SessionBook, connection_closed: Callable[[], bool]
) -> Call[HapticdError | None]:
    """Closes every session the client opened and has not closed (skipping those the
    server has reclaimed) while the connection is open; the first error met, if any."""
    failure: HapticdError | None = None
    for session_id in book.open_ids():
        if connection_closed():
            break
        try:
            yield from close_session(book, session_id, b"", None)
        except RemoteError as exc:
            if exc.code != "NOT_FOUND" and failure is None:
                failure = exc
        except HapticdError as exc:
            failure = failure or exc
    return failure


# ---- telemetry ----


def subscribe_request(
    rate_hz: float, session_ids: Iterable[int], default_timeout_s: float, timeout_s: float | None
) -> tuple[pb.Subscribe, float]:
    """A Subscribe for Client.subscribe, and how long each sample is waited for (the
    client's timeout plus two sample periods unless timeout_s says)."""
    rate = check.limited(rate_hz, "rate_hz", "subscribe_rate_hz")
    if timeout_s is None:
        wait_s = default_timeout_s + 2 / rate
    else:
        wait_s = check.positive(timeout_s, "timeout_s")
    return pb.Subscribe(rate_hz=rate, session_ids=list(session_ids)), wait_s


def telemetry(reply: pb.Reply) -> Telemetry:
    """The sample a subscription's reply carries; RemoteError for an Error reply."""
    if reply.WhichOneof("body") == "error":
        raise remote_error(reply.error, "subscribe")
    return decoded(codec.telemetry_from, body(reply, "telemetry", pb.Telemetry))


def unsubscribe(subscription_id: int) -> Call[None]:
    """Ends a subscription on the server."""
    message = pb.Unsubscribe(subscription_id=subscription_id)
    body((yield Request("unsubscribe", message)), "done", pb.Done)
