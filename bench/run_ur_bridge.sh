#!/usr/bin/env bash
# The UR bridge's command latency against the RTDE period and the bare ur_rtde loop, and
# the arm's lag with the simulated lookahead (issue 15; bench/ur_bridge_latency.py),
# against the controller simulator in tests/ur_sim. Writes bench/results/ur_bridge.md
# with the machine and the date, the runs in bench/results/raw/ur_bridge.jsonl. About
# 2 minutes after the build.
#   bench/run_ur_bridge.sh [--seconds 6] [--blocks 2]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
mkdir -p bench/results/raw
table="$(.venv/bin/python bench/ur_bridge_latency.py build/bin "$@" 2>bench/results/raw/ur_bridge.jsonl)"
out=bench/results/ur_bridge.md
{
  echo "# The UR bridge: command latency and the arm's lag"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)),"
  echo "load average before the run: $load_before. Produced by bench/run_ur_bridge.sh $*,"
  echo "against the protocol-level controller simulator (tests/ur_sim), not a robot."
  echo
  echo "$table"
} >"$out"
echo "wrote $out" >&2
