"""Rendering across a delayed channel in hapticd-sim (FORMAT.md's `remote`): the local
model renders a stiff box as the no-delay run does, at 50 ms each way with jitter and
loss, where the direct mode is active; two-port TDPA keeps the channel's energy at or
below zero over a grid up to a 1 s round trip; the deadband cuts the messages with the
force held within its Weber fraction; the servo lag of device.response_time_s; and the
section's refusals, each naming the field."""

import copy
import itertools
import json
import math
import subprocess

import pytest
from test_sim_physics import IDENTITY, SIM, run_sim

K = 5000  # N/m: a stiff wall

# A hand that presses the device 10 mm (its path's depth) into a stiff box and holds
# there; the wall holds the device about 1 mm in.
PRESS = {
    "rate_hz": 1000,
    "duration_s": 1.5,
    "scene": {"objects": [{
        "name": "box", "shape": {"type": "box", "half_extents": [0.05, 0.05, 0.02]}, "position": [0, 0, -0.02],
        "rotation": IDENTITY,
        "material": {"stiffness": K, "damping": 0, "static_friction": 0, "dynamic_friction": 0},
    }]},
    "avatar": {"type": "point", "radius": 0, "method": "god_object", "force_shading": False},
    "device": {"mode": "impedance", "mass": 0.05, "damping": 0.5, "max_force": 8.0,
               "position_resolution": 0, "start": [0, 0, 0.02]},
    "hand": {"mass": 0.3, "stiffness": 300, "damping": 5,
             "path": [[0.0, 0, 0, 0.02], [0.5, 0, 0, -0.01], [1.5, 0, 0, -0.01]]},
    "channel": {"delay_ms": 0, "jitter_ms": 0, "loss": 0, "seed": 1},
}
NETWORK = ["channel.delay_ms=50", "channel.jitter_ms=20", "channel.loss=0.1"]


def steady_force(rows):
    """The mean force over the last 0.3 s (the hold)."""
    tail = [float(r["f_z"]) for r in rows if float(r["t"]) >= 1.2]
    return sum(tail) / len(tail)


def test_the_default_remote_section_changes_nothing(tmp_path):
    plain, plain_rows = run_sim(tmp_path, PRESS, *NETWORK, trace=True)
    scenario = copy.deepcopy(PRESS)
    scenario["remote"] = {"mode": "direct", "passivity": "none", "deadband": 0}
    explicit, explicit_rows = run_sim(tmp_path, scenario, *NETWORK, trace=True)
    assert explicit_rows == plain_rows and explicit == plain
    # every tick sends each way, before loss
    assert plain["packets_up"] == plain["packets_down"] == 1500


def test_the_local_model_holds_a_stiff_wall_across_delay_jitter_and_loss(tmp_path):
    near, near_rows = run_sim(tmp_path, PRESS, trace=True)
    direct, _ = run_sim(tmp_path, PRESS, *NETWORK)
    local, local_rows = run_sim(tmp_path, PRESS, *NETWORK, "remote.mode=local_model", trace=True)
    # the failure kept: the direct mode is active behind 100 ms round trips
    assert direct["energy_j"] > 0.01 and direct["channel_energy_j"] > 0.01
    assert direct["max_penetration_m"] > 0.005
    # the local model: passive, the proxy never inside, the steady force within 2% of
    # the no-delay run's and of k d at the device's depth
    assert local["energy_j"] <= 0
    assert local["max_proxy_penetration_m"] == 0
    steady = steady_force(local_rows)
    assert abs(steady - steady_force(near_rows)) <= 0.02 * abs(steady_force(near_rows))
    depth = -float(local_rows[-1]["dev_z"])
    assert abs(float(local_rows[-1]["f_z"]) - K * depth) <= 0.02 * K * depth
    # a box is a primitive the model holds whole: after the first model arrives the
    # device renders exactly what the no-delay run did
    first = next(i for i, r in enumerate(local_rows) if float(r["t"]) >= 0.12)
    assert local_rows[first:] == near_rows[first:]
    assert local["models_taken"] > 100 and local["ticks_outside_model"] <= 120
    assert near["max_penetration_m"] == local["max_penetration_m"]


@pytest.mark.parametrize("mode", ["direct", "local_model"])
def test_tdpa_keeps_the_channel_from_generating_energy(tmp_path, mode):
    worst = -math.inf
    for delay, jitter, loss, stiffness in itertools.product([0, 5, 50, 500], [0, 20], [0, 0.2], [1000, K, 30000]):
        summary, _ = run_sim(tmp_path, PRESS, f"channel.delay_ms={delay}", f"channel.jitter_ms={jitter}",
                             f"channel.loss={loss}", f"scene.objects.0.material.stiffness={stiffness}",
                             f"remote.mode={mode}", "remote.passivity=tdpa", "duration_s=1.0")
        worst = max(worst, summary["channel_energy_j"])
        assert summary["channel_energy_j"] <= 0, (delay, jitter, loss, stiffness, summary)
    assert worst > -1  # the runs pressed something


