"""The Embree backend through the real server: `--ray-backend embree` puts the default
scene's mesh (the ring) on it and an object can name its own backend; queries and forces
come out the same as on a native server given the same requests."""

import hapticd
import numpy as np
import pytest
from server_process import running_server

RING_CENTRE = np.array([0.0, -0.15, 0.012])  # the default scene's torus: radii 0.04, 0.012


def probe(server_tcp: str, backend: str) -> tuple[list, list]:
    """The same requests to a server: fixed-seed rays and closest points around the ring,
    then a device pressing 2 mm into the tube's top. Returns the answers."""
    answers, forces = [], []
    with hapticd.connect(server_tcp) as client:
        assert client.scene().object("ring").ray_backend == backend
        rng = np.random.default_rng(5)
        for _ in range(300):
            origin = RING_CENTRE + rng.uniform(-0.06, 0.06, 3) + np.array([0, 0, 0.03])
            hit = client.ray_cast(origin, rng.normal(size=3), 0.2)
            near = client.closest_point(origin, 0.2)
            answers.append((hit.hit, hit.object, hit.distance, near.object, near.signed_distance))
        # a point off the mesh's vertices and edges on the tube's top
        top = RING_CENTRE + np.array([0.04 * np.cos(0.05), 0.04 * np.sin(0.05), 0.0119])
        info = client.open_session("impedance", start=top + np.array([0, 0, 0.01]))
        with hapticd.DeviceSession(info) as device:
            for z in np.linspace(0.01, -0.002, 13):
                command = device.exchange(top + np.array([0, 0, z]), timeout_s=1.0)
                forces.append(command.force)
        client.close_session(info.session_id)
    return answers, forces


def test_embree_and_native_servers_answer_alike(bin_dir):
    results = {}
    for backend in ("native", "embree"):
        with running_server(bin_dir, "--ray-backend", backend, "--log-level", "warning") as server:
            results[backend] = probe(server.tcp, backend)
    (native_answers, native_forces), (embree_answers, embree_forces) = results["native"], results["embree"]
    assert sum(1 for answer in native_answers if answer[1] == "ring") > 30
    for on_native, on_embree in zip(native_answers, embree_answers, strict=True):
        assert on_native[:2] == on_embree[:2] and on_native[3] == on_embree[3]
        assert on_native[2] == pytest.approx(on_embree[2], abs=1e-12)
        assert on_native[4] == pytest.approx(on_embree[4], abs=1e-12)
    assert np.allclose(native_forces, embree_forces, atol=1e-9)
    assert embree_forces[-1][2] == pytest.approx(2000 * 0.0021, rel=0.05)  # k d, up to the facets


def test_an_object_names_its_own_backend(server):
    with hapticd.connect(server.tcp) as client:
        tetra = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]) + np.array([1.0, 1.0, 0])
        faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
        client.add_mesh("tetra", tetra, faces, "mesh", ray_backend="embree", material={"stiffness": 900})
        assert client.scene().object("tetra").ray_backend == "embree"
        assert client.scene().object("ring").ray_backend == "native"  # the server's default
        assert client.scene().object("box").ray_backend == ""
        hit = client.ray_cast((1.02, 1.02, 0.5), (0, 0, -1), 1.0)
        assert hit.object == "tetra" and hit.point[2] == pytest.approx(0.1 - 0.04, abs=1e-12)
        with pytest.raises(hapticd.LocalError, match="ray_backend"):
            client.add_mesh("bad", tetra, faces, ray_backend="optix")
        client.remove_object("tetra")


def test_a_ray_batch_answers_as_single_rays(bin_dir):
    """Many segments in one request (the ring on Embree traces them in packets) give the
    answers of the same segments one at a time; bad batches are refused by name."""
    with running_server(bin_dir, "--ray-backend", "embree", "--log-level", "warning") as server:
        with hapticd.connect(server.tcp) as client:
            rng = np.random.default_rng(9)
            origins = RING_CENTRE + rng.uniform(-0.08, 0.08, (400, 3)) + np.array([0, 0, 0.04])
            directions = rng.normal(size=(400, 3))
            batch = client.ray_cast_batch(origins, directions, 0.3)
            assert batch.hit.shape == (400,) and batch.point.shape == (400, 3)
            for i in range(400):
                one = client.ray_cast(origins[i], directions[i], 0.3)
                assert bool(batch.hit[i]) == one.hit and batch.objects[i] == one.object
                if one.hit:
                    assert batch.distance[i] == pytest.approx(one.distance, abs=1e-12)
                    assert np.allclose(batch.point[i], one.point, atol=1e-12)
            assert batch.objects.count("ring") > 20 and batch.objects.count("floor") > 20
            with pytest.raises(hapticd.LocalError, match=r"directions\[1\] is zero"):
                client.ray_cast_batch(origins[:3], np.array([[0, 0, 1], [0, 0, 0], [1, 0, 0]]))
            with pytest.raises(hapticd.LocalError, match="one direction per origin"):
                client.ray_cast_batch(origins[:3], directions[:2])
