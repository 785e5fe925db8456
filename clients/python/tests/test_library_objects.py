"""Objects from the libraries users hold: a trimesh.Trimesh wherever a mesh is taken, a
scipy Rotation wherever a rotation is, and the hint naming hapticd's (w, x, y, z) order
when a quaternion may be scipy's (x, y, z, w) (the rule: _validate.hint_quaternion_order)."""

import warnings

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from hapticd import LocalError, Mesh, Pose, QuaternionOrderWarning, SceneEdits
from hapticd import _codec as codec
from hapticd.v1 import hapticd_pb2 as pb


def sent_object(edits):
    """The object of the batch's last add_object."""
    return edits.message().edits[-1].add_object.object


def test_add_mesh_takes_a_trimesh():
    box = trimesh.creation.box(extents=(0.2, 0.4, 0.6))
    edits = SceneEdits()
    edits.add_mesh("crate", box, representation="box", position=(1, 0, 0))
    mesh = sent_object(edits).shape.mesh
    assert np.array_equal(np.reshape(mesh.vertices, (-1, 3)), box.vertices)
    assert np.array_equal(np.reshape(mesh.triangles, (-1, 3)), box.faces)
    assert mesh.representation == pb.REPRESENTATION_BOX
    from_trimesh = Mesh.from_trimesh(box, "mesh")
    assert np.array_equal(from_trimesh.triangles, box.faces)
    assert from_trimesh.representation == "mesh"


def test_add_mesh_refuses_what_is_not_one_mesh():
    box = trimesh.creation.box()
    edits = SceneEdits()
    with pytest.raises(LocalError, match="the Trimesh's faces are its triangles"):
        edits.add_mesh("crate", box, box.faces)
    with pytest.raises(LocalError, match="vertices and no triangles"):
        edits.add_mesh("crate", box.vertices)
    scene = trimesh.Scene([box, trimesh.creation.icosphere()])
    with pytest.raises(LocalError, match=r"trimesh.Scene of 2 geometries.*scene.to_mesh\(\)"):
        edits.add_mesh("both", scene)
    with pytest.raises(LocalError, match="mesh is str; it must be a trimesh.Trimesh"):
        Mesh.from_trimesh("box.stl")
    assert len(edits) == 0


def test_a_scipy_rotation_is_taken_wherever_a_rotation_is():
    turn = Rotation.from_euler("xyz", [10, 20, 30], degrees=True)
    pose = Pose.of((0, 0, 0), turn)
    assert np.allclose(pose.rotation, turn.as_matrix(), atol=1e-15)
    edits = SceneEdits()
    edits.add_box("crate", (0.1, 0.1, 0.1), rotation=turn)
    edits.move_kinematic("crate", (0, 0, 0), rotation=turn)
    quat = edits.message().edits[0].add_object.object.pose.orientation
    assert np.allclose([quat.w, quat.x, quat.y, quat.z], turn.as_quat(scalar_first=True))
    moved = edits.message().edits[1].move_kinematic.pose.orientation
    assert np.allclose([moved.w, moved.x, moved.y, moved.z], turn.as_quat(scalar_first=True))


def test_a_stack_of_rotations_is_refused():
    with pytest.raises(LocalError, match="rotation is a scipy Rotation holding 3 rotations"):
        Pose.of((0, 0, 0), Rotation.random(3, rng=1))


def test_scipys_identity_quaternion_gets_the_hint_naming_both_readings():
    with pytest.warns(QuaternionOrderWarning) as caught:
        pose = Pose.of((0, 0, 0), (0, 0, 0, 1))
    message = str(caught[0].message)
    assert "read as (w, x, y, z): a turn of 180 degrees about [0, 0, 1]" in message
    assert "in scipy's (x, y, z, w) order it would be no turn" in message
    assert "pass a scipy Rotation itself" in message
    # a hint, not a refusal: the quaternion is used as (w, x, y, z)
    assert np.allclose(pose.rotation, np.diag([-1.0, -1.0, 1.0]))


def test_the_hint_points_at_the_callers_line():
    edits = SceneEdits()
    with pytest.warns(QuaternionOrderWarning) as caught:
        edits.add_sphere("ball", 0.1, rotation=(0, 0, 0, 1))
    assert caught[0].filename == __file__


def test_the_rule_on_many_turns():
    turns = Rotation.random(2000, rng=7)
    angles = turns.magnitude()
    for turn, angle in zip(turns, angles, strict=True):
        wxyz = turn.as_quat(scalar_first=True)
        xyzw = turn.as_quat()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            Pose.of((0, 0, 0), wxyz)
            hinted_ours = bool(caught)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            Pose.of((0, 0, 0), xyzw)
            hinted_scipys = bool(caught)
        # under 90 degrees: ours never hinted, scipy's always
        if angle < np.pi / 2:
            assert not hinted_ours and hinted_scipys, turn.as_rotvec()
        # and exactly the rule |q[3]| > |q[0]|
        assert hinted_ours == (abs(wxyz[3]) > abs(wxyz[0]))
        assert hinted_scipys == (abs(xyzw[3]) > abs(xyzw[0]))
        # a Rotation or a matrix never gets the hint
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            Pose.of((0, 0, 0), turn)
            Pose.of((0, 0, 0), turn.as_matrix())


def test_a_quarter_turn_about_z_in_our_order_gets_no_hint():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Pose.of((0, 0, 0), (0.7071067811865476, 0, 0, 0.7071067811865476))
        Pose.of((0, 0, 0), (1, 0, 0, 0))


def test_what_the_server_sends_is_never_hinted_at():
    message = pb.Pose(orientation=pb.Quat(w=0, x=0, y=0, z=1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pose = codec.pose_from(message)
    assert pose.orientation.tolist() == [0, 0, 0, 1]
