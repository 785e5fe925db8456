"""RtdeLinkWatch against real TCP connections on loopback, IPv4 and IPv6: it finds this
process's connections to the port, and says lost once the far side shuts or resets one,
also after the near side's own descriptor is closed (as ur_rtde does before it
reconnects)."""

from __future__ import annotations

import os
import socket
import struct
import time

import pytest

from hapticd.ur_link import RtdeLinkWatch


@pytest.fixture(params=["127.0.0.1", "::1"])
def robot(request):
    """A listener on loopback (the robot's host and port; IPv4 and IPv6, each parsed from
    its own /proc table) and the connections made to it: the client sockets and the
    accepted ones, in pairs."""
    host = request.param
    listener = socket.create_server(
        (host, 0), family=socket.AF_INET6 if ":" in host else socket.AF_INET
    )
    pairs: list[tuple[socket.socket, socket.socket]] = []

    def connect() -> tuple[socket.socket, socket.socket]:
        client = socket.create_connection((host, listener.getsockname()[1]))
        accepted, _ = listener.accept()
        pairs.append((client, accepted))
        return client, accepted

    yield host, listener.getsockname()[1], connect
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
    host, port, connect = robot
    client, _ = connect()
    connect()
    extra = socket.socket(fileno=os.dup(client.fileno()))  # a second descriptor
    other = socket.create_server(("127.0.0.1", 0))  # a socket not connected to the port
    watch = RtdeLinkWatch(host, port)
    try:
        assert watch.watched == 2
        assert not watch.lost()
    finally:
        watch.close()
        extra.close()
        other.close()


def test_the_far_side_closing_one_connection_is_lost_for_good(robot):
    host, port, connect = robot
    client, accepted = connect()
    connect()
    watch = RtdeLinkWatch(host, port)
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
    host, port, connect = robot
    _, accepted = connect()
    watch = RtdeLinkWatch(host, port)
    try:
        accepted.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        accepted.close()  # RST
        assert lost_within(watch)
    finally:
        watch.close()


def test_no_connection_to_the_port_watches_nothing(robot):
    host, port, _ = robot
    watch = RtdeLinkWatch(host, port)
    assert watch.watched == 0 and not watch.lost()
    watch.close()


def test_an_ipv4_robot_reached_through_an_ipv6_socket_is_watched():
    """A dual-stack client socket connected to an IPv4 robot shows in /proc's tcp6
    table with the IPv4-mapped address (::ffff:127.0.0.1)."""
    listener = socket.create_server(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    client = socket.socket(socket.AF_INET6, socket.SOCK_STREAM)
    client.connect(("::ffff:127.0.0.1", port))
    accepted, _ = listener.accept()
    watch = RtdeLinkWatch("127.0.0.1", port)
    try:
        assert watch.watched == 1
        assert not watch.lost()
        accepted.close()
        assert lost_within(watch)
    finally:
        watch.close()
        client.close()
        listener.close()
