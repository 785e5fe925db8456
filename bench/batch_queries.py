"""Batch queries per point against batch ray casts per ray, through the Python package
and a real server, in one run (bench/run_batch_queries.sh writes
bench/results/batch_queries.md).

The scene: hapticd's default scene (a floor plane, a box, a ball, a capsule, a torus
mesh) plus two icospheres of 1,280 triangles kept as meshes, one on each backend
(native, Embree). The points: N uniform in the box the objects fill (so some lie
inside solids, some far from all); the rays start at the same points with directions
uniform on the sphere. Each round times, on the same points and in this order,
ray_cast_batch (one origin per ray), ray_cast_batch from one origin (a fan, the origin
sent once), closest_point_batch and find_contacts_batch (radius 1 cm), each call end
to end: arguments checked and encoded, the request sent, answered and decoded into
numpy arrays. Rounds alternate the queries, so a burst of other work on the machine
does not land on one only; small batches get more rounds (rounds x 10,000 / N, at
least rounds), as their calls are short and a burst weighs more. A query's time is
its median over the rounds, and the ratio is that median per point over
ray_cast_batch's per ray (below 1: faster). The same for the AsyncClient on its own
event loop.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import pathlib
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import hapticd
import numpy as np
import trimesh

REPO = pathlib.Path(__file__).resolve().parent.parent
LOW = np.array([-0.25, -0.25, -0.02])
HIGH = np.array([0.25, 0.25, 0.15])
CONTACT_RADIUS_M = 0.01
MAX_DISTANCE_M = 1.0
QUERIES = ("ray_cast_batch", "ray_cast_batch, one origin", "closest_point_batch", "find_contacts_batch")


def start_server(bin_dir: pathlib.Path) -> tuple[subprocess.Popen[str], str]:
    """hapticd on free loopback ports; its control endpoint."""
    server = subprocess.Popen(
        [str(bin_dir / "hapticd"), "--tcp-port", "0", "--udp-port", "0", "--log-level", "error"],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert server.stdout is not None
    return server, json.loads(server.stdout.readline())["tcp"]


def add_meshes(client: hapticd.Client) -> None:
    """The two icospheres, one per backend, beside the default scene's objects."""
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.04)
    for name, x, backend in (("ico_native", -0.1, "native"), ("ico_embree", 0.1, "embree")):
        client.add_mesh(
            name, ball.vertices, ball.faces, "mesh", ray_backend=backend, position=(x, 0.15, 0.06)
        )


