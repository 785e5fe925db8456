#!/usr/bin/env bash
# The admittance stability map for a UR-like robot (issue 15; bench/admittance_maps.py):
# robot lag x virtual mass x virtual damping x wall stiffness x hand stiffness through
# hapticd-sim. Writes bench/results/admittance/ (map_*.png, runs.csv, summary.md). About
# 3 minutes after the build on 2 cores.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null
out=bench/results/admittance
mkdir -p "$out"
table="$(.venv/bin/python bench/admittance_maps.py --out "$out" "$@")"
{
  echo "# Admittance on a lagging robot: the stability map"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs))."
  echo "Produced by bench/run_admittance_maps.sh; the runs in runs.csv, the maps in map_*.png."
  echo
  echo "$table"
} >"$out/summary.md"
echo "wrote $out/summary.md" >&2
