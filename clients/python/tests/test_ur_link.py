"""RtdeLinkWatch against real TCP connections on loopback: it finds this process's
connections to the port, and says lost once the far side shuts or resets one, also after
the near side's own descriptor is closed (as ur_rtde does before it reconnects)."""

from __future__ import annotations

import os
import socket
import struct
import time

import pytest

from hapticd.ur_link import RtdeLinkWatch


@pytest.fixture
def robot():
    """A listener on loopback (the robot's port) and the connections made to it: the
    client sockets and the accepted ones, in pairs."""
    listener = socket.create_server(("127.0.0.1", 0))
    pairs: list[tuple[socket.socket, socket.socket]] = []

    def connect() -> tuple[socket.socket, socket.socket]:
        client = socket.create_connection(listener.getsockname())
        accepted, _ = listener.accept()
        pairs.append((client, accepted))
        return client, accepted

    yield listener.getsockname()[1], connect
    for pair in pairs:
        for sock in pair:
            sock.close()
    listener.close()


def lost_within(watch: RtdeLinkWatch, seconds: float = 2.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if watch.lost():
            return True
        time.sleep(0.001)
    return False


def test_it_watches_each_connection_to_the_port_once(robot):
    port, connect = robot
    client, _ = connect()
    connect()
    extra = socket.socket(fileno=os.dup(client.fileno()))  # a second descriptor
    other = socket.create_server(("127.0.0.1", 0))  # a socket not connected to the port
    watch = RtdeLinkWatch("127.0.0.1", port)
    try:
        assert watch.watched == 2
        assert not watch.lost()
    finally:
        watch.close()
        extra.close()
        other.close()


def test_the_far_side_closing_one_connection_is_lost_for_good(robot):
    port, connect = robot
    client, accepted = connect()
    connect()
    watch = RtdeLinkWatch("127.0.0.1", port)
    try:
        accepted.sendall(b"state")  # data waiting is not a loss
        time.sleep(0.05)
        assert not watch.lost()
        accepted.close()
        assert lost_within(watch)
        client.close()  # the near side lets go, as ur_rtde does before reconnecting
        connect()  # and connects again: still lost
        assert watch.lost()
    finally:
        watch.close()


def test_a_reset_connection_is_lost(robot):
    port, connect = robot
    _, accepted = connect()
    watch = RtdeLinkWatch("127.0.0.1", port)
    try:
        accepted.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        accepted.close()  # RST
        assert lost_within(watch)
    finally:
        watch.close()


def test_no_connection_to_the_port_watches_nothing(robot):
    port, _ = robot
    watch = RtdeLinkWatch("127.0.0.1", port)
    assert watch.watched == 0 and not watch.lost()
    watch.close()
