"""Fixtures for the package's unit tests: no hapticd server is needed. A Client runs
over one end of a socket pair; a FakeServer thread (or the test itself) is the other."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator

import pytest

from hapticd._connection import Connection
from hapticd._framing import FrameDecoder, encode_frame
from hapticd.client import Client
from hapticd.v1 import hapticd_pb2 as pb

Handler = Callable[[pb.Request], list[pb.Reply]]


class FakeServer:
    """Answers each Request frame with the replies handler returns, on its own thread,
    and records the requests."""

    def __init__(self, sock: socket.socket, handler: Handler) -> None:
        self.sock = sock
        self.handler = handler
        self.requests: list[pb.Request] = []
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        decoder = FrameDecoder()
        while True:
            try:
                data = self.sock.recv(1 << 16)
            except OSError:
                return
            if not data:
                return
            for frame in decoder.feed(data):
                request = pb.Request.FromString(frame)
                self.requests.append(request)
                for reply in self.handler(request):
                    self.sock.sendall(encode_frame(reply.SerializeToString()))

    def close(self) -> None:
        self.sock.close()
        self._thread.join(timeout=2)


def make_client(sock: socket.socket, timeout_s: float = 1.0) -> Client:
    """A Client over sock, as connect() would make it after the Hello."""
    return Client(Connection(sock, "127.0.0.1"), timeout_s, "fake", "127.0.0.1:1")


@pytest.fixture
def fake_server() -> Iterator[Callable[[Handler], tuple[Client, FakeServer]]]:
    """A factory: (client, server) pairs whose server answers with a handler."""
    made: list[tuple[Client, FakeServer]] = []

    def make(handler: Handler) -> tuple[Client, FakeServer]:
        ours, theirs = socket.socketpair()
        pair = (make_client(ours), FakeServer(theirs, handler))
        made.append(pair)
        return pair

    yield make
    for client, server in made:
        client.close()
        server.close()


class OfflineClient:
    """A Client whose peer never answers, and a check that nothing reached the peer."""

    def __init__(self) -> None:
        ours, self._peer = socket.socketpair()
        self._peer.setblocking(False)
        self.client = make_client(ours)

    def nothing_sent(self) -> bool:
        """Whether no byte has arrived at the peer."""
        try:
            return not self._peer.recv(1)
        except BlockingIOError:
            return True

    def close(self) -> None:
        self.client.close()
        self._peer.close()


@pytest.fixture
def offline() -> Iterator[OfflineClient]:
    """A Client with no server behind it, for checks that must not send anything."""
    made = OfflineClient()
    yield made
    made.close()
