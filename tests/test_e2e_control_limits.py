"""A hostile or careless control client cannot bloat or stall the server (issue 11,
section 3): buffers grow only as bytes arrive, frames are small until a Hello succeeds,
names and replies are bounded, a token is required on every connection where one is
configured, and running out of descriptors backs off instead of spinning."""

import socket
import struct
import time

import hapticd
import numpy as np
import pytest
import trimesh
from hapticd._framing import FrameDecoder, encode_frame
from hapticd.v1 import hapticd_pb2 as pb
from server_process import running_server

TOKEN = "limits-token-0123456789"


def connect_raw(server, timeout_s=10):
    host, port = server.tcp.rsplit(":", 1)
    return socket.create_connection((host, int(port)), timeout=timeout_s)


class Replies:
    """The replies arriving on a raw socket, one at a time."""

    def __init__(self, sock):
        self._sock = sock
        self._decoder = FrameDecoder()
        self._pending = []

    def next(self):
        """The next reply, or None when the server closed the connection first."""
        while not self._pending:
            data = self._sock.recv(65536)
            if not data:
                return None
            self._pending.extend(self._decoder.feed(data))
        return pb.Reply.FromString(self._pending.pop(0))


def send_request(sock, request_id, **body):
    sock.sendall(encode_frame(pb.Request(request_id=request_id, **body).SerializeToString()))


def hello(sock, replies, token=""):
    send_request(sock, 1, hello=pb.Hello(protocol_version=1, access_token=token))
    reply = replies.next()
    assert reply is not None and reply.HasField("hello"), reply


def test_announced_frames_take_memory_only_as_bytes_arrive(bin_dir):
    # Eight connections announce 64 MiB frames and send 1 kB of each: the old server
    # reserved the whole 64 MiB per connection at once (16 MB -> 528 MB).
    with running_server(bin_dir, "--log-level", "warning") as server:
        before = server.rss_bytes()
        sockets = []
        for _ in range(8):
            sock = connect_raw(server)
            hello(sock, Replies(sock))
            sock.sendall(struct.pack(">I", 64 * 1024 * 1024) + b"\x08" * 1024)
            sockets.append(sock)
        time.sleep(0.5)
        grown = server.rss_bytes() - before
        assert grown < 16 * 1024 * 1024, f"the server grew by {grown} bytes"
        # and it still serves everybody else
        with hapticd.connect(server.tcp, timeout_s=10) as client:
            assert client.stats().counters.connections_open == 9
        for sock in sockets:
            sock.close()


def test_before_hello_a_frame_is_small(bin_dir):
    with running_server(bin_dir, "--log-level", "warning") as server:
        with connect_raw(server) as sock:
            replies = Replies(sock)
            sock.sendall(struct.pack(">I", 5000))
            reply = replies.next()
            assert reply.error.code == pb.Error.CODE_FRAME_TOO_LARGE
            assert reply.error.message == (
                "a frame announced 5000 bytes; the limit is 4096 bytes until a Hello succeeds; closing")
            assert replies.next() is None


def test_names_and_replies_are_bounded(bin_dir):
    # A 9.6 kB ray batch once got a 210 MB reply: each hit repeated a 100 kB name.
    with running_server(bin_dir, "--log-level", "warning", "--max-request-bytes", "1000000") as server:
        # the server refuses a long name itself (past the client's own check)
        with connect_raw(server) as sock:
            replies = Replies(sock)
            hello(sock, replies)
            ball = pb.Object(name="n" * 129, shape=pb.Shape(sphere=pb.Sphere(radius=0.1)),
                             material=pb.Material(stiffness=1000))
            send_request(sock, 2, add_object=pb.AddObject(object=ball))
            refused = replies.next()
            assert refused.error.code == pb.Error.CODE_BAD_REQUEST
            assert refused.error.message.endswith(".name has 129 bytes; the budget is 128 (max_name_bytes)")
        with hapticd.connect(server.tcp, timeout_s=10) as client:
            client.add_sphere("n" * 128, radius=0.1, position=(0, 0, 3))
            origins = [(0.0, 0.0, 4.0)] * 7000
            directions = [(0.0, 0.0, -1.0)] * 7000
            with pytest.raises(hapticd.RemoteError) as too_big:
                client.ray_cast_batch(origins, directions, max_distance=2)
            assert too_big.value.code == "FRAME_TOO_LARGE"
            assert "the reply would be" in too_big.value.message
            assert "the limit is 1000000 bytes" in too_big.value.message
            # a smaller batch is answered, and the connection carries on
            hits = client.ray_cast_batch(origins[:100], directions[:100], max_distance=2)
            assert len(hits.hit) == 100 and hits.hit.all() and set(hits.objects) == {"n" * 128}


