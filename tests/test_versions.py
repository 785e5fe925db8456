"""One version everywhere: hapticd.__version__ is the installed package's version, the
one clients/python/pyproject.toml gives, and `--version` of the Python command line
(python -m hapticd, the hapticd script) and of every C++ binary (hapticd,
hapticd-proxy, hapticd-sim, hapticd-query, which CMake builds from the same line)
prints it."""

import pathlib
import re
import subprocess
import sys

import hapticd
import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent


def pyproject_version() -> str:
    text = (REPO / "clients" / "python" / "pyproject.toml").read_text()
    return re.search(r'^version = "([0-9.]+)"$', text, re.MULTILINE).group(1)


def test_the_package_has_the_pyprojects_version():
    assert re.fullmatch(r"[0-9]+\.[0-9]+\.[0-9]+", hapticd.__version__)
    assert hapticd.__version__ == pyproject_version()


@pytest.mark.parametrize("binary", ["hapticd", "hapticd-proxy", "hapticd-sim", "hapticd-query"])
def test_every_binary_prints_the_same_version(bin_dir, binary):
    done = subprocess.run([str(bin_dir / binary), "--version"], capture_output=True, text=True,
                          timeout=30)
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"{binary} {hapticd.__version__}\n"


@pytest.mark.parametrize(
    "command",
    [[sys.executable, "-m", "hapticd"], [str(pathlib.Path(sys.executable).parent / "hapticd")]],
    ids=["python -m hapticd", "hapticd script"],
)
def test_the_python_command_line_prints_it_too(command):
    done = subprocess.run([*command, "--version"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"hapticd {hapticd.__version__} (Python client)\n"
