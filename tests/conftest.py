"""Shared fixtures for the end-to-end tests: paths to the built binaries and shared/,
a server, and `connect`: each test that takes it runs with the blocking Client and with
the AsyncClient (the package's test helper clients/python/tests/blocking_async.py)."""
import os
import pathlib
import sys

import pytest
from server_process import running_server

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "clients" / "python" / "tests"))
from blocking_async import CONNECTS  # noqa: E402


@pytest.fixture(scope="session")
def bin_dir() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("HAPTICD_BIN", REPO / "build" / "bin"))
    assert path.is_dir(), "build first: bash deploy/build.sh"
    return path


@pytest.fixture(scope="session")
def shared_dir() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("HAPTICD_SHARED", REPO.parent / "shared"))
    assert (path / "conformance").is_dir(), f"no conformance cases under {path}"
    return path


@pytest.fixture(scope="module")
def server(bin_dir):
    """A hapticd process on its default scene for one test module (server_process.py)."""
    with running_server(bin_dir, "--log-level", "warning") as process:
        yield process


@pytest.fixture(params=sorted(CONNECTS))
def connect(request):
    """hapticd.connect, or connect_async behind a blocking wrapper: the same calls."""
    return CONNECTS[request.param]
