"""The peers of the speed-accuracy chart, on hapticd's inputs and tessellations.

Reads what ``build/bin/speed_accuracy`` wrote (``manifest.json``, the query inputs,
their analytic ground truth and every tessellation as ``.npy``) and answers the same
questions with
  * coal and python-fcl: distance from each point (a sphere of radius 0) to the mesh's
    OBBRSS BVH, and to their sphere primitive;
  * embreex: the first hit of each segment (one batched ``run`` call: float rays
    org = p, dir = q - p, t in [0, 1]).
Errors and times are measured as in the C++ program: one untimed pass over every input
for the errors, then repetitions of a batch (all inputs, or as many as a 0.5 s budget
allows), median per query. Python calls cost a binding overhead the C++ rows do not
pay: ``overhead_ns`` gives it (coal, python-fcl: the same call on their cheapest pair,
a point against a small sphere 1 m away; embreex: the same batch of rays 10 m away
from the mesh, which also takes Embree's own cost of a ray that misses its root box),
so that the chart can show the time net of it. hapticd's first-hit rows carry the same
measure of their own (segments that miss at their first box), so that first hits are
compared net of it on both sides.

The peers come from PyPI, pinned, in a benchmark-only virtual environment
(bench/.venv-peers) that this script creates on first use and then re-runs itself in.

    python3 bench/speed_accuracy_peers.py WORK_DIR [--out CSV]
"""

from __future__ import annotations

import argparse
import csv
import gc
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
VENV = REPO / "bench" / ".venv-peers"
REQUIREMENTS = ("coal==3.0.3", "python-fcl==0.7.0.11", "embreex==4.4.0.post1", "numpy==2.4.6")
CSV_COLUMNS = (
    "query,surface,representation,level,triangles,implementation,backend,queries,reps,"
    "time_ns,time_ns_min,overhead_ns,error_unit,error_max,error_p99,error_median,misses,note"
).split(",")


def ensure_peer_environment() -> None:
    """Re-runs this script in bench/.venv-peers, creating or updating it first."""
    if Path(sys.prefix).resolve() == VENV.resolve():
        return
    python = VENV / "bin" / "python"
    stamp = VENV / ".requirements"
    wanted = "\n".join(REQUIREMENTS)
    if not python.exists() or not stamp.exists() or stamp.read_text() != wanted:
        print(
            f"peers: creating {VENV.relative_to(REPO)} ({', '.join(REQUIREMENTS)})", file=sys.stderr
        )
        # Debian's own Python where there is one, as deploy/install.sh does
        base = "/usr/bin/python3" if Path("/usr/bin/python3").exists() else sys.executable
        subprocess.run([base, "-m", "venv", str(VENV)], check=True)
        subprocess.run(
            [
                str(python),
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
                *REQUIREMENTS,
            ],
            check=True,
        )
        stamp.write_text(wanted)
    os.execv(str(python), [str(python), str(Path(__file__).resolve()), *sys.argv[1:]])


def timed_batch_size(n: int, pass_s: float, timing: dict[str, Any], min_items: int = 64) -> int:
    """As TimedBatchSize in bench/speed_accuracy_io.cc."""
    affordable = n * timing["budget_s"] / (timing["min_reps"] * max(pass_s, 1e-12))
    return int(min(max(affordable, min(min_items, n)), n))


