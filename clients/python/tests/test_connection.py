"""The control channel's client side against a scripted fake server: replies matched to
requests, telemetry interleaved, errors, timeouts, late replies, and a server that
misbehaves."""

import socket
import struct
import threading
import time

import numpy as np
import pytest

import hapticd
from hapticd import ConnectionClosed, ProtocolError, RemoteError, Timeout
from hapticd._connection import is_loopback
from hapticd._framing import FrameDecoder, encode_frame
from hapticd.v1 import hapticd_pb2 as pb


def done(request, version=7):
    return pb.Reply(request_id=request.request_id, done=pb.Done(scene_version=version))


def telemetry(request_id, server_time_ns):
    sample = pb.Telemetry(server_time_ns=server_time_ns, scene_version=3)
    sample.sessions.add(session_id=9, state=pb.SESSION_STATE_ACTIVE, force=pb.Vec3(z=1.5))
    return pb.Reply(request_id=request_id, telemetry=sample)


def test_an_edit_returns_the_scene_version_and_sends_the_object(fake_server):
    client, server = fake_server(lambda request: [done(request, version=12)])
    version = client.add_sphere("ball", 0.05, position=(1, 2, 3), material={"stiffness": 2000})
    assert version == 12
    sent = server.requests[0].add_object.object
    assert sent.name == "ball"
    assert sent.shape.sphere.radius == 0.05
    assert (sent.pose.position.x, sent.pose.position.y, sent.pose.position.z) == (1, 2, 3)
    assert sent.material.stiffness == 2000


def test_a_mesh_arrives_as_its_arrays(fake_server):
    client, server = fake_server(lambda request: [done(request)])
    rng = np.random.default_rng(4)
    vertices = rng.normal(size=(200, 3))
    triangles = rng.integers(0, 200, size=(300, 3))
    client.add_mesh("m", vertices, triangles, representation="mesh")
    mesh = server.requests[0].add_object.object.shape.mesh
    assert np.array_equal(np.array(mesh.vertices).reshape(-1, 3), vertices)
    assert np.array_equal(np.array(mesh.triangles).reshape(-1, 3), triangles)
    assert mesh.representation == pb.REPRESENTATION_MESH


def test_an_error_reply_raises_remote_error_with_code_and_message(fake_server):
    def refuse(request):
        error = pb.Error(code=pb.Error.CODE_NOT_FOUND, message='objects["nope"] does not exist')
        return [pb.Reply(request_id=request.request_id, error=error)]

    client, _ = fake_server(refuse)
    with pytest.raises(RemoteError) as caught:
        client.remove_object("nope")
    assert caught.value.code == "NOT_FOUND"
    assert caught.value.code_value == pb.Error.CODE_NOT_FOUND
    assert caught.value.message == 'objects["nope"] does not exist'
    assert (
        str(caught.value) == 'remove_object: server error NOT_FOUND: objects["nope"] does not exist'
    )


def test_a_reply_of_the_wrong_kind_is_a_protocol_error(fake_server):
    client, _ = fake_server(lambda request: [done(request)])
    with pytest.raises(ProtocolError, match="expected a ray_hit reply, got done"):
        client.ray_cast((0, 0, 1), (0, 0, -1))


def test_query_results_are_typed_with_numpy_vectors(fake_server):
    def answer(request):
        hit = pb.RayHit(
            hit=True, distance=0.5, point=pb.Vec3(z=0.5), normal=pb.Vec3(z=1), object="floor"
        )
        return [pb.Reply(request_id=request.request_id, ray_hit=hit)]

    client, _ = fake_server(answer)
    hit = client.ray_cast((0, 0, 1), (0, 0, -1))
    assert hit.hit and hit.object == "floor" and hit.distance == 0.5
    assert isinstance(hit.point, np.ndarray) and np.array_equal(hit.normal, [0, 0, 1])


def test_telemetry_between_requests_is_queued_in_order(fake_server):
    subscription_ids = []

    def handler(request):
        if request.WhichOneof("body") == "subscribe":
            subscription_ids.append(request.request_id)
            return [telemetry(request.request_id, 1)]
        if request.WhichOneof("body") == "unsubscribe":
            return [telemetry(subscription_ids[0], 99), done(request)]
        # two samples arrive before this request's answer
        return [telemetry(subscription_ids[0], 2), telemetry(subscription_ids[0], 3), done(request)]

    client, _ = fake_server(handler)
    with client.subscribe(100) as subscription:
        assert client.clear_scene() == 7
        samples = [subscription.next(timeout_s=1) for _ in range(3)]
    assert [s.server_time_ns for s in samples] == [1, 2, 3]
    assert samples[0].session(9).state == "active"
    assert np.array_equal(samples[0].session(9).force, [0, 0, 1.5])
    # the sample that raced the unsubscribe is dropped, and the client still works
    assert client.clear_scene() == 7


