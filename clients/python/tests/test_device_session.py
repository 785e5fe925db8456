"""DeviceSession over a real UDP socket against a scripted fake server: the round trip,
what the state carries, and the counting of lost, stale and bad commands."""

import math
import socket
import threading

import numpy as np
import pytest

from hapticd import DeviceSession, LocalError, SessionInfo
from hapticd._datagram import decode_state, encode_command
from hapticd.v1 import hapticd_pb2 as pb

KEY = bytes(range(100, 132))
SESSION_ID = 77


class FakeRealtimeServer:
    """Answers each state with the datagrams script(state) returns."""

    def __init__(self, script):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.script = script
        self.states = []
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while True:
            try:
                datagram, sender = self.sock.recvfrom(2048)
            except OSError:
                return
            state = decode_state(datagram, KEY)
            self.states.append(state)
            for reply in self.script(state):
                self.sock.sendto(reply, sender)

    def info(self, device_type="impedance"):
        port = self.sock.getsockname()[1]
        return SessionInfo(SESSION_ID, KEY, "127.0.0.1", port, 512, device_type, 1000.0)

    def close(self):
        self.sock.close()


@pytest.fixture
def realtime_server():
    servers = []

    def make(script):
        servers.append(FakeRealtimeServer(script))
        return servers[-1]

    yield make
    for server in servers:
        server.close()


def command_for(state, session_id=SESSION_ID, key=KEY, sequence=None, **fields):
    message = pb.DeviceCommand(
        session_id=session_id,
        sequence=state.sequence if sequence is None else sequence,
        echo_send_time_ns=state.send_time_ns,
        **fields,
    )
    return encode_command(message, key)


def test_a_state_is_answered_with_its_command(realtime_server):
    server = realtime_server(lambda s: [command_for(s, force=pb.Vec3(z=2.5), contact=True)])
    with DeviceSession(server.info()) as device:
        command = device.exchange((0.1, 0.2, 0.3), (1, 0, 0), buttons=3, timeout_s=1)
        assert command is not None
        assert np.array_equal(command.force, [0, 0, 2.5]) and command.contact
        assert command.sequence == 1 and 0 < command.rtt_ns < 1e9
        # the next state holds the last command's force and reports the round trip
        device.exchange((0.1, 0.2, 0.3), timeout_s=1)
    first, second = server.states
    assert (first.position.x, first.position.y, first.position.z) == (0.1, 0.2, 0.3)
    assert first.velocity.x == 1 and first.buttons == 3 and first.session_id == SESSION_ID
    assert first.held_force.z == 0 and second.held_force.z == 2.5
    assert second.sequence == 2 and second.send_time_ns > first.send_time_ns
    assert second.rtt_us == command.rtt_ns // 1000
    assert device.counters.sent == 2 and device.counters.received == 2
    assert len(device.rtt_ns) == 2


def test_bad_and_stale_datagrams_are_counted_and_skipped(realtime_server):
    def script(state):
        return [
            b"garbage",
            command_for(state, key=bytes(32)),
            command_for(state, session_id=SESSION_ID + 1),
            command_for(state, sequence=state.sequence + 5),
            command_for(state, sequence=state.sequence - 1),
            command_for(state, sequence=0, flags=pb.COMMAND_FLAGS_WATCHDOG),
            command_for(state, force=pb.Vec3(x=1)),
        ]

    server = realtime_server(script)
    with DeviceSession(server.info()) as device:
        device.exchange((0, 0, 0), timeout_s=1)
        command = device.exchange((0, 0, 0), timeout_s=1)
    assert command is not None and command.force[0] == 1
    assert device.counters.bad == 8
    assert device.counters.stale == 4
    assert device.counters.received == 2 and device.counters.lost == 0


def test_a_missing_command_is_lost_and_its_late_arrival_stale(realtime_server):
    held = []

    def script(state):
        # hold the first state's answer back until the second state
        if state.sequence == 1:
            held.append(state)
            return []
        return [command_for(held[0]), command_for(state)]

    server = realtime_server(script)
    with DeviceSession(server.info()) as device:
        assert device.exchange((0, 0, 0), timeout_s=0.05) is None
        assert device.counters.lost == 1
        assert device.exchange((0, 0, 0), timeout_s=1) is not None
    assert device.counters.stale == 1 and device.counters.received == 1


def test_an_admittance_device_sends_the_sensed_force(realtime_server):
    server = realtime_server(lambda s: [command_for(s, position=pb.Vec3(z=-0.01))])
    with DeviceSession(server.info("admittance")) as device:
        with pytest.raises(LocalError, match="sensed_force is missing"):
            device.send_state((0, 0, 0))
        command = device.exchange((0, 0, 0), sensed_force=(0, 0, -10), timeout_s=1)
    assert command is not None and np.array_equal(command.position, [0, 0, -0.01])
    assert server.states[0].sensed_force.z == -10


def test_a_non_finite_state_is_refused_before_sending(realtime_server):
    server = realtime_server(lambda s: [command_for(s)])
    with DeviceSession(server.info()) as device:
        with pytest.raises(LocalError, match=r"position is \[nan, 0.0, 0.0\]; it must be finite"):
            device.send_state((math.nan, 0, 0))
        with pytest.raises(LocalError, match=r"held_force is \[0.0, inf, 0.0\]; it must be finite"):
            device.send_state((0, 0, 0), held_force=(0, math.inf, 0))
        assert device.counters.sent == 0 and device.sequence == 0


def test_next_command_returns_watchdog_commands_uncounted(realtime_server):
    def script(state):
        watchdog = pb.DeviceCommand(
            session_id=SESSION_ID, force=pb.Vec3(z=0.5), flags=pb.COMMAND_FLAGS_WATCHDOG
        )
        return [command_for(state), encode_command(watchdog, KEY)]

    server = realtime_server(script)
    with DeviceSession(server.info()) as device:
        assert device.exchange((0, 0, 0), timeout_s=1) is not None
        command = device.next_command(timeout_s=1)
        assert command is not None and command.watchdog and command.sequence == 0
        assert command.force[2] == 0.5 and command.rtt_ns == 0
        assert device.next_command(timeout_s=0.05) is None
    assert device.counters.stale == 0 and device.counters.lost == 0
    assert len(device.rtt_ns) == 1


def test_a_command_carrying_a_model_fragment_is_received_whole(realtime_server):
    # over a state's 512 bytes: a receive sized for states would cut it and fail its tag
    fragment = pb.ModelFragment(version=1, index=0, count=1, data=bytes(1024))
    server = realtime_server(lambda s: [command_for(s, force=pb.Vec3(z=1), model=fragment)])
    with DeviceSession(server.info()) as device:
        command = device.exchange((0, 0, 0), timeout_s=1)
    assert command is not None and command.force[2] == 1
    assert device.counters.bad == 0 and device.counters.received == 1
