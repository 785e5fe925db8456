"""hapticd.view against a fake server: what it asks for (one subscription, a GetScene
when the scene's version moves on, a mesh's data once per shape digest) and the bounds
of its arguments, refused by name. The page in a browser: tests/test_e2e_view.py."""

import threading
import time

import pytest

from hapticd import LocalError, RemoteError
from hapticd import view as hapticd_view
from hapticd.v1 import hapticd_pb2 as pb

TETRA = [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]
TETRA_TRIANGLES = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]



@pytest.fixture
def client_kind() -> str:
    """The view drives a blocking Client (an asyncio program hands it one of its own)."""
    return "blocking"

def scene(version, digest, with_data):
    """A sphere and a mesh kept as a mesh (its data only when asked)."""
    ball = pb.ObjectInfo(name="ball", shape="sphere", representation="sphere")
    ball.represented_shape.sphere.radius = 0.1
    kept = pb.ObjectInfo(
        name="kept", shape="mesh", representation="mesh", shape_digest=digest, closed=True
    )
    kept.represented_shape.mesh.representation = pb.REPRESENTATION_MESH
    kept.mesh.representation = pb.REPRESENTATION_MESH
    kept.mesh_pose.orientation.w = 1
    if with_data:
        kept.mesh.vertices.extend(TETRA)
        kept.mesh.triangles.extend(TETRA_TRIANGLES)
    for info in (ball, kept):
        info.material.stiffness = 1000
        info.pose.orientation.w = 1
        info.pose.position.x = 0.01 * version
    return pb.SceneDescription(version=version, tolerance=1e-4, objects=[ball, kept])


class FakeScene:
    """Telemetry with scene versions 1, 1, 2, 3; the mesh's digest changes at version 3."""

    VERSIONS = (1, 1, 2, 3)

    def __init__(self):
        self.version = 0
        self.reads = []

    def digest(self):
        return 11 if self.version < 3 else 12

    def __call__(self, request):
        kind = request.WhichOneof("body")
        if kind == "subscribe":
            return [
                pb.Reply(request_id=request.request_id, telemetry=pb.Telemetry(scene_version=v))
                for v in self.VERSIONS
            ]
        if kind == "get_scene":
            names = list(request.get_scene.mesh_data_for)
            if not names:
                self.version += 1
            self.reads.append(names)
            body = scene(self.version, self.digest(), bool(names))
            return [pb.Reply(request_id=request.request_id, scene=body)]
        return [pb.Reply(request_id=request.request_id, done=pb.Done())]


def test_the_view_reads_the_scene_when_its_version_moves_and_a_mesh_once_per_digest(
    fake_server,
):
    fake = FakeScene()
    client, server = fake_server(fake)
    with hapticd_view.serve(client, port=0) as view:
        deadline = time.monotonic() + 30
        while view.counters.samples < len(FakeScene.VERSIONS) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert view.url.startswith("http://127.0.0.1:")
    assert view.error is None
    # version 1: the scene and the mesh's data; 1 again: nothing; 2: the scene (the same
    # digest: no mesh read); 3: the scene and, its digest new, the mesh's data again
    assert fake.reads == [[], ["kept"], [], [], ["kept"]]
    assert (view.counters.samples, view.counters.scene_reads, view.counters.mesh_reads) == (
        4,
        3,
        2,
    )
    kinds = [r.WhichOneof("body") for r in server.requests]
    assert kinds.count("subscribe") == 1 and kinds[-1] == "unsubscribe"
    assert server.requests[0].subscribe.rate_hz == hapticd_view.DEFAULT_RATE_HZ


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"rate_hz": 61}, r"rate_hz is 61.0; it must be in \[1, 60\] Hz"),
        ({"rate_hz": 0.5}, r"rate_hz is 0.5; it must be in \[1, 60\] Hz"),
        ({"port": 70000}, r"port is 70000; it must be an integer in \[0, 65535\]"),
        ({"port": True}, r"port is True; it must be an integer"),
        ({"force_scale_m_per_n": 0}, r"force_scale_m_per_n is 0.0; it must be in \(0, 1\] m/N"),
        ({"camera": ((0, 0, 1),)}, r"camera is .*; it must be \(position, look_at\)"),
        ({"camera": ((0, 0, 1), (0, 0))}, r"camera\[1\] has shape \(2,\)"),
    ],
)
def test_bad_arguments_are_refused_by_name_before_anything_starts(fake_server, arguments, message):
    client, server = fake_server(FakeScene())
    with pytest.raises(LocalError, match=message):
        hapticd_view.serve(client, **arguments)
    assert server.requests == []


def test_a_view_needs_a_client():
    with pytest.raises(LocalError, match="it must be a hapticd Client"):
        hapticd_view.serve("127.0.0.1:7460")


def test_a_refused_subscription_is_raised_and_leaves_no_page_behind(fake_server):
    def refuse(request):
        error = pb.Error(code=pb.Error.CODE_RESOURCE_EXHAUSTED, message="16 subscriptions")
        return [pb.Reply(request_id=request.request_id, error=error)]

    client, _ = fake_server(refuse)
    threads_before = threading.active_count()
    with pytest.raises(RemoteError, match="RESOURCE_EXHAUSTED"):
        hapticd_view.serve(client, port=0)
    # the page's server thread is gone again
    deadline = time.monotonic() + 10
    while threading.active_count() > threads_before and time.monotonic() < deadline:
        time.sleep(0.05)
    assert threading.active_count() <= threads_before
