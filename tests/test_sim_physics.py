"""Closed-loop physics through hapticd-sim: passivity, admittance and pop-through, on
scenarios in the shared format (../shared/scenarios/FORMAT.md), and the shipped
example scenarios."""

import copy
import csv
import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SIM = Path(os.environ.get("HAPTICD_BIN", REPO / "build" / "bin")) / "hapticd-sim"
EXAMPLES = REPO / "bench" / "scenarios"
TRACE_COLUMNS = ["t", "dev_x", "dev_y", "dev_z", "dev_vx", "dev_vy", "dev_vz",
                 "avatar_x", "avatar_y", "avatar_z", "f_x", "f_y", "f_z", "contact"]
IDENTITY = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]

# A wall (the half-space z <= 0) and a hand that presses the device 10 mm into it and
# holds: device damping b = 0.5 N·s/m, T = 1 ms, so Colgate's condition b > K T / 2
# holds for K < 1000 N/m.
WALL = {
    "rate_hz": 1000,
    "duration_s": 2.0,
    "scene": {"objects": [{
        "name": "wall", "shape": {"type": "plane"}, "position": [0, 0, 0], "rotation": IDENTITY,
        "material": {"stiffness": 500, "damping": 0, "static_friction": 0, "dynamic_friction": 0},
    }]},
    "avatar": {"type": "point", "radius": 0, "method": "god_object", "force_shading": False},
    "device": {"mode": "impedance", "mass": 0.05, "damping": 0.5, "max_force": 8.0,
               "position_resolution": 0, "start": [0, 0, 0.01]},
    "hand": {"mass": 0.3, "stiffness": 300, "damping": 5,
             "path": [[0.0, 0, 0, 0.01], [0.2, 0, 0, -0.01], [2.0, 0, 0, -0.01]]},
    "channel": {"delay_ms": 0, "jitter_ms": 0, "loss": 0, "seed": 1},
    "control": {"passivity": False},
}


def run_sim(tmp_path, scenario, *sets, trace=False):
    path = tmp_path / "scenario.json"
    path.write_text(json.dumps(scenario))
    command = [str(SIM), str(path)]
    trace_path = tmp_path / "trace.csv"
    if trace:
        command += ["--trace", str(trace_path)]
    for assignment in sets:
        command += ["--set", assignment]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    if not trace:
        return summary, None
    with trace_path.open() as handle:
        rows = list(csv.DictReader(handle))
    return summary, rows


def device_damper_dissipation(rows, damping, dt):
    """b times the integral of |v|^2, from the trace's sampled velocities."""
    return sum(damping * sum(float(r[k]) ** 2 for k in ("dev_vx", "dev_vy", "dev_vz")) * dt for r in rows)


@pytest.mark.parametrize("method", ["god_object", "penalty"])
def test_wall_within_colgates_condition_does_no_net_work_when_pressed(tmp_path, method):
    summary, _ = run_sim(tmp_path, WALL, f"avatar.method={method}")
    assert summary["energy_j"] <= 0
    assert summary["max_force_n"] > 2.0  # the device really pressed into the wall


def test_wall_within_colgates_condition_is_passive_with_the_device_over_a_cycle(tmp_path):
    # in and out again: the sampled wall may do a little work, but never more than the
    # device's own damper dissipates (b > K T / 2)
    cycle = copy.deepcopy(WALL)
    cycle["hand"]["path"] = [[0, 0, 0, 0.01], [0.2, 0, 0, -0.01], [1.0, 0, 0, -0.01],
                             [1.2, 0, 0, 0.01], [2.0, 0, 0, 0.01]]
    summary, rows = run_sim(tmp_path, cycle, trace=True)
    dissipated = device_damper_dissipation(rows, 0.5, 0.001)
    assert summary["energy_j"] < dissipated
    assert summary["contact_ticks"] > 500


def test_stiff_wall_generates_energy_without_the_passivity_controller(tmp_path):
    # K = 20000 N/m: K T / 2 = 10 N·s/m, twenty times the device's damping
    first, _ = run_sim(tmp_path, WALL, "scene.objects.0.material.stiffness=20000", "duration_s=1.0")
    both, _ = run_sim(tmp_path, WALL, "scene.objects.0.material.stiffness=20000")
    assert first["energy_j"] > 0.01
    assert both["energy_j"] > first["energy_j"] + 0.01  # and it keeps growing


def test_passivity_controller_keeps_the_stiff_wall_at_or_below_zero_work(tmp_path):
    for duration in ("1.0", "2.0"):
        summary, _ = run_sim(tmp_path, WALL, "scene.objects.0.material.stiffness=20000",
                             "control.passivity=true", f"duration_s={duration}")
        # at or below zero, up to the one-tick prediction error at an impact (~1e-6 J)
        assert summary["energy_j"] <= 1e-5, summary
        assert summary["passivity_activations"] > 0


