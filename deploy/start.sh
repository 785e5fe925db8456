#!/usr/bin/env bash
# The main job, from a bare checkout: setup, build, then the server on its embedded
# default scene, on loopback (control 127.0.0.1:7460, realtime 127.0.0.1:7461). Extra
# arguments go to hapticd (see build/bin/hapticd --help); Ctrl-C stops it.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"

bash deploy/install.sh
bash deploy/build.sh normal
exec build/bin/hapticd "$@"
