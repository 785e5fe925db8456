#!/usr/bin/env bash
# The network lab in namespaces (root; iproute2): a server namespace and N device
# namespaces, each joined to a router namespace by a veth pair. The router forwards IP
# (the control channel's TCP goes straight through) and runs hapticd-netem, so a device
# that sends its realtime datagrams to the relay (hapticd-proxy --udp-via) gets the
# impaired path. Addresses live inside the namespaces only:
#
#    dev1  10.77.1.2 ---- 10.77.1.1 \
#    dev2  10.77.2.2 ---- 10.77.2.1  router (relay on :9000) 10.77.0.1 ---- 10.77.0.2  server
#    ...                            /
#
#   netlab.sh up NAME [--devices N]   make lab NAME (1 to 8 lower-case letters and
#                                     digits; 1 to 16 devices, default 1); prints JSON
#   netlab.sh down NAME               remove it (what is left of it; quiet if none)
#   netlab.sh exec NAME NS CMD...     run CMD in namespace NS: server, router, dev1...
#   netlab.sh run [--devices N] [--name NAME] [--relay-port P] [--server-udp-port P]
#                 [hapticd-netem flags...] -- CMD...
#                                     up, the relay in the router (--listen 0.0.0.0:P,
#                                     default 9000, --forward the server's UDP port,
#                                     default 7461), CMD with NETLAB_NAME, NETLAB_SERVER
#                                     (the server's address) and NETLAB_RELAY (the relay
#                                     as dev1 reaches it) set, then down: on exit and
#                                     when interrupted. CMD's status is run's; the
#                                     relay's summary goes to stderr.
# Namespaces are named hnl-NAME-server, hnl-NAME-router, hnl-NAME-devK.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"

die() { echo "netlab: $*" >&2; exit 2; }

check_name() {
  [[ "$1" =~ ^[a-z0-9]{1,8}$ ]] || die "NAME is \"$1\"; it must be 1 to 8 lower-case letters and digits"
}

ns() { echo "hnl-$1-$2"; }

lab_exists() { ip netns list | grep -q "^hnl-$1-router\b"; }

up() {
  local name="$1" devices="$2"
  check_name "$name"
  [[ "$devices" =~ ^[0-9]+$ ]] && ((devices >= 1 && devices <= 16)) ||
    die "--devices is \"$devices\"; it must be a whole number from 1 to 16"
  [[ $EUID -eq 0 ]] || die "network namespaces need root"
  lab_exists "$name" && die "lab $name exists (netlab.sh down $name)"
  local router server tag
  router="$(ns "$name" router)"
  server="$(ns "$name" server)"
  # the veth pairs are made in this namespace first: names unique to this lab
  tag="$(printf '%s' "$name" | md5sum | cut -c1-6)"
  ip netns add "$router"
  ip netns add "$server"
  ip -n "$router" link set lo up
  ip -n "$server" link set lo up
  ip netns exec "$router" sysctl -qw net.ipv4.ip_forward=1
  ip link add "h${tag}s0" type veth peer name "h${tag}s1"
  ip link set "h${tag}s0" netns "$router" name to-server
  ip link set "h${tag}s1" netns "$server" name eth0
  ip -n "$router" addr add 10.77.0.1/24 dev to-server
  ip -n "$server" addr add 10.77.0.2/24 dev eth0
  ip -n "$router" link set to-server up
  ip -n "$server" link set eth0 up
  ip -n "$server" route add default via 10.77.0.1
  local k device
  for ((k = 1; k <= devices; k++)); do
    device="$(ns "$name" "dev$k")"
    ip netns add "$device"
    ip -n "$device" link set lo up
    ip link add "h${tag}d${k}a" type veth peer name "h${tag}d${k}b"
    ip link set "h${tag}d${k}a" netns "$router" name "to-dev$k"
    ip link set "h${tag}d${k}b" netns "$device" name eth0
    ip -n "$router" addr add "10.77.$k.1/24" dev "to-dev$k"
    ip -n "$device" addr add "10.77.$k.2/24" dev eth0
    ip -n "$router" link set "to-dev$k" up
    ip -n "$device" link set eth0 up
    ip -n "$device" route add default via "10.77.$k.1"
  done
  local list=""
  for ((k = 1; k <= devices; k++)); do
    list+="${list:+, }{\"namespace\": \"$(ns "$name" "dev$k")\", \"address\": \"10.77.$k.2\", \"router\": \"10.77.$k.1\"}"
  done
  echo "{\"name\": \"$name\", \"server\": {\"namespace\": \"$server\", \"address\": \"10.77.0.2\"}," \
    "\"router\": {\"namespace\": \"$router\", \"address\": \"10.77.0.1\"}, \"devices\": [$list]}"
}

