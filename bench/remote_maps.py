"""Stability and transparency across a delayed channel (issue 14): the four ways of
rendering across it (direct, direct + TDPA, local model, local model + TDPA) swept over
stiffness x delay x jitter x loss x approach speed on three scenes, through hapticd-sim,
and the perceptual deadband's messages saved against its force error:

    .venv/bin/python bench/remote_maps.py [--sim build/bin/hapticd-sim] [--jobs N]
                                          [--out bench/results/remote]

The run is stability_maps.py's (bench/scenarios/stability_base.json: a hand presses a
1 kHz impedance device through a god-object into a 1 mm plate with about 3 N and holds),
with `remote` and `channel` set, on three scenes:
- plate: straight down onto the middle of the plate;
- edge: down 0.5 mm inside the plate's edge (the model must hold the edge);
- moving: the plate rises at 5 mm/s (a kinematic object the model carries by its
  velocity); heights are judged relative to the plate.
A last set runs the local model with the device's own passivity controller on
(control.passivity), at no delay, at 50 ms each way with 20 ms jitter and 10% loss, and
at 250 ms with 20% loss. Each run is classified as stability_maps.py classifies (stable, limit cycle, energy
growing, pop-through), and measured for transparency against the run without delay,
jitter or loss (direct, same scene, stiffness and speed): the steady force error (the
mean f_z over the last 0.3 s, as a fraction of the reference's) and the penetration.
The channel's energy (the two ports' observers, FORMAT.md's channel_energy_j) is in
every row.
"""
from __future__ import annotations

import argparse
import concurrent.futures
import csv
import itertools
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from stability_maps import BASE_SCENARIO, CLASSES, REPO, classify, read_trace  # noqa: E402

MODES = (("direct", "none"), ("direct", "tdpa"), ("local_model", "none"), ("local_model", "tdpa"))
SCENES = ("plate", "edge", "moving")
STIFFNESS_N_PER_M = (300, 1000, 3000, 5000, 10000, 30000)
DELAY_MS = (0, 5, 20, 50, 200, 500)  # each way
JITTER_MS = (0, 20)
LOSS = (0, 0.1, 0.2)
SPEED_M_PER_S = (0.1, 0.5)
DEADBANDS = (0, 0.05, 0.1, 0.2)
PLATE_HALF_M = 0.0005
START_ABOVE_M = 0.03
PRESS_BELOW_M = 0.01
SETTLE_S = 1.5
RISE_M_PER_S = 0.005
WINDOW_S = 0.3


def overrides(scene: str, mode: str, passivity: str, k: float, delay: float, jitter: float, loss: float,
              speed: float, deadband: float = 0, controller: bool = False) -> list[str]:
    x = 0.1 - 0.0005 if scene == "edge" else 0.0
    z_start, z_end = PLATE_HALF_M + START_ABOVE_M, PLATE_HALF_M - PRESS_BELOW_M
    t_reach = (START_ABOVE_M + PRESS_BELOW_M) / speed
    sets = [f"duration_s={START_ABOVE_M / speed + SETTLE_S:g}", f"scene.objects.0.material.stiffness={k:g}",
            f"device.start=[{x:g},0,{z_start:g}]", f"hand.path=[[0,{x:g},0,{z_start:g}],[{t_reach:g},{x:g},0,{z_end:g}]]",
            f"channel.delay_ms={delay:g}", f"channel.jitter_ms={jitter:g}", f"channel.loss={loss:g}",
            f"remote.mode={mode}", f"remote.passivity={passivity}", f"remote.deadband={deadband:g}",
            f"control.passivity={'true' if controller else 'false'}"]
    if scene == "moving":
        sets.append(f"scene.objects.0.motion={{\"velocity\":[0,0,{RISE_M_PER_S:g}]}}")
    return sets


