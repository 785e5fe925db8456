"""Isolation between sessions on the one realtime thread (issue 11, section 2): the
round trip of one 1 kHz session (the C++ proxy's simulated hand stroking the default
scene) alone, beside a heavy neighbour under the default tick work budget, and beside
the same neighbour with the budget out of reach (--tick-work-budget 10000000), in
alternating blocks on one machine.

The heavy neighbour is a second proxy whose hand pushes up and down through a stack of
`--triangles` different triangles sharing one bounding box, 1 m from the default scene:
no BVH can split them, so each of its ticks near the stack visits them all unless the
budget stops it. Prints one JSON line per block, then a Markdown table of medians over
blocks (bench/run_tick_isolation.sh writes it to bench/results/tick_isolation.md)."""

import argparse
import json
import pathlib
import statistics
import subprocess
import sys
import time

import hapticd
import numpy as np

REPO = pathlib.Path(__file__).resolve().parents[1]
BIN = REPO / "build" / "bin"
UNBOUNDED = 10_000_000


def unsplittable_stack(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n triangles in the plane z = 0.05 at x = -1, all with the box [-1.1, -0.9] x
    [-0.1, 0.1]: a fan whose apex slides along the box's far edge."""
    apex_x = np.linspace(-1.1, -0.9, n)
    vertices = np.concatenate(
        [[[-1.1, -0.1, 0.05], [-0.9, -0.1, 0.05]], np.stack([apex_x, np.full(n, 0.1), np.full(n, 0.05)], 1)]
    )
    triangles = np.stack([np.zeros(n, int), np.ones(n, int), np.arange(n) + 2], 1)
    return vertices, triangles


def heavy_path(seconds: float) -> str:
    """Up and down through the stack's plane every 0.4 s, as hapticd-proxy's --path."""
    points = []
    t = 0.0
    while t <= seconds + 0.4:
        points.append(f"{t:.2f},-1,0.02,0.07")
        points.append(f"{t + 0.2:.2f},-1,0.02,0.03")
        t += 0.4
    return ";".join(points)


def start_server(budget: int | None) -> tuple[subprocess.Popen, dict]:
    args = [str(BIN / "hapticd"), "--log-level", "warning"]
    if budget is not None:
        args += ["--tick-work-budget", str(budget)]
    server = subprocess.Popen(args, stdout=subprocess.PIPE, text=True)
    assert server.stdout is not None
    endpoints = json.loads(server.stdout.readline())
    return server, endpoints


def proxy(tcp: str, seconds: float, path: str | None) -> subprocess.Popen:
    args = [str(BIN / "hapticd-proxy"), "--server", tcp, "--seconds", str(seconds), "--realtime-priority", "0"]
    if path is not None:
        args += ["--path", path]
    return subprocess.Popen(args, stdout=subprocess.PIPE, text=True)


def last_json_line(text: str) -> dict | None:
    lines = text.strip().splitlines()
    return json.loads(lines[-1]) if lines else None


def run_block(case: str, triangles: int, seconds: float) -> dict:
    budget = UNBOUNDED if case == "neighbour, no budget" else None
    server, endpoints = start_server(budget)
    try:
        with hapticd.connect(endpoints["tcp"], timeout_s=60) as client:
            vertices, faces = unsplittable_stack(triangles)
            client.add_mesh("stack", vertices, faces, "mesh")
            heavy = None
            if case != "alone":
                heavy = proxy(endpoints["tcp"], seconds + 1, heavy_path(seconds + 1))
                time.sleep(0.5)
            light = proxy(endpoints["tcp"], seconds, None)
            # a proxy whose session the server reclaimed (no command for 2 s) prints no
            # report: its block counts as starved
            report = last_json_line(light.communicate(timeout=seconds + 30)[0])
            heavy_report = None
            if heavy is not None:
                heavy_report = last_json_line(heavy.communicate(timeout=seconds + 30)[0])
            overruns = [s.tick_overruns for s in client.stats().sessions]
    finally:
        server.terminate()
        server.wait(timeout=10)
    return {"case": case, "light": report, "heavy": heavy_report, "tick_overruns": overruns}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--blocks", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=4)
    parser.add_argument("--triangles", type=int, default=200_000)
    args = parser.parse_args()
    cases = ["alone", "neighbour, default budget", "neighbour, no budget"]
    blocks: dict[str, list[dict]] = {case: [] for case in cases}
    for _ in range(args.blocks):
        for case in cases:
            block = run_block(case, args.triangles, args.seconds)
            print(json.dumps(block), file=sys.stderr, flush=True)
            blocks[case].append(block)

    def median(case: str, pick) -> float:
        return statistics.median(pick(block) for block in blocks[case])

    print("| case | light p50 µs | light p99 µs | light p99.9 µs | light max µs | light lost or late | "
          "neighbour p99 µs | neighbour lost or late | overruns (all sessions) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for case in cases:
        starved = sum(block["light"] is None for block in blocks[case])
        if starved:
            print(f"| {case} | starved in {starved} of {len(blocks[case])} blocks: no command for 2 s, "
                  "the session timed out | | | | | | | |")
            continue

        def rtt(key: str, case: str = case) -> float:
            return median(case, lambda b: b["light"][f"rtt_{key}_us"])

        lost = median(case, lambda b: b["light"]["packets_lost"] + b["light"]["packets_late"])
        if case == "alone" or any(block["heavy"] is None for block in blocks[case]):
            neighbour = "- | -"
        else:
            neighbour = (f"{median(case, lambda b: b['heavy']['rtt_p99_us']):.0f} | "
                         f"{median(case, lambda b: b['heavy']['packets_lost'] + b['heavy']['packets_late']):.0f}")
        overruns = median(case, lambda b: sum(b["tick_overruns"]))
        print(f"| {case} | {rtt('p50'):.0f} | {rtt('p99'):.0f} | {rtt('p999'):.0f} | {rtt('max'):.0f} | "
              f"{lost:.0f} | {neighbour} | {overruns:.0f} |")


if __name__ == "__main__":
    main()
