#!/usr/bin/env bash
# Runs the sweep of rendering across a delayed channel (bench/remote_maps.py: direct,
# direct + TDPA, local model, local model + TDPA over stiffness x delay x jitter x loss x
# speed on three scenes, and the deadband's sweep) and writes bench/results/remote/.
#   bench/run_remote_maps.sh [--jobs N]
# HAPTICD_SIM=path/to/hapticd-sim skips the build and uses that simulator.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
if [[ -z "${HAPTICD_SIM:-}" ]]; then
  bash deploy/build.sh normal >/dev/null
fi
.venv/bin/python bench/remote_maps.py --sim "${HAPTICD_SIM:-build/bin/hapticd-sim}" "$@"
echo "wrote bench/results/remote/" >&2