def time_batch(
    items: int, timing: dict[str, Any], run_batch: Callable[[], object]
) -> tuple[float, float, int]:
    """(lower median, minimum) time per item in ns and the repetitions, as TimeBatch."""
    per_item: list[float] = []
    spent = 0.0
    while len(per_item) < timing["max_reps"] and (
        len(per_item) < timing["min_reps"] or spent < timing["budget_s"]
    ):
        begin = time.perf_counter()
        run_batch()
        seconds = time.perf_counter() - begin
        spent += seconds
        per_item.append(1e9 * seconds / items)
    per_item.sort()
    return per_item[(len(per_item) - 1) // 2], per_item[0], len(per_item)


def error_stats(errors: Any) -> tuple[float, float, float]:
    """Max, p99 and median (nearest rank), as SummarizeErrors."""
    import numpy as np

    ordered = np.sort(np.asarray(errors, dtype=np.float64))
    n = len(ordered)

    def at(q: float) -> float:
        return float(ordered[min(max(int(np.ceil(q * n)), 1), n) - 1])

    return float(ordered[-1]), at(0.99), at(0.5)


class Peers:
    """Builds each peer's structures for one surface and measures its rows."""

    def __init__(self, work: Path, manifest: dict[str, Any]) -> None:
        import numpy as np

        self.np = np
        self.work = work
        self.timing = manifest["timing"]
        self.rows: list[dict[str, Any]] = []
        self.overhead_ns: dict[str, float] = {}

    def load(self, name: str) -> Any:
        return self.np.load(self.work / f"{name}.npy")

    def add_row(
        self,
        identity: dict[str, Any],
        n: int,
        errors: Any,
        timing: tuple[float, float, int],
        misses: int = 0,
        note: str = "",
    ) -> None:
        median, fastest, reps = timing
        error_max, error_p99, error_median = error_stats(errors)
        row = dict(
            identity,
            queries=n,
            reps=reps,
            time_ns=f"{median:.6g}",
            time_ns_min=f"{fastest:.6g}",
            error_unit="m",
            error_max=f"{error_max:.6g}",
            error_p99=f"{error_p99:.6g}",
            error_median=f"{error_median:.6g}",
            misses=misses,
            note=note,
        )
        row.setdefault("overhead_ns", 0)
        self.rows.append(row)
        print("  " + ",".join(str(row[c]) for c in CSV_COLUMNS), file=sys.stderr, flush=True)

    def measure_distances(
        self,
        identity: dict[str, Any],
        points: Any,
        true_distance: Any,
        distance: Callable[[int], float],
        note: str = "",
    ) -> None:
        """A closest-point row: distance(i) answers point i."""
        np = self.np
        n = len(points)
        begin = time.perf_counter()
        answers = np.array([distance(i) for i in range(n)])
        timed = timed_batch_size(n, time.perf_counter() - begin, self.timing)
        timing = time_batch(timed, self.timing, lambda: [distance(i) for i in range(timed)])
        self.add_row(identity, timed, np.abs(np.abs(answers) - true_distance), timing, note=note)

    def measure_first_hits(
        self,
        identity: dict[str, Any],
        p: Any,
        q: Any,
        true_hit: Any,
        cast: Callable[[int], Any],
        note: str = "",
    ) -> None:
        """A first-hit row: cast(k) answers the first k segments with parameters t (NaN: miss)."""
        np = self.np
        n = len(p)
        begin = time.perf_counter()
        t = cast(n)
        timed = timed_batch_size(n, time.perf_counter() - begin, self.timing)
        timing = time_batch(timed, self.timing, lambda: cast(timed))
        missed = np.isnan(t)
        # a miss lets a proxy through to q
        answer = np.where(missed[:, None], q, p + np.nan_to_num(t)[:, None] * (q - p))
        errors = np.linalg.norm(answer - true_hit, axis=1)
        self.add_row(identity, timed, errors, timing, misses=int(missed.sum()), note=note)

    def closest_point_rows(
        self,
        surface: dict[str, Any],
        level: int,
        vertices: Any,
        triangles: Any,
        points: Any,
        true_distance: Any,
    ) -> None:
        """coal and python-fcl: point to mesh (and to their sphere primitive, first)."""
        import coal
        import fcl

        np = self.np
        name = surface["name"]
        # coal: a radius-0 sphere moved to each point; ComputeDistance keeps the solver
        coal_point = coal.Sphere(0.0)
        identity_tf = coal.Transform3s()
        transforms = []
        for p in points:
            tf = coal.Transform3s()
            tf.setTranslation(p)
            transforms.append(tf)
        request = coal.DistanceRequest()
        result = coal.DistanceResult()

        def coal_distance(compute: Any) -> Callable[[int], float]:
            def distance(i: int) -> float:
                result.clear()
                return float(compute(transforms[i], identity_tf, request, result))

            return distance

        # python-fcl: a radius-0 sphere object moved to each point; signed distance on, as
        # without it fcl answers -1 for overlapping shapes (a point inside its sphere)
        fcl_point = fcl.CollisionObject(fcl.Sphere(0.0), fcl.Transform())
        fcl_request = fcl.DistanceRequest(enable_signed_distance=True)
        point_list = list(points)

        def fcl_distance(other: Any) -> Callable[[int], float]:
            def distance(i: int) -> float:
                fcl_point.setTranslation(point_list[i])
                return float(fcl.distance(fcl_point, other, fcl_request, fcl.DistanceResult()))

            return distance

        base = dict(query="closest_point", surface=name)
        # the binding's cost per call: the same call against a small sphere 1 m away
        # (coal's and fcl's cheapest pair); the geometry must outlive the calls
        far_tf = coal.Transform3s()
        far_tf.setTranslation(np.array([1.0, 0.0, 0.0]))
        coal_far_sphere = coal.Sphere(1e-3)
        coal_far = coal.ComputeDistance(coal_point, coal_far_sphere)
        fcl_far = fcl.CollisionObject(fcl.Sphere(1e-3), fcl.Transform(np.array([1.0, 0.0, 0.0])))
        n = len(points)

        def coal_far_batch() -> list[float]:
            out = []
            for tf in transforms:
                result.clear()
                out.append(coal_far(tf, far_tf, request, result))
            return out

        for library, batch in (
            ("coal", coal_far_batch),
            ("python-fcl", lambda: [fcl_distance(fcl_far)(i) for i in range(n)]),
        ):
            if library not in self.overhead_ns:
                self.overhead_ns[library] = time_batch(n, self.timing, batch)[0]
        if level == 0 and surface["has_primitive"]:
            coal_sphere_shape = coal.Sphere(surface["radius"])
            coal_sphere = coal.ComputeDistance(coal_point, coal_sphere_shape)
            fcl_sphere = fcl.CollisionObject(fcl.Sphere(surface["radius"]), fcl.Transform())
            for library, distance in (
                ("coal", coal_distance(coal_sphere)),
                ("python-fcl", fcl_distance(fcl_sphere)),
            ):
                identity = dict(
                    base,
                    representation="primitive",
                    level=-1,
                    triangles=0,
                    implementation=library,
                    backend="shape",
                    overhead_ns=f"{self.overhead_ns[library]:.6g}",
                )
                self.measure_distances(identity, points, true_distance, distance)
        identity = dict(
            base, representation="mesh", level=level, triangles=len(triangles), backend="bvh_obbrss"
        )
        begin = time.perf_counter()
        model = coal.BVHModelOBBRSS()
        model.beginModel(len(triangles), len(vertices))
        model.addVertices(vertices)
        model.addTriangles(triangles.astype(np.int64))
        model.endModel()
        build_s = time.perf_counter() - begin
        self.measure_distances(
            dict(identity, implementation="coal", overhead_ns=f"{self.overhead_ns['coal']:.6g}"),
            points,
            true_distance,
            coal_distance(coal.ComputeDistance(coal_point, model)),
            note=f"BVH build {build_s:.2f} s",
        )
        del model
        begin = time.perf_counter()
        fcl_model = fcl.BVHModel()
        fcl_model.beginModel(len(vertices), len(triangles))
        fcl_model.addSubModel(vertices, triangles)
        fcl_model.endModel()
        fcl_mesh = fcl.CollisionObject(fcl_model, fcl.Transform())
        build_s = time.perf_counter() - begin
        self.measure_distances(
            dict(
                identity,
                implementation="python-fcl",
                overhead_ns=f"{self.overhead_ns['python-fcl']:.6g}",
            ),
            points,
            true_distance,
            fcl_distance(fcl_mesh),
            note=f"BVH build {build_s:.2f} s",
        )
        del fcl_mesh, fcl_model
        gc.collect()

    def first_hit_rows(
        self,
        surface: dict[str, Any],
        level: int,
        vertices: Any,
        triangles: Any,
        p: Any,
        q: Any,
        true_hit: Any,
    ) -> None:
        """embreex: the segments as float rays through Embree 4's own triangle test."""
        from embreex import mesh_construction, rtcore_scene

        np = self.np
        scene = rtcore_scene.EmbreeScene()
        mesh_construction.TriangleMesh(
            scene, vertices.astype(np.float32), triangles.astype(np.int32)
        )
        origins = p.astype(np.float32)
        directions = (q - p).astype(np.float32)
        ones = np.ones(len(p), dtype=np.float32)
        # the same rays 10 m away: each leaves at Embree's root box, the cost of the call
        far_origins = origins + np.float32(10.0)

        def cast_from(start: Any) -> Callable[[int], Any]:
            def cast(k: int) -> Any:
                out = scene.run(
                    start[:k], directions[:k], dists=ones[:k], query="INTERSECT", output=1
                )
                hit = (out["geomID"].astype(np.int64) & 0xFFFFFFFF) != 0xFFFFFFFF
                return np.where(hit, out["tfar"].astype(np.float64), np.nan)

            return cast

        # the first run commits the scene (builds Embree's BVH)
        begin = time.perf_counter()
        cast_from(origins)(1)
        build_s = time.perf_counter() - begin
        n = len(p)
        overhead = time_batch(n, self.timing, lambda: cast_from(far_origins)(n))[0]
        identity = dict(
            query="first_hit",
            surface=surface["name"],
            representation="mesh",
            level=level,
            triangles=len(triangles),
            implementation="embreex",
            backend="embree4_float",
            overhead_ns=f"{overhead:.6g}",
        )
        self.measure_first_hits(
            identity,
            p,
            q,
            true_hit,
            cast_from(origins),
            note=f"float; unconfirmed; scene build {build_s:.2f} s",
        )


def main(argv: Sequence[str] | None = None) -> int:
    ensure_peer_environment()
    import numpy as np

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("work", type=Path, help="the directory speed_accuracy wrote")
    parser.add_argument("--out", type=Path, help="CSV to write (default WORK/peers.csv)")
    args = parser.parse_args(argv)
    manifest = json.loads((args.work / "manifest.json").read_text())
    peers = Peers(args.work, manifest)
    for surface in manifest["surfaces"]:
        name = surface["name"]
        points = peers.load(f"{name}_points")
        true_distance = np.linalg.norm(points - peers.load(f"{name}_true_closest"), axis=1)
        segment_p = peers.load(f"{name}_segment_p")
        segment_q = peers.load(f"{name}_segment_q")
        true_hit = peers.load(f"{name}_true_hit")
        for level in surface["levels"]:
            print(
                f"peers: {name} level {level['level']}, {level['triangles']} triangles",
                file=sys.stderr,
            )
            vertices = peers.load(f"{level['stem']}_vertices")
            triangles = peers.load(f"{level['stem']}_triangles")
            peers.closest_point_rows(
                surface, level["level"], vertices, triangles, points, true_distance
            )
            peers.first_hit_rows(
                surface, level["level"], vertices, triangles, segment_p, segment_q, true_hit
            )
    out = args.out or args.work / "peers.csv"
    with out.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=CSV_COLUMNS, quoting=csv.QUOTE_MINIMAL)
        writer.writeheader()
        writer.writerows(peers.rows)
    print(f"peers: wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