def test_a_refused_subscription_raises_at_subscribe(fake_server):
    def refuse(request):
        error = pb.Error(code=pb.Error.CODE_RESOURCE_EXHAUSTED, message="too many subscriptions")
        return [pb.Reply(request_id=request.request_id, error=error)]

    client, _ = fake_server(refuse)
    with pytest.raises(RemoteError, match="RESOURCE_EXHAUSTED: too many subscriptions"):
        client.subscribe(10)


def test_a_timeout_is_raised_and_the_late_reply_dropped(fake_server):
    pending = []

    def handler(request):
        # the first request is answered only together with the second
        if not pending:
            pending.append(request)
            return []
        return [done(pending[0], version=1), done(request, version=2)]

    client, _ = fake_server(handler)
    started = time.monotonic()
    with pytest.raises(Timeout, match=r"no reply to clear_scene within 0.2 s"):
        client.clear_scene(timeout_s=0.2)
    assert time.monotonic() - started < 1.0
    assert client.clear_scene() == 2


def test_a_garbage_reply_is_a_protocol_error_and_closes(fake_server):
    client, server = fake_server(lambda request: [])
    server.sock.sendall(encode_frame(b"\xff\xff\xff\xff"))
    with pytest.raises(ProtocolError, match="reply frame does not parse"):
        client.scene()
    assert client.closed


def test_an_oversized_reply_length_is_a_protocol_error(fake_server):
    client, server = fake_server(lambda request: [])
    server.sock.sendall(struct.pack(">I", 64 * 1024 * 1024 + 1))
    with pytest.raises(ProtocolError, match="over the 67108864-byte limit"):
        client.scene()


def test_a_reply_to_a_request_never_sent_is_a_protocol_error(fake_server):
    client, _ = fake_server(lambda request: [pb.Reply(request_id=1000, done=pb.Done())])
    with pytest.raises(ProtocolError, match="request_id 1000, which was never sent"):
        client.clear_scene()


def test_a_server_that_hangs_up_raises_connection_closed_every_time(fake_server):
    servers = []

    def hang_up(request):
        servers[0].sock.shutdown(socket.SHUT_RDWR)
        return []

    client, server = fake_server(hang_up)
    servers.append(server)
    started = time.monotonic()
    with pytest.raises(ConnectionClosed) as hung_up:
        client.scene(timeout_s=30)
    # at once, and said so: no word of a timeout
    assert time.monotonic() - started < 10
    assert str(hung_up.value) == (
        "the server closed the connection (awaiting the reply to get_scene)"
    )
    assert client.closed
    # later calls say the same, not "you misused the API"
    for call in (client.scene, client.clear_scene, client.stats):
        with pytest.raises(ConnectionClosed) as later:
            call()
        assert str(later.value) == (
            "the connection is closed: the server closed the connection "
            "(awaiting the reply to get_scene)"
        )


def test_a_subscription_whose_server_hangs_up_raises_connection_closed(fake_server):
    def first_sample(request):
        if request.HasField("subscribe"):
            return [telemetry(request.request_id, 1)]
        return []

    client, server = fake_server(first_sample)
    subscription = client.subscribe(100, timeout_s=30)
    assert subscription.next().server_time_ns == 1
    server.sock.shutdown(socket.SHUT_RDWR)
    with pytest.raises(ConnectionClosed) as hung_up:
        subscription.next()
    assert str(hung_up.value) == (
        "the server closed the connection (awaiting the telemetry of subscription 1)"
    )
    with pytest.raises(ConnectionClosed, match=r"^the connection is closed: the server closed"):
        subscription.next()
    with pytest.raises(ConnectionClosed, match=r"^the connection is closed: the server closed"):
        client.scene()
    # nothing left to unsubscribe from, nor to close
    subscription.close()
    client.close()


def test_a_client_closed_by_its_owner_is_misuse(fake_server):
    client, _ = fake_server(lambda request: [done(request)])
    client.close()
    closed_here = r"^the connection is closed \(close\(\) was called\)$"
    with pytest.raises(hapticd.LocalError, match=closed_here):
        client.clear_scene()


def big_scene(objects):
    """A scene description of that many spheres (about 90 bytes each)."""
    scene = pb.SceneDescription(version=5, tolerance=1e-4)
    for i in range(objects):
        info = scene.objects.add(name=f"ball-{i:05d}", shape="sphere", representation="sphere")
        info.pose.position.x = i
        info.pose.orientation.w = 1
        info.material.stiffness = 1000 + i
        info.bounds_min.x, info.bounds_max.x = i - 1, i + 1
    return scene


