#!/usr/bin/env bash
# Configures and builds hapticd into build/ (binaries in build/bin/).
#   deploy/build.sh            the normal build (optimized, without debug information:
#                              the test command builds everything twice on two cores)
#   deploy/build.sh sanitize   every test under ASan+UBSan, in build/sanitize/
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="${HAPTICD_JOBS:-$(nproc)}"

case "${1:-normal}" in
  normal)
    cmake -S "$repo" -B "$repo/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
    ninja -C "$repo/build" -j "$jobs"
    ;;
  sanitize)
    cmake -S "$repo" -B "$repo/build/sanitize" -G Ninja -DCMAKE_BUILD_TYPE=Debug \
      -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DHAPTICD_SANITIZE=ON -DHAPTICD_BUILD_BENCHMARKS=OFF >/dev/null
    ninja -C "$repo/build/sanitize" -j "$jobs"
    ;;
  *)
    echo "usage: deploy/build.sh [normal|sanitize]" >&2
    exit 2
    ;;
esac
