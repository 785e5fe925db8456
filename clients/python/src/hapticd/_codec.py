"""Protobuf messages to the package's types and back; the only module besides the
transports that knows the wire types. Mesh and convex arrays are encoded straight from
numpy (packed fields), so a large mesh costs no per-element Python work.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hapticd._validate import FloatArray
from hapticd.errors import LocalError
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
    SessionTelemetry,
    Stats,
    Telemetry,
)
from hapticd.v1 import hapticd_pb2 as pb

REPRESENTATION_VALUES = {
    "auto": pb.REPRESENTATION_AUTO,
    "sphere": pb.REPRESENTATION_SPHERE,
    "box": pb.REPRESENTATION_BOX,
    "capsule": pb.REPRESENTATION_CAPSULE,
    "convex": pb.REPRESENTATION_CONVEX,
    "mesh": pb.REPRESENTATION_MESH,
}
REPRESENTATION_NAMES = {value: name for name, value in REPRESENTATION_VALUES.items()}
RAY_BACKEND_VALUES = {
    "default": pb.RAY_BACKEND_DEFAULT,
    "native": pb.RAY_BACKEND_NATIVE,
    "embree": pb.RAY_BACKEND_EMBREE,
}
SESSION_STATE_NAMES = {
    pb.SESSION_STATE_UNSPECIFIED: "unspecified",
    pb.SESSION_STATE_WAITING: "waiting",
    pb.SESSION_STATE_ACTIVE: "active",
    pb.SESSION_STATE_RAMPING: "ramping",
    pb.SESSION_STATE_TIMED_OUT: "timed_out",
    pb.SESSION_STATE_CLOSED: "closed",
}


# ---- vectors and poses ----


def vec3(values: FloatArray) -> pb.Vec3:
    """A Vec3 from a (3,) array."""
    return pb.Vec3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def array3(message: pb.Vec3) -> FloatArray:
    """A (3,) float64 array from a Vec3."""
    return np.array([message.x, message.y, message.z], dtype=np.float64)


def pose_message(pose: Pose) -> pb.Pose:
    """A Pose message from a Pose."""
    w, x, y, z = (float(c) for c in pose.orientation)
    return pb.Pose(position=vec3(pose.position), orientation=pb.Quat(w=w, x=x, y=y, z=z))


def pose_from(message: pb.Pose) -> Pose:
    """A Pose from a Pose message; an absent orientation is the identity."""
    q = message.orientation
    if message.HasField("orientation"):
        orientation = np.array([q.w, q.x, q.y, q.z], dtype=np.float64)
    else:
        orientation = np.array([1.0, 0.0, 0.0, 0.0])
    return Pose(array3(message.position), orientation)


def material_message(material: Material) -> pb.Material:
    """A Material message; force_shading is sent only when set."""
    message = pb.Material(
        stiffness=material.stiffness,
        damping=material.damping,
        static_friction=material.static_friction,
        dynamic_friction=material.dynamic_friction,
    )
    if material.force_shading is not None:
        message.force_shading = material.force_shading
    return message


def material_change_message(fields: dict[str, Any]) -> pb.MaterialChange:
    """A MaterialChange holding the (checked) fields named; force_shading None is the
    server's default, True."""
    message = pb.MaterialChange()
    for key, value in fields.items():
        setattr(message, key, True if key == "force_shading" and value is None else value)
    return message


def material_from(message: pb.Material) -> Material:
    """A Material from its message (force_shading None when absent)."""
    return Material(
        stiffness=message.stiffness,
        damping=message.damping,
        static_friction=message.static_friction,
        dynamic_friction=message.dynamic_friction,
        force_shading=message.force_shading if message.HasField("force_shading") else None,
    )


# ---- packed arrays ----


def _varint(value: int) -> bytes:
    """The protobuf varint of a non-negative int."""
    out = bytearray()
    while value >= 0x80:
        out.append((value & 0x7F) | 0x80)
        value >>= 7
    out.append(value)
    return bytes(out)


