"""The scene read back: a SceneDescription decoded into numpy arrays and the package's
shapes, ObjectInfo.spec() adding an object again as it was, the GetScene a Client
sends, scene files written so that they read back the same, and export_scene reading
meshes one at a time when they do not fit in one reply."""

import json
import pathlib

import numpy as np
import pytest

from hapticd import (
    Box,
    Capsule,
    Convex,
    LocalError,
    Material,
    Mesh,
    ObjectSpec,
    Plane,
    Pose,
    RemoteError,
    Sphere,
)
from hapticd import _calls as calls
from hapticd import _codec as codec
from hapticd.scene_files import read_scene_file, scene_document, write_scene_file
from hapticd.scene_readback import READ_ATTEMPTS, read_whole_scene
from hapticd.v1 import hapticd_pb2 as pb

TETRA = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
TETRA_TRIANGLES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
HALF = 0.7071067811865476


def object_info(name, **fields):
    info = pb.ObjectInfo(name=name, material=pb.Material(stiffness=500), **fields)
    info.pose.orientation.w = 1
    return info


def mesh_info(name, representation, with_data, pin=pb.REPRESENTATION_AUTO):
    """An object given as a mesh, as the server describes it."""
    info = object_info(name, shape="mesh", representation=representation, shape_digest=7)
    info.mesh.representation = pin
    if with_data:
        info.mesh.vertices.extend(TETRA.ravel().tolist())
        info.mesh.triangles.extend(TETRA_TRIANGLES.ravel().tolist())
    info.mesh_pose.position.x = 2.0
    info.mesh_pose.orientation.w = 1
    if representation == "box":
        info.represented_shape.box.half_extents.x = 0.5
        info.represented_shape.box.half_extents.y = 0.5
        info.represented_shape.box.half_extents.z = 0.5
    else:
        info.represented_shape.mesh.representation = pb.REPRESENTATION_MESH
    return info


def description(*objects):
    return pb.SceneDescription(version=4, tolerance=1e-4, objects=list(objects))


def test_each_shape_decodes_to_the_packages_shape_with_numpy_arrays():
    sphere = object_info("ball", shape="sphere", representation="sphere")
    sphere.represented_shape.sphere.radius = 0.25
    box = object_info("crate", shape="box", representation="box")
    box.represented_shape.box.half_extents.CopyFrom(pb.Vec3(x=0.1, y=0.2, z=0.3))
    capsule = object_info("pill", shape="capsule", representation="capsule")
    capsule.represented_shape.capsule.radius = 0.05
    capsule.represented_shape.capsule.half_length = 0.4
    plane = object_info("floor", shape="plane", representation="plane")
    plane.represented_shape.plane.SetInParent()
    hull = object_info("hull", shape="convex", representation="convex")
    hull.represented_shape.convex.points.extend(TETRA.ravel().tolist())
    scene = codec.scene_from(description(sphere, box, capsule, plane, hull))

    assert scene.object("ball").represented == Sphere(0.25)
    half_extents = scene.object("crate").represented.half_extents
    assert half_extents.dtype == np.float64 and half_extents.tolist() == [0.1, 0.2, 0.3]
    assert scene.object("pill").represented == Capsule(0.05, 0.4)
    assert isinstance(scene.object("floor").represented, Plane)
    points = scene.object("hull").represented.points
    assert points.shape == (4, 3) and np.array_equal(points, TETRA)
    for info in scene.objects:
        assert info.mesh is None and info.mesh_pose is None and info.pinned_representation == ""


def test_a_mesh_decodes_with_its_frame_pin_and_data_only_when_it_came():
    scene = codec.scene_from(
        description(
            mesh_info("boxed", "box", True, pb.REPRESENTATION_BOX),
            mesh_info("kept", "mesh", True, pb.REPRESENTATION_MESH),
            mesh_info("unread", "mesh", False),
        )
    )
    boxed = scene.object("boxed")
    assert isinstance(boxed.represented, Box)
    assert boxed.pinned_representation == "box" and boxed.mesh.representation == "box"
    assert np.array_equal(boxed.mesh.vertices, TETRA)
    assert boxed.mesh.triangles.dtype == np.uint32
    assert np.array_equal(boxed.mesh.triangles, TETRA_TRIANGLES)
    assert boxed.mesh_pose.position.tolist() == [2.0, 0.0, 0.0]
    # kept as a mesh: the data comes once, and is the represented shape too
    kept = scene.object("kept")
    assert kept.represented is kept.mesh
    unread = scene.object("unread")
    assert unread.represented is None and unread.mesh is None
    assert unread.pinned_representation == "auto" and unread.shape_digest == 7


