#!/usr/bin/env bash
# How a render tick scales with the number of objects (10 against 10,000, in one run),
# what 100 kinematic moves a tick cost, and how an edit's cost grows with the scene
# (10,000 add_sphere requests to a real server); writes bench/results/scene_scale.md
# with the machine and the date.
#   bench/run_scene_scale.sh [--ticks N]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null

out="bench/results/scene_scale.md"
{
  echo "# A render tick in scenes of 10 and 10,000 objects"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)),"
  echo "load average before the run: $(cut -d' ' -f1-3 /proc/loadavg). One thread. The device slides"
  echo "on a circle pressed 1 mm into a 10 cm box; the other objects (spheres, boxes, capsules,"
  echo "320-triangle meshes, 2-10 cm, 1% of them kinematic) lie in a 4 m cube, none within"
  echo "20 cm of the box. Produced by bench/run_scene_scale.sh."
  echo
  build/bin/scene_scale "$@"
  echo
  echo "## Edits through the control channel of a real server (bench/scene_edit_scale.py)"
  echo
  .venv/bin/python bench/scene_edit_scale.py
} >"$out"
echo "wrote $out" >&2
