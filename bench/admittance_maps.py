"""Stability map of admittance rendering on a UR-like robot (issue 15): where a
position-controlled arm that lags its command bounces on a hard virtual wall, and which
virtual mass and damping the UR bridge defaults to because of it.

Each run is bench/scenarios/admittance_wall.json through hapticd-sim at 500 Hz (the
e-Series' RTDE rate): a hand (0.5 kg, a spring of hand_stiffness N/m and 10 N·s/m)
pulls the robot's tool toward a point 33 mm inside a wall from 50 mm above it, which
presses about 10 N (300 N/m) or 50 N (1500 N/m, a person who stiffens the arm); the
robot follows its pose command as a first-order lag of device.response_time_s (the
servo's lookahead: 0.03 s trails by 34 ms on a real arm, URCL#86). Swept with --set:
response_time_s x virtual_mass x virtual_damping x wall stiffness x hand stiffness.

The classes, from the trace after the first contact (the first that applies wins):
- bounces: the tool leaves the wall again (contact lost) BOUNCE_LOSSES or more times;
- oscillates: in the last 0.5 s the tool's height still swings by more than OSC_M;
- stable: it came to rest on the wall.

    .venv/bin/python bench/admittance_maps.py [--sim build/bin/hapticd-sim] [--out bench/results/admittance]

Writes map.png, runs.csv and prints a markdown summary on stdout.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import pathlib
import subprocess
import tempfile

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the headless backend)

REPO = pathlib.Path(__file__).resolve().parent.parent
SCENARIO = REPO / "bench" / "scenarios" / "admittance_wall.json"
LAGS_S = (0.0, 0.01, 0.03, 0.05, 0.1)
MASSES_KG = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
DAMPINGS = (5.0, 20.0, 50.0, 100.0, 200.0)
WALLS = (1000.0, 5000.0, 20000.0)
HANDS = (300.0, 1500.0)
DURATION_S = 4.0
BOUNCE_LOSSES = 2
OSC_M = 0.0005
CLASSES = ("stable", "oscillates", "bounces")
COLOURS = {"stable": "#4c9f70", "oscillates": "#e0b040", "bounces": "#c8453a"}
# the bridge's defaults (hapticd.ur_bridge.BridgeOptions)
DEFAULT_MASS, DEFAULT_DAMPING = 5.0, 100.0


def run_one(sim: str, trace: pathlib.Path, lag: float, mass: float, damping: float,
            wall: float, hand: float) -> dict:  # fmt: skip
    sets = {
        "duration_s": DURATION_S,
        "device.response_time_s": lag,
        "device.virtual_mass": mass,
        "device.virtual_damping": damping,
        "scene.objects.0.material.stiffness": wall,
        "hand.stiffness": hand,
    }
    command = [sim, str(SCENARIO), "--trace", str(trace)]
    for key, value in sets.items():
        command += ["--set", f"{key}={value}"]
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    summary = json.loads(done.stdout)
    data = np.genfromtxt(trace, delimiter=",", names=True)
    contact = data["contact"] > 0.5
    first = int(np.argmax(contact)) if contact.any() else len(contact)
    after = contact[first:]
    losses = int(np.count_nonzero(after[:-1] & ~after[1:])) if after.size > 1 else 0
    t = data["t"]
    late = data["dev_z"][t >= t[-1] - 0.5]
    swing = float(late.max() - late.min())
    if losses >= BOUNCE_LOSSES:
        verdict = "bounces"
    elif swing > OSC_M or not contact.any():
        verdict = "oscillates"
    else:
        verdict = "stable"
    return {
        "lag_s": lag, "virtual_mass_kg": mass, "virtual_damping": damping, "wall_n_per_m": wall,
        "hand_n_per_m": hand, "class": verdict, "contact_losses": losses, "late_swing_m": swing,
        "max_penetration_m": summary["max_penetration_m"], "max_force_n": summary["max_force_n"],
        "energy_j": summary["energy_j"], "first_contact_s": float(t[first]) if contact.any() else -1.0,
    }  # fmt: skip


def draw(rows: list[dict], path: pathlib.Path, wall: float) -> None:
    """One panel per (hand, lag): mass across, damping up, coloured by class."""
    fig, axes = plt.subplots(len(HANDS), len(LAGS_S), figsize=(3 * len(LAGS_S), 3 * len(HANDS)),
                             sharex=True, sharey=True, squeeze=False)  # fmt: skip
    for (i, hand), (j, lag) in itertools.product(enumerate(HANDS), enumerate(LAGS_S)):
        ax = axes[i][j]
        for r in rows:
            if r["hand_n_per_m"] == hand and r["lag_s"] == lag and r["wall_n_per_m"] == wall:
                x = MASSES_KG.index(r["virtual_mass_kg"])
                y = DAMPINGS.index(r["virtual_damping"])
                ax.add_patch(plt.Rectangle((x - 0.5, y - 0.5), 1, 1, color=COLOURS[r["class"]]))
        ax.plot(MASSES_KG.index(DEFAULT_MASS), DAMPINGS.index(DEFAULT_DAMPING), "k*", markersize=12)
        ax.set_xlim(-0.5, len(MASSES_KG) - 0.5)
        ax.set_ylim(-0.5, len(DAMPINGS) - 0.5)
        ax.set_xticks(range(len(MASSES_KG)), [f"{m:g}" for m in MASSES_KG])
        ax.set_yticks(range(len(DAMPINGS)), [f"{b:g}" for b in DAMPINGS])
        ax.set_title(f"lag {lag * 1e3:.0f} ms, hand {hand:.0f} N/m", fontsize=9)
        if i == len(HANDS) - 1:
            ax.set_xlabel("virtual mass, kg")
        if j == 0:
            ax.set_ylabel("virtual damping, N·s/m")
    handles = [plt.Rectangle((0, 0), 1, 1, color=COLOURS[c]) for c in CLASSES]
    fig.legend(handles, CLASSES, loc="upper right")
    fig.suptitle(f"Admittance on a lagging robot against a {wall:.0f} N/m wall (★ the bridge's default)")
    fig.tight_layout(rect=(0, 0, 0.93, 0.95))
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sim", default=str(REPO / "build" / "bin" / "hapticd-sim"))
    parser.add_argument("--out", type=pathlib.Path, default=REPO / "bench" / "results" / "admittance")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        trace = pathlib.Path(tmp) / "trace.csv"
        for lag, mass, damping, wall, hand in itertools.product(LAGS_S, MASSES_KG, DAMPINGS, WALLS, HANDS):
            rows.append(run_one(args.sim, trace, lag, mass, damping, wall, hand))
    with (args.out / "runs.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    for wall in WALLS:
        draw(rows, args.out / f"map_{wall:.0f}.png", wall)
    # the summary: classes by lag, and by wall stiffness (which the avatar never enters)
    print("| lag ms | " + " | ".join(CLASSES) + " | runs |")
    print("| ---: | " + " | ".join("---:" for _ in CLASSES) + " | ---: |")
    for lag in LAGS_S:
        mine = [r for r in rows if r["lag_s"] == lag]
        counts = [sum(r["class"] == c for r in mine) for c in CLASSES]
        print(f"| {lag * 1e3:.0f} | " + " | ".join(map(str, counts)) + f" | {len(mine)} |")
    print()
    print("| wall N/m | " + " | ".join(CLASSES) + " |")
    print("| ---: | " + " | ".join("---:" for _ in CLASSES) + " |")
    for wall in WALLS:
        mine = [r for r in rows if r["wall_n_per_m"] == wall]
        print(f"| {wall:.0f} | " + " | ".join(str(sum(r['class'] == c for r in mine)) for c in CLASSES) + " |")
    print()
    print("The smallest virtual damping that is stable at every lag, wall and hand, per mass:\n")
    print("| virtual mass kg | least stable damping N·s/m | 20 N push: top speed m/s | time constant s |")
    print("| ---: | ---: | ---: | ---: |")
    for mass in MASSES_KG:
        stable = [b for b in DAMPINGS
                  if all(r["class"] == "stable" for r in rows
                         if r["virtual_mass_kg"] == mass and r["virtual_damping"] == b)]  # fmt: skip
        if stable:
            b = min(stable)
            print(f"| {mass:g} | {b:g} | {(20 - 3) / b:.3f} | {mass / b:.3f} |")
        else:
            print(f"| {mass:g} | none | | |")
    default = [r for r in rows if r["virtual_mass_kg"] == DEFAULT_MASS and r["virtual_damping"] == DEFAULT_DAMPING]
    classes = sorted({r["class"] for r in default})
    print(f"\nThe bridge's default ({DEFAULT_MASS:g} kg, {DEFAULT_DAMPING:g} N·s/m): {', '.join(classes)} "
          f"in all {len(default)} runs; worst penetration "
          f"{max(r['max_penetration_m'] for r in default) * 1e3:.2f} mm.")  # fmt: skip


if __name__ == "__main__":
    main()
