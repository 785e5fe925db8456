"""End to end, the Python client's promises against a real hapticd process: leaving a
DeviceSession or a client's with block closes the server's sessions it opened; a
partial set_material keeps the fields it does not name; threads sharing one client
each get their own large replies; and when the server dies, every later call says the
connection is closed (ConnectionClosed), not that the caller misused the API. Each
runs with the blocking Client and with the AsyncClient (the `connect` fixture)."""

import threading
import time

import hapticd
import numpy as np
import pytest
from hapticd import ConnectionClosed, Material, RemoteError
from server_process import ServerProcess, wait_until

ABOVE = (0.0, 0.0, 0.3)  # free space over the default scene
LONG_TIMEOUT_S = 60.0  # a session timeout no test waits for


@pytest.fixture
def client(server, connect):
    with connect(server.tcp, timeout_s=10) as connected:
        yield connected


def session_state(client, session_id):
    """The session's state in the server's stats; None when it is not listed."""
    for session in client.stats().sessions:
        if session.session_id == session_id:
            return session.state
    return None


def closed_on_the_server(client, session_id):
    """Whether the server has closed the session: it is listed as closed (the realtime
    thread closes it on its next tick after CloseSession), or not listed at all, and
    CloseSession finds no open session of that id."""
    if session_state(client, session_id) not in ("closed", None):
        return False
    with pytest.raises(RemoteError, match="NOT_FOUND"):
        client.close_session(session_id)
    return True


def test_leaving_a_device_session_closes_its_session_on_the_server(server, client, connect):
    timed_out = client.stats().counters.sessions_timed_out
    info = client.open_session("impedance", start=ABOVE, session_timeout_s=LONG_TIMEOUT_S)
    with hapticd.DeviceSession(info) as device:
        assert device.exchange(ABOVE, timeout_s=1) is not None
        # active, or ramping when this machine stalled past the 50 ms watchdog: it has states
        assert session_state(client, info.session_id) in ("active", "ramping")
    # closed by CloseSession, long before its timeout could have reclaimed it
    with connect(server.tcp, timeout_s=10) as other:
        assert wait_until(lambda: closed_on_the_server(other, info.session_id), 5.0)
    assert client.stats().counters.sessions_timed_out == timed_out
    # closing it again from the client that closed it is quiet
    client.close_session(info.session_id)


def test_leaving_a_client_closes_the_sessions_it_opened_and_no_others(server, client, connect):
    theirs = client.open_session("impedance", start=ABOVE, session_timeout_s=LONG_TIMEOUT_S)
    with connect(server.tcp, timeout_s=10) as owner:
        waiting = owner.open_session("impedance", start=ABOVE, session_timeout_s=LONG_TIMEOUT_S)
        active = owner.open_session("impedance", start=ABOVE, session_timeout_s=LONG_TIMEOUT_S)
        device = hapticd.DeviceSession(active)
        assert device.exchange(ABOVE, timeout_s=1) is not None
        already = owner.open_session("impedance", start=ABOVE, session_timeout_s=LONG_TIMEOUT_S)
        owner.close_session(already.session_id)
        assert session_state(client, waiting.session_id) == "waiting"
        assert session_state(client, active.session_id) in ("active", "ramping")
    # the device outlived its client: closing it has nothing left to close
    device.close()
    for info in (waiting, active, already):
        assert wait_until(lambda info=info: closed_on_the_server(client, info.session_id), 5.0)
    # another client's session is not this one's to close
    assert session_state(client, theirs.session_id) == "waiting"
    client.close_session(theirs.session_id)


