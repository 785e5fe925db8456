"""The realtime channel from the device's side: a DeviceSession sends the device's state
over a real UDP socket and receives the server's command for it.

Theory of operation. Each tick the device sends one DeviceState (sequence 1, 2, ...,
its send time on time.monotonic_ns) and waits, up to a timeout, for the DeviceCommand
that answers that sequence; the round trip is now minus the command's echoed send time:

    device ── DeviceState{seq=n, send_time_ns=t} + tag ──▶ server
           ◀── DeviceCommand{sequence=n, echo=t} + tag ─── (rtt = now - t)

Whatever else arrives meanwhile is counted and dropped: a command for an older sequence
(late after its own timeout) or a watchdog command is stale; a datagram whose tag does
not verify, that does not parse or that names another session is bad. A state whose
command does not come in time is lost. An impedance device reports in held_force the
force it rendered since its previous state (by default the last command's force); an
admittance device reports the person's force in sensed_force and goes where the
command's position says.

A local-model session (Client.open_session(remote_mode="local_model")) renders its
force on the device: the commands carry fragments of models of the scene near the
device, which every authentic command of the session hands to a LocalRenderer
(local_model.py, the server's own renderer), and render() gives each tick's force from
the newest model, whether or not a command came. Its states tell the server the newest
model held and the avatar on it, about which the server cuts the next.

A session opened with tdpa or a deadband (Client.open_session(tdpa=True, deadband=0.1))
runs the device's end of the channel (local_model.DeviceChannel, the C++ hapticd-proxy
runs): each send_state samples its passivity port (the force held over the handle's
move) and sends its energies; limit_force(force, dt) is the force to render under
two-port passivity, bounded by the energy the server's commands report (a local-model
session's: by what the hand put into render()'s rendering, relative to the surface it
touched, render() passing that surface's velocity on); and under the
deadband send_state sends only a state the server could not predict, or a keep-alive,
returning 0 when it held one back (counted in counters.held).
"""

from __future__ import annotations

import math
import socket
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hapticd._closing import ClosesOnExit
from hapticd._datagram import MAX_COMMAND_BYTES, decode_command, encode_state
from hapticd._validate import FloatArray
from hapticd.errors import ConnectionClosed, LocalError, ProtocolError, SessionEnded
from hapticd.local_model import DeviceChannel, LocalForce, LocalRenderer
from hapticd.results import SessionInfo
from hapticd.v1 import hapticd_pb2 as pb

MAX_RTT_US = 2**32 - 1


@dataclass(frozen=True, eq=False)
class Command:
    """A command from the server: the state's sequence it answers (0: a watchdog
    command), force (N) and torque (N·m) to render (impedance), position and orientation
    (w, x, y, z) to take (admittance), the avatar's position (m), contact, whether the
    watchdog is ramping the force down, whether the tick overran the server's work budget
    (the force is then the last safe one and the avatar did not move), the snapshot's
    scene version, and the measured round trip (ns)."""

    sequence: int
    force: FloatArray
    torque: FloatArray
    position: FloatArray
    orientation: FloatArray
    avatar: FloatArray
    contact: bool
    watchdog: bool
    overrun: bool
    scene_version: int
    rtt_ns: int


@dataclass
class DeviceCounters:
    """What happened on the realtime channel: states sent, fresh commands received,
    states whose command never came in time (lost), late or watchdog commands (stale),
    and datagrams that failed their tag, did not parse or named another session (bad)."""

    sent: int = 0
    received: int = 0
    lost: int = 0
    stale: int = 0
    bad: int = 0
    held: int = 0  # deadband: states held back (not sent)
    keepalives: int = 0  # deadband: states sent for the keep-alive alone


def _vec3(message: pb.Vec3) -> FloatArray:
    return np.array([message.x, message.y, message.z], dtype=np.float64)


def _set_vec3(target: pb.Vec3, value: ArrayLike, name: str) -> tuple[float, float, float]:
    """Writes a finite 3-vector into target; LocalError naming it otherwise."""
    try:
        x, y, z = (float(c) for c in np.asarray(value, dtype=np.float64).reshape(3))
    except (TypeError, ValueError) as exc:
        raise LocalError(f"{name} is {value!r}; it must be 3 numbers") from exc
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise LocalError(f"{name} is {[x, y, z]}; it must be finite")
    target.x, target.y, target.z = x, y, z
    return x, y, z