@pytest.mark.parametrize("mode", ["direct", "local_model"])
def test_tdpa_holds_when_a_thin_plate_rises_into_the_hand(tmp_path, mode):
    # a 1 mm plate rising at 5 mm/s, hit at 0.5 m/s: the surface moves into the avatar
    # within each tick beyond the avatar's own step, and the device point ends nearer
    # the plate's far face than the one its proxy touches
    scenario = copy.deepcopy(PRESS)
    plate = scenario["scene"]["objects"][0]
    plate["shape"]["half_extents"] = [0.1, 0.1, 0.0005]
    plate["position"] = [0, 0, 0]
    plate["motion"] = {"velocity": [0, 0, 0.005]}
    scenario["device"]["start"] = [0, 0, 0.0305]
    scenario["hand"]["path"] = [[0, 0, 0, 0.0305], [0.08, 0, 0, -0.0095]]
    for delay, loss, stiffness in itertools.product([0, 50], [0, 0.1, 0.2], [300, K]):
        summary, _ = run_sim(tmp_path, scenario, f"channel.delay_ms={delay}", f"channel.loss={loss}",
                             f"scene.objects.0.material.stiffness={stiffness}", f"remote.mode={mode}",
                             "remote.passivity=tdpa")
        assert summary["channel_energy_j"] <= 0, (delay, loss, stiffness, summary)


def test_tdpa_with_the_local_model_keeps_the_wall_as_stiff_and_the_rendering_passive(tmp_path):
    # the device's port is a one-port on its own rendering: across the delay the steady
    # force is the local model's own (k d within 2%), the device no deeper, and the
    # rendered work and the channel's energy at or below zero (before, the port was held
    # to what the server's end let in, and the wall softened to nothing at rest)
    plain, plain_rows = run_sim(tmp_path, PRESS, *NETWORK, "remote.mode=local_model", trace=True)
    guarded, guarded_rows = run_sim(tmp_path, PRESS, *NETWORK, "remote.mode=local_model", "remote.passivity=tdpa",
                                    trace=True)
    assert guarded["energy_j"] <= 0 and guarded["channel_energy_j"] <= 0
    assert steady_force(guarded_rows) == pytest.approx(steady_force(plain_rows), rel=0.02)
    assert guarded["max_penetration_m"] <= plain["max_penetration_m"] + 1e-4
    # the renderer's end neither observes nor limits: no drift
    assert guarded["max_drift_m"] == 0 and guarded["tdpa_renderer_activations"] == 0


def test_without_tdpa_the_same_grid_has_an_active_channel(tmp_path):
    summary, _ = run_sim(tmp_path, PRESS, "channel.delay_ms=50", "duration_s=1.0")
    assert summary["channel_energy_j"] > 0.01


def test_the_deadband_sends_a_fifth_of_the_messages_within_its_weber_fraction(tmp_path):
    full, full_rows = run_sim(tmp_path, PRESS, "remote.mode=local_model", trace=True)
    cut, cut_rows = run_sim(tmp_path, PRESS, "remote.mode=local_model", "remote.deadband=0.1", trace=True)
    assert cut["packets_up"] <= 0.2 * full["packets_up"]
    assert cut["packets_down"] <= 0.2 * full["packets_down"]
    # the device renders from its own sample: the deadband costs it no force at all here
    errors = [abs(float(a["f_z"]) - float(b["f_z"])) for a, b in zip(full_rows, cut_rows, strict=True)]
    assert max(errors) <= 1e-9
    # direct, no delay, on a 1000 N/m wall: the renderer renders the states predicted
    # on between them, as hapticd does, and answers only what leaves the band; the force
    # held between messages stays within the deadband of the one the renderer would send
    # (its Weber fraction of the last sent, plus the floor), and the press stays passive.
    # (At 5000 N/m the force held between commands makes the wall ring: direct with a
    # deadband is active even without delay, over real UDP too.)
    soft = "scene.objects.0.material.stiffness=1000"
    direct, direct_rows = run_sim(tmp_path, PRESS, soft, trace=True)
    held, held_rows = run_sim(tmp_path, PRESS, soft, "remote.deadband=0.1", trace=True)
    assert held["packets_up"] <= 0.2 * direct["packets_up"]
    assert held["packets_down"] <= 0.1 * direct["packets_down"]
    steady = steady_force(direct_rows)
    assert abs(steady_force(held_rows) - steady) <= 0.1 * abs(steady)
    assert held["energy_j"] <= 0 and held["watchdog_trips"] == 0