def test_admittance_avatar_pushed_into_a_wall_settles_on_it(tmp_path):
    scenario = copy.deepcopy(WALL)
    scenario["device"].update({"mode": "admittance", "virtual_mass": 1.0, "virtual_damping": 20,
                               "max_force": 20.0})
    # a hand pulled 33 mm under the wall: about 10 N at the handle once stopped
    scenario["hand"]["path"] = [[0.0, 0, 0, 0.01], [0.1, 0, 0, -0.0333], [2.0, 0, 0, -0.0333]]
    summary, rows = run_sim(tmp_path, scenario, trace=True)
    avatar_z = [float(r["avatar_z"]) for r in rows]
    assert min(avatar_z) >= -1e-9  # never passes the surface
    assert abs(avatar_z[-1]) <= 1e-6  # settled on it
    pushes = [-float(r["f_z"]) for r in rows[-100:]]
    assert 9.0 < min(pushes) and max(pushes) < 11.0
    assert all(int(r["contact"]) == 1 for r in rows[-100:])


def plate_stroke(method, radius):
    scenario = copy.deepcopy(WALL)
    scenario["scene"]["objects"][0] = {
        "name": "plate", "shape": {"type": "box", "half_extents": [0.1, 0.1, 0.0005]},
        "position": [0, 0, 0], "rotation": IDENTITY,
        "material": {"stiffness": 2000, "damping": 0, "static_friction": 0, "dynamic_friction": 0}}
    scenario["avatar"] = {"type": "point" if radius == 0 else "sphere", "radius": radius,
                          "method": method, "force_shading": False}
    # a 1 m/s stroke from 20 mm above to 20 mm below, then held
    scenario["device"]["start"] = [0.01, 0.02, 0.02 + radius]
    scenario["device"]["max_force"] = 100.0
    scenario["hand"] = {"mass": 0.3, "stiffness": 3000, "damping": 50,
                        "path": [[0.0, 0.01, 0.02, 0.02 + radius], [0.04, 0.01, 0.02, -0.02 + radius],
                                 [0.5, 0.01, 0.02, -0.02 + radius]]}
    scenario["duration_s"] = 0.5
    return scenario


@pytest.mark.parametrize("method,radius", [("god_object", 0.0), ("finger_proxy", 0.004)])
def test_proxies_never_cross_a_thin_plate_at_one_metre_per_second(tmp_path, method, radius):
    summary, rows = run_sim(tmp_path, plate_stroke(method, radius), trace=True)
    assert min(float(r["avatar_z"]) for r in rows) >= 0.0005 + radius - 1e-8
    assert float(rows[-1]["f_z"]) > 10  # still held, pulling the device back up
    # the device itself went through (the hand pulls hard): only the proxy held
    assert min(float(r["dev_z"]) for r in rows) < -0.005
    assert summary["max_force_n"] > 10


def test_penalty_pops_through_the_same_plate(tmp_path):
    summary, rows = run_sim(tmp_path, plate_stroke("penalty", 0.0), trace=True)
    assert float(rows[-1]["dev_z"]) < -0.01  # through and below
    assert float(rows[-1]["f_z"]) == 0.0     # and nothing holds it any more


def test_bad_scenarios_are_refused_with_the_field_named(tmp_path):
    bad = copy.deepcopy(WALL)
    bad["device"]["mass"] = -1
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(bad))
    done = subprocess.run([str(SIM), str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "device.mass" in done.stderr
    unknown = copy.deepcopy(WALL)
    unknown["device"]["maxforce"] = 3
    path.write_text(json.dumps(unknown))
    done = subprocess.run([str(SIM), str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "maxforce" in done.stderr
    done = subprocess.run([str(SIM), str(tmp_path / "scenario.json")], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2


def test_nan_in_a_scenario_is_refused(tmp_path):
    path = tmp_path / "nan.json"
    path.write_text(json.dumps(WALL).replace('"damping": 0.5', '"damping": NaN'))
    done = subprocess.run([str(SIM), str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "invalid JSON at line 1" in done.stderr  # NaN is not JSON
    path.write_text(json.dumps(WALL))
    done = subprocess.run([str(SIM), str(path), "--set", "device.damping=NaN"], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2
    assert "device.damping" in done.stderr


@pytest.mark.parametrize("example", sorted(EXAMPLES.glob("*.json")), ids=lambda p: p.stem)
def test_every_shipped_scenario_runs(tmp_path, example):
    trace = tmp_path / "trace.csv"
    done = subprocess.run([str(SIM), str(example), "--trace", str(trace)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    for key in ("ticks", "max_force_n", "max_penetration_m", "energy_j"):
        assert key in summary
    with trace.open() as handle:
        header = next(csv.reader(handle))
    assert header[:len(TRACE_COLUMNS)] == TRACE_COLUMNS
