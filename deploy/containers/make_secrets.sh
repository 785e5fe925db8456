#!/usr/bin/env bash
# A self-signed certificate for the server's name inside the container network
# ("server", and any more names given) and an access token, for deploy/compose.yaml and
# deploy/k8s/: writes DIR/cert.pem, DIR/key.pem and DIR/token (readable by the
# containers' user).
#   deploy/containers/make_secrets.sh DIR [NAME...]
set -euo pipefail
[[ $# -ge 1 ]] || { echo "usage: make_secrets.sh DIR [NAME...]" >&2; exit 2; }
dir="$1"
shift
names=(server "$@")
san="$(printf 'DNS:%s,' "${names[@]}")IP:127.0.0.1"
mkdir -p "$dir"
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -keyout "$dir/key.pem" \
  -out "$dir/cert.pem" -days 30 -subj "/CN=server" -addext "subjectAltName=$san" 2>/dev/null
head -c 24 /dev/urandom | base64 | tr -d '/+=' >"$dir/token"
chmod 644 "$dir/cert.pem" "$dir/key.pem" "$dir/token"
