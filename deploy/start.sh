#!/usr/bin/env bash
# The main job, from a bare checkout: setup, build, then (until the server exists) the
# conformance runner on the public geometry cases.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
shared="${HAPTICD_SHARED:-$(cd "$repo/.." && pwd)/shared}"

bash deploy/install.sh
bash deploy/build.sh normal
python3 "$shared/conformance/check.py" --runner build/bin/hapticd-query \
  "$shared"/conformance/public/*.jsonl
