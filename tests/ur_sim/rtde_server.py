"""The RTDE server (TCP 30004): one connection per client, any number of clients (ur_rtde's
receive and control interfaces each open one).

Theory of operation: a connection's thread reads and answers setup requests and applies
input data packages to the controller; the clock thread calls publish() once per period,
which sends each started connection its output package when the period is one of that
connection's (every rate / frequency periods). All sends go through a per-connection
bounded buffer with non-blocking writes, so a client that stops reading (or a stalled
peer) never blocks the clock: its packages are dropped and counted instead.

An input variable may be set up by one connection at a time; another connection asking
for it is answered IN_USE, as the controller does. Unknown names are answered NOT_FOUND.
"""

from __future__ import annotations

import logging
import socket
import threading
import time

from . import rtde_protocol as rp
from .controller import Controller, output_accessor

log = logging.getLogger("ur_sim")

MAX_PENDING_BYTES = 256 * 1024


class RtdeConnection:
    """One client: its recipes, its send buffer and its started state."""

    def __init__(self, sock: socket.socket, server: RtdeServer) -> None:
        self.sock = sock
        self.server = server
        self.started = False
        self.output_recipe: rp.Recipe | None = None
        self.output_accessors: list = []
        self.divisor = 1
        self.input_recipes: dict[int, rp.Recipe] = {}
        self.dropped_packages = 0
        self.closed = False
        self._pending = bytearray()
        self._send_lock = threading.Lock()

    # --- sending -----------------------------------------------------------------
    def send(self, data: bytes) -> None:
        """Queue data and write what the socket takes now; drop data past the bound."""
        with self._send_lock:
            if self.closed:
                return
            if len(self._pending) + len(data) > MAX_PENDING_BYTES:
                self.dropped_packages += 1
            else:
                self._pending += data
            try:
                while self._pending:
                    sent = self.sock.send(self._pending, socket.MSG_DONTWAIT)
                    del self._pending[:sent]
            except BlockingIOError:
                pass
            except OSError:
                self.close()

    def close(self) -> None:
        self.closed = True
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass

    # --- receiving ---------------------------------------------------------------
    def serve(self) -> None:
        parser = rp.PacketParser()
        try:
            while not self.closed:
                data = self.sock.recv(65536)
                if not data:
                    break
                for packet in parser.feed(data):
                    self._handle(packet)
        except rp.ProtocolError as exc:
            log.warning("RTDE client sent a bad packet: %s", exc)
        except OSError:
            pass
        finally:
            self.closed = True
            self.server.forget(self)
            self.sock.close()

    def _handle(self, packet: rp.Packet) -> None:
        kind = packet.kind
        if kind == rp.DATA_PACKAGE:
            self._input_package(packet.payload)
        elif kind == rp.REQUEST_PROTOCOL_VERSION:
            version = int.from_bytes(packet.payload[:2], "big") if len(packet.payload) >= 2 else 0
            self.send(rp.encode_accepted(kind, version == rp.PROTOCOL_VERSION))
        elif kind == rp.GET_URCONTROL_VERSION:
            self.send(rp.encode_version(*self.server.controller.config.version))
        elif kind == rp.SETUP_OUTPUTS:
            self._setup_outputs(packet.payload)
        elif kind == rp.SETUP_INPUTS:
            self._setup_inputs(packet.payload)
        elif kind == rp.START:
            ok = (
                self.output_recipe is not None
                and self.output_recipe.valid
                or bool(self.input_recipes)
            )
            self.started = ok
            self.send(rp.encode_accepted(kind, ok))
        elif kind == rp.PAUSE:
            self.started = False
            self.send(rp.encode_accepted(kind, True))
        elif kind == rp.TEXT_MESSAGE:
            with self.server.controller.lock:
                self.server.controller.event(
                    "rtde_text_message", text=rp.decode_text_message(packet.payload)
                )
        else:
            self.send(rp.encode_text_message(f"unknown RTDE command {kind}", level=1))

    def _setup_outputs(self, payload: bytes) -> None:
        frequency, names = rp.decode_output_setup(payload)
        types = [rp.OUTPUT_TYPES.get(name, rp.NOT_FOUND) for name in names]
        recipe = rp.Recipe(1, names, types)
        self.send(rp.encode_setup_reply(rp.SETUP_OUTPUTS, recipe))
        if not recipe.valid:
            return
        rate = self.server.controller.config.rate_hz
        self.divisor = max(1, round(rate / frequency)) if frequency > 0 else 1
        self.output_accessors = [
            (output_accessor(n, w), w) for n, w in zip(names, recipe.widths, strict=True)
        ]
        self.output_recipe = recipe

    def _setup_inputs(self, payload: bytes) -> None:
        names = rp.split_names(payload)
        types = self.server.claim_inputs(self, names)
        recipe = rp.Recipe(len(self.input_recipes) + 1, names, types)
        self.send(rp.encode_setup_reply(rp.SETUP_INPUTS, recipe))
        if recipe.valid:
            self.input_recipes[recipe.recipe_id] = recipe

    def _input_package(self, payload: bytes) -> None:
        controller = self.server.controller
        recipe = self.input_recipes.get(payload[0]) if payload else None
        try:
            # accepted also before start: ur_rtde's IO interface never sends start
            if recipe is None:
                raise rp.ProtocolError(f"data package for unknown input recipe {payload[:1].hex()}")
            values = recipe.unpack(payload)
        except rp.ProtocolError as exc:
            with controller.lock:
                controller.counters["bad_packages"] += 1
            self.send(rp.encode_text_message(str(exc), level=1))
            return
        controller.apply_inputs(values, time.monotonic())

    # --- output -------------------------------------------------------------------
    def output_package(self, frame: dict) -> bytes:
        values: list = []
        for accessor, width in self.output_accessors:
            value = accessor(frame)
            if width == 1:
                values.append(value)
            else:
                values.extend(value)
        assert self.output_recipe is not None
        return rp.encode(rp.DATA_PACKAGE, self.output_recipe.pack(values))


