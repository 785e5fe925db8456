#!/usr/bin/env bash
# Installs those of the given Debian packages that are not installed yet (root): apt
# runs only when something is missing, so a set-up script that calls this is quick
# when everything is there.
#   deploy/apt_install_missing.sh LABEL PACKAGE...   (LABEL names the caller in the log)
set -euo pipefail
label="$1"
shift
missing=()
for p in "$@"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "$label: apt packages: ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
