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
from hapticd.errors import LocalError
from hapticd.objects import Material, Mesh, ObjectSpec, Pose, Shape


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
    open, a pinned representation beyond the tolerance).

    Read back: `represented`, the shape the server renders in the frame of `pose` (a
    Sphere, Box, Capsule, Plane, the hull as a Convex of its vertices, or for an object
    kept as a mesh its Mesh; None for that mesh when the scene was read without mesh
    data); for an object given as a mesh, `mesh`, the mesh as validated (vertices as
    given, triangles wound so the normals point out; its representation the one pinned,
    "auto" when the server chose) in the frame of `mesh_pose` (None without mesh data),
    `mesh_pose` (`pose` is mesh_pose composed with where the representation sits in
    the mesh's frame) and `pinned_representation`; a kinematic object's velocity (m/s,
    of mesh_pose's origin for a mesh, else of pose's) and angular_velocity (rad/s), both
    in W; and shape_digest, which changes when the shape does (not when it moves)."""

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
    represented: Shape | None = None
    mesh: Mesh | None = None
    mesh_pose: Pose | None = None
    pinned_representation: str = ""
    velocity: FloatArray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: FloatArray = field(default_factory=lambda: np.zeros(3))
    shape_digest: int = 0

    def spec(self) -> ObjectSpec:
        """The ObjectSpec that adds this object again as it is (a mesh as given, pinned
        as it was; a hull as its vertices); LocalError when the object was given as a
        mesh and the scene was read without its mesh data (read it with
        include_mesh_data=True or mesh_data_for=[name])."""
        shape: Shape | None
        pose = self.pose
        if self.pinned_representation:
            shape, pose = self.mesh, self.mesh_pose or self.pose
        else:
            shape = self.represented
        if shape is None:
            raise LocalError(
                f"object {self.name!r} was given as a mesh and the scene was read without its "
                "vertices and triangles; read it with include_mesh_data=True or "
                f"mesh_data_for=[{self.name!r}]"
            )
        return ObjectSpec(
            name=self.name,
            shape=shape,
            pose=pose,
            material=self.material,
            kinematic=self.kinematic,
            velocity=self.velocity if self.kinematic else np.zeros(3),
            angular_velocity=self.angular_velocity if self.kinematic else np.zeros(3),
        )


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


@dataclass(frozen=True, eq=False)
class ClosestPoints:
    """A batch closest-point query's answers, one row per point in order: found (N,)
    bool (False: no surface within the query's max_distance), signed_distance (N,) m
    (negative inside a solid; +inf where not found), point (N, 3) the nearest surface
    point and normal (N, 3) the unit outward normal there, both in the world frame W
    (zeros where not found), and object_index (N,) the object's index in the scene the
    server answered from (scene_version; the order Client.scene() lists them at that
    version; -1 where not found). object_names names each index that occurs."""

    found: NDArray[np.bool_]
    signed_distance: FloatArray
    point: FloatArray
    normal: FloatArray
    object_index: NDArray[np.int64]
    object_names: dict[int, str]
    scene_version: int

    def __len__(self) -> int:
        return len(self.found)

    @property
    def objects(self) -> list[str]:
        """The object of each row by name ("" where not found)."""
        return [self.object_names.get(int(i), "") for i in self.object_index]


@dataclass(frozen=True, eq=False)
class ContactsBatch:
    """A batch contact query's answers: each query sphere's contacts (those
    Client.find_contacts gives it, in scene order), laid end to end. counts (N,) says
    how many sphere i has and offsets (N + 1,) where they are: rows offsets[i] up to
    offsets[i + 1] of the contact arrays, which hold one row per contact: center_index
    (M,) the sphere's index, object_index (M,) the object's index in the scene answered
    from (scene_version; named in object_names), point (M, 3) the object's nearest
    surface point and normal (M, 3) its unit outward normal, in the world frame W, and
    depth (M,) m, >= 0 (radius - signed distance)."""

    counts: NDArray[np.int64]
    offsets: NDArray[np.int64]
    center_index: NDArray[np.int64]
    object_index: NDArray[np.int64]
    point: FloatArray
    normal: FloatArray
    depth: FloatArray
    object_names: dict[int, str]
    scene_version: int

    def __len__(self) -> int:
        return len(self.counts)

    @property
    def objects(self) -> list[str]:
        """The object of each contact row by name."""
        return [self.object_names.get(int(i), "") for i in self.object_index]

    def contacts_of(self, center: int) -> list[Contact]:
        """Sphere center's contacts as Client.find_contacts gives them; IndexError for
        an index outside [0, N)."""
        if not -len(self.counts) <= center < len(self.counts):
            raise IndexError(f"center {center} is outside this batch of {len(self.counts)}")
        center %= len(self.counts)
        rows = range(int(self.offsets[center]), int(self.offsets[center + 1]))
        return [
            Contact(
                object=self.object_names.get(int(self.object_index[k]), ""),
                point=self.point[k].copy(),
                normal=self.normal[k].copy(),
                depth=float(self.depth[k]),
            )
            for k in rows
        ]


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
