"""End to end, a batch of scene edits (Client.edit_scene): thousands of objects added,
moved, re-materialled and removed in one request become one scene version that the
server answers queries against; a batch with one bad edit changes nothing and the
error names the edit (bench/scene_edit_scale.py measures what a batch saves)."""

import hapticd
import numpy as np
import pytest
from server_process import running_server


@pytest.fixture
def client(bin_dir):
    with running_server(bin_dir, "--log-level", "warning", "--max-objects", "4096") as server:
        with hapticd.connect(server.tcp, timeout_s=30) as connected:
            yield connected


def grid(n):
    """n points 2 cm apart on a plane well above the default scene."""
    side = int(np.ceil(np.sqrt(n)))
    return [(0.02 * (i % side), 0.02 * (i // side), 1.0) for i in range(n)]


def test_a_batch_is_one_version_and_the_scene_answers_for_it(client):
    before = client.scene()
    edits = hapticd.SceneEdits()
    points = grid(2000)
    for i, point in enumerate(points):
        assert edits.add_sphere(f"grain{i}", 0.005, position=point) == i
    edits.add_box("lid", (0.05, 0.05, 0.01), position=(0, 0, 2), kinematic=True)
    edits.move_kinematic("lid", (0, 0, 3))
    edits.set_material("grain5", hapticd.Material(stiffness=321))
    edits.remove_object("grain6")
    assert len(edits) == 2004
    version = client.edit_scene(edits)
    assert version == before.version + 1
    scene = client.scene()
    assert scene.version == version
    names = {info.name: info for info in scene.objects}
    assert len(scene.objects) == len(before.objects) + 2000
    assert "grain6" not in names
    assert names["grain5"].material.stiffness == 321
    np.testing.assert_array_equal(names["lid"].pose.position, (0, 0, 3))
    # a ray down onto grain 42 meets its top
    x, y, z = points[42]
    hit = client.ray_cast(origin=(x, y, z + 0.1), direction=(0, 0, -1))
    assert hit.hit and hit.object == "grain42"
    assert hit.distance == pytest.approx(0.1 - 0.005, abs=1e-9)


def test_a_refused_edit_leaves_the_scene_as_it_was(client):
    before = client.scene()
    edits = hapticd.SceneEdits()
    edits.add_sphere("kept_out", 0.01, position=(0, 0, 1))
    edits.remove_object("no_such_object")
    with pytest.raises(hapticd.RemoteError) as refused:
        client.edit_scene(edits)
    assert refused.value.code == "NOT_FOUND"
    assert "edit_scene.edits[1].remove_object.name" in str(refused.value)
    after = client.scene()
    assert after.version == before.version
    assert [o.name for o in after.objects] == [o.name for o in before.objects]


def test_a_batch_checks_its_edits_as_they_are_made():
    edits = hapticd.SceneEdits()
    with pytest.raises(hapticd.LocalError, match="radius"):
        edits.add_sphere("bad", -1.0)
    with pytest.raises(hapticd.LocalError, match="timeout_s"):
        edits.add_sphere("slow", 0.1, timeout_s=1.0)
    with pytest.raises(hapticd.LocalError, match=r"^material.dampng is not a material field"):
        edits.set_material("x", {"dampng": 2})
    assert len(edits) == 0


def test_a_batch_changes_some_fields_of_a_material_as_it_stands_then(client):
    client.clear_scene()
    client.add_box("box", (0.05, 0.05, 0.05),
                   material=hapticd.Material(1500, static_friction=0.6, force_shading=True))
    edits = hapticd.SceneEdits()
    edits.set_material("box", {"damping": 2})
    edits.set_material("box", {"dynamic_friction": 0.5})  # beside the static 0.6 kept
    client.edit_scene(edits)
    assert client.scene().object("box").material == hapticd.Material(
        1500, damping=2, static_friction=0.6, dynamic_friction=0.5, force_shading=True
    )
