"""How an edit's cost grows with the scene (issue 12): one add_sphere request after
another through the control channel of a real hapticd, 10,000 of them, timed per
thousand, and then 100 set_material edits at the full size. Before snapshots shared
their objects every edit copied the whole scene (3,000 adds took 1.8 s, 10,000 took
13 s: quadratic); the ratio of the last thousand's time to the first's shows what is
left. Then the same adds as one batch (Client.edit_scene, one request, one new
version) on an emptied scene, against the same adds one request each. Prints a
Markdown table (bench/run_scene_scale.sh adds it to bench/results/scene_scale.md)."""

import argparse
import json
import pathlib
import subprocess
import time

import hapticd

REPO = pathlib.Path(__file__).resolve().parents[1]
BIN = REPO / "build" / "bin"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--objects", type=int, default=10000)
    args = parser.parse_args()
    server = subprocess.Popen(
        [str(BIN / "hapticd"), "--log-level", "warning", "--max-objects", str(args.objects + 10)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert server.stdout is not None
    endpoints = json.loads(server.stdout.readline())
    per_thousand = []
    try:
        with hapticd.connect(endpoints["tcp"], timeout_s=60) as client:
            client.clear_scene()
            started = time.perf_counter()
            block_started = started
            for i in range(args.objects):
                client.add_sphere(f"s{i}", 0.01, position=(i % 100 * 0.05, i // 100 % 100 * 0.05, i // 10000 * 0.05))
                if (i + 1) % 1000 == 0:
                    now = time.perf_counter()
                    per_thousand.append(now - block_started)
                    block_started = now
            total = time.perf_counter() - started
            edits_started = time.perf_counter()
            # a whole Material: a dict would first read the whole scene back (client side)
            for i in range(100):
                client.set_material(f"s{i * 97 % args.objects}", hapticd.Material(stiffness=500 + i))
            edit_ms = (time.perf_counter() - edits_started) * 10
            reads_started = time.perf_counter()
            for _ in range(10):
                client.scene()
            scene_ms = (time.perf_counter() - reads_started) * 100
            client.clear_scene()
            batch_started = time.perf_counter()
            edits = hapticd.SceneEdits()
            for i in range(args.objects):
                edits.add_sphere(f"s{i}", 0.01, position=(i % 100 * 0.05, i // 100 % 100 * 0.05, i // 10000 * 0.05))
            made = time.perf_counter()
            client.edit_scene(edits)
            batch_total = time.perf_counter() - batch_started
            batch_sent = time.perf_counter() - made
    finally:
        server.terminate()
        server.wait(timeout=10)
    print("| objects in the scene | time for these 1,000 add_sphere (s) | per add (ms) |")
    print("|---:|---:|---:|")
    for k, seconds in enumerate(per_thousand):
        print(f"| {k * 1000}-{(k + 1) * 1000} | {seconds:.3f} | {seconds:.3f} |")
    print()
    print(f"All {args.objects} adds: {total:.2f} s; the last thousand took "
          f"{per_thousand[-1] / per_thousand[0]:.2f} times the first. "
          f"set_material at {args.objects} objects: {edit_ms:.2f} ms per edit (mean of 100); "
          f"reading the scene back (client.scene()): {scene_ms:.1f} ms (mean of 10).")
    print()
    print(f"The same {args.objects} adds as one batch (Client.edit_scene): {batch_total:.2f} s "
          f"({batch_sent:.2f} s of it the request, the rest making the edits in Python), "
          f"{total / batch_total:.1f} times faster than one request each.")


if __name__ == "__main__":
    main()
