"""The channel itself across a real delay: two-port time-domain passivity and the
perceptual deadband over real UDP, hapticd-proxy against a real server, through
hapticd-netem where the channel is impaired (the press of test_e2e_local_model.py: 50 ms
each way, 5 ms jitter, 10% loss each way, a 5000 N/m box).

- TDPA (--tdpa): with the commands' force rendered directly, the same press that
  test_e2e_local_model.test_rendering_the_delayed_force_instead_is_active shows
  generating joules is passive: the channel puts no energy into the hand, as both the
  proxy and the server's telemetry measure it. It is not transparent: the server lets
  the avatar into the box only with energy the hand put in against a force it already
  feels, and there is none, so the avatar waits at the surface (the drift, reported).
  With the local model the channel carries the scene, not power: the device's port is a
  one-port on its own rendering, which lets out no more than the hand put in, and the
  wall is as stiff as without TDPA (its steady force k d).
- Deadband (--deadband 0.1): on a hand at rest only keep-alives go up (one per 10 ms:
  90% of the states held back) and only their answers come down, the force rendered
  exactly the server's; on a wall settled under the local model the same, the force
  within the Weber fraction of k d (the device renders it itself).

The proxy and the relay run at real-time priority (root here; their reports say): a
stalled relay makes gaps no keep-alive covers, so on a loaded machine normal priority
would measure the machine. TDPA holds at any priority: a force the proxy's loop holds
across its own stall is observed at the next sample and taken back after it (the
proxy's report says how much work stalls did and what the device's port still owes)."""

import json
import subprocess
import threading

import hapticd
import pytest
from server_process import running_server
from test_e2e_local_model import CHANNEL, PATH, STIFFNESS, TOP, write_box_scene
from test_netem import running_relay

SECONDS = 4


