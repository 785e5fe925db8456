"""hapticd-proxy, the C++ device proxy, against a real server: its 1 kHz loop with the
simulated hand strokes the default scene over the UDP channel and reports round trips,
deadline lateness and packet counts as one JSON line."""

import json
import subprocess

import pytest
from server_process import running_server


def run_proxy(bin_dir, *args, timeout=60):
    return subprocess.run(
        [str(bin_dir / "hapticd-proxy"), *args], capture_output=True, text=True, timeout=timeout
    )


def test_the_proxy_strokes_the_default_scene(bin_dir):
    with running_server(bin_dir, "--log-level", "warning") as server:
        done = run_proxy(bin_dir, "--server", server.tcp, "--seconds", "2", "--max-force", "4")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 1
    report = json.loads(lines[0])
    # every tick of the 2 s run, run or skipped after a stall of this shared machine
    ticks = report["ticks"]
    assert report["peer"] == "hapticd" and ticks + report["skipped_ticks"] == 2000
    assert ticks > 1500 and report["packets_sent"] == ticks
    # loopback: every state answered, a handful at most after the tick's budget
    assert report["packets_lost"] == 0 and report["bad"] == 0
    assert report["packets_answered"] + report["packets_late"] == ticks
    assert 0 < report["rtt_p50_us"] <= report["rtt_p99_us"] <= report["rtt_p999_us"] <= report["rtt_max_us"]
    assert 0 <= report["lateness_p50_us"] <= report["lateness_p99_us"] <= report["lateness_max_us"]
    # the hand presses into the 2000 N/m floor harder than the device's 4 N limit
    assert report["contacts"] > report["packets_answered"] // 4
    assert report["max_force_n"] == pytest.approx(4.0, abs=1e-6)


def test_the_proxy_names_bad_options_and_refusals(bin_dir):
    done = run_proxy(bin_dir, "--server", "127.0.0.1:1", "--seconds", "-1")
    assert done.returncode == 2
    assert "--seconds is -1" in done.stderr
    done = run_proxy(bin_dir, "--seconds", "1")
    assert done.returncode == 2
    assert "--server HOST:PORT or --echo HOST:PORT" in done.stderr
    # nothing listens on port 1: a clear failure, not a hang
    done = run_proxy(bin_dir, "--server", "127.0.0.1:1", "--timeout-s", "2")
    assert done.returncode == 1
    assert "cannot connect to 127.0.0.1:1" in done.stderr
