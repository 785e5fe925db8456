#!/usr/bin/env bash
# Measures the per-tick time of the rendering pipeline (p50, p99, p99.9) and writes
# bench/results/render_tick.md with the machine and the date.
#   bench/run_render_tick.sh [--ticks N]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null

out="bench/results/render_tick.md"
{
  echo "# Per-tick time of RenderSession::Tick"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)),"
  echo "load average before the run: $(cut -d' ' -f1-3 /proc/loadavg). One thread; the device"
  echo "slides around the object's equator pressed 1 mm in at 0.2 m/s (every tick in contact);"
  echo "every tick timed on its own. Objects are 10 cm across; meshes are icospheres pinned as"
  echo "meshes; the sphere avatar's radius is 5 mm. Produced by bench/run_render_tick.sh."
  echo
  build/bin/render_tick_percentiles "$@"
} > "$out"
echo "wrote $out" >&2
