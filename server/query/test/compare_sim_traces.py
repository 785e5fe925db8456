#!/usr/bin/env python3
"""Runs haptic scenarios through two hapticd-sim binaries and compares their traces.

    compare_sim_traces.py OLD_SIM NEW_SIM [--stability] [--scenarios DIR ...]

Every scenario (bench/scenarios/*.json and ../shared/scenarios/*.json by default) is run
with --trace by both binaries, and again with each mesh object on the Embree backend;
with --stability, every proxy-method point of bench/stability_maps.py's grid as well.
Every trace column is compared row by row: positions and velocities to 1e-9 (m, m/s),
forces to 1e-6 N, contact and time exactly. Prints the largest difference per column and
exits 1 when any run differs beyond them (or the runs differ in length), 0 otherwise.
"""

from __future__ import annotations

import argparse
import csv
import json
import pathlib
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

REPO = pathlib.Path(__file__).resolve().parents[3]
TOLERANCE = {"dev": 1e-9, "avatar": 1e-9, "f": 1e-6}


def tolerance_of(column: str) -> float:
    """The allowed difference of a trace column (0: exact)."""
    return TOLERANCE.get(column.split("_")[0], 0.0)


def mesh_objects(scenario: pathlib.Path) -> list[int]:
    """Indices of the scenario's mesh objects."""
    objects = json.loads(scenario.read_text())["scene"]["objects"]
    return [i for i, o in enumerate(objects) if o["shape"]["type"] == "mesh"]


def runs(scenario_dirs: list[pathlib.Path], stability: bool) -> list[tuple[str, pathlib.Path, list[str]]]:
    """(name, scenario, --set overrides) of every run to compare."""
    out = []
    for directory in scenario_dirs:
        for scenario in sorted(directory.glob("*.json")):
            out.append((scenario.stem, scenario, []))
            meshes = mesh_objects(scenario)
            if meshes:
                out.append((scenario.stem + "+embree", scenario,
                            [f"scene.objects.{i}.ray_backend=embree" for i in meshes]))
    if stability:
        sys.path.insert(0, str(REPO / "bench"))
        import stability_maps  # noqa: PLC0415 (matplotlib only when asked)
        for spec in stability_maps.build_grid():
            if spec.method == "penalty":
                continue
            name = "stability:" + ",".join(o.split("=")[1] for o in spec.overrides()[1:])
            out.append((name, stability_maps.BASE_SCENARIO, spec.overrides()))
    return out


def trace(sim: str, scenario: pathlib.Path, overrides: list[str], path: pathlib.Path) -> list[list[str]]:
    """The rows of one run's trace (the header first)."""
    args = [sim, str(scenario), "--trace", str(path)]
    for override in overrides:
        args += ["--set", override]
    done = subprocess.run(args, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{sim} failed on {scenario} {overrides}: {done.stderr.strip()}")
    with path.open() as f:
        return list(csv.reader(f))


def compare(old: list[list[str]], new: list[list[str]]) -> tuple[dict[str, float], list[str]]:
    """The largest difference per column, and what exceeds the tolerances."""
    problems = []
    if old[0] != new[0] or len(old) != len(new):
        return {}, [f"header or length differs ({len(old)} against {len(new)} rows)"]
    worst = {column: 0.0 for column in old[0]}
    for row, (a, b) in enumerate(zip(old[1:], new[1:], strict=True), start=1):
        for column, x, y in zip(old[0], a, b, strict=True):
            difference = abs(float(x) - float(y)) if x != y else 0.0
            if difference > worst[column]:
                worst[column] = difference
            if difference > tolerance_of(column) and len(problems) < 5:
                problems.append(f"row {row} {column}: {x} against {y}")
    return worst, problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old_sim")
    parser.add_argument("new_sim")
    parser.add_argument("--stability", action="store_true", help="the stability maps' proxy runs too")
    parser.add_argument("--scenarios", nargs="*", type=pathlib.Path,
                        default=[REPO / "bench" / "scenarios", REPO.parent / "shared" / "scenarios"])
    parser.add_argument("--jobs", type=int, default=2)
    arguments = parser.parse_args()

    todo = runs([d for d in arguments.scenarios if d.is_dir()], arguments.stability)
    worst: dict[str, float] = {}
    failed = 0
    with tempfile.TemporaryDirectory() as scratch:
        def one(item: tuple[int, tuple[str, pathlib.Path, list[str]]]):
            k, (name, scenario, overrides) = item
            old = trace(arguments.old_sim, scenario, overrides, pathlib.Path(scratch) / f"{k}.old.csv")
            new = trace(arguments.new_sim, scenario, overrides, pathlib.Path(scratch) / f"{k}.new.csv")
            return name, len(old) - 1, *compare(old, new)

        with ThreadPoolExecutor(arguments.jobs) as pool:
            for name, rows, differences, problems in pool.map(one, enumerate(todo)):
                for column, difference in differences.items():
                    worst[column] = max(worst.get(column, 0.0), difference)
                if problems:
                    failed += 1
                    print(f"DIFFERS {name}: " + "; ".join(problems))
                elif len(todo) < 50:
                    print(f"same    {name} ({rows} ticks)")
    print(f"{len(todo)} runs, {failed} differ; largest difference per column:")
    print("  " + ", ".join(f"{column} {difference:.3g}" for column, difference in worst.items()))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
