"""Stability maps of the haptic rendering methods (issue 3).

For each force method (penalty, god-object, finger proxy), with the passivity
controller off and on, sweeps plate stiffness x device damping x channel delay x
approach speed x plate thickness through hapticd-sim, classifies every run from its
trace and summary, and writes one heatmap (PNG) and one table (CSV, a row per run) per
method and passivity state:

    .venv/bin/python bench/stability_maps.py [--sim build/bin/hapticd-sim] [--jobs N]
                                             [--out bench/results/stability]

The run. bench/scenarios/stability_base.json: a 200 x 200 mm plate (a box at the
origin, top face at z = h), a 1 kHz impedance device (0.05 kg, 8 N), and a hand
(0.3 kg, 300 N/m, 5 N s/m) whose path starts 30 mm above the contact height and goes
straight down at the approach speed to 10 mm below it, then holds: the person keeps
pressing with about 3 N. The contact height is the plate's top for a point avatar and
h + r for the 5 mm finger sphere (its centre when it touches), so every method is
pressed equally hard. Each run lasts 1.5 s after the path reaches the plate. Every
swept field is passed with --set; `--command` prints the command line that replays one
run.

The classes, from the trace over two windows at the end, late = [T - 0.3, T) and
early = [T - 0.6, T - 0.3) (T the run's end, h the plate's half-thickness, r the
avatar's radius); the first that applies wins:
- pop_through: the avatar (the proxy; for penalty the device point) is ever below the
  plate's far side, avatar_z < -(h + r): the plate failed to hold it.
- energy_growing: the contact oscillates at the end (late peak-to-peak of dev_z above
  OSC_DEV_M or of f_z above OSC_FORCE_N), the oscillation does not decay, and the
  rendering keeps feeding it: its net work on the device over the late window is above
  ENERGY_GROWTH_J, or the peak-to-peak of dev_z grew by GROWTH_RATIO with any net
  work > 0.
- limit_cycle: the contact oscillates at the end and does not decay, but the rendering
  puts in less than that; or the force saturated in more than SATURATED_SHARE of the
  late ticks.
- stable: the contact settled, or its oscillation is decaying (late peak-to-peak below
  DECAY_RATIO x early, for both dev_z and f_z).
"""
from __future__ import annotations

import argparse
import concurrent.futures
import csv
import itertools
import json
import os
import pathlib
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the headless backend)
from matplotlib.colors import ListedColormap  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parent.parent
BASE_SCENARIO = REPO / "bench" / "scenarios" / "stability_base.json"
DEFAULT_SIM = "build/bin/hapticd-sim"  # relative to REPO

# The sweep.
METHODS = (("penalty", "point", 0.0), ("god_object", "point", 0.0), ("finger_proxy", "sphere", 0.005))
PASSIVITY = (False, True)
STIFFNESS_N_PER_M = (300, 1000, 3000, 10000, 30000)
DEVICE_DAMPING_NS_PER_M = (0.05, 0.5, 2)
DELAY_MS = (0, 2, 5, 10, 20, 50)
SPEED_M_PER_S = (0.1, 0.5, 1.0)
THICKNESS_M = (0.001, 0.010)

# The path: from START_ABOVE_M above the contact height down to PRESS_BELOW_M below it,
# then SETTLE_S of holding after the path reaches the plate.
START_ABOVE_M = 0.03
PRESS_BELOW_M = 0.01
SETTLE_S = 1.5

# The classifier's thresholds (see the module comment), judged from the traces:
# - OSC_DEV_M, OSC_FORCE_N: a contact that still moves 0.2 mm or whose force still swings
#   0.5 N (a sixth of the press) 1.2 s after the hit has not settled. The late
#   peak-to-peaks spread continuously over 1e-8..0.06 m and 1e-5..16 N, so these are a
#   judgement, not a gap in the data. The force test is what catches the passivity
#   controller's chatter, which switches the force by 2-6 N and moves the handle < 0.6 mm.
# - ENERGY_GROWTH_J: once the path holds, the hand and the device only dissipate, so an
#   oscillation that survives is fed by the rendering. 1 mJ per 0.3 s is below the
#   kinetic energy of the slowest approach (0.35 kg at 0.1 m/s: 1.75 mJ): a wall that
#   adds more than that each window is an energy source on the scale of the contact.
# - DECAY_RATIO: contacts with the linear damping margin (see the README) lose half of
#   their swing or more per 0.3 s; those within ~10% of the boundary lose less.
WINDOW_S = 0.3
OSC_DEV_M = 2e-4
OSC_FORCE_N = 0.5
GROWTH_RATIO = 1.25
DECAY_RATIO = 0.8
ENERGY_GROWTH_J = 1e-3
SATURATED_SHARE = 0.02
CLASSES = ("stable", "limit_cycle", "energy_growing", "pop_through")