def test_spec_adds_an_object_again_as_it_was_given():
    kinematic = object_info("mover", shape="sphere", representation="sphere", kinematic=True)
    kinematic.represented_shape.sphere.radius = 0.1
    kinematic.velocity.CopyFrom(pb.Vec3(x=0.5))
    kinematic.angular_velocity.CopyFrom(pb.Vec3(z=2))
    scene = codec.scene_from(
        description(kinematic, mesh_info("boxed", "box", True, pb.REPRESENTATION_BOX))
    )
    mover = scene.object("mover").spec()
    assert mover.kinematic and mover.velocity.tolist() == [0.5, 0, 0]
    assert mover.angular_velocity.tolist() == [0, 0, 2]
    assert mover.material.stiffness == 500
    # a mesh: the mesh as given, at its own frame, pinned as it was
    boxed = scene.object("boxed").spec()
    assert isinstance(boxed.shape, Mesh) and boxed.shape.representation == "box"
    assert boxed.pose.position.tolist() == [2.0, 0.0, 0.0]
    unread = codec.scene_from(description(mesh_info("unread", "mesh", False))).object("unread")
    with pytest.raises(LocalError, match="include_mesh_data=True or mesh_data_for=\\['unread'\\]"):
        unread.spec()


def test_the_client_asks_for_mesh_data_as_told(fake_server):
    def answer(request):
        return [pb.Reply(request_id=request.request_id, scene=description())]

    client, server = fake_server(answer)
    client.scene()
    client.scene(include_mesh_data=True)
    client.scene(mesh_data_for=["a", "b"])
    sent = [request.get_scene for request in server.requests]
    assert sent[0] == pb.GetScene()
    assert sent[1] == pb.GetScene(include_mesh_data=True)
    assert list(sent[2].mesh_data_for) == ["a", "b"]
    with pytest.raises(LocalError, match="give include_mesh_data or mesh_data_for, not both"):
        client.scene(include_mesh_data=True, mesh_data_for=["a"])
    with pytest.raises(LocalError, match=r"mesh_data_for\[\] is ''"):
        client.scene(mesh_data_for=[""])
    assert len(server.requests) == 3


def every_kind_of_object():
    rotation = Pose.of((0.1, 0.2, 0.3), (HALF, 0, HALF, 0))
    return [
        ObjectSpec("ball", Sphere(0.1 + 0.2), pose=rotation, material=Material(2000, 3, 0.5, 0.25)),
        ObjectSpec("crate", Box(np.array([0.1, 0.2, 0.3])), material=Material(force_shading=False)),
        ObjectSpec("pill", Capsule(0.05, 0.0)),
        ObjectSpec("floor", Plane(), pose=Pose.of((0, 0, -1))),
        ObjectSpec("hull", Convex(TETRA * 0.1)),
        ObjectSpec("tetra", Mesh(TETRA, TETRA_TRIANGLES, "convex", "embree"), pose=rotation),
        ObjectSpec(
            "mover",
            Mesh(TETRA, TETRA_TRIANGLES),
            kinematic=True,
            velocity=np.array([0.01, 0, 0]),
            angular_velocity=np.array([0, 0, 1 / 3]),
        ),
    ]


def assert_same_spec(read, written):
    assert read.name == written.name
    assert type(read.shape) is type(written.shape)
    for key, value in vars(written.shape).items():
        got = getattr(read.shape, key)
        assert np.array_equal(got, value) if isinstance(value, np.ndarray) else got == value, key
    assert np.array_equal(read.pose.position, written.pose.position)
    assert np.allclose(read.pose.orientation, written.pose.orientation, rtol=0, atol=1e-15)
    assert read.material == written.material
    assert read.kinematic == written.kinematic
    assert np.array_equal(read.velocity, written.velocity)
    assert np.array_equal(read.angular_velocity, written.angular_velocity)


