"""A hapticd server as a real process for the end-to-end tests: started on ephemeral
loopback ports (--tcp-port 0 --udp-port 0), its endpoints read from the first stdout
line, stopped with SIGTERM, which must end it with exit status 0."""

import json
import os
import pathlib
import resource
import selectors
import signal
import subprocess
import tempfile
import time
from contextlib import contextmanager

START_TIMEOUT_S = 20
STOP_TIMEOUT_S = 10
FEW_DESCRIPTORS_SUPP = pathlib.Path(__file__).resolve().parent / "ubsan_few_descriptors.supp"


class ServerProcess:
    """A started server: tcp and udp are its "host:port" endpoints; stderr_text() is
    its log so far."""

    def __init__(self, bin_dir: pathlib.Path, *args: str, max_open_files: int | None = None) -> None:
        self._stderr = tempfile.TemporaryFile()
        command = [str(bin_dir / "hapticd"), "--tcp-port", "0", "--udp-port", "0", *args]

        def limit_descriptors() -> None:
            if max_open_files is not None:
                resource.setrlimit(resource.RLIMIT_NOFILE, (max_open_files, max_open_files))

        env = None
        if max_open_files is not None:
            # a sanitized build's vptr check needs a descriptor of its own (the file says why)
            options = os.environ.get("UBSAN_OPTIONS", "")
            env = {**os.environ, "UBSAN_OPTIONS": f"{options}:suppressions={FEW_DESCRIPTORS_SUPP}".lstrip(":")}
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=self._stderr, text=True,
            preexec_fn=limit_descriptors, env=env,
        )
        endpoints = json.loads(self._first_line())
        self.tcp: str = endpoints["tcp"]
        self.udp: str = endpoints["udp"]

    def _first_line(self) -> str:
        """The first stdout line, within START_TIMEOUT_S; the log if it never comes."""
        assert self.process.stdout is not None
        with selectors.DefaultSelector() as selector:
            selector.register(self.process.stdout, selectors.EVENT_READ)
            if not selector.select(timeout=START_TIMEOUT_S):
                self.process.kill()
                raise AssertionError(f"hapticd printed no endpoints line: {self.stderr_text()}")
        line = self.process.stdout.readline()
        if not line:
            self.process.wait(timeout=STOP_TIMEOUT_S)
            raise AssertionError(
                f"hapticd exited ({self.process.returncode}): {self.stderr_text()}"
            )
        return line

    def rss_bytes(self) -> int:
        """The process's resident memory now."""
        status = pathlib.Path(f"/proc/{self.process.pid}/status").read_text()
        return int(next(line for line in status.splitlines() if line.startswith("VmRSS:")).split()[1]) * 1024

    def cpu_seconds(self) -> float:
        """User plus system CPU time the process used so far."""
        fields = pathlib.Path(f"/proc/{self.process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def stderr_text(self) -> str:
        """What the server logged so far."""
        self._stderr.seek(0)
        return self._stderr.read().decode(errors="replace")

    @property
    def alive(self) -> bool:
        """Whether the process is still running."""
        return self.process.poll() is None

    def stop(self) -> int:
        """SIGTERM, then its exit status (killed after STOP_TIMEOUT_S)."""
        if self.alive:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode


@contextmanager
def running_server(bin_dir: pathlib.Path, *args: str, max_open_files: int | None = None):
    """A server for the with block; afterwards it must stop cleanly on SIGTERM."""
    server = ServerProcess(bin_dir, *args, max_open_files=max_open_files)
    try:
        yield server
    finally:
        code = server.stop()
    assert code == 0, f"hapticd exited {code} on SIGTERM: {server.stderr_text()[-3000:]}"


def wait_until(predicate, timeout_s: float, interval_s: float = 0.02) -> bool:
    """Polls predicate until it is true or timeout_s passes; its last value."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value or time.monotonic() > deadline:
            return bool(value)
        time.sleep(interval_s)
