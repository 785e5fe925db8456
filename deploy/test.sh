#!/usr/bin/env bash
# Runs every hapticd test from a bare checkout: setup, build, the GoogleTest suites,
# the same suites under AddressSanitizer and UndefinedBehaviorSanitizer, the
# conformance cases, the end-to-end tests, and a bounded fuzzing run.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
export HAPTICD_SHARED="${HAPTICD_SHARED:-$(cd "$repo/.." && pwd)/shared}"

# each step's heading says how long the run has taken so far (the whole must stay
# under 45 minutes from a fresh clone on a 2-core machine)
step() { echo "== [$((SECONDS / 60)) min $((SECONDS % 60)) s] $*"; }

bash deploy/install.sh
bash deploy/build.sh normal
bash deploy/build.sh sanitize

# Embree picks its kernels by CPU at run time: say which, so a CPU change shows in the log.
step "CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | xargs); Embree: $(build/bin/hapticd-query --embree-info)"
step "unit tests"
ctest --test-dir build --output-on-failure -j 2 --timeout 300
step "unit tests under ASan+UBSan"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build/sanitize --output-on-failure -j 2 --timeout 600
for backend in native embree; do
  step "conformance, mesh ops on the $backend backend"
  python3 "$HAPTICD_SHARED/conformance/check.py" --runner "build/bin/hapticd-query --ray-backend $backend" \
    "$HAPTICD_SHARED"/conformance/public/*.jsonl
done
step "Python: lint (the package by its own rules, the other scripts by ruff.toml), the package's types and unit tests"
.venv/bin/ruff check .
(cd clients/python && ../../.venv/bin/mypy)
.venv/bin/python -m pytest -q clients/python/tests
step "Python package: its wheel in a clean environment, its API guide (mkdocs --strict)"
bash deploy/check_package.sh
.venv/bin/mkdocs build --strict -f clients/python/mkdocs.yml
step "end-to-end tests"
.venv/bin/python -m pytest -q tests
step "end-to-end server tests against the ASan+UBSan build"
HAPTICD_BIN=build/sanitize/bin .venv/bin/python -m pytest -q tests/test_e2e_*.py
step "fuzzing, a fixed number of executions of each target under ASan+UBSan (deploy/fuzz.sh --ci)"
bash deploy/fuzz.sh --ci
step "all passed"