def test_a_written_scene_file_reads_back_to_the_same_objects(tmp_path):
    written = every_kind_of_object()
    path = tmp_path / "scene.json"
    write_scene_file(path, written, tolerance=2.5e-4)
    read = read_scene_file(path)
    assert read.tolerance == 2.5e-4
    assert len(read.objects) == len(written)
    for got, want in zip(read.objects, written, strict=True):
        assert_same_spec(got, want)
    # strict JSON: the readers refuse NaN and Infinity, and so does the writer
    json.loads(path.read_text(), parse_constant=pytest.fail)
    # a failed write leaves the earlier file whole
    with pytest.raises(LocalError, match="cannot be written"):
        write_scene_file(tmp_path / "no_such_dir" / "scene.json", written)
    assert read_scene_file(path).tolerance == 2.5e-4


def test_the_document_names_only_what_differs_from_the_defaults():
    document = scene_document([ObjectSpec("kept", Mesh(TETRA, TETRA_TRIANGLES))])
    entry = document["scene"]["objects"][0]
    assert "representation" not in entry and "ray_backend" not in entry and "motion" not in entry
    assert "force_shading" not in entry["material"]
    assert "tolerance" not in document["scene"]


class FakeScenes:
    """The call reading the scene once (_calls.scene): too large with every mesh at once,
    then one mesh a request, whose digest is given by digests (one per call for each
    mesh read). Its calls answer at once, asking the transport nothing."""

    def __init__(self, digests):
        self.digests = list(digests)
        self.calls = []

    def __call__(self, include_mesh_data=False, mesh_data_for=()):
        self.calls.append((include_mesh_data, list(mesh_data_for)))
        return self._answer(include_mesh_data, mesh_data_for)

    def _answer(self, include_mesh_data, mesh_data_for):
        if include_mesh_data:
            raise RemoteError("RESOURCE_EXHAUSTED", 5, "too much")
        if mesh_data_for:
            info = mesh_info("m", "box", True, pb.REPRESENTATION_BOX)
            info.shape_digest = self.digests.pop(0)
        else:
            info = mesh_info("m", "box", False, pb.REPRESENTATION_BOX)
        return codec.scene_from(description(info))
        yield  # a generator: a call that needs no request


def read_whole(reads):
    """read_whole_scene driven as the clients drive a call (no request reaches this
    transport: FakeScenes answers every read itself)."""
    return calls.run(read_whole_scene(reads), perform=pytest.fail)


def test_meshes_too_large_for_one_reply_are_read_one_at_a_time():
    reads = FakeScenes([7])
    scene = read_whole(reads)
    assert reads.calls == [(True, []), (False, []), (False, ["m"])]
    assert np.array_equal(scene.object("m").mesh.vertices, TETRA)
    assert isinstance(scene.object("m").represented, Box)


def test_a_mesh_that_keeps_changing_while_read_is_given_up_on():
    # the scene says digest 7, and every read of the mesh itself finds another
    reads = FakeScenes([8] * READ_ATTEMPTS)
    with pytest.raises(Exception, match=f"changed each of the {READ_ATTEMPTS} times"):
        read_whole(reads)
    # one changed reading, then a stable one: the second attempt succeeds
    assert read_whole(FakeScenes([8, 7])).object("m").mesh is not None


def golden(name):
    """A vector of proto/golden/vectors.json (checked by the C++ server's tests too)."""
    path = pathlib.Path(__file__).resolve().parents[3] / "proto" / "golden" / "vectors.json"
    return next(v for v in json.loads(path.read_text())["vectors"] if v["name"] == name)


def test_the_golden_get_scene_is_what_the_client_sends(fake_server):
    def answer(request):
        return [pb.Reply(request_id=request.request_id, scene=description())]

    client, server = fake_server(answer)
    client.scene(mesh_data_for=["tetra"])
    sent = server.requests[0]
    sent.request_id = 12
    assert sent.SerializeToString().hex() == golden("get_scene_mesh_data")["hex"]


def test_the_golden_scene_reply_decodes_to_numpy_arrays():
    reply = pb.Reply.FromString(bytes.fromhex(golden("scene_reply")["hex"]))
    scene = codec.scene_from(reply.scene)
    mover, tetra = scene.object("mover"), scene.object("tetra")
    assert mover.represented == Sphere(0.05) and mover.kinematic
    assert mover.velocity.tolist() == [0.5, 0, 0] and mover.angular_velocity.tolist() == [0, 0, 2]
    assert mover.shape_digest == 16654918056353844564
    assert tetra.represented is tetra.mesh and tetra.pinned_representation == "mesh"
    assert np.array_equal(tetra.mesh.vertices, TETRA)
    assert np.array_equal(tetra.mesh.triangles, TETRA_TRIANGLES)
    assert tetra.mesh_pose.position.tolist() == [1, 0, 0]