def test_a_name_that_is_not_utf8_is_refused_by_name_and_floods_no_log(bin_dir):
    # protobuf refuses a string field that is not UTF-8, and once wrote a line of its own
    # to the server's stderr for each such frame: 2,000 frames, 426 kB of log
    with running_server(bin_dir, "--log-level", "info") as server:
        ball = pb.Object(name="AAAA", shape=pb.Shape(sphere=pb.Sphere(radius=0.1)),
                         material=pb.Material(stiffness=1000))
        frame = pb.Request(request_id=2, add_object=pb.AddObject(object=ball)).SerializeToString()
        frame = frame.replace(b"AAAA", b"caf\xe9")
        with connect_raw(server) as sock:
            replies = Replies(sock)
            hello(sock, replies)
            log_before = len(server.stderr_text())
            sock.sendall(encode_frame(frame) * 2000)
            for _ in range(2000):
                refused = replies.next()
                assert refused.error.code == pb.Error.CODE_BAD_REQUEST
                assert refused.error.message == (
                    f"a frame of {len(frame)} bytes is not a hapticd.v1.Request: "
                    "hapticd.v1.Object.name is not valid UTF-8")
            # the connection carries on, and the log holds nothing of it
            send_request(sock, 3, get_scene=pb.GetScene())
            assert replies.next().HasField("scene")
            assert server.stderr_text()[log_before:] == ""


def test_a_query_over_the_request_work_budget_is_refused(bin_dir):
    # A batch of rays from inside a hull of 81,920 faces: each ray asks the faces which is
    # nearest, again and again; unmetered, a million such rays held the control thread
    # (and every other client) for about 17 minutes.
    sphere = trimesh.creation.icosphere(subdivisions=6, radius=0.05)
    with running_server(bin_dir, "--log-level", "warning", "--max-request-work", "1000000") as server:
        with hapticd.connect(server.tcp, timeout_s=30) as client:
            client.add_mesh("hull", sphere.vertices, sphere.faces, "convex", position=(-1, 0, 0.1))
            inside = np.tile([-1.0, 0.001, 0.1], (1000, 1))
            with pytest.raises(hapticd.RemoteError) as refused:
                client.ray_cast_batch(inside, (0, 0, 1), max_distance=1.0)
            assert refused.value.code == "RESOURCE_EXHAUSTED"
            assert refused.value.message.startswith(
                "ray_cast_batch needs more than 1000000 units of work, the most one request may take "
                "(--max-request-work;")
            # a smaller batch is answered, and the connection carries on
            hits = client.ray_cast_batch(inside[:10], (0, 0, 1), max_distance=1.0)
            assert hits.hit.all() and set(hits.objects) == {"hull"}
            assert hits.distance == pytest.approx(0.05, abs=1e-3)


def test_a_configured_token_is_required_on_loopback_too(bin_dir, tmp_path):
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n")
    with running_server(bin_dir, "--log-level", "error", "--access-token-file", str(token_file)) as server:
        with connect_raw(server) as sock:
            replies = Replies(sock)
            send_request(sock, 2, get_scene=pb.GetScene())
            assert replies.next().error.code == pb.Error.CODE_UNAUTHENTICATED
            # a wrong token: refused, and the connection is closed
            send_request(sock, 3, hello=pb.Hello(protocol_version=1, access_token="wrong"))
            reply = replies.next()
            assert reply.error.code == pb.Error.CODE_UNAUTHENTICATED
            assert replies.next() is None
        with hapticd.connect(server.tcp, timeout_s=10, access_token=TOKEN) as client:
            counters = client.stats().counters
            assert counters.hello_failures == 1


def test_out_of_descriptors_accept_backs_off_instead_of_spinning(bin_dir):
    # With 40 descriptors the server runs out after a few dozen connections; the old
    # server retried accept at once, spinning a core and logging 100+ MB in 5 s.
    with running_server(bin_dir, "--log-level", "warning", max_open_files=40) as server:
        sockets = [connect_raw(server, timeout_s=2) for _ in range(60)]
        time.sleep(0.5)
        cpu_before = server.cpu_seconds()
        time.sleep(2.0)
        cpu = server.cpu_seconds() - cpu_before
        log_lines = server.stderr_text().count("accept failed")
        assert cpu < 0.3, f"the server used {cpu} s of CPU in 2 s while out of descriptors"
        assert 1 <= log_lines <= 10, log_lines
        for sock in sockets:
            sock.close()
        # descriptors free again: served
        deadline = time.monotonic() + 5
        while True:
            try:
                with hapticd.connect(server.tcp, timeout_s=2) as client:
                    assert client.scene().object("box")
                break
            except (hapticd.ConnectionClosed, hapticd.Timeout, OSError):
                assert server.process.poll() is None, f"the server exited: {server.stderr_text()[-2000:]}"
                assert time.monotonic() < deadline, "not served after the descriptors came back"
                time.sleep(0.2)
