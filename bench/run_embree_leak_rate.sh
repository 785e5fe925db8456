#!/usr/bin/env bash
# Raw Embree against hapticd's Embree backend on the same segments, aimed exactly
# through the vertices and edges of meshes (steep and grazing): how many pass through a
# closed surface without a hit. Writes bench/results/embree_leak_rate.md and the raw
# JSON beside it in bench/results/raw/. About 10 seconds after the build.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null

raw="bench/results/raw/embree_leak_rate.json"
mkdir -p bench/results/raw
build/bin/embree_leak_rate 8 >"$raw"
.venv/bin/python - "$raw" >bench/results/embree_leak_rate.md <<'PY'
import json
import sys

run = json.load(open(sys.argv[1]))
print("# Segments through vertices and edges: raw Embree against hapticd's Embree backend\n")
print(f"Embree {run['embree_version']}, {run['segments_per_target']} segments per vertex or edge target, "
      f"seed {run['seed']}; `bash bench/run_embree_leak_rate.sh`. A *leak* is a segment that "
      "crosses the closed surface (the exact watertight test hits it) and is reported as a miss; "
      "*differences* count any answer other than the exact one.\n")
print("| mesh | triangles | directions | segments | raw robust leaks | raw robust rate | "
      "raw leaks | raw rate | backend leaks | backend differences |")
print("| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
totals = {"segments": 0, "robust": 0, "raw": 0, "backend": 0}
for case in run["cases"]:
    robust, raw, backend = case["raw_embree_robust"], case["raw_embree_not_robust"], case["backend"]
    print(f"| {case['mesh']} | {case['triangles']} | {case['directions']} | {case['segments']} | "
          f"{robust['leaks']} | {100 * robust['leak_rate']:.3f}% | {raw['leaks']} | {100 * raw['leak_rate']:.3f}% | "
          f"{backend['leaks']} | {backend['differences']} |")
    totals["segments"] += case["segments"]
    totals["robust"] += robust["leaks"]
    totals["raw"] += raw["leaks"]
    totals["backend"] += backend["leaks"]
n = totals["segments"]
print(f"\nAll {n} segments: raw Embree (robust) leaks {totals['robust']} ({100 * totals['robust'] / n:.3f}%), "
      f"raw Embree (not robust) {totals['raw']} ({100 * totals['raw'] / n:.3f}%), hapticd's backend "
      f"{totals['backend']}. The backend uses Embree's BVH only to pick candidate triangles (boxes grown "
      "by a guard that covers float rounding) and decides each with the exact watertight test "
      "(server/embree/embree_mesh.h).")
PY
echo "wrote bench/results/embree_leak_rate.md" >&2
