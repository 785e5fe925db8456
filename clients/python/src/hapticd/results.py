"""What the server answers, as plain typed values: the scene's description, query
results, sessions and telemetry. Vectors are float64 numpy arrays of shape (3,) in the
world frame W, SI units; anything else carries a suffix (_us, _ns, _hz).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from hapticd._validate import FloatArray
from hapticd.objects import Material, Pose


@dataclass(frozen=True, eq=False)
class ObjectInfo:
    """One object as the server holds it: its shape ("sphere", ..., "mesh"), the
    representation it renders it as and that representation's error bound (m), its
    world bounds (infinite for a plane), pose, material, and a mesh's triangle count
    and query backend ("native" or "embree"; "" for the other shapes). For an object
    given as a mesh (whatever represents it): closed (it bounds a solid), topology
    ("closed", "open" or "non-orientable"; an open mesh is a surface: distances to it
    are unsigned and nothing is inside it), rewound_triangles (how many the server
    turned so that the normals point out), and warnings, one sentence each (rewound,
    open, a pinned representation beyond the tolerance)."""

    name: str
    shape: str
    representation: str
    representation_error: float
    bounds_min: FloatArray
    bounds_max: FloatArray
    pose: Pose
    material: Material
    kinematic: bool
    triangles: int
    ray_backend: str = ""
    closed: bool = False
    topology: str = ""
    rewound_triangles: int = 0
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class SceneInfo:
    """The scene: its version (bumped by every edit), tolerance (m) and objects."""

    version: int
    tolerance: float
    objects: list[ObjectInfo]

    def object(self, name: str) -> ObjectInfo:
        """The object called name; KeyError if there is none."""
        for info in self.objects:
            if info.name == name:
                return info
        raise KeyError(name)


@dataclass(frozen=True, eq=False)
class RayHit:
    """A ray cast's first hit: distance along the ray (m), point and normal in W (the
    surface's normal turned towards the ray's origin: outward for a ray from outside,
    inward for one that starts inside a solid and so reports where it leaves), and the
    object hit. hit is False (and the rest zero) on a miss."""

    hit: bool
    distance: float
    point: FloatArray
    normal: FloatArray
    object: str


@dataclass(frozen=True, eq=False)
class RayHits:
    """A batch ray cast's first hits, one row per segment in order: hit (N,) bool,
    distance (N,) m (0 on a miss), point and normal (N, 3) in W (zeros on a miss;
    normals towards the origin), and the objects hit ("" on a miss)."""

    hit: NDArray[np.bool_]
    distance: FloatArray
    point: FloatArray
    normal: FloatArray
    objects: list[str]


@dataclass(frozen=True, eq=False)
class ClosestPoint:
    """The nearest surface point: signed distance (m, negative inside), point and
    outward normal in W, and its object. found is False when nothing lies within the
    query's max_distance."""

    found: bool
    signed_distance: float
    point: FloatArray
    normal: FloatArray
    object: str


@dataclass(frozen=True, eq=False)
class Contact:
    """One object a query sphere touches: the contact point and the object's outward
    normal in W, and the penetration depth (m, >= 0)."""

    object: str
    point: FloatArray
    normal: FloatArray
    depth: float


@dataclass(frozen=True)
class SessionInfo:
    """An open device session: its id, the 32-byte key its datagrams are tagged with,
    the server's UDP endpoint (host, port), the largest datagram (bytes), and what the
    handshake asked for (device type "impedance" or "admittance", the state rate).
    close_session, set by the Client that opened it, closes the server's session; the
    DeviceSession made from this info calls it when it closes (None: nothing to close
    from here, e.g. an info built by hand). remote_mode is "direct" or "local_model";
    open_request the encoded OpenSession the session was opened with (a local-model
    device renders with the same settings)."""

    session_id: int
    key: bytes = field(repr=False)
    udp_host: str
    udp_port: int
    max_datagram: int
    device_type: str
    rate_hz: float
    close_session: Callable[[], None] | None = field(default=None, repr=False, compare=False)
    remote_mode: str = "direct"
    open_request: bytes = field(default=b"", repr=False, compare=False)


@dataclass(frozen=True)
class ServerCounters:
    """The server's counters since it started."""

    datagrams_received: int = 0
    commands_sent: int = 0
    malformed: int = 0
    oversized: int = 0
    unknown_session: int = 0
    bad_mac: int = 0
    replayed: int = 0
    reordered: int = 0
    send_errors: int = 0
    sessions_opened: int = 0
    sessions_closed: int = 0
    sessions_timed_out: int = 0
    control_errors: int = 0
    connections_open: int = 0
    connections_refused: int = 0
    connections_timed_out: int = 0
    hello_failures: int = 0


@dataclass(frozen=True, eq=False)
class SessionTelemetry:
    """One session as the server sees it: state ("waiting", "active", "ramping",
    "timed_out", "closed"), the last force (N), device and avatar positions (m), the
    device's reported round trip (µs), and its counters. tick_us_max is the longest
    render tick since the previous sample; tick_overruns counts the ticks that spent the
    server's work budget (--tick-work-budget). A local-model session (the device renders
    its own force from models of the scene the server sends) also reports the newest
    model the device holds (model_version, 0: none yet), the device's own avatar on it
    (device_avatar, m) and the model fragments the server sent. The channel's two ports
    (J; the device's as its newest state reported them) and its net energy
    (channel_energy, positive: the channel generated energy); under tdpa the avatar
    input's drift behind the device (m, now and at most) and the ticks the server's port
    cut; under a deadband the states the device held back, the keep-alives, the
    commands the server held back and the ticks it rendered on a prediction."""

    session_id: int
    state: str
    force: FloatArray
    device_position: FloatArray
    avatar: FloatArray
    contact: bool
    rtt_us: int
    last_sequence: int
    ticks: int
    states_received: int
    commands_sent: int
    replayed: int
    reordered: int
    bad_mac: int
    nonfinite_inputs: int
    absurd_inputs: int
    force_saturations: int
    watchdog_trips: int
    passivity_activations: int
    tick_us_max: float
    tick_overruns: int
    model_version: int
    device_avatar: FloatArray | None
    model_fragments_sent: int
    server_energy_in: float = 0.0
    server_energy_out: float = 0.0
    device_energy_in: float = 0.0
    device_energy_out: float = 0.0
    channel_energy: float = 0.0
    drift: float = 0.0
    max_drift: float = 0.0
    tdpa_activations: int = 0
    states_held: int = 0
    keepalives: int = 0
    commands_held: int = 0
    predicted_ticks: int = 0


@dataclass(frozen=True)
class Telemetry:
    """One telemetry sample: the server's clock (ns), scene version, sessions and
    counters."""

    server_time_ns: int
    scene_version: int
    sessions: list[SessionTelemetry]
    counters: ServerCounters

    def session(self, session_id: int) -> SessionTelemetry:
        """The sample of one session; KeyError if it is not in this sample."""
        for sample in self.sessions:
            if sample.session_id == session_id:
                return sample
        raise KeyError(session_id)


@dataclass(frozen=True)
class Stats:
    """The server's statistics now: scene version, sessions and counters."""

    scene_version: int
    sessions: list[SessionTelemetry]
    counters: ServerCounters

    def session(self, session_id: int) -> SessionTelemetry:
        """The statistics of one session; KeyError if the server has none for it."""
        for sample in self.sessions:
            if sample.session_id == session_id:
                return sample
        raise KeyError(session_id)
