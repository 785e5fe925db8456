#!/usr/bin/env bash
# The hapticd package on its own: builds its wheel from clients/python (an isolated
# build, whose hook has protoc generate the protocol's code), installs the wheel into a
# clean virtual environment from the pinned wheels deploy/install.sh keeps in
# .venv/wheelhouse (no network), and there runs a smoke use (deploy/package_smoke.py)
# and the command line's --version. About half a minute.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
wheelhouse="$repo/.venv/wheelhouse"
pip=("$repo/.venv/bin/pip" --disable-pip-version-check)
version="$(sed -n 's/^version = "\(.*\)"$/\1/p' "$repo/clients/python/pyproject.toml")"

"${pip[@]}" wheel --quiet --no-deps --no-index --find-links "$wheelhouse" -w "$work/dist" "$repo/clients/python"
/usr/bin/python3 -m venv --without-pip "$work/venv"
"${pip[@]}" --python "$work/venv/bin/python" install --quiet --no-compile --no-index \
  --find-links "$wheelhouse" "$work/dist/hapticd-$version-py3-none-any.whl"
(cd "$work" && "$work/venv/bin/python" "$repo/deploy/package_smoke.py" "$version")
said="$("$work/venv/bin/hapticd" --version)"
if [[ "$said" != "hapticd $version (Python client)" ]]; then
  echo "check_package: the installed hapticd --version says \"$said\", not version $version" >&2
  exit 1
fi
