"""Stability and transparency across a delayed channel (issue 14): the four ways of
rendering across it (direct, direct + TDPA, local model, local model + TDPA) swept over
stiffness x delay x jitter x loss x approach speed on three scenes, through hapticd-sim,
and the perceptual deadband's messages saved against its force error:

    .venv/bin/python bench/remote_maps.py [--sim build/bin/hapticd-sim] [--jobs N]
                                          [--out bench/results/remote] [--replot]

(--replot draws the PNGs again from the CSV in --out, running nothing; --command prints
the hapticd-sim command line of one run, from a CSV row's first nine columns.)

The plate and the moving plate are stability_maps.py's run (bench/scenarios/
stability_base.json: a hand presses a 1 kHz impedance device through a god-object into
a 1 mm plate with about 3 N and holds); the edge is bench/scenarios/box_edge.json. With
`remote` and `channel` set, the scenes are:
- plate: straight down onto the middle of the plate;
- edge: a box 80 x 80 x 40 mm; the hand presses on its top 10 mm from an edge, holds
  0.2 s, slides out over the edge (the force must vanish there), 15 mm beyond it, and
  back in, so that it ends pressing on the side face 10 mm below the edge (the model
  must hold the edge and the neighbouring face before the avatar gets there);
- moving: the plate rises at 5 mm/s (a kinematic object the model carries by its
  velocity); heights are judged relative to the plate.
All speeds of the path (down, out and back) are the approach speed.
Further sets:
- controller: the local model with the device's own passivity controller on
  (control.passivity), at no delay, at 50 ms each way with 20 ms jitter and 10% loss,
  and at 250 ms with 20% loss;
- colgate: the no-delay direct run and the local model at 50 ms each way with 20 ms
  jitter and 10% loss, at 5,000-30,000 N/m on the plate and the edge, with the
  device's damping raised from 0.5 N s/m to 1.2 K T / 2 (Colgate's condition for a
  wall sampled at T = 1 ms wants b > K T / 2): whether the channel adds energy, or
  the sampled wall makes it;
- deadband: 5, 10 and 20% on the plate and the edge at 0.1 m/s, no jitter or loss,
  every way, every stiffness, 0, 20, 50 and 200 ms each way (the runs with deadband 0
  are the main sweep's);
- edge_mesh: the edge with the box as a tiled mesh (bench/scenarios/box_edge_mesh.json,
  768 triangles, which the local model cuts into a patch about the avatar instead of
  holding it whole) for the local model at a few points; each run costs some 25 times
  a primitive's (the device builds a scene of the patch at every model), so only these.
Each run is classified as stability_maps.py classifies (stable, limit cycle, energy
growing, pop-through; at the edge along the side face's normal, and pop-through when
the avatar is ever 1 mm inside the box) and measured for transparency against the run
without delay, jitter or loss (direct, same scene, stiffness and speed): the steady
force error (the mean force vector over the last 0.3 s, |F - F_ref| / |F_ref|) and the
penetration (penetration_m: how deep the device point went beneath the face it
pressed: the plate's top, through the plate too; the box's top until the path turns
back, its side face after). The deadband's runs are measured against the same run with
deadband 0: the messages saved (packets_up + packets_down) and the steady force's
change. The channel's energy (the two ports' observers, FORMAT.md's channel_energy_j)
is in every row, and surface_energy_j is energy_j in the surface's frame (on the moving
plate, less the work the plate does by carrying the hand).
"""
from __future__ import annotations

import argparse
import concurrent.futures
import csv
import itertools
import json
import math
import os
import pathlib
import shlex
import subprocess
import sys
import tempfile
import time

import matplotlib
import matplotlib.ticker
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.colors import LogNorm
from matplotlib.lines import Line2D

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from stability_maps import BASE_SCENARIO, CLASSES, REPO, classify, read_trace