def packed_doubles(field_number: int, values: FloatArray) -> bytes:
    """A packed repeated double field: tag, byte length, little-endian doubles."""
    payload = np.ascontiguousarray(values, dtype="<f8").tobytes()
    return _varint(field_number << 3 | 2) + _varint(len(payload)) + payload


def packed_uint32(field_number: int, values: NDArray[np.uint32]) -> bytes:
    """A packed repeated uint32 field, the varints computed for all values at once: value
    v takes n = 1..5 bytes, byte k holding bits 7k..7k+6 and, for k < n - 1, the high bit."""
    v = np.ascontiguousarray(values, dtype=np.uint32).ravel()
    n = np.ones(len(v), dtype=np.uint8)
    for k in range(1, 5):
        n += v >= (1 << (7 * k))
    out = np.empty((len(v), 5), dtype=np.uint8)
    for k in range(5):
        out[:, k] = ((v >> (7 * k)) & 0x7F).astype(np.uint8) | ((n > k + 1).astype(np.uint8) << 7)
    used = np.arange(5)[None, :] < n[:, None]
    payload = out[used].tobytes()
    return _varint(field_number << 3 | 2) + _varint(len(payload)) + payload


# ---- objects ----


def fill_shape(target: pb.Shape, shape: Shape) -> None:
    """Writes shape into a Shape message in place (a mesh is parsed straight into it,
    never copied)."""
    if isinstance(shape, Sphere):
        target.sphere.radius = shape.radius
    elif isinstance(shape, Box):
        target.box.half_extents.CopyFrom(vec3(shape.half_extents))
    elif isinstance(shape, Capsule):
        target.capsule.radius = shape.radius
        target.capsule.half_length = shape.half_length
    elif isinstance(shape, Plane):
        target.plane.SetInParent()
    elif isinstance(shape, Convex):
        target.convex.ParseFromString(packed_doubles(1, shape.points))
    else:
        target.mesh.ParseFromString(
            packed_doubles(1, shape.vertices) + packed_uint32(2, shape.triangles)
        )
        target.mesh.representation = REPRESENTATION_VALUES[shape.representation]


def fill_object(target: pb.Object, spec: ObjectSpec) -> None:
    """Writes spec into an Object message in place; velocities only for a kinematic
    object."""
    target.name = spec.name
    fill_shape(target.shape, spec.shape)
    target.pose.CopyFrom(pose_message(spec.pose))
    target.material.CopyFrom(material_message(spec.material))
    target.kinematic = spec.kinematic
    if isinstance(spec.shape, Mesh):
        target.ray_backend = RAY_BACKEND_VALUES[spec.shape.ray_backend]
    if spec.kinematic:
        target.velocity.CopyFrom(vec3(spec.velocity))
        target.angular_velocity.CopyFrom(vec3(spec.angular_velocity))


def object_message(spec: ObjectSpec) -> pb.Object:
    """The Object message of a spec."""
    message = pb.Object()
    fill_object(message, spec)
    return message


def get_scene_message(include_mesh_data: bool, mesh_data_for: list[str]) -> pb.GetScene:
    """A GetScene asking for every mesh's data, or the named objects' (or none)."""
    return pb.GetScene(include_mesh_data=include_mesh_data, mesh_data_for=mesh_data_for)


def _points(values: Iterable[float]) -> FloatArray:
    """A flat x0 y0 z0 x1 ... field as an (N, 3) array."""
    return np.array(values, dtype=np.float64).reshape(-1, 3)


def _given_mesh(info: pb.ObjectInfo) -> Mesh | None:
    """The mesh an object was given as, when its data came (else None)."""
    if not info.HasField("mesh") or len(info.mesh.triangles) == 0:
        return None
    return Mesh(
        _points(info.mesh.vertices),
        np.array(info.mesh.triangles, dtype=np.uint32).reshape(-1, 3),
        REPRESENTATION_NAMES[info.mesh.representation],
        info.ray_backend or "default",
    )


