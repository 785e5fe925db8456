"""The command line without a server: bad arguments and bad input files exit 2 with a
message naming the problem, before any connection is tried; an unreachable server
exits 1."""

import json
import math
import socket

import numpy as np
import pytest

from hapticd.cli import _strict_json, main


@pytest.fixture
def closed_port():
    """A loopback port nothing listens on."""
    with socket.create_server(("127.0.0.1", 0)) as listener:
        return f"127.0.0.1:{listener.getsockname()[1]}"


def run(argv, capsys):
    with pytest.raises(SystemExit) as exited:
        main(argv)
    return exited.value.code, capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["demo", "--seconds", "-1"], "argument --seconds: '-1' must be a finite number > 0"),
        (["demo", "--seconds", "nan"], "argument --seconds: 'nan' must be a finite number > 0"),
        (["bench", "latency", "--rate-hz", "fast"], "argument --rate-hz: 'fast' is not a number"),
        (["scene"], "the following arguments are required: ACTION"),
        (["frobnicate"], "invalid choice: 'frobnicate'"),
        (["scene", "show", "--server", "nowhere"], "--server is 'nowhere'; it must be HOST:PORT"),
    ],
)
def test_bad_arguments_exit_2_naming_them(capsys, argv, message):
    code, err = run(argv, capsys)
    assert code == 2
    assert message in err


@pytest.mark.parametrize(
    ("argv", "unknown"),
    [
        # abbreviations of --timeout, --stiffness, --seconds and --server
        (["scene", "show", "--tim"], "--tim"),
        (["scene", "load", "x.json", "--stiff", "5"], "--stiff 5"),
        (["demo", "--sec"], "--sec"),
        (["bench", "latency", "--serv", "127.0.0.1:1"], "--serv 127.0.0.1:1"),
        (["scene", "clear", "--bogus"], "--bogus"),
    ],
)
def test_an_unknown_flag_is_refused_as_unknown(capsys, argv, unknown):
    code, err = run(argv, capsys)
    assert code == 2
    assert err.splitlines()[-1] == f"python -m hapticd: error: unrecognized arguments: {unknown}"


def test_printed_json_holds_no_bare_infinity_or_nan():
    printed = json.dumps(
        _strict_json({"a": [math.inf, -math.inf, math.nan, 1.5], "b": {"c": np.float64("inf")}}),
        allow_nan=False,
    )
    assert json.loads(printed) == {"a": ["inf", "-inf", "nan", 1.5], "b": {"c": "inf"}}


def test_a_bad_scene_file_exits_2_before_connecting(tmp_path, capsys, closed_port):
    path = tmp_path / "scene.json"
    path.write_text(
        json.dumps(
            {
                "scene": {
                    "objects": [
                        {
                            "name": "s",
                            "shape": {"type": "sphere", "radius": -1},
                            "position": [0, 0, 0],
                            "material": {"stiffness": 1},
                        }
                    ]
                }
            }
        )
    )
    code, err = run(["scene", "load", str(path), "--server", closed_port], capsys)
    assert code == 2
    assert "scene.objects[0]: radius is -1.0; it must be in (0, 1000] m" in err


def test_a_missing_mesh_file_exits_2(capsys, closed_port):
    code, err = run(["scene", "load", "/nonexistent/part.stl", "--server", closed_port], capsys)
    assert code == 2 and "mesh file '/nonexistent/part.stl' does not exist" in err


def test_a_plot_into_a_missing_directory_exits_2(capsys, closed_port):
    code, err = run(["demo", "--plot", "/nonexistent/dir/x.png", "--server", closed_port], capsys)
    assert code == 2 and "its directory does not exist" in err


def test_an_unreachable_server_exits_1(capsys, closed_port):
    code, err = run(["scene", "show", "--server", closed_port], capsys)
    assert code == 1 and f"cannot connect to {closed_port}" in err


def test_version_is_the_packages(capsys):
    import hapticd

    with pytest.raises(SystemExit) as exited:
        main(["--version"])
    assert exited.value.code == 0
    assert capsys.readouterr().out == f"hapticd {hapticd.__version__} (Python client)\n"