MODES = (("direct", "none"), ("direct", "tdpa"), ("local_model", "none"), ("local_model", "tdpa"))
SCENES = ("plate", "edge", "moving")
STIFFNESS_N_PER_M = (300, 1000, 3000, 5000, 10000, 30000)
DELAY_MS = (0, 5, 20, 50, 200, 500)  # each way
JITTER_MS = (0, 20)
LOSS = (0, 0.1, 0.2)
SPEED_M_PER_S = (0.1, 0.5)
DEADBANDS = (0.05, 0.1, 0.2)
DEADBAND_DELAY_MS = (0, 20, 50, 200)
PLATE_HALF_M = 0.0005
START_ABOVE_M = 0.03
PRESS_BELOW_M = 0.01
SETTLE_S = 1.5
RISE_M_PER_S = 0.005
WINDOW_S = 0.3
# The edge: the box of box_edge.json, its top at z = 0 and the side face pressed at
# x = EDGE_X. The press starts EDGE_IN_M inside the edge, the slide goes EDGE_OUT_M
# beyond it, after EDGE_HOLD_S of pressing on the top.
EDGE_SCENARIO = REPO / "bench" / "scenarios" / "box_edge.json"
EDGE_MESH_SCENARIO = REPO / "bench" / "scenarios" / "box_edge_mesh.json"
_box = json.loads(EDGE_SCENARIO.read_text())["scene"]["objects"][0]
BOX_CENTRE_M = np.array(_box["position"], dtype=float)
BOX_HALF_M = np.array(_box["shape"]["half_extents"], dtype=float)
EDGE_X = float(BOX_CENTRE_M[0] + BOX_HALF_M[0])
BOX_TOP_Z = float(BOX_CENTRE_M[2] + BOX_HALF_M[2])
EDGE_IN_M = 0.01
EDGE_OUT_M = 0.015
EDGE_HOLD_S = 0.2
# A run without deadband whose steady force is below this share of the no-delay one
# renders no force (direct + TDPA): a change against it is not a Weber fraction.
NO_FORCE_SHARE = 0.1
DEVICE_DAMPING_NS_PER_M = float(json.loads(BASE_SCENARIO.read_text())["device"]["damping"])


def scenario_of(scene: str) -> pathlib.Path:
    return {"edge": EDGE_SCENARIO, "edge_mesh": EDGE_MESH_SCENARIO}.get(scene, BASE_SCENARIO)


def edge_times(speed: float) -> tuple[float, float, float]:
    """When the edge's path reaches the press, its farthest point out, and the press again."""
    t_press = (START_ABOVE_M + PRESS_BELOW_M) / speed
    t_out = t_press + EDGE_HOLD_S + (EDGE_IN_M + EDGE_OUT_M) / speed
    return t_press, t_out, t_out + (EDGE_IN_M + EDGE_OUT_M) / speed


def overrides(scene: str, mode: str, passivity: str, k: float, delay: float, jitter: float, loss: float,
              speed: float, deadband: float = 0, controller: bool = False,
              damping: float = DEVICE_DAMPING_NS_PER_M) -> list[str]:
    if scene.startswith("edge"):
        x_in, x_out = EDGE_X - EDGE_IN_M, EDGE_X + EDGE_OUT_M
        z_start, z_end = BOX_TOP_Z + START_ABOVE_M, BOX_TOP_Z - PRESS_BELOW_M
        t_press, t_out, t_back = edge_times(speed)
        path = [(0, x_in, z_start), (t_press, x_in, z_end), (t_press + EDGE_HOLD_S, x_in, z_end),
                (t_out, x_out, z_end), (t_back, x_in, z_end)]
        # SETTLE_S after the path comes back to the side face, as the plate's after its top
        duration = t_out + EDGE_OUT_M / speed + SETTLE_S
    else:
        z_start, z_end = PLATE_HALF_M + START_ABOVE_M, PLATE_HALF_M - PRESS_BELOW_M
        t_press = (START_ABOVE_M + PRESS_BELOW_M) / speed
        duration = START_ABOVE_M / speed + SETTLE_S
        path = [(0, 0.0, z_start), (t_press, 0.0, z_end)]
        if scene == "moving":
            # the hand rides with the plate, so the press is steady in the plate's frame (a
            # fixed hand under a rising plate ramps the force, which reads as a limit cycle)
            path = [(t, x, z + RISE_M_PER_S * t) for t, x, z in path + [(duration, 0.0, z_end)]]
    points = ",".join(f"[{t:.9g},{x:.9g},0,{z:.9g}]" for t, x, z in path)
    sets = [f"duration_s={duration:.9g}", f"scene.objects.0.material.stiffness={k:g}",
            f"device.start=[{path[0][1]:.9g},0,{z_start:.9g}]", f"hand.path=[{points}]",
            f"channel.delay_ms={delay:g}", f"channel.jitter_ms={jitter:g}", f"channel.loss={loss:g}",
            f"remote.mode={mode}", f"remote.passivity={passivity}", f"remote.deadband={deadband:g}",
            f"control.passivity={'true' if controller else 'false'}", f"device.damping={damping:g}"]
    if scene == "moving":
        sets.append(f"scene.objects.0.motion={{\"velocity\":[0,0,{RISE_M_PER_S:g}]}}")
    return sets


