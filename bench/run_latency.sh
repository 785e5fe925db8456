#!/usr/bin/env bash
# The realtime channel's latency, in one run on this machine:
#   0. the CPU hapticd and the echo use a second while idle (no session, no client);
#   1. device-to-command round trip of one 1 kHz session (the C++ proxy's simulated hand
#      stroking the default scene) against hapticd and against a plain UDP echo, in
#      alternating blocks;
#   2. sessions one server holds: N sessions at 1 kHz from one proxy (its loop threads
#      sharing the sessions), against hapticd and against the echo at the same N, in
#      alternating blocks; added latency = the difference; the CPU time each side used;
#      the proxy's own misses (states it sent late against its schedule);
#   3. one session while a 10 MB mesh is uploaded, edited and removed in a loop, beside
#      the same session quiet (bench/scene_edit_load.py);
#   4. the datagram codec's cost per datagram (Google Benchmark).
# Writes bench/results/latency.md (tables and a reading against issue 4's aims),
# bench/results/latency.csv (one row per proxy run) and the raw runs in
# bench/results/raw/latency_runs.jsonl and latency_codec.json (bench/latency_table.py
# turns them into the tables again). About 3 minutes after the build.
# The binaries come from $HAPTICD_BUILD_DIR (default build/, built by deploy/build.sh);
# another directory is configured and only the bench's programs built there, with
# $HAPTICD_JOBS jobs (default: every CPU).
# Blocks alternate between hapticd and the echo and the tables report medians over
# blocks, so a burst of other work on the machine does not land on one side only.
#   bench/run_latency.sh [--blocks 5] [--block-seconds 4] [--scale-blocks 3] [--scale-seconds 1.5]
#                        [--proxy-threads T]   (the sessions part's loop threads; default: the CPUs)
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"

blocks=5
block_seconds=4
scale_blocks=3
scale_seconds=1.5
proxy_threads="$(nproc)"
while (($#)); do
  case "$1" in
    --blocks) blocks="$2"; shift 2 ;;
    --block-seconds) block_seconds="$2"; shift 2 ;;
    --scale-blocks) scale_blocks="$2"; shift 2 ;;
    --scale-seconds) scale_seconds="$2"; shift 2 ;;
    --proxy-threads) proxy_threads="$2"; shift 2 ;;
    *)
      echo "usage: bench/run_latency.sh [--blocks N] [--block-seconds S] [--scale-blocks N] [--scale-seconds S] [--proxy-threads T]" >&2
      exit 2
      ;;
  esac
done
sessions_list=(1 10 25 50 100 150 200)

bash deploy/install.sh
build="${HAPTICD_BUILD_DIR:-build}"
if [[ "$build" == build ]]; then
  bash deploy/build.sh normal >/dev/null
else
  cmake -S "$repo" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  ninja -C "$build" -j "${HAPTICD_JOBS:-$(nproc)}" bin/hapticd bin/hapticd-udp-echo bin/hapticd-proxy \
    bin/datagram_codec_bench >/dev/null
fi
bin="$build/bin"

work="$(mktemp -d)"
load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# start NAME COMMAND...: runs it in the background and waits (10 s at most) for its
# first stdout line, the JSON naming its endpoints
start() {
  local name="$1"
  shift
  "$@" >"$work/$name.out" 2>"$work/$name.err" &
  pids+=($!)
  for _ in $(seq 200); do
    [[ -s "$work/$name.out" ]] && return 0
    sleep 0.05
  done
  echo "run_latency: $name did not start:" >&2
  cat "$work/$name.err" >&2
  exit 1
}
field() { .venv/bin/python -c "import json,sys; print(json.loads(sys.stdin.readline())['$1'])" <"$work/$2.out"; }

start hapticd "$bin/hapticd" --tcp-port 0 --udp-port 0 --log-level warning
hapticd_pid="${pids[-1]}"
start echo "$bin/hapticd-udp-echo" --port 0
echo_pid="${pids[-1]}"
server="$(field tcp hapticd)"
echo_udp="$(field udp echo)"
echo "run_latency: hapticd control $server, echo $echo_udp" >&2

