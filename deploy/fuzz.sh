#!/usr/bin/env bash
# Builds the libFuzzer targets of server/fuzz with clang, under ASan+UBSan, into
# build/fuzz/, and runs each for a bounded time from seed corpora made afresh from the
# project's inputs (server/fuzz/make_seed_corpora.py). First each saved reproducer in
# server/fuzz/regressions/<target>/ is replayed, except those open.txt lists (bugs not
# fixed yet). Fails if any target crashes, leaks, hangs or breaks a check, printing the
# input's path; ends with "fuzz: N passed, M failed".
#   deploy/fuzz.sh [SECONDS [TARGET...]]   seconds per target (default 20), all targets by default
#   deploy/fuzz.sh --ci                    what the test command runs: each target for a fixed
#                                          number of executions (about 20 s each on this
#                                          project's 2-core machine), so that a run is the
#                                          same run everywhere: seed, corpus and count fixed
# Each run's libFuzzer log is build/fuzz/logs/<target>.log (bench/run_fuzz_campaign.sh reads them).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
# executions per target in --ci mode (measured rates here: 20 s of each)
declare -A ci_runs=([fuzz_datagram]=650000 [fuzz_control]=8000 [fuzz_scene_file]=250000 [fuzz_scenario]=200000
                    [fuzz_mesh_file]=170000 [fuzz_mesh_validation]=28000 [fuzz_conformance_line]=25000)
ci=false
if [[ "${1:-}" == "--ci" ]]; then
  ci=true
  shift
  seconds=0
else
  seconds="${1:-20}"
  shift || true
fi
jobs="${HAPTICD_JOBS:-$(nproc)}"
build="$repo/build/fuzz"
targets=("$@")
if ((${#targets[@]} == 0)); then
  targets=(fuzz_datagram fuzz_control fuzz_scene_file fuzz_scenario fuzz_mesh_file fuzz_mesh_validation
           fuzz_conformance_line)
fi

# The module libraries get coverage and sanitizer instrumentation; the targets link libFuzzer.
CXX=clang++ cmake -S "$repo" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
  -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link -fsanitize-ignorelist=$repo/server/fuzz/ubsan_ignorelist.txt" \
  -DHAPTICD_SANITIZE=ON -DHAPTICD_FUZZ=ON \
  -DHAPTICD_BUILD_TESTS=OFF -DHAPTICD_BUILD_BENCHMARKS=OFF >/dev/null
ninja -C "$build" -j "$jobs" hapticd_fuzz

rm -rf "$build/seeds" "$build/corpus" "$build/artifacts" "$build/logs"
mkdir -p "$build/logs"
python3 server/fuzz/make_seed_corpora.py --out "$build/seeds" --control-seeds "$build/bin/make_control_seeds"

export ASAN_OPTIONS="detect_leaks=1"
export UBSAN_OPTIONS="print_stacktrace=1"
flags=(-seed=1 -rss_limit_mb=2048 -timeout=10 -print_final_stats=1)
open_list="server/fuzz/regressions/open.txt"
passed=0
failed=0
for target in "${targets[@]}"; do
  log="$build/logs/$target.log"
  artifacts="$build/artifacts/$target/"
  mkdir -p "$artifacts" "$build/corpus/$target"
  # reproducers of fixed bugs, once each (open.txt: "target/file", bugs still open)
  replay=()
  for input in server/fuzz/regressions/"$target"/*; do
    [[ -f "$input" ]] || continue
    grep -qxF "$target/$(basename "$input")" "$open_list" 2>/dev/null || replay+=("$input")
  done
  status=0
  if ((${#replay[@]})); then
    "$build/bin/$target" "${flags[@]}" -artifact_prefix="$artifacts" "${replay[@]}" >"$build/logs/$target.replay.log" 2>&1 ||
      status=$?
  fi
  if ((status == 0)); then
    if $ci; then bound=(-runs="${ci_runs[$target]}"); else bound=(-max_total_time="$seconds"); fi
    "$build/bin/$target" "${flags[@]}" -artifact_prefix="$artifacts" "${bound[@]}" \
      "$build/corpus/$target" "$build/seeds/$target" >"$log" 2>&1 || status=$?
  else
    log="$build/logs/$target.replay.log"
  fi
  runs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)"
  done_line="$(grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -1 || true)"
  if ((status == 0)); then
    passed=$((passed + 1))
    echo "fuzz: $target passed: ${runs:-?} runs;${done_line#*DONE}"
  else
    failed=$((failed + 1))
    found="$(find "$artifacts" -type f | head -1)"
    echo "fuzz: $target FAILED (exit $status); input: ${found:-none saved}; log: $log" >&2
    grep -E 'ERROR: |FUZZ_CHECK|runtime error|#[0-9]+ 0x' "$log" | head -30 >&2 || true
  fi
done
echo "fuzz: $passed passed, $failed failed"
((failed == 0))