def _represented_shape(info: pb.ObjectInfo, mesh: Mesh | None) -> Shape | None:
    """The shape the server renders (a mesh representation is the given mesh itself:
    its data comes once, in info.mesh)."""
    shape = info.represented_shape
    kind = shape.WhichOneof("kind")
    if kind == "sphere":
        return Sphere(shape.sphere.radius)
    if kind == "box":
        return Box(array3(shape.box.half_extents))
    if kind == "capsule":
        return Capsule(shape.capsule.radius, shape.capsule.half_length)
    if kind == "plane":
        return Plane()
    if kind == "convex":
        return Convex(_points(shape.convex.points))
    return mesh


def object_info_from(info: pb.ObjectInfo) -> ObjectInfo:
    """An ObjectInfo from its message."""
    mesh = _given_mesh(info)
    return ObjectInfo(
        name=info.name,
        shape=info.shape,
        representation=info.representation,
        representation_error=info.representation_error,
        bounds_min=array3(info.bounds_min),
        bounds_max=array3(info.bounds_max),
        pose=pose_from(info.pose),
        material=material_from(info.material),
        kinematic=info.kinematic,
        triangles=info.triangles,
        ray_backend=info.ray_backend,
        closed=info.closed,
        topology=info.topology,
        rewound_triangles=info.rewound_triangles,
        warnings=tuple(info.warnings),
        represented=_represented_shape(info, mesh),
        mesh=mesh,
        mesh_pose=pose_from(info.mesh_pose) if info.HasField("mesh_pose") else None,
        pinned_representation=(
            REPRESENTATION_NAMES[info.mesh.representation] if info.HasField("mesh") else ""
        ),
        velocity=array3(info.velocity),
        angular_velocity=array3(info.angular_velocity),
        shape_digest=info.shape_digest,
    )


def scene_from(message: pb.SceneDescription) -> SceneInfo:
    """A SceneInfo from a SceneDescription; LocalError if it holds an invalid pose,
    material or shape (the caller turns that into a ProtocolError)."""
    objects = [object_info_from(info) for info in message.objects]
    return SceneInfo(version=message.version, tolerance=message.tolerance, objects=objects)


# ---- queries ----


def ray_hit_from(message: pb.RayHit) -> RayHit:
    """A RayHit from its message."""
    return RayHit(
        hit=message.hit,
        distance=message.distance,
        point=array3(message.point),
        normal=array3(message.normal),
        object=message.object,
    )


def ray_hits_from(message: pb.RayHits) -> RayHits:
    """A RayHits from its message (its arrays copied into numpy once)."""
    return RayHits(
        hit=np.array(message.hit, dtype=bool),
        distance=np.array(message.distance, dtype=np.float64),
        point=np.array(message.points, dtype=np.float64).reshape(-1, 3),
        normal=np.array(message.normals, dtype=np.float64).reshape(-1, 3),
        objects=list(message.objects),
    )


def closest_point_from(message: pb.ClosestPointResult) -> ClosestPoint:
    """A ClosestPoint from its message."""
    return ClosestPoint(
        found=message.found,
        signed_distance=message.signed_distance,
        point=array3(message.point),
        normal=array3(message.normal),
        object=message.object,
    )


def contacts_from(message: pb.ContactsResult) -> list[Contact]:
    """The contacts of a ContactsResult, in the server's order."""
    return [
        Contact(object=c.object, point=array3(c.point), normal=array3(c.normal), depth=c.depth)
        for c in message.contacts
    ]


def _column(values: Iterable[Any], rows: int, what: str, dtype: Any, width: int = 1) -> Any:
    """A repeated field as a numpy array of rows rows (of width values each, as (rows,
    width) when width > 1); LocalError naming what when it holds another count. (numpy
    reads a parsed repeated field at memory speed.)"""
    array = np.array(values, dtype=dtype)
    if len(array) != rows * width:
        raise LocalError(f"it holds {len(array)} {what} values for {rows} rows")
    return array.reshape(rows, width) if width > 1 else array


def object_names_from(message: pb.ObjectNames) -> dict[int, str]:
    """The index -> name table of a batch's answers."""
    if len(message.indices) != len(message.names):
        raise LocalError(
            f"its object table has {len(message.indices)} indices and {len(message.names)} names"
        )
    return dict(zip(message.indices, message.names, strict=True))


