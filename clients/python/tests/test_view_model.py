"""What the browser view draws (hapticd._view_model), without a browser: each object as
the server represents it, one colour per representation, the force arrow scaled in m/N,
mesh data read once per shape digest, and the panels' text. The page itself is tested
in a real browser by tests/test_e2e_view.py."""

import colorsys
import itertools

import numpy as np
import pytest

from hapticd import _codec as codec
from hapticd import _view_model as model
from hapticd.v1 import hapticd_pb2 as pb

TETRA = [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]
TETRA_TRIANGLES = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]


def info(name, representation, *, bounds=((0, 0, 0), (1, 1, 1)), **fields):
    message = pb.ObjectInfo(name=name, representation=representation, **fields)
    message.material.stiffness = 1000
    message.pose.position.CopyFrom(pb.Vec3(x=1, y=2, z=3))
    message.pose.orientation.w = 1
    message.bounds_min.CopyFrom(pb.Vec3(x=bounds[0][0], y=bounds[0][1], z=bounds[0][2]))
    message.bounds_max.CopyFrom(pb.Vec3(x=bounds[1][0], y=bounds[1][1], z=bounds[1][2]))
    return message


def scene_of(*objects):
    return codec.scene_from(pb.SceneDescription(version=3, tolerance=1e-4, objects=objects))


def hue(rgb):
    return colorsys.rgb_to_hsv(*(c / 255 for c in rgb))[0] * 360


def test_every_representation_and_session_colour_has_a_hue_of_its_own():
    coloured = [c for name, c in model.REPRESENTATION_COLOURS.items() if name != "plane"]
    coloured += [model.AVATAR_COLOUR, model.FORCE_COLOUR]
    for a, b in itertools.combinations(coloured, 2):
        gap = abs(hue(a) - hue(b))
        assert min(gap, 360 - gap) >= 20, (a, b)


def test_each_shape_is_drawn_as_represented():
    sphere = info("ball", "sphere")
    sphere.represented_shape.sphere.radius = 0.25
    box = info("crate", "box")
    box.represented_shape.box.half_extents.CopyFrom(pb.Vec3(x=0.1, y=0.2, z=0.3))
    capsule = info("pill", "capsule")
    capsule.represented_shape.capsule.radius = 0.1
    capsule.represented_shape.capsule.half_length = 0.2
    hull = info("hull", "convex")
    cube = [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)] + [[0, 0, 0]]
    hull.represented_shape.convex.points.extend(np.ravel(cube).tolist())
    plane = info("floor", "plane", bounds=((-np.inf,) * 3, (np.inf, np.inf, 0)))
    plane.represented_shape.plane.SetInParent()
    scene = scene_of(sphere, box, capsule, hull, plane)
    drawn = {o.name: model.object_drawing(o, 5.0) for o in scene.objects}

    assert drawn["ball"].kind == "sphere" and drawn["ball"].radius == 0.25
    assert drawn["ball"].colour == model.REPRESENTATION_COLOURS["sphere"]
    assert drawn["ball"].position.tolist() == [1, 2, 3]
    assert drawn["crate"].kind == "box" and drawn["crate"].dimensions.tolist() == [0.2, 0.4, 0.6]
    pill = drawn["pill"]
    assert np.allclose(pill.vertices.min(axis=0), [-0.1, -0.1, -0.3], atol=1e-3)
    assert np.allclose(pill.vertices.max(axis=0), [0.1, 0.1, 0.3], atol=1e-3)
    # the hull's triangles cover the cube's 6 faces and leave out the centre
    assert len(drawn["hull"].faces) == 12 and drawn["hull"].double_sided
    assert 8 not in drawn["hull"].faces
    floor = drawn["floor"]
    assert np.ptp(floor.vertices, axis=0).tolist() == [5.0, 5.0, 0.0]
    assert floor.opacity < 1 and floor.colour == model.REPRESENTATION_COLOURS["plane"]


def test_a_mesh_is_drawn_once_its_data_is_read_and_read_again_when_its_digest_moves():
    unread = info("kept", "mesh", shape="mesh", shape_digest=11, closed=True)
    unread.mesh.representation = pb.REPRESENTATION_MESH
    unread.represented_shape.mesh.representation = pb.REPRESENTATION_MESH
    read = pb.ObjectInfo()
    read.CopyFrom(unread)
    read.mesh.vertices.extend(TETRA)
    read.mesh.triangles.extend(TETRA_TRIANGLES)
    boxed = info("boxed", "box", shape="mesh", shape_digest=12)
    boxed.represented_shape.box.half_extents.CopyFrom(pb.Vec3(x=1, y=1, z=1))
    boxed.mesh.representation = pb.REPRESENTATION_BOX

    scene = scene_of(unread, boxed)
    assert model.object_drawing(scene.object("kept"), 1.0) is None
    # only a mesh kept as a mesh needs its data: a boxed one is drawn as its box
    assert model.meshes_to_read(scene, {}) == ["kept"]
    assert model.meshes_to_read(scene, {"kept": 11}) == []
    assert model.meshes_to_read(scene, {"kept": 10}) == ["kept"]
    drawing = model.object_drawing(scene_of(read).object("kept"), 1.0)
    assert drawing.kind == "mesh" and drawing.faces.tolist()[0] == [0, 2, 1]
    assert not drawing.double_sided
    moved = model.object_drawing(scene_of(read).object("kept"), 1.0)
    assert drawing.same_geometry(moved)


def test_the_plane_is_sized_from_the_finite_objects():
    plane = info("floor", "plane", bounds=((-np.inf,) * 3, (np.inf, np.inf, 0)))
    assert model.plane_size(scene_of(plane)) == model.MIN_PLANE_SIZE_M
    big = info("wall", "box", bounds=((0, 0, 0), (2, 0.5, 0.5)))
    assert model.plane_size(scene_of(plane, big)) == pytest.approx(6.0)


def sample(state=pb.SESSION_STATE_ACTIVE, force=(0, 0, 2.0), contact=True):
    message = pb.SessionTelemetry(session_id=0x1A2B3C4D, state=state, contact=contact)
    message.force.CopyFrom(pb.Vec3(x=force[0], y=force[1], z=force[2]))
    message.avatar.CopyFrom(pb.Vec3(x=0.1, z=0.0))
    message.device_position.CopyFrom(pb.Vec3(x=0.1, z=-0.002))
    return codec.session_telemetry_from(message)


def test_the_force_arrow_starts_at_the_avatar_and_is_scaled_in_metres_per_newton():
    drawing = model.session_drawing(sample(), 0.01)
    assert drawing.avatar.tolist() == [0.1, 0, 0]
    assert drawing.force_arrow.tolist() == [[0.1, 0, 0], [0.1, 0, 0.02]]
    assert model.session_drawing(sample(force=(0, 0, 0), contact=False), 0.01).force_arrow is None
    assert model.session_drawing(sample(state=pb.SESSION_STATE_CLOSED), 0.01) is None


def test_the_panels_say_what_is_drawn():
    unbounded = info("pinned", "box", representation_error=float("inf"))
    unbounded.represented_shape.box.half_extents.CopyFrom(pb.Vec3(x=1, y=1, z=1))
    table = model.objects_table_html(scene_of(unbounded))
    assert "scene version 3" in table and "no bound" in table and "pinned" in table
    sessions = model.sessions_html([sample()], 0.01)
    assert "session 1a2b3c4d: active, in contact, |F| = 2.000 N" in sessions
    assert "avatar (+0.1000, +0.0000, +0.0000) m" in sessions
    assert model.sessions_html([], 0.01) == "<p>no sessions</p>"