@dataclass(frozen=True)
class RunSpec:
    """One point of the sweep."""
    method: str
    avatar: str
    radius_m: float
    passivity: bool
    stiffness_n_per_m: float
    damping_ns_per_m: float
    delay_ms: float
    speed_m_per_s: float
    thickness_m: float

    def overrides(self) -> list[str]:
        """The --set arguments that turn the base scenario into this run."""
        h = self.thickness_m / 2
        z_contact = h + self.radius_m
        z_start = round(z_contact + START_ABOVE_M, 9)
        z_end = round(z_contact - PRESS_BELOW_M, 9)
        t_reach = round((START_ABOVE_M + PRESS_BELOW_M) / self.speed_m_per_s, 9)
        duration = round(START_ABOVE_M / self.speed_m_per_s + SETTLE_S, 9)
        sets = {
            "duration_s": duration,
            "avatar.method": self.method,
            "avatar.type": self.avatar,
            "avatar.radius": self.radius_m,
            "control.passivity": "true" if self.passivity else "false",
            "scene.objects.0.material.stiffness": self.stiffness_n_per_m,
            "scene.objects.0.shape.half_extents": f"[0.1,0.1,{h:g}]",
            "device.damping": self.damping_ns_per_m,
            "device.start": f"[0,0,{z_start:g}]",
            "channel.delay_ms": self.delay_ms,
            "hand.path": f"[[0,0,0,{z_start:g}],[{t_reach:g},0,0,{z_end:g}]]",
        }
        return [f"{key}={value:g}" if isinstance(value, float) else f"{key}={value}"
                for key, value in sets.items()]

    def command(self, sim: str) -> str:
        """The shell command that replays this run, with a trace."""
        sets = " ".join(f"--set {shlex.quote(o)}" for o in self.overrides())
        return f"{sim} {BASE_SCENARIO.relative_to(REPO)} --trace /tmp/run.csv {sets}"

    def label(self) -> str:
        """The map this run belongs to, e.g. god_object_passivity_on."""
        return f"{self.method}_passivity_{'on' if self.passivity else 'off'}"


def build_grid() -> list[RunSpec]:
    """Every run, map by map."""
    return [RunSpec(method, avatar, radius, passivity, k, b, delay, speed, thickness)
            for (method, avatar, radius), passivity, k, b, delay, speed, thickness in itertools.product(
                METHODS, PASSIVITY, STIFFNESS_N_PER_M, DEVICE_DAMPING_NS_PER_M, DELAY_MS,
                SPEED_M_PER_S, THICKNESS_M)]


def find_run(columns: list[str]) -> RunSpec:
    """The grid's run with these CSV values (method, passivity 0/1, k, b, delay, speed,
    thickness); exits with a message naming the values when there is none."""
    method, passivity, *numbers = columns
    values = [float(v) for v in numbers]
    for spec in build_grid():
        if (spec.method == method and int(spec.passivity) == int(passivity)
                and [spec.stiffness_n_per_m, spec.damping_ns_per_m, spec.delay_ms, spec.speed_m_per_s,
                     spec.thickness_m] == values):
            return spec
    sys.exit(f"no run with method={method} passivity={passivity} k, b, delay, speed, thickness = {numbers}")


def read_trace(path: pathlib.Path) -> dict[str, np.ndarray]:
    """The trace CSV as columns by name (extra columns are kept too)."""
    with path.open() as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}


def peak_to_peak(x: np.ndarray) -> float:
    """max - min, 0 for an empty window."""
    return float(np.ptp(x)) if x.size else 0.0


