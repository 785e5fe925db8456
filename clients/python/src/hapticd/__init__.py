"""hapticd: the Python client of the hapticd haptic rendering server.

    import hapticd

    with hapticd.connect("127.0.0.1:7460") as client:
        client.add_box("crate", (0.05, 0.05, 0.05), position=(0.3, 0, 0.05))
        info = client.open_session("impedance", start=(0, 0, 0.1))
        with hapticd.DeviceSession(info) as device:
            command = device.exchange(position=(0, 0, 0.1))

connect() gives a Client for the control channel (scene edits, queries, sessions,
telemetry), connect_async() an AsyncClient with the same methods for asyncio programs;
DeviceSession speaks the UDP realtime channel; SimImpedanceDevice and
SimAdmittanceDevice simulate a device held by a hand. Errors are HapticdError
subclasses: LocalError (misuse), RemoteError (the server refused), ProtocolError,
ConnectionClosed, Timeout. Units SI (m, N, s, kg), world frame W, quaternions in the
order (w, x, y, z).
"""

import importlib.metadata

from hapticd.async_client import AsyncClient, AsyncSubscription, connect_async
from hapticd.client import Client, SessionOptions, Subscription, connect
from hapticd.device import Command, DeviceCounters, DeviceSession, RttSummary, summarize_rtt
from hapticd.errors import (
    ConnectionClosed,
    HapticdError,
    LocalError,
    ProtocolError,
    QuaternionOrderWarning,
    RemoteError,
    SessionEnded,
    Timeout,
)
from hapticd.objects import (
    Box,
    Capsule,
    Convex,
    Material,
    Mesh,
    ObjectSpec,
    Plane,
    Pose,
    Shape,
    Sphere,
)
from hapticd.results import (
    ClosestPoint,
    ClosestPoints,
    Contact,
    ContactsBatch,
    ObjectInfo,
    RayHit,
    RayHits,
    SceneInfo,
    ServerCounters,
    SessionInfo,
    SessionTelemetry,
    Stats,
    Telemetry,
)
from hapticd.scene_edits import MAX_EDITS_PER_BATCH, SceneEdits
from hapticd.scene_files import read_mesh_file, read_scene_file
from hapticd.sim_device import DeviceSpec, HandSpec, SimAdmittanceDevice, SimImpedanceDevice

try:
    # the version the package was installed as: pyproject.toml's, the one source of the
    # C++ binaries' version too (CMakeLists.txt reads it)
    __version__ = importlib.metadata.version("hapticd")
except importlib.metadata.PackageNotFoundError:  # pragma: no cover - run from a bare tree
    __version__ = "0+unknown"

__all__ = [
    "MAX_EDITS_PER_BATCH",
    "AsyncClient",
    "AsyncSubscription",
    "Box",
    "Capsule",
    "Client",
    "ClosestPoint",
    "ClosestPoints",
    "Command",
    "ConnectionClosed",
    "Contact",
    "ContactsBatch",
    "Convex",
    "DeviceCounters",
    "DeviceSession",
    "DeviceSpec",
    "HandSpec",
    "HapticdError",
    "LocalError",
    "Material",
    "Mesh",
    "ObjectInfo",
    "ObjectSpec",
    "Plane",
    "Pose",
    "ProtocolError",
    "QuaternionOrderWarning",
    "RayHit",
    "RayHits",
    "RemoteError",
    "RttSummary",
    "SceneEdits",
    "SceneInfo",
    "ServerCounters",
    "SessionEnded",
    "SessionInfo",
    "SessionOptions",
    "SessionTelemetry",
    "Shape",
    "SimAdmittanceDevice",
    "SimImpedanceDevice",
    "Sphere",
    "Stats",
    "Subscription",
    "Telemetry",
    "Timeout",
    "__version__",
    "connect",
    "connect_async",
    "read_mesh_file",
    "read_scene_file",
    "summarize_rtt",
]