def test_threads_sharing_a_client_each_get_their_own_replies(fake_server):
    """Scene readers (1.3 MB replies), ray casters (answers echo the question) and a
    subscriber (a sample after every cast) share one client; each gets its own."""
    scene = big_scene(15_000)
    assert scene.ByteSize() > 1_300_000
    subscriptions = []

    def handler(request):
        kind = request.WhichOneof("body")
        if kind == "get_scene":
            return [pb.Reply(request_id=request.request_id, scene=scene)]
        if kind == "subscribe":
            subscriptions.append(request.request_id)
            return [telemetry(request.request_id, 0)]
        if kind == "unsubscribe":
            return [done(request)]
        origin = request.ray_cast.origin
        hit = pb.RayHit(hit=True, distance=1, point=origin, normal=pb.Vec3(z=1), object="x")
        replies = [pb.Reply(request_id=request.request_id, ray_hit=hit)]
        if subscriptions:
            replies.append(telemetry(subscriptions[0], int(origin.x * 1000 + origin.y)))
        return replies

    client, _ = fake_server(handler)
    client.timeout_s = 30
    subscription = client.subscribe(1000)
    casts = 100
    results: dict[str, object] = {}

    def read_scene(name):
        results[name] = [len(client.scene().objects) for _ in range(2)]

    def cast(name, row):
        points = [client.ray_cast((row, k, 1), (0, 0, -1)).point for k in range(casts)]
        results[name] = [tuple(p) for p in points]

    def watch(name):
        results[name] = [subscription.next().server_time_ns for _ in range(2 * casts)]

    threads = [threading.Thread(target=read_scene, args=(f"scene{i}",)) for i in range(3)]
    threads += [threading.Thread(target=cast, args=(f"cast{r}", r)) for r in (1, 2)]
    threads.append(threading.Thread(target=watch, args=("watch",)))
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert not any(thread.is_alive() for thread in threads)
    for i in range(3):
        assert results[f"scene{i}"] == [15_000] * 2
    for r in (1, 2):
        assert results[f"cast{r}"] == [(r, k, 1) for k in range(casts)]
    # every cast's sample, each caster's in its order (the first sample came at subscribe)
    samples = results["watch"]
    every_cast = {r * 1000 + k for r in (1, 2) for k in range(casts)}
    assert samples[0] == 0 and len(set(samples[1:])) == 2 * casts - 1
    assert set(samples[1:]) <= every_cast
    for r in (1, 2):
        mine = [t - r * 1000 for t in samples if r * 1000 <= t < r * 1000 + casts]
        assert mine == sorted(mine)
    subscription.close()
    assert not client.closed


def serve_hello_once(listener, protocol_version):
    sock, _ = listener.accept()
    decoder = FrameDecoder()
    frames = []
    while not frames:
        frames = decoder.feed(sock.recv(4096))
    request = pb.Request.FromString(frames[0])
    hello = pb.HelloReply(
        protocol_version=protocol_version, server_name="fake", udp_endpoint="127.0.0.1:9"
    )
    sock.sendall(
        encode_frame(pb.Reply(request_id=request.request_id, hello=hello).SerializeToString())
    )
    sock.recv(1)
    sock.close()


@pytest.mark.parametrize("version", [1, 2])
def test_connect_says_hello_and_checks_the_protocol_version(version):
    with socket.create_server(("127.0.0.1", 0)) as listener:
        thread = threading.Thread(target=serve_hello_once, args=(listener, version), daemon=True)
        thread.start()
        address = f"127.0.0.1:{listener.getsockname()[1]}"
        if version == 1:
            with hapticd.connect(address, timeout_s=2) as client:
                assert client.server_name == "fake" and client.udp_endpoint == "127.0.0.1:9"
        else:
            with pytest.raises(ProtocolError, match="server speaks protocol version 2"):
                hapticd.connect(address, timeout_s=2)
        thread.join(timeout=2)


def test_connect_to_a_closed_port_raises_connection_closed():
    with socket.create_server(("127.0.0.1", 0)) as listener:
        port = listener.getsockname()[1]
    with pytest.raises(ConnectionClosed, match=f"cannot connect to 127.0.0.1:{port}"):
        hapticd.connect(f"127.0.0.1:{port}", timeout_s=1)


def test_loopback_is_recognised():
    assert is_loopback("127.0.0.1") and is_loopback("127.3.2.1") and is_loopback("::1")
    assert not is_loopback("10.0.0.1") and not is_loopback("localhost")
