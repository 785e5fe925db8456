"""Turns Google Benchmark JSON files into one markdown table of medians, with the
machine and the date, for bench/results/geometry.md."""
import json
import pathlib
import sys


def format_time(ns: float) -> str:
    if ns >= 1e6:
        return f"{ns / 1e6:.2f} ms"
    if ns >= 1e3:
        return f"{ns / 1e3:.2f} µs"
    return f"{ns:.1f} ns"


def main(paths: list[str]) -> None:
    context = None
    print("# Geometry core benchmarks\n")
    rows = []
    for path in paths:
        data = json.loads(pathlib.Path(path).read_text())
        context = context or data["context"]
        program = pathlib.Path(path).stem
        for run in data["benchmarks"]:
            if run.get("aggregate_name") not in ("median", "stddev"):
                continue
            scale = {"ns": 1, "us": 1e3, "ms": 1e6, "s": 1e9}[run["time_unit"]]
            rows.append((program, run["run_name"], run["aggregate_name"], run["real_time"] * scale,
                         {k: v for k, v in run.items() if k not in KNOWN_KEYS}))
    assert context is not None, "no benchmark output"
    print(f"Machine: {context['host_name']}, {context['num_cpus']} CPUs at "
          f"{context['mhz_per_cpu']} MHz; date {context['date']}; "
          f"library build type {context['library_build_type']}. "
          "Median (and standard deviation) of 5 repetitions, wall time per iteration.\n")
    print("| program | benchmark | median | stddev | counters |")
    print("| --- | --- | ---: | ---: | --- |")
    stddev = {(p, n): t for p, n, agg, t, _ in rows if agg == "stddev"}
    for program, name, agg, ns, extra in rows:
        if agg != "median":
            continue
        counters = ", ".join(f"{k}={v:.4g}" for k, v in extra.items() if isinstance(v, (int, float)))
        print(f"| {program} | {name} | {format_time(ns)} | {format_time(stddev.get((program, name), 0))} "
              f"| {counters} |")


KNOWN_KEYS = {"name", "family_index", "per_family_instance_index", "run_name", "run_type",
              "repetitions", "threads", "aggregate_name", "aggregate_unit", "iterations",
              "real_time", "cpu_time", "time_unit", "repetition_index"}

if __name__ == "__main__":
    main(sys.argv[1:])