class RtdeServer:
    """The listening side: the set of connections and who owns which input variable."""

    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self._lock = threading.Lock()
        self._connections: list[RtdeConnection] = []
        self._input_owner: dict[str, RtdeConnection] = {}

    def handle(self, sock: socket.socket, _address: tuple) -> None:
        """Listener handler: serve one client until it goes."""
        conn = RtdeConnection(sock, self)
        with self._lock:
            self._connections.append(conn)
        conn.serve()

    def forget(self, conn: RtdeConnection) -> None:
        with self._lock:
            if conn in self._connections:
                self._connections.remove(conn)
            for name in [n for n, owner in self._input_owner.items() if owner is conn]:
                del self._input_owner[name]

    def claim_inputs(self, conn: RtdeConnection, names: list[str]) -> list[str]:
        """Types for an input setup; the names are claimed only if every one is valid."""
        with self._lock:
            types = []
            for name in names:
                owner = self._input_owner.get(name)
                if name not in rp.INPUT_TYPES:
                    types.append(rp.NOT_FOUND)
                elif owner is not None and owner is not conn and not owner.closed:
                    types.append(rp.IN_USE)
                else:
                    types.append(rp.INPUT_TYPES[name])
            if all(t in rp.TYPE_FORMATS for t in types):
                for name in names:
                    self._input_owner[name] = conn
            return types

    def publish(self, k: int, frame: dict) -> None:
        """Clock callback: send period k's outputs to every started connection due."""
        with self._lock:
            connections = list(self._connections)
        for conn in connections:
            if conn.started and conn.output_recipe is not None and k % conn.divisor == 0:
                conn.send(conn.output_package(frame))

    def drop_all(self) -> int:
        """Close every connection (a fault); returns how many were open."""
        with self._lock:
            connections = list(self._connections)
        for conn in connections:
            conn.close()
        return len(connections)

    def connection_count(self) -> int:
        with self._lock:
            return len(self._connections)
