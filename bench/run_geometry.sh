#!/usr/bin/env bash
# Runs the geometry benchmarks and writes bench/results/geometry.md (medians of
# repeated runs) with the machine and the date, plus the raw JSON beside it.
#   bench/run_geometry.sh [BENCH_FILTER]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null

raw="bench/results/raw"
mkdir -p "$raw"
for program in build/bin/*_bench; do
  name="$(basename "$program")"
  # The datagram codec is the realtime channel's; bench/run_latency.sh reports it.
  [[ "$name" == datagram_codec_bench ]] && continue
  echo "== $name" >&2
  "$program" --benchmark_filter="${1:-.}" --benchmark_repetitions=5 \
    --benchmark_report_aggregates_only=true --benchmark_out_format=json \
    --benchmark_out="$raw/$name.json" >&2
done
.venv/bin/python bench/geometry_table.py "$raw"/*_bench.json > bench/results/geometry.md
echo "wrote bench/results/geometry.md" >&2
