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


def test_a_server_that_hangs_up_raises_connection_closed(fake_server):
    client, server = fake_server(lambda request: [])
    server.sock.shutdown(socket.SHUT_RDWR)
    with pytest.raises(ConnectionClosed):
        client.scene()
    with pytest.raises(hapticd.LocalError, match="the connection is closed"):
        client.scene()


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
