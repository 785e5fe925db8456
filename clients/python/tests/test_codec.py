"""Messages to the package's types and back: packed arrays byte-identical to
protobuf's own encoding, every shape, poses and the scene description."""

import math

import numpy as np
import pytest

from hapticd import _codec as codec
from hapticd import _validate as check
from hapticd.objects import Box, Capsule, Convex, Material, Mesh, ObjectSpec, Plane, Pose, Sphere
from hapticd.v1 import hapticd_pb2 as pb


def test_packed_arrays_match_protobufs_own_encoding():
    rng = np.random.default_rng(7)
    vertices = rng.normal(size=(500, 3))
    # every varint length: 1 to 5 bytes, and both ends of each
    edges = [0, 127, 128, 16383, 16384, 2**21 - 1, 2**21, 2**28 - 1, 2**28, 2**32 - 1]
    indices = np.concatenate([edges, rng.integers(0, 2**32, size=590)]).astype(np.uint32)
    ours = pb.Mesh.FromString(codec.packed_doubles(1, vertices) + codec.packed_uint32(2, indices))
    theirs = pb.Mesh(vertices=vertices.ravel().tolist(), triangles=indices.tolist())
    assert ours.SerializeToString() == theirs.SerializeToString()


def test_empty_packed_arrays_decode_empty():
    mesh = pb.Mesh.FromString(
        codec.packed_doubles(1, np.zeros((0, 3))) + codec.packed_uint32(2, np.zeros(0, np.uint32))
    )
    assert len(mesh.vertices) == 0 and len(mesh.triangles) == 0


@pytest.mark.parametrize(
    ("shape", "kind"),
    [
        (Sphere(0.5), "sphere"),
        (Box((0.1, 0.2, 0.3)), "box"),
        (Capsule(0.1, 0.2), "capsule"),
        (Plane(), "plane"),
        (Convex(np.eye(4, 3)), "convex"),
        (Mesh(np.eye(3), np.array([[0, 1, 2]]), "convex"), "mesh"),
    ],
)
def test_every_shape_fills_its_oneof(shape, kind):
    message = pb.Shape()
    codec.fill_shape(message, shape)
    assert message.WhichOneof("kind") == kind


def test_an_object_message_carries_every_field():
    spec = ObjectSpec(
        "k",
        Box((0.1, 0.2, 0.3)),
        pose=Pose.of((1, 2, 3), (0, 1, 0, 0)),
        material=Material(500, 2, 0.5, 0.25, force_shading=False),
        kinematic=True,
        velocity=(0.1, 0, 0),
        angular_velocity=(0, 0, 1),
    )
    message = codec.object_message(spec)
    assert message.shape.box.half_extents.z == 0.3
    assert message.pose.orientation.x == 1 and message.pose.position.z == 3
    assert message.material.stiffness == 500 and message.material.dynamic_friction == 0.25
    assert message.material.HasField("force_shading") and not message.material.force_shading
    assert message.kinematic and message.velocity.x == 0.1 and message.angular_velocity.z == 1


def test_an_unset_force_shading_is_not_sent():
    assert not codec.material_message(Material(1000)).HasField("force_shading")


def test_a_static_object_sends_no_velocities():
    message = codec.object_message(ObjectSpec("s", Sphere(1)))
    assert not message.HasField("velocity") and not message.HasField("angular_velocity")


def test_the_scene_description_becomes_typed_values():
    description = pb.SceneDescription(version=4, tolerance=1e-4)
    description.objects.add(
        name="floor",
        shape="plane",
        representation="plane",
        bounds_min=pb.Vec3(x=-math.inf, y=-math.inf, z=-math.inf),
        bounds_max=pb.Vec3(x=math.inf, y=math.inf, z=0),
        pose=pb.Pose(position=pb.Vec3(z=0.5)),
        material=pb.Material(stiffness=2000),
    )
    scene = codec.scene_from(description)
    floor = scene.object("floor")
    assert scene.version == 4 and floor.representation == "plane"
    assert np.array_equal(floor.pose.orientation, [1, 0, 0, 0])
    assert np.array_equal(floor.pose.position, [0, 0, 0.5])
    assert floor.bounds_max[2] == 0 and floor.material.stiffness == 2000
    with pytest.raises(KeyError):
        scene.object("nothing")


@pytest.mark.parametrize("seed", range(20))
def test_rotation_matrix_and_quaternion_round_trip(seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    rotation = check.quaternion_to_rotation(q)
    back = check.quaternion(rotation, "rotation")
    # q and -q are the same rotation; the conversion picks w >= 0
    assert np.allclose(back, q if q[0] >= 0 else -q)