def test_a_partial_material_keeps_the_fields_it_does_not_name(client):
    client.clear_scene()
    first = Material(1500, damping=2, static_friction=0.6, dynamic_friction=0.4,
                     force_shading=False)
    client.add_box("box", (0.05, 0.05, 0.05), position=(0, 0, 0.05), material=first)
    assert client.scene().object("box").material == first
    client.set_material("box", {"damping": 3})
    assert client.scene().object("box").material == Material(
        1500, damping=3, static_friction=0.6, dynamic_friction=0.4, force_shading=False
    )
    # valid only beside the object's static friction (0.6), not the default's (0)
    client.set_material("box", {"dynamic_friction": 0.5, "force_shading": True})
    assert client.scene().object("box").material == Material(
        1500, damping=3, static_friction=0.6, dynamic_friction=0.5, force_shading=True
    )
    # a Material replaces the whole material
    client.set_material("box", Material(800))
    assert client.scene().object("box").material == Material(800, force_shading=True)
    with pytest.raises(hapticd.LocalError, match=r"^material.dampng is not a material field"):
        client.set_material("box", {"dampng": 1})
    with pytest.raises(RemoteError, match="NOT_FOUND"):
        client.set_material("cup", {"damping": 1})
    # the server checks the material the change makes: a dynamic friction above the
    # object's static one is refused, naming the field, and nothing changes
    with pytest.raises(RemoteError, match=r"set_material.change.dynamic_friction"):
        client.set_material("box", {"dynamic_friction": 0.9})
    assert client.scene().object("box").material == Material(800, force_shading=True)


def test_threads_sharing_one_client_each_get_their_own_large_replies(client):
    """Four threads cast 20,000 rays each (a 1.3 MB reply) over one client while a fifth
    reads telemetry and a sixth the scene; every answer is its own question's."""
    client.clear_scene()
    client.add_plane("floor")
    rays = 20_000
    results = {}

    def cast(row):
        origins = np.column_stack([np.arange(rays) * 1e-4, np.full(rays, row), np.ones(rays)])
        directions = np.tile([0.0, 0.0, -1.0], (rays, 1))
        for _ in range(3):
            hits = client.ray_cast_batch(origins, directions, max_distance=2)
            assert hits.hit.all() and set(hits.objects) == {"floor"}
            assert np.array_equal(hits.point[:, :2], origins[:, :2])
        results[row] = True

    def watch():
        with client.subscribe(200) as samples:
            results["watch"] = [next(samples).server_time_ns for _ in range(20)]

    def read_scene():
        results["scene"] = [[o.name for o in client.scene().objects] for _ in range(20)]

    threads = [threading.Thread(target=cast, args=(row,)) for row in range(4)]
    threads += [threading.Thread(target=watch), threading.Thread(target=read_scene)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert not any(thread.is_alive() for thread in threads)
    assert all(results.get(row) for row in range(4)), results.keys()
    times = results["watch"]
    assert len(times) == 20 and times == sorted(times) and len(set(times)) == 20
    assert results["scene"] == [["floor"]] * 20
    assert not client.closed and client.scene().object("floor")


def test_a_server_that_dies_gives_connection_closed_every_time(bin_dir, connect):
    process = ServerProcess(bin_dir, "--log-level", "error")
    try:
        client = connect(process.tcp, timeout_s=5)
        subscription = client.subscribe(20)
        next(subscription)
        process.process.kill()
        process.process.wait(timeout=10)
        # samples already on their way may come first; then the end, said as it is
        with pytest.raises(ConnectionClosed) as ended:
            for _ in range(1000):
                subscription.next(timeout_s=5)
        assert str(ended.value).startswith(
            "the server closed the connection (awaiting the telemetry of subscription 2"
        )
        assert "within" not in str(ended.value)
        # and every later call says the connection is closed, and why
        for call in (client.scene, client.stats, subscription.next, client.scene):
            with pytest.raises(ConnectionClosed) as later:
                call()
            assert str(later.value) == f"the connection is closed: {ended.value}"
        subscription.close()
        client.close()
    finally:
        if process.alive:
            process.process.kill()
            process.process.wait()


def test_another_connection_closes_a_session_only_with_its_key(server, connect):
    # Sessions belong to the connection that opened them; the same client after a
    # reconnection proves it is the owner with the session's key.
    with connect(server.tcp, timeout_s=10) as first:
        info = first.open_session("impedance", start=(0, 0, 0.5), session_timeout_s=30)
        with connect(server.tcp, timeout_s=10) as second:
            with pytest.raises(hapticd.RemoteError) as refused:
                second.close_session(info.session_id)
            assert refused.value.code == "PERMISSION_DENIED"
            assert "needs its session_key" in refused.value.message
            second.close_session(info.session_id, session_key=info.key)
            # closed on the server: its owner finds nothing left to close
            deadline = time.monotonic() + 5
            while info.session_id in {s.session_id for s in first.stats().sessions if s.state != "closed"}:
                assert time.monotonic() < deadline, "the session was never closed"
                time.sleep(0.02)
