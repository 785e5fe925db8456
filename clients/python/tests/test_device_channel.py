"""The device's end of a session's channel in Python (local_model.DeviceChannel, the C++
that hapticd-proxy runs, loaded from build/lib): its passivity port and its states'
deadband, alone and inside a DeviceSession against a scripted fake server."""

import dataclasses
import time

import numpy as np
import pytest
from test_device_session import KEY, command_for, realtime_server  # noqa: F401 (a fixture)

from hapticd import DeviceSession
from hapticd.errors import LocalError
from hapticd.local_model import DeviceChannel
from hapticd.v1 import hapticd_pb2 as pb


def open_request(**fields) -> bytes:
    request = pb.OpenSession(device_type=pb.DEVICE_TYPE_IMPEDANCE, degrees_of_freedom=3,
                             max_force=10, max_velocity=1, rate_hz=1000, **fields)
    request.start.z = 0.1
    return request.SerializeToString()


def test_the_port_observes_the_held_forces_work():
    channel = DeviceChannel(open_request(tdpa=True), 0.05)
    assert channel.sample(0.0, (0, 0, 0.1), (0, 0, 0), (0, 0, 0)) == DeviceChannel.SEND
    channel.sample(0.001, (0, 0, 0.099), (0, 0, -1), (0, 0, 2))  # 2 N up over 1 mm down: in
    assert channel.energy_in == pytest.approx(0.002)
    channel.sample(0.002, (0, 0, 0.1), (0, 0, 1), (0, 0, 3))  # 3 N up over 1 mm up: out
    assert channel.energy_out == pytest.approx(0.003)
    channel.close()


def test_under_tdpa_the_force_waits_for_the_servers_energy():
    channel = DeviceChannel(open_request(tdpa=True), 0.05)
    channel.sample(0.0, (0, 0, 0.1), (0, 0, 0.1), (0, 0, 0))
    channel.sample(0.001, (0, 0, 0.1001), (0, 0, 0.1), (0, 0, 0))
    # along the motion, nothing let in at the server: none of it (a brake at most)
    assert channel.limit(0.0, (0, 0, 5), 0.001)[2] <= 0
    # saturated at the session's 10 N even when the server let plenty in, and a force
    # against the motion is never cut
    assert channel.limit(10.0, (0, 0, -50), 0.001) == pytest.approx([0, 0, -10])
    # without tdpa: saturation only
    plain = DeviceChannel(open_request(), 0.05)
    plain.sample(0.0, (0, 0, 0.1), (0, 0, 0.1), (0, 0, 0))
    assert plain.limit(0.0, (0, 0, 5), 0.001) == pytest.approx([0, 0, 5])
    with pytest.raises(LocalError, match="force is"):
        plain.limit(0.0, (0, float("nan"), 5), 0.001)


def test_the_deadband_holds_a_handle_at_rest_but_for_keepalives():
    channel = DeviceChannel(open_request(deadband=0.1, keepalive_s=0.01), 0.05)
    verdicts = [channel.sample(k * 0.001, (0, 0, 0.1), (0, 0, 0), (0, 0, 0)) for k in range(100)]
    assert verdicts[0] == DeviceChannel.SEND
    assert verdicts.count(DeviceChannel.KEEPALIVE) == 9
    assert verdicts.count(DeviceChannel.HOLD) == 90
    # a move the server could not predict goes up at once
    assert channel.sample(0.1005, (0, 0, 0.1002), (0, 0, 0), (0, 0, 0)) == DeviceChannel.SEND


def test_bad_settings_are_refused_by_name():
    with pytest.raises(LocalError, match="open_session.deadband is 1; a Weber fraction must be in"):
        DeviceChannel(open_request(deadband=1.0), 0.05)
    with pytest.raises(LocalError, match="mass must be a finite number > 0"):
        DeviceChannel(open_request(tdpa=True), 0.0)


def test_a_session_sends_its_energies_and_holds_back_what_it_can(realtime_server):  # noqa: F811
    server = realtime_server(
        lambda s: [command_for(s, force=pb.Vec3(z=3), energy_in=0.5, commands_held=7)]
    )
    info = dataclasses.replace(server.info(), open_request=open_request(tdpa=True, deadband=0.1))
    with DeviceSession(info) as device:
        assert device.channel is not None
        first = device.exchange((0, 0, 0.1), timeout_s=1)
        assert first is not None
        assert device.server_energy_in == 0.5 and device.commands_held == 7
        force = device.limit_force(first.force, 0.001)
        assert force == pytest.approx([0, 0, 3])  # at rest, with energy let in: all of it
        # at rest, within the keep-alive: held back, nothing sent, nothing awaited
        assert device.send_state((0, 0, 0.1)) == 0
        assert device.exchange((0, 0, 0.1), timeout_s=1) is None
        assert device.counters.held == 2 and device.counters.lost == 0
        time.sleep(0.012)
        assert device.exchange((0, 0, 0.1), timeout_s=1) is not None
        assert device.counters.keepalives == 1
    first_state, keepalive = server.states
    assert not first_state.keepalive and keepalive.keepalive
    assert keepalive.states_held == 2
    # the held force is the limited one, and the port saw no work: the handle never moved
    assert keepalive.held_force.z == pytest.approx(3)
    assert keepalive.energy_in == 0 and keepalive.energy_out == 0


def test_a_session_without_tdpa_or_deadband_needs_no_channel(realtime_server):  # noqa: F811
    server = realtime_server(lambda s: [command_for(s)])
    with DeviceSession(server.info()) as device:
        assert device.channel is None
        assert np.array_equal(device.limit_force((0, 0, 20), 0.001), [0, 0, 20])
