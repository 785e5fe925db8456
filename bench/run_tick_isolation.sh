#!/usr/bin/env bash
# Isolation between sessions on the realtime thread: one 1 kHz session's round trip
# alone, beside a neighbour whose every tick meets an unsplittable stack of triangles
# under the default --tick-work-budget, and beside it with the budget out of reach, in
# alternating blocks (bench/tick_isolation.py). Writes bench/results/tick_isolation.md
# with the machine and the date, and the raw blocks in bench/results/raw/tick_isolation.jsonl.
#   bench/run_tick_isolation.sh [--blocks 3] [--seconds 4] [--triangles 200000]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
raw="$(mktemp)"
table="$(.venv/bin/python bench/tick_isolation.py "$@" 2>"$raw")"
# the blocks (JSON lines) only; a starved proxy's own complaints stay out
grep '^{' "$raw" >bench/results/raw/tick_isolation.jsonl || true
rm -f "$raw"
out="bench/results/tick_isolation.md"
{
  echo "# Isolation between sessions: the tick work budget"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)),"
  echo "load average before the run: $load_before. Produced by bench/run_tick_isolation.sh $*."
  echo
  echo "The light session is hapticd-proxy's simulated hand stroking the default scene at 1 kHz."
  echo "The neighbour is a second proxy whose hand goes up and down through a stack of"
  echo "triangles that share one bounding box (no BVH splits them), 1 m away; both proxies"
  echo "and the server share this machine's cores. Round trips are device-to-command (µs);"
  echo "lost or late: states whose command did not come within the proxy's 500 µs budget."
  echo "Medians over blocks; the cases alternate, one server each."
  echo
  echo "$table"
} >"$out"
echo "wrote $out" >&2
