#!/usr/bin/env bash
# Batch closest points and batch contacts per point against batch ray casts per ray,
# through the Python package (the blocking Client and the AsyncClient) and a real
# server, alternating in one run (bench/batch_queries.py says how). Writes
# bench/results/batch_queries.md. About a minute after the build.
#   bench/run_batch_queries.sh [--sizes 1000 10000 100000] [--rounds 9]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
if [[ ! -x build/bin/hapticd ]]; then
  bash deploy/build.sh normal
fi
.venv/bin/python bench/batch_queries.py --bin-dir build/bin "$@"