def run_proxy(bin_dir, tcp: str, *args: str, via=None) -> dict:
    command = [str(bin_dir / "hapticd-proxy"), "--server", tcp, "--seconds", str(SECONDS), "--realtime-priority", "0",
               *args]
    if via is not None:
        command += ["--udp-via", f"{via[0]}:{via[1]}"]
    run = subprocess.run(command, check=False, capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def last_telemetry(tcp: str, seen: dict, done: threading.Event) -> None:
    """Keeps the newest telemetry of the first session seen until done (20 Hz)."""
    with hapticd.connect(tcp, timeout_s=10) as client, client.subscribe(20) as samples:
        for sample in samples:
            if sample.sessions:
                seen["session"] = sample.sessions[0]
            if done.is_set():
                return


def press(bin_dir, scene, *args: str, relay: bool = True) -> tuple[dict, object]:
    """The proxy's run (at real-time priority) and the server's last telemetry of its
    session."""
    args = (*args, "--realtime-priority", "20")
    seen, done = {}, threading.Event()
    with running_server(bin_dir, "--scene", str(scene), "--log-level", "warning") as server:
        watcher = threading.Thread(target=last_telemetry, args=(server.tcp, seen, done))
        watcher.start()
        try:
            if relay:
                with running_relay(bin_dir, server.udp, *CHANNEL, "--realtime-priority", "20") as (address, _):
                    report = run_proxy(bin_dir, server.tcp, *args, via=address)
            else:
                report = run_proxy(bin_dir, server.tcp, *args)
        finally:
            done.set()
            watcher.join(timeout=20)
    return report, seen.get("session")


@pytest.fixture
def box_scene(tmp_path):
    return write_box_scene(tmp_path / "box.json")


def test_tdpa_makes_the_direct_press_through_the_delay_passive(bin_dir, box_scene):
    report, session = press(bin_dir, box_scene, "--path", PATH, "--remote-mode", "direct", "--tdpa")
    assert report["tdpa"] is True and report["remote_mode"] == "direct"
    # the channel was the press's: delayed, lossy
    assert report["wire_rtt_p50_us"] >= 90_000
    assert report["packets_lost"] > 0.1 * report["packets_sent"]
    # the net work the rendered force did on the hand: none gained (the same run without
    # TDPA gains joules: test_e2e_local_model)
    assert report["energy_j"] <= 0
    # the channel's two ports, as the proxy sees them: it generated nothing
    assert report["channel_energy_j"] <= 1e-12
    assert report["device_energy_out_j"] <= report["server_energy_in_j"] + 1e-12
    # the hand went in unresisted: the server held its avatar at the surface, the drift
    # the rest of the way (reported in telemetry), its port active
    depth = TOP - report["final_position_m"][2]
    assert depth > 0.005
    assert session is not None, "no telemetry of the session"
    assert session.tdpa_activations > 0
    assert session.max_drift > 0.005
    assert session.channel_energy <= 1e-12
    assert session.server_energy_out <= session.device_energy_in + 1e-12


def test_tdpa_with_the_local_model_keeps_the_channel_passive(bin_dir, box_scene):
    report, session = press(bin_dir, box_scene, "--path", PATH, "--remote-mode", "local-model", "--tdpa")
    assert report["tdpa"] is True and report["models_adopted"] >= 1
    # the hand pushed into the device's own rendering: the wall is felt, as stiff as
    # without TDPA (the steady force k d within 2%, as test_e2e_local_model's press), the
    # proxy on its face
    assert report["device_energy_in_j"] > 0
    depth = TOP - report["final_position_m"][2]
    assert 0.0003 < depth < 0.001
    assert report["final_force_n"][2] == pytest.approx(STIFFNESS * depth, rel=0.02)
    assert report["lowest_avatar_z_m"] >= TOP - 1e-9
    # the server's end neither observes nor limits a local model's session
    assert report["server_energy_in_j"] == 0 and report["server_energy_out_j"] == 0
    # and the channel generated none, whatever the machine's load: a force held across a
    # stall of the proxy's own loop (ticks skipped) does work no tick's prediction
    # covered; the device's port observes it at the next sample, owes what it let out
    # beyond what the hand put in, and repays that from the energy that comes in next
    # (its brake). So the channel is at most what the port still owes at the end, which
    # only stalls leave (the held forces' work across them, reported; 1 uJ for a tick's
    # own prediction), and on a loop that never stalled, nothing.
    stalls = report["stall_work_j"]
    assert (report["skipped_ticks"] > 0) or stalls == 0
    assert report["device_owed_j"] <= stalls + 1e-6
    assert report["channel_energy_j"] <= report["device_owed_j"] + 1e-9
    assert report["device_energy_out_j"] <= report["device_energy_in_j"] + report["device_owed_j"] + 1e-9
    assert session is not None and session.channel_energy <= stalls + 1e-6
    assert session.server_energy_in == 0 and session.server_energy_out == 0


def ramp_commands(session) -> int:
    """The most commands the server's watchdog ramps can have sent: one a silent tick for
    its 100 ms ramp, per trip (a stalled relay can delay five keep-alives in a row)."""
    return 101 * session.watchdog_trips


def test_the_deadband_sends_a_hand_at_rest_as_keepalives(bin_dir, tmp_path):
    # a handle held 2 mm into a floor (2000 N/m: 4 N), through the lossy, delayed relay.
    # The device holds the last command 100 ms (its default 50 ms would ramp after five
    # lost keep-alive round trips in a row, which at 10% loss each way comes about once
    # in 400)
    scene = tmp_path / "floor.json"
    scene.write_text(json.dumps({"scene": {"objects": [{
        "name": "floor", "shape": {"type": "plane"}, "position": [0, 0, 0], "material": {"stiffness": 2000}}]}}))
    report, session = press(bin_dir, scene, "--path", "press", "--deadband", "0.1", "--hold-ms", "100")
    assert session is not None
    ticks = report["ticks"] + report["skipped_ticks"]
    sent, held = report["packets_sent"], report["states_held"]
    # up: the first state and one keep-alive per 10 ms of the loop's clock: 90% held
    assert sent + held == report["ticks"]
    assert report["keepalives"] == sent - 1
    assert sent <= ticks // 10 + 1
    assert held / (sent + held) >= 0.89
    # down: the server answered every keep-alive that reached it and held nothing back
    # (the force never changed); besides, only its watchdog's ramps, if any
    assert report["commands_held"] == 0 and session.commands_held == 0
    assert session.states_received <= sent
    answers = session.commands_sent - ramp_commands(session)
    assert answers <= session.states_received <= session.commands_sent
    assert answers <= 0.11 * ticks
    # the force held is the floor's k d
    assert report["final_force_n"][2] == pytest.approx(2000 * 0.002, rel=1e-6)
    assert report["max_force_n"] == pytest.approx(4.0, rel=1e-6)
    # the server saw the device's count of states held and its keep-alives
    assert session.keepalives > 0
    assert session.states_held / (session.states_held + session.states_received) > 0.85


def test_the_deadband_on_a_wall_settled_under_the_local_model(bin_dir, box_scene):
    # the local model's press through the relay: the device renders the box itself, so
    # once the hand has come to rest only keep-alives go up and their answers come down
    # (a model goes down only when one is cut); during the press itself the velocity
    # leaves its band often, so over the run at least 80% of the states are held
    report, session = press(bin_dir, box_scene, "--path", PATH, "--remote-mode", "local-model", "--deadband", "0.1")
    assert session is not None and report["models_adopted"] >= 1
    ticks = report["ticks"] + report["skipped_ticks"]
    sent, held = report["packets_sent"], report["states_held"]
    assert sent + held == report["ticks"]
    assert held / (sent + held) >= 0.8
    answers = session.commands_sent - ramp_commands(session)
    assert answers <= 0.2 * ticks
    assert session.commands_held + session.commands_sent >= session.states_received
    # the force on the settled wall: the wall's k d, within the Weber fraction (here the
    # device renders it itself: it is the no-delay force), the press passive, the avatar
    # never inside
    depth = TOP - report["final_position_m"][2]
    assert 0.0003 < depth < 0.001
    wall = STIFFNESS * depth
    assert abs(report["final_force_n"][2] - wall) <= 0.1 * wall
    assert report["energy_j"] <= 0
    assert report["lowest_avatar_z_m"] >= TOP - 1e-9
