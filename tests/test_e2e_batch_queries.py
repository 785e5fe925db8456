"""End to end, the batch queries against a real hapticd process, with the blocking Client
and with the AsyncClient (`connect`): a batch of closest points answers as the same
points asked one at a time, a batch of contacts as the same spheres one at a time (laid
end to end), a fan of rays from one origin as rays with their own origins; and the
bounds are refused by name, locally and by the server."""

import numpy as np
import pytest
from hapticd import LocalError, RemoteError

# The default scene: floor (plane z = 0), box, ball, pillar and the ring (a torus mesh).
NAMES = {"floor", "box", "ball", "pillar", "ring"}


@pytest.fixture
def client(server, connect):
    with connect(server.tcp, timeout_s=30) as connected:
        yield connected


def random_points(n, seed):
    """Points about the default scene's objects, some inside them, some far from all."""
    rng = np.random.default_rng(seed)
    return rng.uniform([-0.25, -0.25, -0.05], [0.25, 0.25, 0.2], size=(n, 3))


def test_closest_points_answer_as_single_points(client):
    points = random_points(300, 1)
    nearest = client.closest_point_batch(points, max_distance=0.05)
    scene = client.scene()
    assert nearest.scene_version == scene.version and len(nearest) == 300
    assert nearest.point.shape == (300, 3) and nearest.normal.shape == (300, 3)
    names = [info.name for info in scene.objects]
    for i, p in enumerate(points):
        one = client.closest_point(p, max_distance=0.05)
        assert nearest.found[i] == one.found
        if not one.found:
            assert nearest.object_index[i] == -1 and np.isinf(nearest.signed_distance[i])
            continue
        assert nearest.objects[i] == one.object == names[nearest.object_index[i]]
        assert nearest.signed_distance[i] == one.signed_distance
        assert np.array_equal(nearest.point[i], one.point)
        assert np.array_equal(nearest.normal[i], one.normal)
    assert set(nearest.objects) - {""} == NAMES
    assert 10 < np.count_nonzero(~nearest.found) < 290
    assert np.any(nearest.signed_distance < 0)  # some points inside solids


def test_contacts_answer_as_single_spheres_laid_end_to_end(client):
    centers = random_points(200, 2)
    radii = np.random.default_rng(3).uniform(0, 0.08, 200)
    found = client.find_contacts_batch(centers, radii)
    assert len(found) == 200 and found.offsets[-1] == len(found.depth) > 100
    assert np.all(found.depth >= 0)
    several = 0
    for i in range(200):
        one = client.find_contacts(centers[i], radii[i])
        batch = found.contacts_of(i)
        assert [c.object for c in batch] == [c.object for c in one]
        for mine, theirs in zip(batch, one, strict=True):
            assert mine.depth == theirs.depth
            assert np.array_equal(mine.point, theirs.point)
            assert np.array_equal(mine.normal, theirs.normal)
        several += len(one) > 1
    assert several > 5
    assert np.array_equal(found.center_index, np.repeat(np.arange(200), found.counts))
    # one radius for all is the same as that radius given to each
    shared = client.find_contacts_batch(centers, 0.03)
    each = client.find_contacts_batch(centers, np.full(200, 0.03))
    assert np.array_equal(shared.counts, each.counts) and shared.objects == each.objects


def test_a_fan_from_one_origin_answers_as_rays_with_their_own_origins(client):
    directions = np.random.default_rng(4).normal(size=(500, 3))
    origin = np.array([0.0, 0.0, 0.12])
    fan = client.ray_cast_batch(origin, directions, max_distance=1.0)
    each = client.ray_cast_batch(np.tile(origin, (500, 1)), directions, max_distance=1.0)
    assert np.array_equal(fan.hit, each.hit) and fan.objects == each.objects
    assert np.array_equal(fan.distance, each.distance)
    assert np.array_equal(fan.point, each.point) and np.array_equal(fan.normal, each.normal)
    assert 100 < np.count_nonzero(fan.hit) < 500
    # parallel rays: one direction for every origin
    starts = np.column_stack([np.linspace(-0.2, 0.2, 50), np.zeros(50), np.full(50, 0.5)])
    down = client.ray_cast_batch(starts, (0, 0, -1), max_distance=1.0)
    assert down.hit.all() and set(down.objects) <= NAMES


def test_empty_batches_give_empty_arrays(client):
    assert len(client.closest_point_batch(np.empty((0, 3)))) == 0
    found = client.find_contacts_batch(np.empty((0, 3)), 0.1)
    assert len(found) == 0 and found.offsets.tolist() == [0] and found.point.shape == (0, 3)


def test_bounds_are_refused_by_name(client):
    with pytest.raises(LocalError, match=r"points has 1000001 rows; at most 1000000 are served"):
        client.closest_point_batch(np.zeros((1_000_001, 3)))
    # the server's bound on contacts: each of these spheres touches the floor and the box
    centers = np.tile([0.15, 0.0, 0.0], (500_001, 1))
    with pytest.raises(RemoteError) as refused:
        client.find_contacts_batch(centers, 0.01)
    assert refused.value.code == "RESOURCE_EXHAUSTED"
    assert refused.value.message == (
        "find_contacts_batch finds more than 1000000 contacts for its 500001 centers, the most "
        "one reply holds; ask fewer centers or a smaller radius"
    )
    # and the connection goes on
    assert client.closest_point_batch(np.zeros((1, 3))).objects == ["floor"]
