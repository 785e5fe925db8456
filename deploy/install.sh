#!/usr/bin/env bash
# Brings a Debian 12 machine (as root) to a working hapticd checkout: Debian's build
# and library packages, then a Python virtual environment in .venv/. Idempotent, and
# fast when everything is already there: apt runs only for what is missing.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

packages=(
  build-essential cmake ninja-build g++ pkg-config git
  libasio-dev libprotobuf-dev protobuf-compiler libembree-dev libeigen3-dev
  libgtest-dev libgmock-dev libbenchmark-dev rapidjson-dev libfmt-dev libssl-dev libsodium-dev
  python3 python3-venv python3-dev openssl
  clang libclang-rt-14-dev
  socat  # two joined pseudo-terminals: a Modbus RTU line for the UR bridge's tests
  # the browser view's end-to-end test: headless Chromium over the DevTools protocol
  chromium fonts-dejavu-core
)

bash "$repo/deploy/apt_install_missing.sh" install "${packages[@]}"

# Debian's own Python, so the venv does not depend on whatever else is on PATH.
venv="$repo/.venv"
requirements="$repo/deploy/requirements.txt"
stamp="$venv/.requirements.sha256"
want="$(sha256sum "$requirements" | cut -d' ' -f1)"
if [[ ! -x "$venv/bin/python" ]] || [[ "$(cat "$stamp" 2>/dev/null)" != "$want" ]]; then
  echo "install: python environment in .venv/" >&2
  /usr/bin/python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$requirements"
  echo "$want" > "$stamp"
fi

# The wheels a clean environment installs the package from (deploy/check_package.sh,
# offline): the package's own dependencies and setuptools to build it, pinned as above.
wheelhouse="$venv/wheelhouse"
if [[ "$(cat "$wheelhouse/.requirements.sha256" 2>/dev/null)" != "$want" ]]; then
  echo "install: the package's wheels in .venv/wheelhouse/" >&2
  mapfile -t pins < <(grep -E '^(setuptools|protobuf|numpy|trimesh|matplotlib)==' "$requirements")
  "$venv/bin/pip" download --quiet --disable-pip-version-check --dest "$wheelhouse" "${pins[@]}"
  echo "$want" > "$wheelhouse/.requirements.sha256"
fi

# The protocol's Python code, from the same .proto and the same protoc as the C++ code,
# then the hapticd package itself (editable: clients/python/src is what runs; installed
# again when the environment's package is another checkout's, or another version: its
# metadata gives hapticd.__version__).
protoc -I "$repo/proto" --python_out="$repo/clients/python/src" --pyi_out="$repo/clients/python/src" \
  "$repo/proto/hapticd/v1/hapticd.proto"
if ! "$venv/bin/python" - "$repo/clients/python" 2>/dev/null <<'PYTHON'; then
import importlib.metadata, pathlib, sys, tomllib
root = pathlib.Path(sys.argv[1]).resolve()
import hapticd
want = tomllib.loads((root / "pyproject.toml").read_text())["project"]["version"]
here = pathlib.Path(hapticd.__file__).resolve().is_relative_to(root / "src")
sys.exit(0 if here and importlib.metadata.version("hapticd") == want else 1)
PYTHON
  "$venv/bin/pip" install --quiet --disable-pip-version-check --no-deps -e "$repo/clients/python"
fi