def _command(message: pb.DeviceCommand, rtt_ns: int) -> Command:
    """A Command from its message; an absent orientation is the identity."""
    q = message.orientation
    orientation = (
        np.array([q.w, q.x, q.y, q.z])
        if message.HasField("orientation")
        else np.array([1.0, 0.0, 0.0, 0.0])
    )
    return Command(
        sequence=message.sequence,
        force=_vec3(message.force),
        torque=_vec3(message.torque),
        position=_vec3(message.position),
        orientation=orientation,
        avatar=_vec3(message.avatar),
        contact=message.contact,
        watchdog=bool(message.flags & pb.COMMAND_FLAGS_WATCHDOG),
        overrun=bool(message.flags & pb.COMMAND_FLAGS_OVERRUN),
        scene_version=message.scene_version,
        rtt_ns=rtt_ns,
    )


class DeviceSession(ClosesOnExit):
    """One device's end of a session opened with Client.open_session (see the module's
    theory of operation). Not thread-safe; close() or leave its with block to end the
    session on the server too."""

    def __init__(self, info: SessionInfo, *, handle_mass: float = 0.05) -> None:
        """handle_mass (kg, > 0): the least mass the device's force moves, which the
        device's passivity port predicts with (tdpa sessions)."""
        self.info = info
        self.counters = DeviceCounters()
        self.rtt_ns: list[int] = []
        self.last_command: Command | None = None
        self._sequence = 0
        self._last_rtt_us = 0
        self._state = pb.DeviceState(session_id=info.session_id)
        # local model: the device's own renderer, on the session's clock from now
        self.local: LocalRenderer | None = None
        if info.remote_mode == "local_model":
            self.local = LocalRenderer(info.open_request)
        # two-port passivity and the deadband: the device's end of the channel
        self.channel: DeviceChannel | None = None
        self.server_energy_in = 0.0  # the largest any command of the session reported
        self.server_energy_out = 0.0
        self.commands_held = 0
        opened = pb.OpenSession()
        opened.ParseFromString(info.open_request)
        self._tdpa = info.device_type == "impedance" and opened.tdpa
        if info.device_type == "impedance" and (opened.tdpa or opened.deadband > 0):
            self.channel = DeviceChannel(info.open_request, handle_mass)
        self._states_held = 0
        self._opened_ns = time.monotonic_ns()
        self._rendered = np.zeros(3)
        family, kind, proto, _, address = socket.getaddrinfo(
            info.udp_host, info.udp_port, type=socket.SOCK_DGRAM
        )[0]
        self._socket: socket.socket | None = socket.socket(family, kind, proto)
        # connected: the kernel drops datagrams from anyone but the server's endpoint
        self._socket.connect(address)

    def __enter__(self) -> DeviceSession:
        return self

    def close(self) -> None:
        """Closes the UDP socket and then the server's session, through the Client that
        opened it (info.close_session: a CloseSession; nothing when that client, or the
        session, is closed already). Idempotent."""
        if self._socket is None:
            return
        self._socket.close()
        self._socket = None
        if self.local is not None:
            self.local.close()
        if self.channel is not None:
            self.channel.close()
        if self.info.close_session is not None:
            self.info.close_session()

    @property
    def sequence(self) -> int:
        """The sequence number of the last state sent (0: none yet)."""
        return self._sequence

    def _live_socket(self) -> socket.socket:
        if self._socket is None:
            raise LocalError("the device session is closed")
        return self._socket

    def send_state(
        self,
        position: ArrayLike,
        velocity: ArrayLike = (0.0, 0.0, 0.0),
        *,
        buttons: int = 0,
        held_force: ArrayLike | None = None,
        sensed_force: ArrayLike | None = None,
    ) -> int:
        """Sends one state: the handle's position (m) and velocity (m/s) in W, the pressed
        buttons (bit i: button i), for impedance the force held since the previous state
        (N; default the last command's force), for admittance the person's force at the
        handle (N, required). Returns its sequence number, or 0 when the session's
        deadband held it back (nothing sent). LocalError for a non-finite value or a
        missing sensed_force. A local-model device's held force defaults to the last one
        render() gave (under tdpa, limit_force()), and its state carries the model it
        holds."""
        sock = self._live_socket()
        state = self._state
        _set_vec3(state.position, position, "position")
        _set_vec3(state.velocity, velocity, "velocity")
        if not 0 <= buttons < 2**32:
            raise LocalError(f"buttons is {buttons!r}; it must fit in 32 bits")
        state.buttons = buttons
        if self.info.device_type == "admittance":
            if sensed_force is None:
                raise LocalError("sensed_force is missing; an admittance device must send it")
            _set_vec3(state.sensed_force, sensed_force, "sensed_force")
        else:
            held = held_force
            if held is None and (self.local is not None or self._tdpa):
                held = self._rendered
            elif held is None:
                held = self.last_command.force if self.last_command else (0.0, 0.0, 0.0)
            _set_vec3(state.held_force, held, "held_force")
        if self.local is not None:
            state.model_version = self.local.model_version
            _set_vec3(state.avatar, self.local.avatar, "avatar")
        if self.channel is not None:
            h = state.held_force
            verdict = self.channel.sample(
                self.session_time_s(), position, velocity, (h.x, h.y, h.z)
            )
            state.energy_in, state.energy_out = self.channel.energy_in, self.channel.energy_out
            if verdict == DeviceChannel.HOLD:
                self._states_held += 1
                self.counters.held += 1
                return 0
            state.keepalive = verdict == DeviceChannel.KEEPALIVE
            self.counters.keepalives += int(state.keepalive)
            state.states_held = self._states_held
        self._sequence += 1
        state.sequence = self._sequence
        state.rtt_us = self._last_rtt_us
        state.send_time_ns = time.monotonic_ns()
        datagram = encode_state(state, self.info.key)
        try:
            sock.send(datagram)
        except OSError as exc:
            raise ConnectionClosed(f"sending state {self._sequence} failed: {exc}") from exc
        self.counters.sent += 1
        return self._sequence

    def _receive_verified(self, deadline: float, what: str) -> tuple[pb.DeviceCommand, int] | None:
        """The next datagram that verifies and names this session, with its arrival time
        (ns), or None at the deadline; counts the bad ones it skips."""
        sock = self._live_socket()
        while True:
            remaining = deadline - time.monotonic()
            try:
                if remaining <= 0:
                    return None
                sock.settimeout(remaining)
                # one byte over the limit, so that an oversized command is seen, not cut
                datagram = sock.recv(MAX_COMMAND_BYTES + 1)
            except TimeoutError:
                return None
            except OSError as exc:
                raise ConnectionClosed(f"receiving {what} failed: {exc}") from exc
            received_ns = time.monotonic_ns()
            try:
                message = decode_command(datagram, self.info.key)
            except ProtocolError:
                self.counters.bad += 1
                continue
            if message.session_id != self.info.session_id:
                self.counters.bad += 1
                continue
            # the server's end of the channel, as it reports it (never decreasing)
            if math.isfinite(message.energy_in):
                self.server_energy_in = max(self.server_energy_in, message.energy_in)
            if math.isfinite(message.energy_out):
                self.server_energy_out = max(self.server_energy_out, message.energy_out)
            self.commands_held = max(self.commands_held, message.commands_held)
            if self.local is not None and message.HasField("model"):
                try:
                    self.local.offer(message.model, self.session_time_s())
                except ProtocolError:
                    pass  # counted in local.models_rejected; the model held stays
            return message, received_ns

    def receive_command(self, sequence: int, timeout_s: float) -> Command | None:
        """The command answering state `sequence`, waiting up to timeout_s; None (and the
        state counted lost) when it does not come in time. ConnectionClosed when the
        server's port is unreachable."""
        deadline = time.monotonic() + timeout_s
        while True:
            received = self._receive_verified(deadline, f"the command for state {sequence}")
            if received is None:
                self.counters.lost += 1
                return None
            message, received_ns = received
            self._raise_if_ended(message)
            # a sequence never sent is bad; an older state's or the watchdog's is stale
            if message.sequence > sequence:
                self.counters.bad += 1
            elif message.sequence != sequence:
                self.counters.stale += 1
            else:
                return self._accept(message, received_ns)

    def next_command(self, timeout_s: float) -> Command | None:
        """The next command of this session whatever it answers, watchdog commands
        included (sequence 0, watchdog True), or None after timeout_s. Use it to watch
        the watchdog after states stop; it records no round trip (rtt_ns 0) and counts
        nothing but bad datagrams."""
        received = self._receive_verified(time.monotonic() + timeout_s, "a command")
        if received is None:
            return None
        self._raise_if_ended(received[0])
        return _command(received[0], 0)

    def _raise_if_ended(self, message: pb.DeviceCommand) -> None:
        """SessionEnded when the server says this session has ended."""
        if message.flags & pb.COMMAND_FLAGS_SESSION_CLOSED:
            raise SessionEnded(message.session_id, "closed")
        if message.flags & pb.COMMAND_FLAGS_SESSION_TIMED_OUT:
            raise SessionEnded(message.session_id, "timed_out")

    def _accept(self, message: pb.DeviceCommand, received_ns: int) -> Command:
        """Records a fresh command and its round trip."""
        rtt_ns = received_ns - message.echo_send_time_ns
        self.rtt_ns.append(rtt_ns)
        self._last_rtt_us = min(max(rtt_ns // 1000, 0), MAX_RTT_US)
        self.counters.received += 1
        command = _command(message, rtt_ns)
        self.last_command = command
        return command

    def session_time_s(self) -> float:
        """Seconds since the session opened (here: the server's clock is a control reply
        ahead), the clock a local model's kinematic objects move on."""
        return (time.monotonic_ns() - self._opened_ns) * 1e-9

    def render(
        self, position: ArrayLike, velocity: ArrayLike = (0.0, 0.0, 0.0), *, dt: float
    ) -> LocalForce:
        """A local-model session's tick of dt s: the force to render now, from the newest
        model (free space before the first), the handle at position (m) moving at
        velocity (m/s). LocalError for a direct session."""
        if self.local is None:
            raise LocalError("render() is for a local-model session; this one is direct")
        rendered = self.local.tick(position, velocity, self._rendered, dt)
        self._rendered = rendered.force
        if self.channel is not None:
            self.channel.surface_velocity(rendered.surface_velocity)
        return rendered

    def limit_force(self, force: ArrayLike, dt: float) -> FloatArray:
        """The force (N) to render over the coming dt s: under tdpa, force saturated at
        the session's max_force and limited by the device's passivity port to what the
        server's commands have let in (a local-model session's: to what the hand put into
        the rendering, relative to the surface render() touched); otherwise force itself."""
        if self.channel is None:
            return np.asarray(force, dtype=np.float64).reshape(3).copy()
        self._rendered = self.channel.limit(self.server_energy_in, force, dt)
        return self._rendered.copy()

    def exchange(
        self,
        position: ArrayLike,
        velocity: ArrayLike = (0.0, 0.0, 0.0),
        *,
        timeout_s: float = 0.01,
        buttons: int = 0,
        held_force: ArrayLike | None = None,
        sensed_force: ArrayLike | None = None,
    ) -> Command | None:
        """send_state then receive_command for it: the command, or None when lost (or,
        under a deadband, when the state was held back: nothing is awaited)."""
        sequence = self.send_state(
            position, velocity, buttons=buttons, held_force=held_force, sensed_force=sensed_force
        )
        if sequence == 0:
            return None
        return self.receive_command(sequence, timeout_s)


@dataclass
class RttSummary:
    """Round-trip percentiles (µs) of a run, and how many round trips they are over."""

    samples: int
    p50_us: float
    p90_us: float
    p99_us: float
    p999_us: float
    max_us: float


def summarize_rtt(rtt_ns: list[int]) -> RttSummary:
    """Percentiles of round trips (ns) in µs; NaN each when there are none."""
    if not rtt_ns:
        nan = float("nan")
        return RttSummary(0, nan, nan, nan, nan, nan)
    values = np.asarray(rtt_ns, dtype=np.float64) / 1000
    p50, p90, p99, p999 = np.percentile(values, [50, 90, 99, 99.9])
    return RttSummary(
        len(values), float(p50), float(p90), float(p99), float(p999), float(values.max())
    )
