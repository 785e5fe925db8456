"""Reads bench/results/remote/remote_maps.csv (bench/remote_maps.py) against issue 14's
aims and prints the numbers the README quotes:

    .venv/bin/python bench/remote_reading.py [CSV]
"""
from __future__ import annotations

import csv
import pathlib
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent


def main() -> int:
    path = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "bench" / "results" / "remote" / "remote_maps.csv"
    rows = list(csv.DictReader(path.open()))
    for r in rows:
        for key in ("stiffness_n_per_m", "delay_ms", "jitter_ms", "loss", "speed_m_per_s", "deadband", "force_error",
                    "channel_energy_j", "energy_j", "max_penetration_m", "messages_saved"):
            r[key] = float(r[key])
    sweep = [r for r in rows if r["deadband"] == 0 and r["controller"] == "0"]
    controlled = [r for r in rows if r["controller"] == "1"]
    reference = {(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"]): r["class"] for r in sweep
                 if r["mode"] == "direct" and r["passivity"] == "none" and r["delay_ms"] == 0 and r["jitter_ms"] == 0
                 and r["loss"] == 0}
    print("mode                  runs  class as without delay  force error <= 2%  channel > 0  max channel J")
    for mode, passivity in (("direct", "none"), ("direct", "tdpa"), ("local_model", "none"), ("local_model", "tdpa")):
        mine = [r for r in sweep if r["mode"] == mode and r["passivity"] == passivity and r["delay_ms"] > 0]
        same = sum(r["class"] == reference[(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"])] for r in mine)
        close = sum(r["force_error"] <= 0.02 for r in mine)
        positive = sum(r["channel_energy_j"] > 0 for r in mine)
        print(f"{mode + '+' + passivity:20s} {len(mine):5d}  {same / len(mine):21.0%}  {close / len(mine):17.0%}"
              f"  {positive:11d}  {max(r['channel_energy_j'] for r in mine):.3g}")
    print("\naim 1: local model, k >= 5000, 50 ms each way, 20 ms jitter, 10% loss")
    for r in sweep:
        if (r["mode"] == "local_model" and r["passivity"] == "none" and r["stiffness_n_per_m"] >= 5000
                and r["delay_ms"] == 50 and r["jitter_ms"] == 20 and r["loss"] == 0.1):
            ref = reference[(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"])]
            print(f"  {r['scene']:7s} k {r['stiffness_n_per_m']:6g} v {r['speed_m_per_s']:g}: {r['class']:15s} "
                  f"(without delay: {ref:15s}) energy {r['energy_j']:+.4f} J  force error {r['force_error']:.2%}")
    print("\naim 1 with the device's passivity controller (control.passivity)")
    for r in controlled:
        if r["stiffness_n_per_m"] >= 5000:
            ref = reference[(r["scene"], r["stiffness_n_per_m"], r["speed_m_per_s"])]
            print(f"  {r['scene']:7s} k {r['stiffness_n_per_m']:6g} v {r['speed_m_per_s']:g} delay {r['delay_ms']:3g} "
                  f"jitter {r['jitter_ms']:g} loss {r['loss']:g}: {r['class']:15s} energy {r['energy_j']:+.4f} J  "
                  f"force error {r['force_error']:.2%}")
    print("\naim 2: TDPA, every run up to 500 ms each way")
    for mode in ("direct", "local_model"):
        mine = [r for r in sweep if r["mode"] == mode and r["passivity"] == "tdpa"]
        worst = max(mine, key=lambda r: r["channel_energy_j"])
        print(f"  {mode}: {sum(r['channel_energy_j'] > 0 for r in mine)} of {len(mine)} above zero; the largest "
              f"{worst['channel_energy_j']:.3g} J ({worst['scene']}, k {worst['stiffness_n_per_m']:g}, delay "
              f"{worst['delay_ms']:g}, loss {worst['loss']:g}, v {worst['speed_m_per_s']:g})")
    print("\naim 3: deadband (plate, 0.1 m/s): messages saved and the steady force's change, against the same run "
          "without it")
    for r in rows:
        if r["deadband"] > 0:
            base = next(b for b in sweep if b["scene"] == "plate" and b["mode"] == r["mode"] and b["passivity"] == "none"
                        and b["stiffness_n_per_m"] == r["stiffness_n_per_m"] and b["delay_ms"] == r["delay_ms"]
                        and b["jitter_ms"] == 0 and b["loss"] == 0 and b["speed_m_per_s"] == 0.1)
            sent = int(r["packets_up"]) + int(r["packets_down"])
            saved = 1 - sent / (int(base["packets_up"]) + int(base["packets_down"]))
            change = abs(float(r["steady_force_n"]) - float(base["steady_force_n"])) / abs(float(base["steady_force_n"]))
            print(f"  {r['mode']:11s} k {r['stiffness_n_per_m']:6g} delay {r['delay_ms']:3g} w {r['deadband']:.2f}: "
                  f"saved {saved:.1%}, steady force {change:.2%} off ({r['class']}, without: {base['class']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
