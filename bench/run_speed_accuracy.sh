#!/usr/bin/env bash
# Speed against accuracy, in one run on this machine:
#   1. build/bin/speed_accuracy: hapticd's rows (closest point, first hit, point- and
#      sphere-avatar force; analytic primitive, convex hull, meshes of 80 .. 1.3M
#      triangles on the native and the Embree backend; sphere and torus), the scene's
#      own representation choices, and the inputs, truth and meshes as .npy;
#   2. bench/speed_accuracy_peers.py: coal, python-fcl and embreex on the same inputs and
#      meshes, in bench/.venv-peers (pinned, from PyPI; made on first use);
#   3. bench/speed_accuracy_chart.py: bench/results/speed_accuracy.png, .csv and .md (the
#      reading: cheapest representation per tolerance, the scene's choice checked against
#      it, the aim against the peers).
# Intermediate files go to build/speed_accuracy/. About 5 minutes after the build on a
# 2-core machine.
#   bench/run_speed_accuracy.sh [--quick]    (--quick: three levels, fewer inputs; a smoke
#                                             test, written to build/speed_accuracy_quick/)
# HAPTICD_BUILD_DIR=dir (default build): build and run from another build directory,
# building only the benchmark there (with HAPTICD_JOBS jobs, default 1), so that a shared
# build/ is left alone.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"

build="${HAPTICD_BUILD_DIR:-build}"
quick=()
work="$build/speed_accuracy"
results=bench/results
case "${1:-}" in
  "") ;;
  --quick) quick=(--quick); work="$build/speed_accuracy_quick"; results="$work/results" ;;
  *) echo "usage: bench/run_speed_accuracy.sh [--quick]" >&2; exit 2 ;;
esac

bash deploy/install.sh
if [[ "$build" == build ]]; then
  bash deploy/build.sh normal >/dev/null
else
  cmake -S "$repo" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  ninja -C "$build" -j "${HAPTICD_JOBS:-1}" bin/speed_accuracy >/dev/null
fi

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
started="$(date +%s)"
echo "run_speed_accuracy: hapticd ($build/bin/speed_accuracy)" >&2
"$build/bin/speed_accuracy" --out "$work" "${quick[@]}" >"$work.log" 2>&1 || { tail -20 "$work.log" >&2; exit 1; }
echo "run_speed_accuracy: peers (coal, python-fcl, embreex)" >&2
python3 bench/speed_accuracy_peers.py "$work" 2>>"$work.log" || { tail -20 "$work.log" >&2; exit 1; }
elapsed=$(($(date +%s) - started))

machine="$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)), load average before the run: $load_before, measurement ${elapsed} s"
.venv/bin/python bench/speed_accuracy_chart.py "$work" --results "$results" --machine "$machine"