def run_one(args: tuple) -> dict:
    (scene, mode, passivity, k, delay, jitter, loss, speed, deadband, controller), sim, trace_dir, index = args
    trace_path = pathlib.Path(trace_dir) / f"run{index}.csv"
    command = [sim, str(BASE_SCENARIO), "--trace", str(trace_path)]
    for o in overrides(scene, mode, passivity, k, delay, jitter, loss, speed, deadband, controller):
        command += ["--set", o]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"hapticd-sim failed for {command}: {done.stderr.strip()}")
    summary = json.loads(done.stdout)
    trace = read_trace(trace_path)
    trace_path.unlink()
    if scene == "moving":  # heights relative to the rising plate
        rise = RISE_M_PER_S * trace["t"]
        trace["dev_z"], trace["avatar_z"] = trace["dev_z"] - rise, trace["avatar_z"] - rise
    result = classify(trace, summary, PLATE_HALF_M, 0.0, 8.0)
    late = trace["t"] >= trace["t"][-1] - WINDOW_S
    return {"scene": scene, "mode": mode, "passivity": passivity, "stiffness_n_per_m": k, "delay_ms": delay,
            "jitter_ms": jitter, "loss": loss, "speed_m_per_s": speed, "deadband": deadband,
            "controller": int(controller),
            "class": result["class"], "steady_force_n": float(trace["f_z"][late].mean()),
            "max_penetration_m": summary["max_penetration_m"], "energy_j": summary["energy_j"],
            "channel_energy_j": summary["channel_energy_j"], "packets_up": summary["packets_up"],
            "packets_down": summary["packets_down"], "max_drift_m": summary["max_drift_m"],
            "ticks_outside_model": summary["ticks_outside_model"], "energy_late_j": result["energy_late_j"]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sim", default=str(REPO / "build" / "bin" / "hapticd-sim"))
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=str(REPO / "bench" / "results" / "remote"))
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    grid = [(s, m, p, k, d, j, l, v, 0.0, False) for s, (m, p), k, d, j, l, v in itertools.product(
        SCENES, MODES, STIFFNESS_N_PER_M, DELAY_MS, JITTER_MS, LOSS, SPEED_M_PER_S)]
    # the deadband's sweep: plate, 0.1 m/s, no jitter or loss
    grid += [("plate", m, "none", k, d, 0.0, 0.0, 0.1, w, False) for m, k, d, w in itertools.product(
        ("direct", "local_model"), (1000, 10000), (0, 50), DEADBANDS[1:])]
    # the local model with the device's own passivity controller (control.passivity),
    # for the stiff walls that a 1 kHz loop makes active even without delay (Colgate)
    grid += [(s, "local_model", "none", k, d, j, l, v, 0.0, True) for s, k, (d, j, l), v in itertools.product(
        SCENES, STIFFNESS_N_PER_M, ((0, 0, 0), (50, 20, 0.1), (250, 20, 0.2)), SPEED_M_PER_S)]
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="remote_maps_") as trace_dir, \
            concurrent.futures.ProcessPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(run_one, [(g, args.sim, trace_dir, i) for i, g in enumerate(grid)], chunksize=8))
    elapsed = time.monotonic() - start
    # transparency against the reference: direct, no delay, jitter or loss, no deadband
    reference = {(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"]): r for r in rows
                 if r["mode"] == "direct" and r["passivity"] == "none" and r["delay_ms"] == 0
                 and r["jitter_ms"] == 0 and r["loss"] == 0 and r["deadband"] == 0 and not r["controller"]}
    for r in rows:
        ref = reference[(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"])]
        r["force_error"] = abs(r["steady_force_n"] - ref["steady_force_n"]) / abs(ref["steady_force_n"])
        r["messages_saved"] = 1 - (r["packets_up"] + r["packets_down"]) / (ref["packets_up"] + ref["packets_down"])
    with (out / "remote_maps.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    sweep = [r for r in rows if r["deadband"] == 0 and not r["controller"]]
    print(f"{len(rows)} runs in {elapsed:.1f} s with {args.jobs} jobs")
    print(f"{'mode':22s} " + " ".join(f"{c:>15s}" for c in CLASSES) + "  channel>0  max channel_energy_j")
    for mode, passivity in MODES:
        mine = [r for r in sweep if r["mode"] == mode and r["passivity"] == passivity]
        counts = [sum(r["class"] == c for r in mine) for c in CLASSES]
        positive = sum(r["channel_energy_j"] > 0 for r in mine)
        print(f"{mode + '+' + passivity:22s} " + " ".join(f"{n:15d}" for n in counts)
              + f"  {positive:9d}  {max(r['channel_energy_j'] for r in mine):.3g}")
    draw(out / "remote_maps.png", sweep)
    return 0


def draw(path: pathlib.Path, rows: list[dict]) -> None:
    """A panel per mode: class by stiffness (columns) x delay (rows), each cell the worst
    class over scene, jitter, loss and speed."""
    colours = np.array([[0.30, 0.69, 0.29], [1.0, 0.75, 0.0], [0.89, 0.10, 0.11], [0.42, 0.24, 0.60]])
    fig, axes = plt.subplots(1, len(MODES), figsize=(16, 4.5), sharey=True)
    for ax, (mode, passivity) in zip(axes, MODES):
        grid = np.zeros((len(DELAY_MS), len(STIFFNESS_N_PER_M)), dtype=int)
        share = np.zeros_like(grid, dtype=float)
        for i, d in enumerate(DELAY_MS):
            for j, k in enumerate(STIFFNESS_N_PER_M):
                cell = [r for r in rows if r["mode"] == mode and r["passivity"] == passivity
                        and r["delay_ms"] == d and r["stiffness_n_per_m"] == k]
                classes = [CLASSES.index(r["class"]) for r in cell]
                grid[i, j] = max(classes)
                share[i, j] = sum(c == 0 for c in classes) / len(classes)
        ax.imshow(colours[grid], aspect="auto")
        for i in range(len(DELAY_MS)):
            for j in range(len(STIFFNESS_N_PER_M)):
                ax.text(j, i, f"{share[i, j]:.0%}", ha="center", va="center", fontsize=8)
        ax.set_xticks(range(len(STIFFNESS_N_PER_M)), [f"{k:g}" for k in STIFFNESS_N_PER_M], fontsize=8)
        ax.set_yticks(range(len(DELAY_MS)), [f"{d:g} ms" for d in DELAY_MS])
        ax.set_xlabel("stiffness (N/m)")
        ax.set_title(f"{mode.replace('_', ' ')}{' + TDPA' if passivity == 'tdpa' else ''}")
    axes[0].set_ylabel("delay each way")
    fig.suptitle("worst class over scene x jitter x loss x speed (green stable, amber limit cycle, red energy "
                 "growing, purple pop-through); the number: share of stable runs", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
