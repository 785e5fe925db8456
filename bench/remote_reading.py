"""Reads bench/results/remote/remote_maps.csv (bench/remote_maps.py) against issue 14's
aims and prints the numbers the README quotes:

    .venv/bin/python bench/remote_reading.py [CSV]
"""
from __future__ import annotations

import csv
import math
import pathlib
import statistics
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent
MODES = (("direct", "none"), ("direct", "tdpa"), ("local_model", "none"), ("local_model", "tdpa"))
SCENES = ("plate", "edge", "moving")
NUMBERS = ("stiffness_n_per_m", "delay_ms", "jitter_ms", "loss", "speed_m_per_s", "deadband", "force_error",
           "channel_energy_j", "energy_j", "surface_energy_j", "penetration_m", "max_penetration_m", "messages_saved",
           "deadband_force_error", "device_damping_ns_per_m", "steady_force_n", "packets_up", "packets_down",
           "sim_s", "model_blends", "max_model_radius_m", "ticks_outside_model")
BASE_DAMPING = 0.5
# A channel energy this close to zero is the rounding of sums of a few hundredths of a joule.
ROUNDING_J = 1e-15


def load(path: pathlib.Path) -> list[dict]:
    rows = list(csv.DictReader(path.open()))
    for r in rows:
        for key in NUMBERS:
            r[key] = float(r[key]) if r[key] != "" else math.nan
        r["controller"] = r["controller"] == "1"
    return rows


def name(mode: str, passivity: str) -> str:
    return mode.replace("_", " ") + (" + TDPA" if passivity == "tdpa" else "")


def verdict(met: bool) -> str:
    return "MET" if met else "MISSED"


def aim_a_runs(sweep: list[dict], passivity: str) -> list[dict]:
    """The local-model runs aim (a) names: k >= 5000 N/m, 50 ms each way, 20 ms jitter, 10% loss."""
    return [r for r in sweep if r["mode"] == "local_model" and r["passivity"] == passivity
            and r["stiffness_n_per_m"] >= 5000 and r["delay_ms"] == 50 and r["jitter_ms"] == 20 and r["loss"] == 0.1]


def print_aim_a_verdict(label: str, mine: list[dict]) -> None:
    """Whether runs are all stable, passive (in the surface's frame) and within 2% of the force."""
    stable = sum(r["class"] == "stable" for r in mine)
    passive = sum(r["surface_energy_j"] <= 0 for r in mine)
    close = sum(r["force_error"] <= 0.02 for r in mine)
    worst = max(r["force_error"] for r in mine)
    print(f"  {label}: stable {stable}/{len(mine)}, passive {passive}/{len(mine)}, "
          f"force within 2% {close}/{len(mine)} (worst {worst:.2%}) -> "
          f"{verdict(stable == passive == close == len(mine))}")