down() {
  local name="$1"
  check_name "$name"
  local namespace
  # deleting a namespace deletes its veth ends, and so their peers
  for namespace in $(ip netns list | awk '{print $1}' | grep "^hnl-$name-" || true); do
    ip netns pids "$namespace" 2>/dev/null | xargs -r kill -TERM 2>/dev/null || true
    ip netns del "$namespace"
  done
}

exec_in() {
  local name="$1" where="$2"
  shift 2
  [[ "${1:-}" == "--" ]] && shift
  check_name "$name"
  [[ $# -gt 0 ]] || die "exec NAME NS needs a command"
  ip netns list | grep -q "^$(ns "$name" "$where")\b" || die "no namespace $where in lab $name"
  exec ip netns exec "$(ns "$name" "$where")" "$@"
}

run() {
  local devices=1 name="r$$" relay_port=9000 server_udp_port=7461
  local relay_flags=()
  while [[ $# -gt 0 && "$1" != "--" ]]; do
    case "$1" in
      --devices) devices="${2:?--devices needs a value}"; shift 2 ;;
      --name) name="${2:?--name needs a value}"; shift 2 ;;
      --relay-port) relay_port="${2:?--relay-port needs a value}"; shift 2 ;;
      --server-udp-port) server_udp_port="${2:?--server-udp-port needs a value}"; shift 2 ;;
      *) relay_flags+=("$1"); shift ;;
    esac
  done
  [[ "${1:-}" == "--" ]] || die "run needs -- CMD..."
  shift
  [[ $# -gt 0 ]] || die "run needs a command after --"
  check_name "$name"
  local netem="${HAPTICD_BIN:-$repo/build/bin}/hapticd-netem"
  [[ -x "$netem" ]] || die "no $netem (build first: bash deploy/build.sh)"
  # globals: the trap runs after run has returned
  run_name="$name"
  run_relay_out="$(mktemp)"
  run_relay_pid=""
  # shellcheck disable=SC2317  # called by the trap
  teardown() {
    # every background job: a signal can come between starting one (cmd &) and
    # keeping its pid ($!), and a command left running would hold the caller's pipes.
    # The command first, then the relay, whose summary comes last.
    local pid others=()
    for pid in $(jobs -p); do
      [[ "$pid" == "$run_relay_pid" ]] || others+=("$pid")
    done
    if ((${#others[@]})); then
      kill -TERM "${others[@]}" 2>/dev/null || true
      wait "${others[@]}" 2>/dev/null || true
    fi
    if [[ -n "$run_relay_pid" ]]; then
      kill -TERM "$run_relay_pid" 2>/dev/null || true
      wait "$run_relay_pid" 2>/dev/null || true
    fi
    # the relay's summary, when it got to write one (its first line is its endpoints)
    if (($(wc -l <"$run_relay_out") > 1)); then tail -n 1 "$run_relay_out" >&2 || true; fi
    rm -f "$run_relay_out"
    down "$run_name"
  }
  trap teardown EXIT
  trap 'exit 130' INT TERM HUP
  up "$name" "$devices" >/dev/null
  ip netns exec "$(ns "$name" router)" "$netem" --listen "0.0.0.0:$relay_port" \
    --forward "10.77.0.2:$server_udp_port" "${relay_flags[@]}" >"$run_relay_out" &
  run_relay_pid=$!
  local waited=0
  until [[ -s "$run_relay_out" ]]; do
    kill -0 "$run_relay_pid" 2>/dev/null || die "the relay did not start (its flags?)"
    sleep 0.05
    ((waited += 1))
    ((waited < 200)) || die "the relay did not start within 10 s"
  done
  # in the background, so that a signal to this script is handled at once (bash runs a
  # trap only after its foreground command ends)
  NETLAB_NAME="$name" NETLAB_SERVER=10.77.0.2 NETLAB_RELAY="10.77.1.1:$relay_port" "$@" &
  local command_pid=$! status=0
  wait "$command_pid" || status=$?
  return "$status"
}

case "${1:-}" in
  up) [[ $# -ge 2 ]] || die "up NAME [--devices N]"
      devices=1
      if [[ "${3:-}" == "--devices" ]]; then devices="${4:?--devices needs a value}"; fi
      up "$2" "$devices" ;;
  down) [[ $# -eq 2 ]] || die "down NAME"; down "$2" ;;
  exec) [[ $# -ge 4 ]] || die "exec NAME NS CMD..."; shift; exec_in "$@" ;;
  run) shift; run "$@" ;;
  *) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d' | sed 's/^# \{0,1\}//' >&2; exit 2 ;;
esac