def classify(trace: dict[str, np.ndarray], summary: dict, half_thickness_m: float,
             radius_m: float, max_force_n: float) -> dict:
    """Measures one run's trace and gives its class (see the module comment)."""
    t, dev_z, f_z = trace["t"], trace["dev_z"], trace["f_z"]
    end = t[-1] + (t[1] - t[0])
    late = t >= end - WINDOW_S
    early = (t >= end - 2 * WINDOW_S) & ~late
    # the rendered work per tick, F_k . (x_k+1 - x_k), over the late window
    dev = np.stack([trace["dev_x"], trace["dev_y"], dev_z], axis=1)
    force = np.stack([trace["f_x"], trace["f_y"], f_z], axis=1)
    work = np.einsum("ij,ij->i", force[:-1], np.diff(dev, axis=0))
    force_norm = np.linalg.norm(force, axis=1)
    measures = {
        "min_avatar_z_m": float(trace["avatar_z"].min()),
        "osc_dev_late_m": peak_to_peak(dev_z[late]),
        "osc_dev_early_m": peak_to_peak(dev_z[early]),
        "osc_force_late_n": peak_to_peak(f_z[late]),
        "osc_force_early_n": peak_to_peak(f_z[early]),
        "saturated_share_late": float(np.mean(force_norm[late] >= 0.999 * max_force_n)),
        "energy_late_j": float(work[late[:-1]].sum()),
        "contact_ticks": int(summary.get("contact_ticks", int(trace["contact"].sum()))),
    }
    dev_late, dev_early = measures["osc_dev_late_m"], measures["osc_dev_early_m"]
    force_late, force_early = measures["osc_force_late_n"], measures["osc_force_early_n"]
    oscillating = dev_late > OSC_DEV_M or force_late > OSC_FORCE_N
    # growth is judged on the motion: a switching force's peak-to-peak varies by itself
    growing = dev_late > OSC_DEV_M and dev_late > GROWTH_RATIO * dev_early
    decaying = dev_late < DECAY_RATIO * dev_early and force_late < DECAY_RATIO * force_early
    # precedence: pop-through > energy growing > limit cycle > stable
    if measures["min_avatar_z_m"] < -(half_thickness_m + radius_m):
        kind = "pop_through"
    elif oscillating and not decaying and ((growing and measures["energy_late_j"] > 0)
                                           or measures["energy_late_j"] > ENERGY_GROWTH_J):
        kind = "energy_growing"
    elif (oscillating and not decaying) or measures["saturated_share_late"] > SATURATED_SHARE:
        kind = "limit_cycle"
    else:
        kind = "stable"
    return {"class": kind, **measures}


def run_one(spec: RunSpec, sim: str, trace_dir: str, index: int, max_force_n: float) -> dict:
    """Runs one sim, classifies it and returns the CSV row."""
    trace_path = pathlib.Path(trace_dir) / f"run{index}.csv"
    args = [sim, str(BASE_SCENARIO), "--trace", str(trace_path)]
    for override in spec.overrides():
        args += ["--set", override]
    done = subprocess.run(args, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"hapticd-sim failed ({done.returncode}) for {spec}: {done.stderr.strip()}")
    summary = json.loads(done.stdout)
    result = classify(read_trace(trace_path), summary, spec.thickness_m / 2, spec.radius_m, max_force_n)
    trace_path.unlink()
    return {
        "method": spec.method, "passivity": int(spec.passivity),
        "stiffness_n_per_m": spec.stiffness_n_per_m, "device_damping_ns_per_m": spec.damping_ns_per_m,
        "delay_ms": spec.delay_ms, "speed_m_per_s": spec.speed_m_per_s, "thickness_m": spec.thickness_m,
        **result,
        "energy_j": summary["energy_j"], "observed_energy_j": summary.get("observed_energy_j", ""),
        "max_penetration_m": summary["max_penetration_m"],
        "max_proxy_penetration_m": summary.get("max_proxy_penetration_m", ""),
        "max_force_n": summary["max_force_n"],
        "force_saturations": summary.get("force_saturations", ""),
        "passivity_activations": summary.get("passivity_activations", ""),
        "final_avatar_z_m": summary["final_avatar"][2] if "final_avatar" in summary else "",
    }


def write_csv(path: pathlib.Path, rows: list[dict]) -> None:
    """One row per run, floats to 6 significant digits."""
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})