def inputs(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n points in the scene's box and n unit directions."""
    rng = np.random.default_rng(seed)
    points = rng.uniform(LOW, HIGH, size=(n, 3))
    directions = rng.normal(size=(n, 3))
    return points, directions / np.linalg.norm(directions, axis=1, keepdims=True)


def calls_of(client: Any, points: np.ndarray, directions: np.ndarray) -> dict[str, Callable[[], Any]]:
    """Each query's call on these inputs (a coroutine function for an AsyncClient)."""
    center = (LOW + HIGH) / 2
    return {
        "ray_cast_batch": lambda: client.ray_cast_batch(points, directions, MAX_DISTANCE_M),
        "ray_cast_batch, one origin": lambda: client.ray_cast_batch(center, directions, MAX_DISTANCE_M),
        "closest_point_batch": lambda: client.closest_point_batch(points, MAX_DISTANCE_M),
        "find_contacts_batch": lambda: client.find_contacts_batch(points, CONTACT_RADIUS_M),
    }


def summarize(times: dict[str, list[float]], n: int) -> dict[str, dict[str, float]]:
    """Median call time and time per point, and the ratio to ray_cast_batch's per ray."""
    rays = statistics.median(times["ray_cast_batch"])
    return {
        name: {
            "median_ms": statistics.median(seconds) * 1e3,
            "per_point_us": statistics.median(seconds) / n * 1e6,
            "ratio_to_rays": statistics.median(seconds) / rays,
        }
        for name, seconds in times.items()
    }


def run_blocking(address: str, n: int, rounds: int, seed: int) -> dict[str, list[float]]:
    points, directions = inputs(n, seed)
    times: dict[str, list[float]] = {name: [] for name in QUERIES}
    with hapticd.connect(address, timeout_s=120) as client:
        calls = calls_of(client, points, directions)
        for name in QUERIES:  # warm up: first touches of the BVHs, the allocator
            calls[name]()
        for _ in range(rounds):
            for name in QUERIES:
                started = time.perf_counter()
                calls[name]()
                times[name].append(time.perf_counter() - started)
    return times


async def run_async(address: str, n: int, rounds: int, seed: int) -> dict[str, list[float]]:
    points, directions = inputs(n, seed)
    times: dict[str, list[float]] = {name: [] for name in QUERIES}
    async with await hapticd.connect_async(address, timeout_s=120) as client:
        calls = calls_of(client, points, directions)
        for name in QUERIES:
            await calls[name]()
        for _ in range(rounds):
            for name in QUERIES:
                started = time.perf_counter()
                await calls[name]()
                times[name].append(time.perf_counter() - started)
    return times


def table(results: list[dict[str, Any]]) -> str:
    lines = [
        "| client | N | rounds | query | median per call (ms) | per point (µs) | ratio to ray_cast_batch per ray |",
        "| --- | ---: | ---: | --- | ---: | ---: | ---: |",
    ]
    for result in results:
        for name, row in result["queries"].items():
            lines.append(
                f"| {result['client']} | {result['n']:,} | {result['rounds']} | {name} | {row['median_ms']:.1f} | "
                f"{row['per_point_us']:.2f} | {row['ratio_to_rays']:.2f} |"
            )
    return "\n".join(lines)


def reading(results: list[dict[str, Any]]) -> str:
    """Each query's range of ratios over the sizes and clients, and where it is highest."""
    lines = []
    for name in QUERIES[1:]:
        rows = [(r["queries"][name]["ratio_to_rays"], r["client"], r["n"]) for r in results]
        low, high = min(rows), max(rows)
        lines.append(
            f"- {name}: {low[0]:.2f} to {high[0]:.2f} of ray_cast_batch's time per ray "
            f"(highest: {high[1]}, N = {high[2]:,})"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin-dir", type=pathlib.Path, default=REPO / "build" / "bin")
    parser.add_argument("--sizes", type=int, nargs="+", default=[1_000, 10_000, 100_000])
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--output", type=pathlib.Path, default=REPO / "bench" / "results" / "batch_queries.md")
    args = parser.parse_args()

    server, address = start_server(args.bin_dir)
    try:
        with hapticd.connect(address) as client:
            add_meshes(client)
            objects = [info.name for info in client.scene().objects]
        results = []
        for n in args.sizes:
            rounds = max(args.rounds, args.rounds * 10_000 // n)
            for kind in ("Client", "AsyncClient"):
                if kind == "Client":
                    times = run_blocking(address, n, rounds, seed=n)
                else:
                    times = asyncio.run(run_async(address, n, rounds, seed=n))
                result = {"client": kind, "n": n, "rounds": rounds, "queries": summarize(times, n)}
                results.append(result)
                print(json.dumps(result), flush=True)
    finally:
        server.terminate()
        server.wait(timeout=10)

    cpu = next(
        (line.split(":", 1)[1].strip() for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines()
         if line.startswith("model name")),
        platform.processor(),
    )
    text = f"""# Batch queries against batch ray casts (bench/run_batch_queries.sh)

`bench/batch_queries.py`, alternating rounds ({args.rounds} per size, more for small
ones: the table says), medians; hapticd
{hapticd.__version__}, Python {platform.python_version()}, {cpu}, {len(__import__('os').sched_getaffinity(0))} CPUs
(shared with other work while it ran: the rounds alternate so that a burst lands on
every query alike). Scene: {', '.join(objects)} (the default scene and two 1,280-triangle
icospheres kept as meshes, on the native and the Embree backend). Points uniform in
{LOW.tolist()} .. {HIGH.tolist()} m; rays from the same points (or, "one origin", from the
box's centre) in uniform directions, max_distance {MAX_DISTANCE_M} m; closest points within
{MAX_DISTANCE_M} m; contacts of spheres of radius {CONTACT_RADIUS_M} m. Each time is one call end to
end: checks, encoding, the request, the server's answer, decoding into numpy arrays.

{table(results)}

Ratio below 1: the query costs less per point than a batch ray cast per ray, on the same
points in the same run.

{reading(results)}

A closest point's cost is the server's (the client decodes its reply about three times
faster than a ray batch's, whose object names are strings), most of it the
nearest-triangle search of the meshes near the point, which the server probes nearest
first, each only as far as the nearest surface found so far \
(query::FindClosestPoints). A ray batch tests each object against all rays at once
and is cheapest per ray in small batches, where its arrays stay in cache; so the two
are close at 1,000 points and closest points pull ahead from 10,000.
"""
    args.output.write_text(text)
    print(f"wrote {args.output}", file=sys.stderr)


if __name__ == "__main__":
    main()
