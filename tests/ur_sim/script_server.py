"""The script ports (TCP 30003 realtime, 30002 secondary): URScript text in, programs out.
A program is `def name():` (or `sec name():`) at column 0 up to the next `end` at column 0;
a line outside a program is a one-line script of its own. The real ports also stream robot
state to their clients; these send nothing (ur_rtde's script client never reads)."""

from __future__ import annotations

import re
import socket

from .controller import Controller

MAX_SCRIPT_BYTES = 1 << 20
_PROGRAM_START = re.compile(r"^(def|sec)\s+\w+\s*\(\s*\)\s*:")


class ScriptAssembler:
    """Sans-I/O: feed() takes text as it arrives and returns the scripts it completed."""

    def __init__(self) -> None:
        self._partial = ""
        self._program: list[str] | None = None

    def feed(self, text: str) -> list[str]:
        self._partial += text
        scripts = []
        while "\n" in self._partial:
            line, self._partial = self._partial.split("\n", 1)
            if self._program is not None:
                self._program.append(line)
                if line.rstrip() == "end":
                    scripts.append("\n".join(self._program) + "\n")
                    self._program = None
            elif _PROGRAM_START.match(line):
                self._program = [line]
            elif line.strip() and not line.lstrip().startswith("#"):
                scripts.append(line + "\n")
        return scripts

    @property
    def buffered(self) -> int:
        return len(self._partial) + sum(len(line) + 1 for line in self._program or [])


def make_handler(controller: Controller):
    """A Listener handler: every complete script goes to controller.load_script."""

    def handle(sock: socket.socket, _address: tuple) -> None:
        assembler = ScriptAssembler()
        with sock:
            while True:
                data = sock.recv(65536)
                if not data:
                    return
                for script in assembler.feed(data.decode("utf-8", errors="replace")):
                    with controller.lock:
                        controller.load_script(script)
                if assembler.buffered > MAX_SCRIPT_BYTES:
                    with controller.lock:
                        controller.event("script_too_long", bytes=assembler.buffered)
                    return

    return handle