# cpu_seconds PID: the CPU time the process's threads have used so far (schedstat, ns,
# not the 10 ms ticks of /proc/PID/stat); main_cpu_seconds PID: its main thread's
# (hapticd's control thread; all of the echo)
cpu_seconds() { cat /proc/"$1"/task/*/schedstat | awk '{ ns += $1 } END { printf "%.6f", ns / 1e9 }'; }
main_cpu_seconds() { awk '{ printf "%.6f", $1 / 1e9 }' "/proc/$1/task/$1/schedstat"; }

# proxy PHASE BLOCK hapticd|echo ARGS...: one proxy run against that peer, its JSON line
# tagged with phase, block and the CPU time the peer used meanwhile
raw="bench/results/raw"
mkdir -p "$raw"
runs="$raw/latency_runs.jsonl"
: >"$runs"
proxy() {
  local phase="$1" block="$2" peer="$3" target pid
  shift 3
  if [[ "$peer" == hapticd ]]; then target=(--server "$server"); pid="$hapticd_pid"; else target=(--echo "$echo_udp"); pid="$echo_pid"; fi
  local before main_before line after main_after
  before="$(cpu_seconds "$pid")"
  main_before="$(main_cpu_seconds "$pid")"
  line="$("$bin/hapticd-proxy" "${target[@]}" "$@")"
  after="$(cpu_seconds "$pid")"
  main_after="$(main_cpu_seconds "$pid")"
  echo "{\"phase\": \"$phase\", \"block\": $block, \"peer_cpu_s\": $(awk -v a="$after" -v b="$before" 'BEGIN { printf "%.4f", a - b }'), \"peer_main_cpu_s\": $(awk -v a="$main_after" -v b="$main_before" 'BEGIN { printf "%.4f", a - b }'), \"result\": $line}" >>"$runs"
}

# 0. both idle (no session, no client): the CPU each uses a second while waiting (over
# 20 s: idle, hapticd's housekeeping wakes every 5 s)
echo "run_latency: idle" >&2
idle_seconds=20
hapticd_before="$(cpu_seconds "$hapticd_pid")"
echo_before="$(cpu_seconds "$echo_pid")"
sleep "$idle_seconds"
echo "{\"phase\": \"idle\", \"block\": 0, \"result\": {\"seconds\": $idle_seconds, \"hapticd_cpu_s\": $(awk -v a="$(cpu_seconds "$hapticd_pid")" -v b="$hapticd_before" 'BEGIN { printf "%.6f", a - b }'), \"echo_cpu_s\": $(awk -v a="$(cpu_seconds "$echo_pid")" -v b="$echo_before" 'BEGIN { printf "%.6f", a - b }')}}" >>"$runs"

# 1. one session, hapticd and echo alternating
for block in $(seq "$blocks"); do
  echo "run_latency: block $block of $blocks" >&2
  proxy compare "$block" hapticd --seconds "$block_seconds"
  proxy compare "$block" echo --seconds "$block_seconds"
done

# 2. sessions: every device held 2 mm into the floor (in contact every tick); a longer
# budget, since a loop sends its share of the N states before it can read an answer; the
# sessions dealt out to up to $proxy_threads loop threads
for n in "${sessions_list[@]}"; do
  echo "run_latency: $n sessions" >&2
  threads=$((n < proxy_threads ? n : proxy_threads))
  for block in $(seq "$scale_blocks"); do
    for peer in hapticd echo; do
      proxy sessions "$block" "$peer" --seconds "$scale_seconds" --sessions "$n" --threads "$threads" --path press \
        --budget-us 900
    done
  done
done

# 3. scene edits: one session in the same stroke, quiet and while a 10 MB mesh is uploaded,
# edited and removed again and again over the control channel
for block in $(seq 3); do
  echo "run_latency: scene edits, block $block of 3" >&2
  proxy edits-quiet "$block" hapticd --seconds "$block_seconds"
  .venv/bin/python bench/scene_edit_load.py --server "$server" --seconds "$block_seconds" >"$work/edits.json" &
  editor=$!
  proxy edits-busy "$block" hapticd --seconds "$block_seconds"
  wait "$editor"
  echo "{\"phase\": \"edits-load\", \"block\": $block, \"result\": $(cat "$work/edits.json")}" >>"$runs"
done

# 4. the codec
echo "run_latency: datagram codec" >&2
"$bin/datagram_codec_bench" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
  --benchmark_min_time=0.2 --benchmark_out_format=json --benchmark_out="$raw/latency_codec.json" >/dev/null

machine="$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)), load average before the run: $load_before"
.venv/bin/python bench/latency_table.py "$runs" "$raw/latency_codec.json" --machine "$machine" \
  --csv bench/results/latency.csv >bench/results/latency.md
echo "wrote bench/results/latency.md and bench/results/latency.csv" >&2
