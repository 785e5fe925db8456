"""A threaded TCP listener: one accept thread, one daemon thread per connection. Every
simulated port uses it; what a connection does is the handler's business."""

from __future__ import annotations

import logging
import socket
import threading
from collections.abc import Callable

log = logging.getLogger("ur_sim")

Handler = Callable[[socket.socket, tuple], None]


class Listener:
    """Listens on (host, port) (port 0 picks a free one; .port tells which) and runs
    handler(sock, address) on its own thread for each connection; the handler owns the
    socket and must close it. close() stops accepting."""

    def __init__(self, name: str, host: str, port: int, handler: Handler) -> None:
        self.name = name
        self._handler = handler
        self._sock = socket.create_server((host, port), reuse_port=False)
        self.host, self.port = self._sock.getsockname()[:2]
        self._thread = threading.Thread(
            target=self._accept_loop, name=f"{name}-accept", daemon=True
        )
        self._thread.start()

    def _accept_loop(self) -> None:
        while True:
            try:
                conn, address = self._sock.accept()
            except OSError:
                return  # closed
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            threading.Thread(
                target=self._run, args=(conn, address), name=f"{self.name}-conn", daemon=True
            ).start()

    def _run(self, conn: socket.socket, address: tuple) -> None:
        try:
            self._handler(conn, address)
        except ConnectionError as exc:  # the client went away mid-exchange, as clients may
            log.info("%s connection from %s ended: %s", self.name, address, exc)
            conn.close()
        except Exception:  # a handler bug must not take the simulator down
            log.exception("%s connection from %s failed", self.name, address)
            conn.close()

    def close(self) -> None:
        try:
            self._sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._sock.close()