def box_depth(p: np.ndarray) -> np.ndarray:
    """Signed distance of points (n x 3) from the edge's box: negative inside."""
    q = np.abs(p - BOX_CENTRE_M) - BOX_HALF_M
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


def edge_frame(trace: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The edge's trace as classify() reads a plate's: the run ends pressing on the side
    face, so its normal (+x) is turned into z by a rotation (which keeps the work), with
    heights from the face as the plate's from its middle; avatar_z is the avatar's
    signed distance from the box, so pop-through is the avatar 1 mm inside it anywhere."""
    out = dict(trace)
    out["dev_x"], out["dev_z"] = -trace["dev_z"], trace["dev_x"] - EDGE_X + PLATE_HALF_M
    out["f_x"], out["f_z"] = -trace["f_z"], trace["f_x"]
    avatar = np.stack([trace["avatar_x"], trace["avatar_y"], trace["avatar_z"]], axis=1)
    out["avatar_z"] = box_depth(avatar) + PLATE_HALF_M
    return out


def run_one(args: tuple) -> dict:
    (scene, mode, passivity, k, delay, jitter, loss, speed, deadband, controller, damping), sim, trace_dir, index = args
    trace_path = pathlib.Path(trace_dir) / f"run{index}.csv"
    command = [sim, str(scenario_of(scene)), "--trace", str(trace_path)]
    for o in overrides(scene, mode, passivity, k, delay, jitter, loss, speed, deadband, controller, damping):
        command += ["--set", o]
    started = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"hapticd-sim failed for {command}: {done.stderr.strip()}")
    seconds = time.monotonic() - started
    summary = json.loads(done.stdout)
    trace = read_trace(trace_path)
    trace_path.unlink()
    late = trace["t"] >= trace["t"][-1] - WINDOW_S
    steady = np.array([trace[c][late].mean() for c in ("f_x", "f_y", "f_z")])
    final = np.array(summary["final_device"], dtype=float)
    if scene == "moving":  # heights relative to the rising plate
        rise = RISE_M_PER_S * trace["t"]
        trace["dev_z"], trace["avatar_z"] = trace["dev_z"] - rise, trace["avatar_z"] - rise
        final[2] -= RISE_M_PER_S * (2 * trace["t"][-1] - trace["t"][-2])
    # the rendered work in the surface's frame: energy_j less what a moving plate does
    # on the hand by carrying it, so it judges the rendering's passivity on every scene
    device = np.stack([trace["dev_x"], trace["dev_y"], trace["dev_z"]], axis=1)
    force = np.stack([trace["f_x"], trace["f_y"], trace["f_z"]], axis=1)
    surface_energy = float(np.einsum("ij,ij->", force, np.diff(np.vstack([device, final]), axis=0)))
    if scene.startswith("edge"):
        # beneath the top until the path turns back at its farthest point, beneath the side
        # face after (the box's nearest face would cap the press on the top at 10 mm)
        top = trace["t"] < edge_times(speed)[1]
        depth = max(float(np.max(BOX_TOP_Z - trace["dev_z"][top & (trace["dev_x"] < EDGE_X)], initial=0)),
                    float(np.max(EDGE_X - trace["dev_x"][~top & (trace["dev_z"] < BOX_TOP_Z)], initial=0)))
        trace = edge_frame(trace)
    else:
        # below the top face, through the plate too: the summary's max_penetration_m is
        # the depth in the object, at most half the 1 mm plate
        depth = PLATE_HALF_M - float(trace["dev_z"].min())
    result = classify(trace, summary, PLATE_HALF_M, 0.0, 8.0)
    return {"scene": scene, "mode": mode, "passivity": passivity, "stiffness_n_per_m": k, "delay_ms": delay,
            "jitter_ms": jitter, "loss": loss, "speed_m_per_s": speed, "deadband": deadband,
            "controller": int(controller), "device_damping_ns_per_m": damping,
            "class": result["class"], "steady_force_n": float(np.linalg.norm(steady)),
            "steady_fx_n": steady[0], "steady_fy_n": steady[1], "steady_fz_n": steady[2],
            "penetration_m": max(depth, 0.0), "max_penetration_m": summary["max_penetration_m"],
            "max_proxy_penetration_m": summary["max_proxy_penetration_m"], "energy_j": summary["energy_j"],
            "surface_energy_j": surface_energy,
            "channel_energy_j": summary["channel_energy_j"], "packets_up": summary["packets_up"],
            "packets_down": summary["packets_down"], "max_drift_m": summary["max_drift_m"],
            "models_taken": summary["models_taken"], "model_blends": summary["model_blends"],
            "ticks_outside_model": summary["ticks_outside_model"],
            "max_model_radius_m": summary["max_model_radius_m"], "energy_late_j": result["energy_late_j"],
            "sim_s": seconds}


def build_grid() -> list[tuple]:
    """(scene, mode, passivity, k, delay, jitter, loss, speed, deadband, controller, damping)"""
    b = DEVICE_DAMPING_NS_PER_M
    # the mesh's runs first: they are the longest, and a pool ends idle behind them
    grid = [("edge_mesh", m, p, k, d, 20.0, 0.1, 0.5, 0.0, False) for (m, p), k, d in itertools.product(
        (("local_model", "none"), ("local_model", "tdpa")), (1000, 5000, 30000), (0, 5, 50, 200))]
    grid = [g + (b,) for g in grid]
    grid += [(s, m, p, k, d, j, loss, v, 0.0, False, b) for s, (m, p), k, d, j, loss, v in itertools.product(
        SCENES, MODES, STIFFNESS_N_PER_M, DELAY_MS, JITTER_MS, LOSS, SPEED_M_PER_S)]
    # the deadband's sweep: 0.1 m/s, no jitter or loss (its deadband 0 is above)
    grid += [(s, m, p, k, d, 0.0, 0.0, 0.1, w, False, b) for s, (m, p), k, d, w in itertools.product(
        ("plate", "edge"), MODES, STIFFNESS_N_PER_M, DEADBAND_DELAY_MS, DEADBANDS)]
    # the local model with the device's own passivity controller (control.passivity),
    # for the stiff walls that a 1 kHz loop makes active even without delay (Colgate)
    grid += [(s, "local_model", "none", k, d, j, loss, v, 0.0, True, b) for s, k, (d, j, loss), v in itertools.product(
        SCENES, STIFFNESS_N_PER_M, ((0, 0, 0), (50, 20, 0.1), (250, 20, 0.2)), SPEED_M_PER_S)]
    # the same walls with the damping Colgate's condition asks for (1.2 K T / 2, T = 1 ms)
    grid += [(s, m, "none", k, d, j, loss, v, 0.0, False, round(1.2 * k * 0.001 / 2, 6))
             for s, k, (m, d, j, loss), v in itertools.product(
                 ("plate", "edge"), (5000, 10000, 30000), (("direct", 0, 0, 0), ("local_model", 50, 20, 0.1)),
                 SPEED_M_PER_S)]
    return grid


def add_comparisons(rows: list[dict]) -> None:
    """force_error against the no-delay reference; messages_saved and deadband_force_error
    against the same run with deadband 0 (NaN where that run renders no force)."""
    reference = {(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"]): r for r in rows
                 if r["mode"] == "direct" and r["passivity"] == "none" and r["delay_ms"] == 0
                 and r["jitter_ms"] == 0 and r["loss"] == 0 and r["deadband"] == 0 and not r["controller"]
                 and r["device_damping_ns_per_m"] == DEVICE_DAMPING_NS_PER_M}

    def steady(r: dict) -> np.ndarray:
        return np.array([r["steady_fx_n"], r["steady_fy_n"], r["steady_fz_n"]])

    def key(r: dict) -> tuple:
        return (r["scene"], r["mode"], r["passivity"], r["stiffness_n_per_m"], r["delay_ms"], r["jitter_ms"],
                r["loss"], r["speed_m_per_s"], r["controller"], r["device_damping_ns_per_m"])

    undeadbanded = {key(r): r for r in rows if r["deadband"] == 0}
    for r in rows:
        # the mesh box is the same box: the primitive's run without delay is its reference
        ref = reference[(r["scene"].replace("edge_mesh", "edge"), r["stiffness_n_per_m"], r["speed_m_per_s"])]
        ref_norm = float(np.linalg.norm(steady(ref)))
        r["force_error"] = float(np.linalg.norm(steady(r) - steady(ref))) / ref_norm
        base = undeadbanded.get(key(r))
        if base is None:
            r["messages_saved"] = r["deadband_force_error"] = math.nan
            continue
        r["messages_saved"] = 1 - (r["packets_up"] + r["packets_down"]) / (base["packets_up"] + base["packets_down"])
        base_norm = float(np.linalg.norm(steady(base)))
        r["deadband_force_error"] = (float(np.linalg.norm(steady(r) - steady(base))) / base_norm
                                     if base_norm >= NO_FORCE_SHARE * ref_norm else math.nan)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sim", default=str(REPO / "build" / "bin" / "hapticd-sim"))
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=str(REPO / "bench" / "results" / "remote"))
    parser.add_argument("--replot", action="store_true", help="draw the PNGs from the CSV in --out")
    parser.add_argument("--command", nargs=9, metavar=("SCENE", "MODE", "PASSIVITY", "K", "DELAY_MS", "JITTER_MS",
                                                        "LOSS", "SPEED", "DEADBAND"),
                        help="print the command of one run (e.g. edge direct tdpa 5000 20 0 0 0.1 0.05) and exit")
    args = parser.parse_args()
    if args.command:
        scene, mode, passivity, *numbers = args.command
        sets = overrides(scene, mode, passivity, *map(float, numbers))
        print(shlex.join([os.path.relpath(args.sim, REPO), str(scenario_of(scene).relative_to(REPO)), "--trace",
                          "/tmp/run.csv"] + [a for o in sets for a in ("--set", o)]))
        return 0
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.replot:
        draw_all(out, read_rows(out / "remote_maps.csv"))
        return 0
    grid = build_grid()
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="remote_maps_") as trace_dir, \
            concurrent.futures.ProcessPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(run_one, [(g, args.sim, trace_dir, i) for i, g in enumerate(grid)], chunksize=4))
    elapsed = time.monotonic() - start
    add_comparisons(rows)
    with (out / "remote_maps.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("" if isinstance(v, float) and math.isnan(v) else f"{v:.6g}" if isinstance(v, float)
                                 else v) for k, v in row.items()})
    sweep = main_sweep(rows)
    print(f"{len(rows)} runs in {elapsed:.1f} s with {args.jobs} jobs "
          f"({sum(r['sim_s'] for r in rows):.1f} s in the simulator)")
    print(f"{'mode':22s} " + " ".join(f"{c:>15s}" for c in CLASSES) + "  channel>0  max channel_energy_j")
    for mode, passivity in MODES:
        mine = [r for r in sweep if r["mode"] == mode and r["passivity"] == passivity]
        counts = [sum(r["class"] == c for r in mine) for c in CLASSES]
        positive = sum(r["channel_energy_j"] > 0 for r in mine)
        print(f"{mode + '+' + passivity:22s} " + " ".join(f"{n:15d}" for n in counts)
              + f"  {positive:9d}  {max(r['channel_energy_j'] for r in mine):.3g}")
    draw_all(out, rows)
    return 0


def main_sweep(rows: list[dict]) -> list[dict]:
    """The four ways over the three scenes, without deadband, controller or added damping."""
    return [r for r in rows if r["scene"] in SCENES and r["deadband"] == 0 and not r["controller"]
            and r["device_damping_ns_per_m"] == DEVICE_DAMPING_NS_PER_M]


def read_rows(path: pathlib.Path) -> list[dict]:
    """The CSV's rows with their numbers as numbers (an empty cell: NaN)."""
    rows = []
    for row in csv.DictReader(path.open()):
        for key, value in row.items():
            if key not in ("scene", "mode", "passivity", "class"):
                row[key] = float(value) if value != "" else math.nan
        rows.append(row)
    return rows


def draw_all(out: pathlib.Path, rows: list[dict]) -> None:
    sweep = main_sweep(rows)
    draw_classes(out / "remote_maps.png", sweep)
    draw_transparency(out / "remote_transparency.png", sweep)
    draw_deadband(out / "remote_deadband.png", [r for r in rows if r["deadband"] > 0])


def cells(rows: list[dict], mode: str, passivity: str, measure) -> list[list[list[float]]]:
    """measure over each delay (row) x stiffness (column) cell of one way."""
    return [[[measure(r) for r in rows if r["mode"] == mode and r["passivity"] == passivity
              and r["delay_ms"] == d and r["stiffness_n_per_m"] == k] for k in STIFFNESS_N_PER_M]
            for d in DELAY_MS]


def title(mode: str, passivity: str) -> str:
    return f"{mode.replace('_', ' ')}{' + TDPA' if passivity == 'tdpa' else ''}"


def label_axes(ax, left: bool) -> None:
    ax.set_xticks(range(len(STIFFNESS_N_PER_M)), [f"{k:g}" for k in STIFFNESS_N_PER_M], fontsize=8)
    ax.set_yticks(range(len(DELAY_MS)), [f"{d:g} ms" for d in DELAY_MS])
    ax.set_xlabel("stiffness (N/m)")
    if left:
        ax.set_ylabel("delay each way")


def draw_classes(path: pathlib.Path, rows: list[dict]) -> None:
    """A panel per mode: class by stiffness (columns) x delay (rows), each cell the worst
    class over scene, jitter, loss and speed."""
    colours = np.array([[0.30, 0.69, 0.29], [1.0, 0.75, 0.0], [0.89, 0.10, 0.11], [0.42, 0.24, 0.60]])
    fig, axes = plt.subplots(1, len(MODES), figsize=(16, 4.5), sharey=True)
    for n, (ax, (mode, passivity)) in enumerate(zip(axes, MODES, strict=True)):
        classes = cells(rows, mode, passivity, lambda r: CLASSES.index(r["class"]))
        grid = np.array([[max(c) for c in line] for line in classes])
        ax.imshow(colours[grid], aspect="auto")
        for i, line in enumerate(classes):
            for j, c in enumerate(line):
                ax.text(j, i, f"{sum(x == 0 for x in c) / len(c):.0%}", ha="center", va="center", fontsize=8)
        label_axes(ax, n == 0)
        ax.set_title(title(mode, passivity))
    fig.suptitle("worst class over scene (plate, box edge, moving plate) x jitter x loss x speed (green stable, "
                 "amber limit cycle, red energy growing, purple pop-through); the number: share of stable runs",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def percent(x: float) -> str:
    """A force error as a cell's text: 0 is exact, 1e-16 rounding."""
    return "0" if x == 0 else "<0.01%" if x < 1e-4 else f"{x:.0%}" if x >= 0.995 else f"{x * 100:.2g}%"


def draw_transparency(path: pathlib.Path, rows: list[dict]) -> None:
    """Two rows of a panel per mode over stiffness x delay: the steady force's error against
    the no-delay run (colour and upper number the median over scene, jitter, loss and
    speed, lower the worst), and how deep the device point went (colour and upper number
    the median of the 0.1 m/s runs, lower of the 0.5 m/s ones: the faster hit saturates
    the 8 N device, so the two differ tenfold and a median over both says neither)."""
    slow, fast = SPEED_M_PER_S
    fig, axes = plt.subplots(2, len(MODES), figsize=(17, 9.5), sharey=True)
    for n, (mode, passivity) in enumerate(MODES):
        errors = cells(rows, mode, passivity, lambda r: r["force_error"])
        depth = {v: cells([r for r in rows if r["speed_m_per_s"] == v], mode, passivity,
                          lambda r: r["penetration_m"] * 1000) for v in (slow, fast)}
        panels = (("steady force error", LogNorm(1e-4, 1), "RdYlGn_r",
                   [[(np.median(c), percent(float(np.median(c))), percent(max(c))) for c in line] for line in errors]),
                  (f"penetration (mm), {slow:g} | {fast:g} m/s", LogNorm(0.3, 30), "viridis",
                   [[(np.median(a), f"{np.median(a):.2g}", f"{np.median(b):.2g}") for a, b in zip(la, lb, strict=True)]
                    for la, lb in zip(depth[slow], depth[fast], strict=True)]))
        for row, (name, norm, cmap, values) in enumerate(panels):
            ax = axes[row, n]
            colour = np.array([[v[0] for v in line] for line in values])
            image = ax.imshow(np.clip(colour, norm.vmin, norm.vmax), norm=norm, cmap=cmap, aspect="auto")
            for i, line in enumerate(values):
                for j, (value, upper, lower) in enumerate(line):
                    dark = row == 1 and value < 3
                    ax.text(j, i, f"{upper}\n{lower}", ha="center", va="center", fontsize=7.5,
                            color="white" if dark else "black")
            label_axes(ax, False)
            ax.set_title(title(mode, passivity), fontsize=10)
            if n == 0:
                ax.set_ylabel(f"{name}\n\ndelay each way")
            if n == len(MODES) - 1:
                fig.colorbar(image, ax=axes[row].tolist(), fraction=0.02, pad=0.01)
    fig.suptitle("transparency over scene (plate, box edge, moving plate) x jitter x loss x speed\n"
                 "force error: |F - F_ref| / |F_ref| of the mean force over the last 0.3 s, F_ref the same scene, "
                 "stiffness and speed rendered directly without delay, jitter or loss; colour and upper number the "
                 "median of a cell's 36 runs, lower the worst\npenetration: how deep the device point went beneath "
                 "the face it pressed (the plate's top, through it too; the box's top, then its side); colour and "
                 "upper number the median at 0.1 m/s, lower at 0.5 m/s", fontsize=10)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


def draw_deadband(path: pathlib.Path, rows: list[dict]) -> None:
    """A panel per mode: messages saved against the steady force's change, both against
    the same run without deadband, a point per run; the Weber fraction of each deadband
    as a line of its colour, the aim (80% fewer at 10%) as a shaded corner. A run whose
    undeadbanded twin renders no force (direct + TDPA) is drawn hollow, its change taken
    against the no-delay force instead."""
    colours = {0.05: "#1f77b4", 0.1: "#d62728", 0.2: "#2ca02c"}
    markers = {"plate": "o", "edge": "^"}
    floor = 1e-5  # a change of 0 (the local model on a settled wall) drawn at the axis
    fig, axes = plt.subplots(1, len(MODES), figsize=(17, 5.2), sharey=True)
    for n, (ax, (mode, passivity)) in enumerate(zip(axes, MODES, strict=True)):
        mine = [r for r in rows if r["mode"] == mode and r["passivity"] == passivity]
        ax.add_patch(plt.Rectangle((floor / 2, 0.8), 0.1 - floor / 2, 0.25, color="#d62728", alpha=0.08, lw=0))
        ax.axhline(0.8, color="grey", lw=0.8, ls=":")
        for w, colour in colours.items():
            ax.axvline(w, color=colour, lw=1, ls="--")
            for scene, marker in markers.items():
                for hollow in (False, True):
                    these = [r for r in mine if r["deadband"] == w and r["scene"] == scene
                             and math.isnan(r["deadband_force_error"]) == hollow]
                    x = [max(r["force_error" if hollow else "deadband_force_error"], floor) for r in these]
                    ax.scatter(x, [r["messages_saved"] for r in these],
                               s=[12 + 4 * math.log10(r["stiffness_n_per_m"] / 100) ** 2 for r in these],
                               facecolors="none" if hollow else colour, edgecolors=colour if hollow else "none",
                               marker=marker, alpha=0.6)
        undefined = sum(math.isnan(r["deadband_force_error"]) for r in mine)
        ax.set_xscale("log")
        ax.set_xlim(floor / 2, 3)
        ax.set_ylim(-0.05, 1.02)
        ax.set_xlabel("steady force change vs. deadband 0")
        ax.set_title(title(mode, passivity) + (f"\n(hollow, {undefined} of {len(mine)}: no force without deadband;\n"
                                               "change vs. the no-delay force)" if undefined else ""), fontsize=10)
        if n == 0:
            ax.set_ylabel("messages saved (packets up + down) vs. deadband 0")
        ax.yaxis.set_major_formatter(matplotlib.ticker.PercentFormatter(1))
    handles = [Line2D([], [], color=c, ls="--", label=f"deadband {w:.0%} and its Weber fraction")
               for w, c in colours.items()]
    handles += [Line2D([], [], color="grey", marker=m, ls="", label=s) for s, m in markers.items()]
    handles += [plt.Rectangle((0, 0), 1, 1, color="#d62728", alpha=0.15,
                              label="aim at 10%: >= 80% saved, change < 10%")]
    fig.legend(handles=handles, loc="lower center", ncol=6, frameon=False, fontsize=9)
    fig.suptitle("deadband: a point per run (0.1 m/s, no jitter or loss, stiffness 300-30,000 N/m "
                 "as the marker's size, "
                 "delay 0, 20, 50, 200 ms each way); a change of 0 is drawn at the left edge", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 0.95))
    fig.savefig(path, dpi=100)
    plt.close(fig)

if __name__ == "__main__":
    sys.exit(main())