@pytest.mark.parametrize("mode", ["direct", "local_model"])
def test_a_deadband_renders_predictions_and_never_starves_the_watchdog(tmp_path, mode):
    # a hand that presses and holds, 20 ms each way: between the states the renderer
    # renders the last one moved on at its velocity, a fresh input to its watchdog (as
    # hapticd does within its keep-alive; the simulator's channel has no keep-alive, as
    # FORMAT.md's deadband sends only what leaves its band). The watchdog used to trip
    # on the device at rest, 2 to 10 times a run.
    for deadband in (0.05, 0.1, 0.2):
        summary, _ = run_sim(tmp_path, PRESS, "channel.delay_ms=20", f"remote.mode={mode}",
                             f"remote.deadband={deadband}")
        assert summary["watchdog_trips"] == 0, (deadband, summary)
        # most ticks had no state: the deadband held them back
        assert summary["ticks_without_input"] >= 0.5 * summary["ticks"], (deadband, summary)


@pytest.mark.parametrize("mode", ["direct", "local_model"])
def test_tdpa_with_a_deadband_keeps_the_channel_passive(tmp_path, mode):
    # the press into the box and the box edge's slide out and back (the maps' rows that
    # ended above zero before: up to +1.1 mJ at 5% with 20 ms each way)
    edge = json.loads((SIM.parents[2] / "bench" / "scenarios" / "box_edge.json").read_text())
    edge["duration_s"] = 2.5
    edge["device"]["start"] = [0.03, 0, 0.03]
    edge["hand"]["path"] = [[0, 0.03, 0, 0.03], [0.4, 0.03, 0, -0.01], [0.6, 0.03, 0, -0.01],
                            [0.85, 0.055, 0, -0.01], [1.1, 0.03, 0, -0.01]]
    for scenario, deadband, delay, stiffness in itertools.product(
            [PRESS, edge], [0.05, 0.2], [0, 20, 200], [300, K, 30000]):
        summary, _ = run_sim(tmp_path, scenario, f"channel.delay_ms={delay}", f"remote.mode={mode}",
                             "remote.passivity=tdpa", f"remote.deadband={deadband}",
                             f"scene.objects.0.material.stiffness={stiffness}")
        assert summary["channel_energy_j"] <= 0, (deadband, delay, stiffness, summary)


def test_an_admittance_device_lags_its_pose_by_its_response_time(tmp_path):
    scenario = json.loads((SIM.parents[2] / "bench" / "scenarios" / "admittance_wall.json").read_text())
    scenario["device"]["response_time_s"] = 0.02
    _, rows = run_sim(tmp_path, scenario, trace=True)
    decay = math.exp(-1 / scenario["rate_hz"] / 0.02)
    for before, after in itertools.pairwise(rows[10:401]):
        x, target, x_next = float(before["dev_z"]), float(before["avatar_z"]), float(after["dev_z"])
        assert abs(x_next - (target + (x - target) * decay)) <= 1e-12


@pytest.mark.parametrize("setting, message", [
    ("remote.mode=relay", "remote.mode"),
    ("remote.passivity=wave", "remote.passivity"),
    ("remote.deadband=1", "remote.deadband is 1"),
    ("remote.deadband=-0.1", "remote.deadband"),
    ("remote.window=3", "remote.window"),
    ("device.response_time_s=0.01", "device.response_time_s is 0.01; it applies to device.mode admittance only"),
])
def test_bad_remote_settings_are_refused_naming_the_field(tmp_path, setting, message):
    path = tmp_path / "scenario.json"
    path.write_text(json.dumps(PRESS))
    done = subprocess.run([str(SIM), str(path), "--set", setting], capture_output=True, text=True, timeout=60,
                          check=False)
    assert done.returncode == 2
    assert message in done.stderr


def test_tdpa_on_an_admittance_device_is_refused_as_not_built(tmp_path):
    scenario = json.loads((SIM.parents[2] / "bench" / "scenarios" / "admittance_wall.json").read_text())
    path = tmp_path / "scenario.json"
    path.write_text(json.dumps(scenario))
    done = subprocess.run([str(SIM), str(path), "--set", "remote.passivity=tdpa"], capture_output=True, text=True,
                          check=False, timeout=60)
    assert done.returncode == 2 and "remote.passivity is tdpa" in done.stderr
