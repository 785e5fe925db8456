#!/usr/bin/env bash
# How a render tick scales with the number of objects (10 against 10,000, in one run),
# what 100 kinematic moves a tick cost, and how an edit's cost grows with the scene
# (10,000 add_sphere requests to a real server); writes bench/results/scene_scale.md
# with the machine and the date.
#   bench/run_scene_scale.sh [--no-edits] [--ticks N]
# --no-edits: keep the edits' section of the last results instead of rerunning it (it
# needs the server in build/; the ticks' sections are measured either way).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
# HAPTICD_BUILD_DIR: a build directory of one's own (only what this needs is built
# there); unset, deploy/build.sh builds build/
build_dir="${HAPTICD_BUILD_DIR:-build}"
bash deploy/install.sh
if [[ -n "${HAPTICD_BUILD_DIR:-}" ]]; then
  cmake -S "$repo" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  ninja -C "$build_dir" -j "${HAPTICD_JOBS:-$(nproc)}" scene_scale >/dev/null
else
  bash deploy/build.sh normal >/dev/null
fi

edits=1
if [[ "${1:-}" == "--no-edits" ]]; then
  edits=0
  shift
fi
out="bench/results/scene_scale.md"
# (without the note a --no-edits run adds below it)
previous_edits="$(sed -n '/^## Edits through the control channel/,$p' "$out" 2>/dev/null | grep -v "^(The edits' section is the previous run's" || true)"
{
  echo "# A render tick in scenes of 10 and 10,000 objects"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)),"
  echo "load average before the run: $(cut -d' ' -f1-3 /proc/loadavg). The device slides on a"
  echo "circle pressed 1 mm into a 10 cm box; the other objects (spheres, boxes, capsules,"
  echo "320-triangle meshes, 2-10 cm, 1% of them kinematic) lie in a 4 m cube, none within"
  echo "20 cm of the box. As in the server, one thread moves the kinematic objects every"
  echo "millisecond and publishes each move as a new snapshot, and the avatar's thread ticks at"
  echo "1 kHz on the latest one (every tick timed on its own; the sleeps between ticks leave"
  echo "the caches as a 1 kHz loop finds them). Produced by bench/run_scene_scale.sh."
  echo
  "$build_dir/bin/scene_scale" "$@"
  echo
  if ((edits)); then
    echo "## Edits through the control channel of a real server (bench/scene_edit_scale.py)"
    echo
    .venv/bin/python bench/scene_edit_scale.py
  else
    echo "$previous_edits"
    echo
    echo "(The edits' section is the previous run's: this run was made with --no-edits.)"
  fi
} >"$out.new"
mv "$out.new" "$out"
echo "wrote $out" >&2
