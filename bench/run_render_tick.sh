#!/usr/bin/env bash
# Measures the per-tick time of the rendering pipeline (p50, p99, p99.9), and how often
# and how long the machine itself interrupts a busy thread, and writes
# bench/results/render_tick.md with the machine and the date.
#   bench/run_render_tick.sh [--ticks N]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
# HAPTICD_BUILD_DIR: a build directory of one's own (only what this needs is built
# there); unset, deploy/build.sh builds build/
build_dir="${HAPTICD_BUILD_DIR:-build}"
bash deploy/install.sh
if [[ -n "${HAPTICD_BUILD_DIR:-}" ]]; then
  cmake -S "$repo" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  ninja -C "$build_dir" -j "${HAPTICD_JOBS:-$(nproc)}" render_tick_percentiles >/dev/null
else
  bash deploy/build.sh normal >/dev/null
fi

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
  "$build_dir/bin/render_tick_percentiles" "$@"
} > "$out"
echo "wrote $out" >&2
