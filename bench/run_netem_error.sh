#!/usr/bin/env bash
# The impairment relay's own error (issue 13): hapticd-proxy --echo against a plain UDP
# echo straight, through hapticd-netem unimpaired, through it with 25 ms each way, and the
# same with --spin-us 100 (waking early and spinning to each release), in
# alternating blocks of one run (bench/netem_error.py). Writes
# bench/results/netem_error.md with the machine and the date, and the runs in
# bench/results/raw/netem_error.jsonl. About 70 seconds after the build.
#   bench/run_netem_error.sh [--blocks 5] [--block-seconds 4] [--delay-ms 25]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
mkdir -p bench/results/raw
table="$(.venv/bin/python bench/netem_error.py build/bin "$@" 2>bench/results/raw/netem_error.jsonl)"
out=bench/results/netem_error.md
{
  echo "# The impairment relay's own error"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)),"
  echo "load average before the run: $load_before. Produced by bench/run_netem_error.sh $*."
  echo
  echo "$table"
} >"$out"
echo "wrote $out" >&2
