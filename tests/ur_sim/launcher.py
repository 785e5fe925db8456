"""Starting the simulator as a process of its own and talking to its control channel,
for the tests and the benchmarks (ur_rtde's constructors block holding Python's GIL, so
the simulator can never share a process with the code under test).

    with running_simulator("--rate-hz", "125") as sim:
        sim.ask(cmd="person", force=[0, 0, -20])

Each simulator takes a loopback address of its own (ur_rtde's ports are fixed). Where
the machine grants SCHED_FIFO it runs at a real-time priority: a 500 Hz Python
controller starved by a loaded machine looks stalled to its client."""

from __future__ import annotations

import json
import os
import pathlib
import selectors
import signal
import socket
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager

TESTS = pathlib.Path(__file__).resolve().parent.parent
START_TIMEOUT_S = 20.0
UR_PORTS = (30004, 29999, 30003, 30002)


def free_loopback_address() -> str:
    """A 127.0.x.y address whose RTDE, dashboard and script ports are all free."""
    for index in range(os.getpid() % 200, os.getpid() % 200 + 4000):
        address = f"127.0.{2 + index // 250 % 250}.{2 + index % 250}"
        probes = []
        try:
            for port in UR_PORTS:
                probe = socket.socket()
                probes.append(probe)
                probe.bind((address, port))
            return address
        except OSError:
            continue
        finally:
            for probe in probes:
                probe.close()
    raise RuntimeError("no free loopback address for a simulator")


def realtime_prefix() -> list[str]:
    """chrt -f 10 where this machine grants SCHED_FIFO, else nothing."""
    try:
        probe = subprocess.run(["chrt", "-f", "10", "true"], capture_output=True, timeout=5)
    except (OSError, subprocess.TimeoutExpired):
        return []
    return ["chrt", "-f", "10"] if probe.returncode == 0 else []


class SimProcess:
    """A running simulator: its host, its endpoints (the JSON line it printed), and its
    control channel (README.md lists the requests)."""

    def __init__(self, *args: str, realtime: bool = True) -> None:
        self.host = free_loopback_address()
        self._stderr = tempfile.TemporaryFile()
        env = dict(os.environ, PYTHONPATH=str(TESTS))
        command = [sys.executable, "-m", "ur_sim", "--host", self.host, "--seed", "7",
                   "--control-port", "0", "--ur-modbus-port", "0", "--ft-modbus-port", "0", *args]
        self.process = subprocess.Popen(
            [*(realtime_prefix() if realtime else []), *command],
            stdout=subprocess.PIPE, stderr=self._stderr, env=env, text=True,
        )  # fmt: skip
        with selectors.DefaultSelector() as selector:
            assert self.process.stdout is not None
            selector.register(self.process.stdout, selectors.EVENT_READ)
            ready = selector.select(timeout=START_TIMEOUT_S)
        line = self.process.stdout.readline() if ready else ""
        if not line:
            self.process.kill()
            raise AssertionError(f"the simulator did not start: {self.log()}")
        self.endpoints = json.loads(line)
        self._control = socket.create_connection((self.host, self.endpoints["control"]), timeout=10)
        self._reader = self._control.makefile("r")

    def ctl(self, **request) -> dict:
        """One control request's answer, whatever it says."""
        self._control.sendall((json.dumps(request) + "\n").encode())
        return json.loads(self._reader.readline())

    def ask(self, **request) -> dict:
        """One control request that must succeed."""
        answer = self.ctl(**request)
        assert answer["ok"], answer
        return answer

    def state(self) -> dict:
        return self.ctl(cmd="state")

    def trace(self, since: float | None = None) -> dict:
        return self.ask(cmd="trace", since_host_time=since)

    def dashboard(self, *commands: str) -> list[str]:
        """Answers to dashboard commands over a plain socket (greeting checked)."""
        with (
            socket.create_connection((self.host, 29999), timeout=5) as sock,
            sock.makefile("r") as reader,
        ):
            assert reader.readline() == "Connected: Universal Robots Dashboard Server\n"
            answers = []
            for command in commands:
                sock.sendall((command + "\n").encode())
                answers.append(reader.readline().rstrip("\n"))
            return answers

    def wait_for(self, predicate, timeout_s: float = 2.0, what: str = "condition") -> dict:
        deadline = time.monotonic() + timeout_s
        while True:
            state = self.state()
            if predicate(state):
                return state
            assert time.monotonic() < deadline, f"timed out waiting for {what}: {state}"
            time.sleep(0.01)

    def log(self) -> str:
        self._stderr.seek(0)
        return self._stderr.read().decode(errors="replace")

    def stop(self) -> int:
        """SIGCONT (a test may have stopped it), SIGTERM; its exit status."""
        for closing in (getattr(self, "_reader", None), getattr(self, "_control", None)):
            if closing is not None:
                closing.close()
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGCONT)
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode


def rows_of(trace: dict) -> list[dict]:
    """A trace's rows as dicts of its fields."""
    fields = trace["fields"]
    return [dict(zip(fields, row, strict=True)) for row in trace["rows"]]


@contextmanager
def running_simulator(*args: str, realtime: bool = True):
    """A simulator for the with block; afterwards it must exit 0 on SIGTERM, with no
    traceback in its log."""
    sim = SimProcess(*args, realtime=realtime)
    try:
        yield sim
    finally:
        rc = sim.stop()
    log = sim.log()
    assert rc == 0, f"simulator exit status {rc}; stderr:\n{log}"
    assert "Traceback" not in log, log
