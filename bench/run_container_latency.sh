#!/usr/bin/env bash
# The network lab's latency benchmark (issue 13; root): the round trip of hapticd-proxy
# against hapticd beside a plain UDP echo over loopback, veth between namespaces and
# between two podman containers; then today's rendering under a grid of injected delay,
# jitter and loss, on the real UDP path (hapticd-netem) and in the simulator
# (bench/container_latency.py), and the local model against direct rendering through the
# namespace topology. Writes bench/results/container_latency.{md,csv,png} and
# the runs in bench/results/raw/container_latency.jsonl. About 5 minutes after the build
# and the image (deploy/containers.sh).
#   bench/run_container_latency.sh [--blocks 3] [--block-seconds 3] [--grid-seconds 3] [--press-seconds 4]
#                                  [--parts layers,udp,sim,remote]
# --parts reruns only those parts (the others' rows come from the last run's raw log);
# without layers the container image is not needed. The remote grid alone takes about
# 5 minutes (7 cells x 6 ways of rendering x the press).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
bash deploy/install.sh
bash deploy/build.sh normal >/dev/null
parts="layers"
for ((i = 1; i <= $#; i++)); do
  case "${!i}" in
    --parts) j=$((i + 1)); parts="${!j}" ;;
    --parts=*) parts="${!i#--parts=}" ;;
  esac
done
if [[ ",$parts," == *",layers,"* ]]; then
  bash deploy/containers.sh
fi

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
mkdir -p bench/results/raw
table="$(.venv/bin/python bench/container_latency.py build/bin bench/results "$@")"
out=bench/results/container_latency.md
{
  echo "# Latency in the network lab: loopback, namespaces, containers, and today's rendering under delay"
  echo
  echo "$(date -u +%F), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)),"
  echo "load average before the run: $load_before. Produced by bench/run_container_latency.sh $*;"
  echo "chart container_latency.png, every row in container_latency.csv."
  echo
  echo "$table"
} >"$out"
echo "wrote $out" >&2
