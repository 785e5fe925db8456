#!/usr/bin/env bash
# Runs the stability sweep of issue 3 (bench/stability_maps.py: every force method,
# passivity off and on, 3240 hapticd-sim runs) and writes one heatmap (PNG) and one
# table (CSV) per method to bench/results/stability/.
#   bench/run_stability_maps.sh [--jobs N]
# HAPTICD_SIM=path/to/hapticd-sim skips the build and uses that simulator.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
if [[ -z "${HAPTICD_SIM:-}" ]]; then
  bash deploy/build.sh normal >/dev/null
fi

.venv/bin/python bench/stability_maps.py --sim "${HAPTICD_SIM:-build/bin/hapticd-sim}" "$@"
echo "wrote bench/results/stability/" >&2