def closest_points_from(message: pb.ClosestPoints) -> ClosestPoints:
    """ClosestPoints from their message (its arrays copied into numpy once); LocalError
    when its columns differ in length (the caller turns that into a ProtocolError)."""
    n = len(message.found)
    return ClosestPoints(
        found=np.array(message.found, dtype=bool),
        signed_distance=_column(message.signed_distance, n, "signed_distance", np.float64),
        point=_column(message.points, n, "point", np.float64, 3),
        normal=_column(message.normals, n, "normal", np.float64, 3),
        object_index=_column(message.objects, n, "object", np.int64),
        object_names=object_names_from(message.object_names),
        scene_version=message.scene_version,
    )


def contacts_batch_from(message: pb.ContactsBatch) -> ContactsBatch:
    """A ContactsBatch from its message; LocalError when its columns do not hold as many
    contacts as its counts add up to (the caller turns that into a ProtocolError)."""
    counts = np.array(message.counts, dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    m = int(offsets[-1])
    return ContactsBatch(
        counts=counts,
        offsets=offsets,
        center_index=np.repeat(np.arange(len(counts), dtype=np.int64), counts),
        object_index=_column(message.objects, m, "object", np.int64),
        point=_column(message.points, m, "point", np.float64, 3),
        normal=_column(message.normals, m, "normal", np.float64, 3),
        depth=_column(message.depths, m, "depth", np.float64),
        object_names=object_names_from(message.object_names),
        scene_version=message.scene_version,
    )


# ---- telemetry ----


def counters_from(message: pb.ServerCounters) -> ServerCounters:
    """ServerCounters from their message, field by field."""
    names = ServerCounters.__dataclass_fields__
    return ServerCounters(**{name: getattr(message, name) for name in names})


def session_telemetry_from(message: pb.SessionTelemetry) -> SessionTelemetry:
    """A SessionTelemetry from its message."""
    return SessionTelemetry(
        session_id=message.session_id,
        state=SESSION_STATE_NAMES.get(message.state, f"state {message.state}"),
        force=array3(message.force),
        device_position=array3(message.device_position),
        avatar=array3(message.avatar),
        contact=message.contact,
        rtt_us=message.rtt_us,
        last_sequence=message.last_sequence,
        ticks=message.ticks,
        states_received=message.states_received,
        commands_sent=message.commands_sent,
        replayed=message.replayed,
        reordered=message.reordered,
        bad_mac=message.bad_mac,
        nonfinite_inputs=message.nonfinite_inputs,
        absurd_inputs=message.absurd_inputs,
        force_saturations=message.force_saturations,
        watchdog_trips=message.watchdog_trips,
        passivity_activations=message.passivity_activations,
        tick_us_max=message.tick_us_max,
        tick_overruns=message.tick_overruns,
        model_version=message.model_version,
        device_avatar=array3(message.device_avatar) if message.HasField("device_avatar") else None,
        model_fragments_sent=message.model_fragments_sent,
        server_energy_in=message.server_energy_in,
        server_energy_out=message.server_energy_out,
        device_energy_in=message.device_energy_in,
        device_energy_out=message.device_energy_out,
        channel_energy=message.channel_energy,
        drift=message.drift,
        max_drift=message.max_drift,
        tdpa_activations=message.tdpa_activations,
        states_held=message.states_held,
        keepalives=message.keepalives,
        commands_held=message.commands_held,
        predicted_ticks=message.predicted_ticks,
    )


def telemetry_from(message: pb.Telemetry) -> Telemetry:
    """A Telemetry sample from its message."""
    return Telemetry(
        server_time_ns=message.server_time_ns,
        scene_version=message.scene_version,
        sessions=[session_telemetry_from(s) for s in message.sessions],
        counters=counters_from(message.counters),
    )


def stats_from(message: pb.Stats) -> Stats:
    """Stats from their message."""
    return Stats(
        scene_version=message.scene_version,
        sessions=[session_telemetry_from(s) for s in message.sessions],
        counters=counters_from(message.counters),
    )