def draw_map(path: pathlib.Path, label: str, rows: list[dict]) -> None:
    """One figure: a panel per plate thickness; columns stiffness x damping, rows delay x speed."""
    colours = ("#4daf4a", "#ffbf00", "#e41a1c", "#6a3d9a")  # stable, limit cycle, growing, pop
    names = ("stable", "limit cycle", "energy growing", "pop-through")
    by_key = {(r["thickness_m"], r["stiffness_n_per_m"], r["device_damping_ns_per_m"], r["delay_ms"],
               r["speed_m_per_s"]): CLASSES.index(r["class"]) for r in rows}
    columns = list(itertools.product(STIFFNESS_N_PER_M, DEVICE_DAMPING_NS_PER_M))
    lines = list(itertools.product(DELAY_MS, SPEED_M_PER_S))

    fig, axes = plt.subplots(1, len(THICKNESS_M), figsize=(15, 8.5), sharey=True)
    for ax, thickness in zip(axes, THICKNESS_M, strict=True):
        grid = np.array([[by_key[(thickness, k, b, d, v)] for k, b in columns] for d, v in lines])
        ax.imshow(grid, cmap=ListedColormap(colours), vmin=-0.5, vmax=3.5, aspect="auto")
        # group separators and two-level tick labels
        for i in range(1, len(STIFFNESS_N_PER_M)):
            ax.axvline(i * len(DEVICE_DAMPING_NS_PER_M) - 0.5, color="white", lw=3)
        for i in range(1, len(DELAY_MS)):
            ax.axhline(i * len(SPEED_M_PER_S) - 0.5, color="white", lw=3)
        ax.set_xticks(range(len(columns)), [f"{b:g}" for _, b in columns], fontsize=8)
        ax.set_yticks(range(len(lines)), [f"{v:g} m/s" for _, v in lines], fontsize=8)
        for i, k in enumerate(STIFFNESS_N_PER_M):
            ax.text((i + 0.5) * len(DEVICE_DAMPING_NS_PER_M) - 0.5, -0.9, f"k = {k:g} N/m",
                    ha="center", va="bottom", fontsize=9, fontweight="bold")
        ax.set_xlabel("device damping b (N·s/m), grouped by plate stiffness k")
        ax.set_title(f"plate {thickness * 1000:g} mm thick", pad=22)
    for i, d in enumerate(DELAY_MS):
        axes[0].text(-0.17, (i + 0.5) * len(SPEED_M_PER_S) - 0.5, f"delay\n{d:g} ms", ha="center",
                     va="center", fontsize=9, fontweight="bold", transform=axes[0].get_yaxis_transform())
    axes[0].set_ylabel("approach speed, grouped by channel delay (each way)", labelpad=62)
    method, passivity = label.split("_passivity_")
    fig.suptitle(f"{method.replace('_', ' ')}, passivity controller {passivity}: "
                 "class of each run (press with ~3 N on a plate, 1 kHz, 8 N device)", fontsize=12)
    fig.legend(handles=[Patch(color=c, label=n) for c, n in zip(colours, names, strict=True)], loc="lower center",
               ncol=4, frameon=False)
    fig.tight_layout(rect=(0.03, 0.05, 1, 0.96))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sim", help="the hapticd-sim binary (default: the repository's "
                                      "build/bin/hapticd-sim)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="sims run at once")
    parser.add_argument("--out", default=str(REPO / "bench" / "results" / "stability"),
                        help="where the PNGs and CSVs go")
    parser.add_argument("--command", nargs=7, metavar=("METHOD", "PASSIVITY", "K", "B", "DELAY_MS",
                                                        "SPEED", "THICKNESS"),
                        help="print the hapticd-sim command of one run (a CSV row's first seven "
                             "columns, e.g. god_object 1 30000 0.05 20 0.5 0.001) and exit")
    args = parser.parse_args()
    sim = os.path.abspath(args.sim) if args.sim else str(REPO / DEFAULT_SIM)
    if args.command:
        # the command runs from the repository's root
        print(find_run(args.command).command(sim if args.sim else DEFAULT_SIM))
        return 0
    if not os.access(sim, os.X_OK):
        sys.exit(f"no hapticd-sim at {sim}: build it (bash deploy/build.sh) or pass --sim PATH")

    base = json.loads(BASE_SCENARIO.read_text())
    max_force_n = float(base["device"]["max_force"])
    grid = build_grid()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    # run every sim, in parallel processes (each also parses its own trace)
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="stability_maps_") as trace_dir, \
            concurrent.futures.ProcessPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(run_one, grid, itertools.repeat(sim), itertools.repeat(trace_dir),
                             range(len(grid)), itertools.repeat(max_force_n), chunksize=8))
    elapsed = time.monotonic() - start

    # one CSV and one map per method and passivity state, and the counts
    print(f"{len(rows)} runs in {elapsed:.1f} s with {args.jobs} jobs")
    print(f"{'map':28s} " + " ".join(f"{c:>15s}" for c in CLASSES))
    for spec_label in dict.fromkeys(spec.label() for spec in grid):
        mine = [row for spec, row in zip(grid, rows, strict=True) if spec.label() == spec_label]
        write_csv(out / f"{spec_label}.csv", mine)
        draw_map(out / f"{spec_label}.png", spec_label, mine)
        counts = [sum(row["class"] == c for row in mine) for c in CLASSES]
        print(f"{spec_label:28s} " + " ".join(f"{n:15d}" for n in counts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