def main() -> int:
    path = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "bench" / "results" / "remote" / "remote_maps.csv"
    rows = load(path)
    plain = [r for r in rows if not r["controller"] and r["device_damping_ns_per_m"] == BASE_DAMPING]
    sweep = [r for r in plain if r["scene"] in SCENES and r["deadband"] == 0]
    reference = {(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"]): r for r in sweep
                 if r["mode"] == "direct" and r["passivity"] == "none" and r["delay_ms"] == 0 and r["jitter_ms"] == 0
                 and r["loss"] == 0}

    def ref(r: dict) -> dict:
        return reference[(r["scene"].replace("edge_mesh", "edge"), r["stiffness_n_per_m"], r["speed_m_per_s"])]

    print(f"{len(rows)} runs, {sum(r['sim_s'] for r in rows):.0f} s in the simulator")
    print("\n| way (runs with delay > 0) | runs | class as without delay | steady force within 2% | penetration, mm: "
          "median at 0.1 / 0.5 m/s (worst) | channel energy > 0 | largest |")
    print("|---|---|---|---|---|---|---|")
    for mode, passivity in MODES:
        mine = [r for r in sweep if r["mode"] == mode and r["passivity"] == passivity and r["delay_ms"] > 0]
        same = sum(r["class"] == ref(r)["class"] for r in mine)
        close = sum(r["force_error"] <= 0.02 for r in mine)
        depth = {v: [r["penetration_m"] * 1000 for r in mine if r["speed_m_per_s"] == v] for v in (0.1, 0.5)}
        positive = sum(r["channel_energy_j"] > 0 for r in mine)
        print(f"| {name(mode, passivity)} | {len(mine)} | {same / len(mine):.0%} | {close / len(mine):.0%} | "
              f"{statistics.median(depth[0.1]):.2g} / {statistics.median(depth[0.5]):.2g} "
              f"({max(depth[0.5] + depth[0.1]):.2g})"
              f" | {positive} | "
              f"{max(r['channel_energy_j'] for r in mine):.2g} J |")
    print("\nthe same by scene: class as without delay / force within 2% / penetration median (mm)")
    for mode, passivity in MODES:
        parts = []
        for scene in SCENES:
            mine = [r for r in sweep if r["mode"] == mode and r["passivity"] == passivity and r["delay_ms"] > 0
                    and r["scene"] == scene]
            same = sum(r["class"] == ref(r)["class"] for r in mine) / len(mine)
            close = sum(r["force_error"] <= 0.02 for r in mine) / len(mine)
            parts.append(f"{scene} {same:.0%} / {close:.0%} / "
                         f"{statistics.median(r['penetration_m'] for r in mine) * 1e3:.2g}")
        print(f"  {name(mode, passivity):20s} " + "; ".join(parts))

    def reference_depth_mm(scene: str, speed: float) -> float:
        """The no-delay reference's median penetration (mm) on a scene at a speed."""
        return statistics.median(r["penetration_m"] for r in reference.values()
                                 if r["scene"] == scene and r["speed_m_per_s"] == speed) * 1e3

    print("\nthe no-delay reference (direct): penetration median at 0.1 / 0.5 m/s, mm: " + ", ".join(
        f"{s} " + " / ".join(f"{reference_depth_mm(s, v):.2g}" for v in (0.1, 0.5))
        for s in SCENES))
    print("classes of the no-delay reference (scene, k, v): " + "; ".join(
        f"{s} {k:g} {v:g} {r['class']}" for (s, k, v), r in sorted(reference.items()) if r["class"] != "stable"))

    print("\n# aim (a): local model, k >= 5000, 50 ms each way, 20 ms jitter, 10% loss: stable, passive, "
          "force within 2%")
    print("  (energy: the rendered work in the surface's frame, surface_energy_j; energy_j on the plate and edge)")
    aim = aim_a_runs(sweep, "none")
    for r in sorted(aim, key=lambda r: (r["stiffness_n_per_m"], SCENES.index(r["scene"]), r["speed_m_per_s"])):
        base = ref(r)
        print(f"  {r['scene']:7s} k {r['stiffness_n_per_m']:6g} v {r['speed_m_per_s']:g}: {r['class']:15s} "
              f"(no delay: {base['class']:15s}) energy {r['surface_energy_j'] * 1e3:+8.3f} mJ (no delay "
              f"{base['surface_energy_j'] * 1e3:+8.3f} mJ, "
              f"the channel adds {(r['surface_energy_j'] - base['surface_energy_j']) * 1e3:+.4f}) "
              f"force error {r['force_error']:.2%}")
    for k in (5000, 10000, 30000):
        mine = [r for r in aim if r["stiffness_n_per_m"] == k]
        stable = sum(r["class"] == "stable" for r in mine)
        passive = sum(r["surface_energy_j"] <= 0 for r in mine)
        close = sum(r["force_error"] <= 0.02 for r in mine)
        added = max(abs(r["surface_energy_j"] - ref(r)["surface_energy_j"]) for r in mine)
        ref_passive = sum(ref(r)["surface_energy_j"] <= 0 for r in mine)
        print(f"  k {k}: stable {stable}/{len(mine)}, passive {passive}/{len(mine)} (no-delay runs passive "
              f"{ref_passive}/{len(mine)}), force within 2% {close}/{len(mine)}, largest energy the channel adds "
              f"{added:.2g} J -> {verdict(stable == passive == close == len(mine))}")
    print("  Colgate: 1 kHz, b > K T / 2 = 2.5 N s/m at 5000 N/m; the device has 0.5 N s/m")
    print("\n  local model + TDPA (the device's port a one-port on its rendering, remote/channel_ends.h):")
    guarded = aim_a_runs(sweep, "tdpa")
    for r in sorted(guarded, key=lambda r: (r["stiffness_n_per_m"], SCENES.index(r["scene"]), r["speed_m_per_s"])):
        print(f"  {r['scene']:7s} k {r['stiffness_n_per_m']:6g} v {r['speed_m_per_s']:g}: {r['class']:15s} "
              f"energy {r['surface_energy_j'] * 1e3:+8.3f} mJ  channel {r['channel_energy_j'] * 1e3:+.4f} mJ  "
              f"force error {r['force_error']:.2%}  penetration {r['penetration_m'] * 1e3:.2f} mm "
              f"(no delay, direct: {ref(r)['penetration_m'] * 1e3:.2f})")
    for k in (5000, 10000, 30000):
        print_aim_a_verdict(f"local model + TDPA, k {k}, 50 ms/20 ms/10%",
                            [r for r in guarded if r["stiffness_n_per_m"] == k])
    print("\n  with the device's own passivity controller (control.passivity):")
    controlled = [r for r in rows if r["controller"] and r["stiffness_n_per_m"] >= 5000]
    for r in sorted(controlled, key=lambda r: (r["stiffness_n_per_m"], r["delay_ms"], SCENES.index(r["scene"]),
                                                r["speed_m_per_s"])):
        print(f"  {r['scene']:7s} k {r['stiffness_n_per_m']:6g} v {r['speed_m_per_s']:g} delay {r['delay_ms']:3g} "
              f"jitter {r['jitter_ms']:g} loss {r['loss']:g}: {r['class']:15s} "
              f"energy {r['surface_energy_j'] * 1e3:+8.3f} mJ  "
              f"force error {r['force_error']:.2%}")
    for k in (5000, 10000, 30000):
        print_aim_a_verdict(f"controller, k {k}, 50 ms/20 ms/10%",
                            [r for r in controlled if r["stiffness_n_per_m"] == k and r["delay_ms"] == 50])
    print("\n  with Colgate's damping (device damping 1.2 K T / 2), no controller:")
    damped = [r for r in rows if r["device_damping_ns_per_m"] != BASE_DAMPING]
    for r in sorted(damped, key=lambda r: (r["stiffness_n_per_m"], SCENES.index(r["scene"]), r["speed_m_per_s"],
                                            r["delay_ms"])):
        twin = next((t for t in damped if t["scene"] == r["scene"] and t["stiffness_n_per_m"] == r["stiffness_n_per_m"]
                     and t["speed_m_per_s"] == r["speed_m_per_s"] and t["mode"] == "direct"), None)
        added = (f", the channel adds {(r['surface_energy_j'] - twin['surface_energy_j']) * 1e3:+.4f} mJ"
                 if r["mode"] != "direct" else "")
        print(f"  {r['scene']:7s} k {r['stiffness_n_per_m']:6g} b {r['device_damping_ns_per_m']:g} v "
              f"{r['speed_m_per_s']:g} {r['mode']:11s} delay {r['delay_ms']:2g}: {r['class']:15s} energy "
              f"{r['surface_energy_j'] * 1e3:+8.3f} mJ{added}, force error vs. b 0.5 {r['force_error']:.2%}")

    print("\n# aim (b): TDPA, channel energy <= 0 in every run up to 500 ms each way")
    for mode in ("direct", "local_model"):
        mine = [r for r in sweep if r["mode"] == mode and r["passivity"] == "tdpa"]
        above = [r for r in mine if r["channel_energy_j"] > 0]
        real = [r for r in above if r["channel_energy_j"] > ROUNDING_J]
        print(f"  {mode}: {len(above)} of {len(mine)} above zero, {len(real)} by more than {ROUNDING_J:g} J"
              f" -> {verdict(not real)}")
        for r in sorted(above, key=lambda r: -r["channel_energy_j"]):
            print(f"    {r['channel_energy_j']:.3g} J: {r['scene']}, k {r['stiffness_n_per_m']:g}, delay "
                  f"{r['delay_ms']:g}, jitter {r['jitter_ms']:g}, loss {r['loss']:g}, v {r['speed_m_per_s']:g}, "
                  f"{r['class']}")
    with_deadband = [r for r in plain if r["passivity"] == "tdpa" and r["deadband"] > 0]
    above = [r for r in with_deadband if r["channel_energy_j"] > ROUNDING_J]
    print(f"  TDPA with a deadband: {len(above)} of {len(with_deadband)} above {ROUNDING_J:g} J")
    for r in sorted(above, key=lambda r: -r["channel_energy_j"]):
        print(f"    {r['channel_energy_j']:.3g} J: {r['mode']}, {r['scene']}, k {r['stiffness_n_per_m']:g}, delay "
              f"{r['delay_ms']:g}, deadband {r['deadband']:g}")

    print("\n# aim (c): deadband 10%: >= 80% fewer messages with the force change under 10%")
    banded = [r for r in plain if r["deadband"] > 0]
    for w in (0.05, 0.1, 0.2):
        print(f"  deadband {w:.0%}:")
        for mode, passivity in MODES:
            mine = [r for r in banded if r["mode"] == mode and r["passivity"] == passivity and r["deadband"] == w]
            defined = [r for r in mine if not math.isnan(r["deadband_force_error"])]
            saved = [r["messages_saved"] for r in mine]
            both = sum(r["messages_saved"] >= 0.8 and r["deadband_force_error"] < w for r in defined)
            under = sum(r["deadband_force_error"] < w for r in defined)
            enough = sum(r["messages_saved"] >= 0.8 for r in mine)
            print(f"    {name(mode, passivity):20s} saved median {statistics.median(saved):.0%} "
                  f"({min(saved):.0%}..{max(saved):.0%}); >= 80% saved {enough}/{len(mine)}; change < {w:.0%} "
                  f"{under}/{len(defined)}; both {both}/{len(defined)}"
                  + (f" ({len(mine) - len(defined)} render no force without it)" if len(defined) < len(mine) else ""))
    print("  deadband 10% by way and stiffness (both met / runs: delay 0, 20, 50, 200 x plate, edge)")
    for mode, passivity in MODES:
        parts = []
        for k in sorted({r["stiffness_n_per_m"] for r in banded}):
            mine = [r for r in banded if r["mode"] == mode and r["passivity"] == passivity and r["deadband"] == 0.1
                    and r["stiffness_n_per_m"] == k and not math.isnan(r["deadband_force_error"])]
            both = sum(r["messages_saved"] >= 0.8 and r["deadband_force_error"] < 0.1 for r in mine)
            parts.append(f"{k:g}: {both}/{len(mine)}")
        print(f"    {name(mode, passivity):20s} " + ", ".join(parts))
    print("  deadband 10%, the misses:")
    for r in banded:
        if r["deadband"] == 0.1 and not math.isnan(r["deadband_force_error"]) and not (
                r["messages_saved"] >= 0.8 and r["deadband_force_error"] < 0.1):
            print(f"    {name(r['mode'], r['passivity']):20s} {r['scene']:5s} k {r['stiffness_n_per_m']:6g} delay "
                  f"{r['delay_ms']:3g}: saved {r['messages_saved']:.0%}, change {r['deadband_force_error']:.1%} "
                  f"({r['class']})")

    print("\n# the edge as a tiled mesh (768 triangles) against the primitive box, same runs")
    mesh = [r for r in rows if r["scene"] == "edge_mesh"]
    for r in mesh:
        twin = next(t for t in sweep if t["scene"] == "edge" and all(
            t[k] == r[k] for k in ("mode", "passivity", "stiffness_n_per_m", "delay_ms", "jitter_ms", "loss",
                                   "speed_m_per_s")))
        print(f"  {name(r['mode'], r['passivity']):20s} k {r['stiffness_n_per_m']:6g} delay {r['delay_ms']:3g}: "
              f"{r['class']:15s} (box {twin['class']:15s}) steady force {r['steady_force_n']:.4f} N (box "
              f"{twin['steady_force_n']:.4f}), energy {r['energy_j'] * 1e3:+.3f} mJ "
              f"(box {twin['energy_j'] * 1e3:+.3f}), "
              f"blends {r['model_blends']:g}, outside model {r['ticks_outside_model']:g}, {r['sim_s']:.2f} s "
              f"(box {twin['sim_s']:.3f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
