"""The speed-accuracy chart: hapticd's rows and the peers' on one chart, and its reading.

Merges the CSVs of ``speed_accuracy`` (hapticd) and ``speed_accuracy_peers.py`` (coal,
python-fcl, embreex), plots time per query (x, log) against the largest error versus
the analytic truth (y, log), one panel per query, and writes beside the chart a short
reading: which representation renders a tolerance at the lowest cost, whether the
scene's own choice (``choices.csv``) follows that rule, and whether hapticd's fastest
exact path is at or ahead of every peer at equal accuracy.

    python bench/speed_accuracy_chart.py WORK_DIR [--results bench/results] [--machine TEXT]

Times are shown net of ``overhead_ns``, what the same call costs on a trivial input: the
peers' Python call on their cheapest pair (distances) or on rays that miss Embree's root
box (embreex), and hapticd's first hits on segments that miss their first box, so that
both sides' first hits are net of the same fixed cost per call. The raw time is the end
of the thin line to the right of such a marker.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import matplotlib
from matplotlib.artist import Artist
from matplotlib.lines import Line2D

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from speed_accuracy_reading import write_reading  # noqa: E402
from speed_accuracy_results import Row, pareto_front, read_choices, read_rows, write_rows  # noqa: E402

QUERIES = {
    "closest_point": "closest point (distance error, m)",
    "first_hit": "first hit of a segment (hit point error, m)",
    "force_point": "point avatar, god-object (force error, N)",
    "force_sphere": "sphere avatar 5 mm, finger proxy (force error, N)",
}
# Errors below this are plotted on it (an exact answer can err by 0).
ERROR_FLOOR = 1e-18


def series_label(series: tuple[str, str, str]) -> str:
    implementation, representation, backend = series
    names = {
        ("hapticd", "primitive", "native"): "hapticd: analytic primitive",
        ("hapticd", "hull", "native"): "hapticd: convex hull",
        ("hapticd", "mesh", "native"): "hapticd: mesh, native BVH",
        ("hapticd", "mesh", "embree"): "hapticd: mesh, Embree backend (exact)",
        ("hapticd", "mesh", "embree_raw"): "raw Embree 3 in hapticd (float, unconfirmed)",
        ("coal", "primitive", "shape"): "coal: sphere primitive",
        ("coal", "mesh", "bvh_obbrss"): "coal: mesh, OBBRSS BVH",
        ("python-fcl", "primitive", "shape"): "python-fcl: sphere primitive",
        ("python-fcl", "mesh", "bvh_obbrss"): "python-fcl: mesh, OBBRSS BVH",
        ("embreex", "mesh", "embree4_float"): "embreex: mesh (Embree 4, float)",
    }
    return names.get(series, " ".join(series))


def plot(rows: list[Row], path: Path, machine: str) -> None:
    all_series = sorted({r.series for r in rows}, key=lambda s: (s[0] != "hapticd", s))
    colors = plt.get_cmap("tab10")
    markers = "os^DvP*Xhp<>"
    style = {s: (colors(i % 10), markers[i % len(markers)]) for i, s in enumerate(all_series)}
    figure, axes = plt.subplots(2, 2, figsize=(15, 11))
    handles: dict[str, Artist] = {}
    for axis, (query, title) in zip(axes.flat, QUERIES.items(), strict=True):
        for surface, line_style in (("sphere", "-"), ("torus", "--")):
            chosen = [r for r in rows if r.query == query and r.surface == surface]
            for series in all_series:
                points = sorted((r for r in chosen if r.series == series), key=lambda r: r.level)
                if not points:
                    continue
                color, marker = style[series]
                xs = [r.net_time_ns for r in points]
                ys = [max(r.error_max, ERROR_FLOOR) for r in points]
                face = color if surface == "sphere" else "none"
                (handle,) = axis.plot(
                    xs,
                    ys,
                    line_style,
                    color=color,
                    marker=marker,
                    markerfacecolor=face,
                    markersize=7,
                    linewidth=1,
                    alpha=0.9,
                )
                handles.setdefault(series_label(series), handle)
                for r, x, y in zip(points, xs, ys, strict=True):
                    if r.overhead_ns > 0:
                        axis.plot(
                            [x, r.time_ns], [y, y], "-", color=color, linewidth=0.6, alpha=0.5
                        )
            front = pareto_front([(r.net_time_ns, max(r.error_max, ERROR_FLOOR)) for r in chosen])
            if front:
                (handle,) = axis.step(
                    [time_ns for time_ns, _ in front],
                    [error for _, error in front],
                    where="post",
                    color="black",
                    linestyle=line_style,
                    linewidth=2.2,
                    alpha=0.35,
                )
                handles.setdefault(f"Pareto front ({surface})", handle)
                # ring the front's members (a front of one point draws no line)
                axis.plot(
                    [time_ns for time_ns, _ in front],
                    [error for _, error in front],
                    "o",
                    markersize=14,
                    markerfacecolor="none",
                    markeredgecolor="black",
                    alpha=0.35,
                )
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_title(title)
        axis.set_xlabel("time per query, ns (net of a trivial call; thin line: raw)")
        axis.set_ylabel("largest error vs analytic truth")
        axis.grid(True, which="major", alpha=0.3)
    # the surfaces, told apart by fill and line
    handles["sphere: filled markers, solid lines"] = Line2D([], [], color="gray", marker="o")
    handles["torus: hollow markers, dashed lines"] = Line2D(
        [], [], color="gray", marker="o", markerfacecolor="none", linestyle="--"
    )
    figure.legend(
        list(handles.values()),
        list(handles),
        loc="lower center",
        ncol=4,
        fontsize=9,
        frameon=False,
    )
    figure.suptitle(
        "hapticd speed against accuracy: sphere R = 50 mm, torus R = 50 mm r = 20 mm; "
        "points along a series = tessellation levels (80 .. 1.3M triangles)\n" + machine,
        fontsize=11,
    )
    figure.tight_layout(rect=(0, 0.09, 1, 0.95))
    figure.savefig(path, dpi=100)
    plt.close(figure)


def embree_force_calls(repo: Path) -> list[str]:
    """The embree:: functions the force library calls (what its Embree backend uses)."""
    calls: set[str] = set()
    for source in sorted((repo / "server" / "force").glob("*.cc")):
        calls.update(re.findall(r"embree::(\w+)\(", source.read_text()))
    return sorted(calls)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("work", type=Path, help="the directory speed_accuracy and the peers wrote")
    parser.add_argument("--results", type=Path, default=Path(__file__).resolve().parent / "results")
    parser.add_argument("--machine", default="", help="one line on the machine and the run")
    args = parser.parse_args()
    rows = read_rows(args.work / "hapticd.csv")
    peers = args.work / "peers.csv"
    if peers.exists():
        rows += read_rows(peers)
    manifest = json.loads((args.work / "manifest.json").read_text())
    args.results.mkdir(parents=True, exist_ok=True)
    write_rows(rows, args.results / "speed_accuracy.csv")
    plot(rows, args.results / "speed_accuracy.png", args.machine)
    repo = Path(__file__).resolve().parent.parent
    reading = write_reading(
        rows,
        read_choices(args.work / "choices.csv"),
        manifest,
        args.machine,
        embree_force_calls(repo),
    )
    (args.results / "speed_accuracy.md").write_text(reading)
    print(f"wrote {args.results}/speed_accuracy.png, .csv and .md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
