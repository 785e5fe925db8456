"""hapticd: the Python client of the hapticd haptic rendering server.

    import hapticd

    with hapticd.connect("127.0.0.1:7460") as client:
        client.add_box("crate", (0.05, 0.05, 0.05), position=(0.3, 0, 0.05))
        info = client.open_session("impedance", start=(0, 0, 0.1))
        with hapticd.DeviceSession(info) as device:
            command = device.exchange(position=(0, 0, 0.1))

connect() gives a Client for the control channel (scene edits, queries, sessions,
telemetry); DeviceSession speaks the UDP realtime channel; SimImpedanceDevice and
SimAdmittanceDevice simulate a device held by a hand. Errors are HapticdError
subclasses: LocalError (misuse), RemoteError (the server refused), ProtocolError,
ConnectionClosed, Timeout. Units SI, world frame W.
"""

from hapticd.client import Client, Subscription, connect
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
    Contact,
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

__all__ = [
    "MAX_EDITS_PER_BATCH",
    "Box",
    "Capsule",
    "Client",
    "ClosestPoint",
    "Command",
    "ConnectionClosed",
    "Contact",
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
    "SessionTelemetry",
    "Shape",
    "SimAdmittanceDevice",
    "SimImpedanceDevice",
    "Sphere",
    "Stats",
    "Subscription",
    "Telemetry",
    "Timeout",
    "connect",
    "read_mesh_file",
    "read_scene_file",
    "summarize_rtt",
]
