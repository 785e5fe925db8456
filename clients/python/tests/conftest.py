"""Fixtures for the package's unit tests: no hapticd server is needed. A client runs
over one end of a socket pair; a FakeServer thread (or the test itself) is the other.
Each test that takes a client runs twice: with the blocking Client and with the
AsyncClient (behind blocking_async.py's wrapper, on a loop thread of its own)."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from blocking_async import BlockingAsyncClient, LoopThread

from hapticd._async_connection import AsyncConnection
from hapticd._connection import Connection
from hapticd._framing import FrameDecoder, encode_frame
from hapticd.async_client import AsyncClient
from hapticd.client import Client
from hapticd.v1 import hapticd_pb2 as pb

CLIENT_KINDS = ("blocking", "asyncio")

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


def make_client(sock: socket.socket, kind: str = "blocking", timeout_s: float = 1.0) -> Any:
    """A client of that kind over sock, as connect() or connect_async() would make it
    after the Hello."""
    if kind == "blocking":
        return Client(Connection(sock, "127.0.0.1"), timeout_s, "fake", "127.0.0.1:1")
    loop = LoopThread()

    async def make() -> AsyncClient:
        connection = await AsyncConnection.adopt(sock, "127.0.0.1")
        return AsyncClient(connection, timeout_s, "fake", "127.0.0.1:1")

    return BlockingAsyncClient(loop.run(make()), loop)


@pytest.fixture(params=CLIENT_KINDS)
def client_kind(request: pytest.FixtureRequest) -> str:
    """Which client a test runs with: "blocking" (Client) or "asyncio" (AsyncClient)."""
    return str(request.param)


@pytest.fixture
def fake_server(client_kind: str) -> Iterator[Callable[[Handler], tuple[Any, FakeServer]]]:
    """A factory: (client, server) pairs whose server answers with a handler."""
    made: list[tuple[Any, FakeServer]] = []

    def make(handler: Handler) -> tuple[Any, FakeServer]:
        ours, theirs = socket.socketpair()
        pair = (make_client(ours, client_kind), FakeServer(theirs, handler))
        made.append(pair)
        return pair

    yield make
    for client, server in made:
        client.close()
        server.close()


class OfflineClient:
    """A Client whose peer never answers, and a check that nothing reached the peer."""

    def __init__(self, kind: str) -> None:
        ours, self._peer = socket.socketpair()
        self._peer.setblocking(False)
        self.client = make_client(ours, kind)

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
def offline(client_kind: str) -> Iterator[OfflineClient]:
    """A client with no server behind it, for checks that must not send anything."""
    made = OfflineClient(client_kind)
    yield made
    made.close()
