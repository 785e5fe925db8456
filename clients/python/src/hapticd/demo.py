"""Closed loops over the real UDP channel: the demo (a simulated hand strokes the default
scene through a simulated impedance device) and the latency benchmark (a still device).

Both run a fixed-rate loop paced by absolute deadlines (start + k / rate_hz), so late
ticks do not shift the ones after them; the simulated physics advances exactly one
period per tick whatever the wall clock does. Each tick sends one state and waits for
its command up to command_timeout_s; a state whose command does not come is lost, and
the device keeps rendering the force it had.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from hapticd import _validate as check
from hapticd.client import Client
from hapticd.device import DeviceSession, summarize_rtt
from hapticd.sim_device import DeviceSpec, HandSpec, SimImpedanceDevice

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# The stroke over the default scene (floor z = 0; box face at x = 0.10): start above the
# floor, press 5 mm into it, slide 2 cm into the box's side, lift back, rest; 2 s a cycle.
STROKE_CYCLE = [
    (0.0, 0.05, 0.0, 0.02),
    (0.4, 0.05, 0.0, -0.005),
    (1.2, 0.12, 0.0, -0.005),
    (1.6, 0.05, 0.0, 0.02),
    (2.0, 0.05, 0.0, 0.02),
]
DEMO_HAND = {"mass": 0.3, "stiffness": 300.0, "damping": 5.0}
DEMO_DEVICE = {"mass": 0.05, "damping": 0.5, "max_force": 10.0}
# A point in free space over the default scene, for the latency benchmark.
BENCH_POSITION = (0.0, 0.0, 0.1)
# Behind by more than this many periods: give up catching up and restart the schedule.
MAX_BACKLOG_TICKS = 10


class Ticker:
    """Absolute-deadline pacing at rate_hz: wait() sleeps until the next deadline and
    counts a miss when that deadline has already passed."""

    def __init__(self, rate_hz: float) -> None:
        self.period_ns = round(1e9 / rate_hz)
        self._next_ns = time.monotonic_ns() + self.period_ns
        self.misses = 0

    def wait(self) -> None:
        """Sleeps until the next tick's deadline (at once if it has passed)."""
        now = time.monotonic_ns()
        if now < self._next_ns:
            time.sleep((self._next_ns - now) / 1e9)
        else:
            self.misses += 1
            # far behind (a stall): restart the schedule rather than burst to catch up
            if now - self._next_ns > MAX_BACKLOG_TICKS * self.period_ns:
                self._next_ns = now
        self._next_ns += self.period_ns


def stroke_path(seconds: float) -> list[tuple[float, float, float, float]]:
    """The demo's hand path: STROKE_CYCLE repeated to cover seconds."""
    cycle_s = STROKE_CYCLE[-1][0]
    cycles = max(1, int(np.ceil(seconds / cycle_s)))
    path = [STROKE_CYCLE[0]]
    for c in range(cycles):
        path += [(t + c * cycle_s, x, y, z) for t, x, y, z in STROKE_CYCLE[1:]]
    return path


@dataclass
class Trace:
    """Per-tick samples of a run: time (s), device position (m), rendered force (N),
    contact."""

    t: list[float] = field(default_factory=list)
    position: list[list[float]] = field(default_factory=list)
    force: list[list[float]] = field(default_factory=list)
    contact: list[bool] = field(default_factory=list)


def _loss_summary(session: DeviceSession, ticker: Ticker) -> dict[str, Any]:
    """The run's RTT percentiles (µs) and packet counters."""
    rtt = summarize_rtt(session.rtt_ns)
    counters = session.counters
    return {
        "rtt_p50_us": round(rtt.p50_us, 1),
        "rtt_p90_us": round(rtt.p90_us, 1),
        "rtt_p99_us": round(rtt.p99_us, 1),
        "rtt_p999_us": round(rtt.p999_us, 1),
        "rtt_max_us": round(rtt.max_us, 1),
        "packets_sent": counters.sent,
        "packets_received": counters.received,
        "packets_lost": counters.lost,
        "stale": counters.stale,
        "bad": counters.bad,
        "deadline_misses": ticker.misses,
    }


def run_demo(
    client: Client,
    seconds: float,
    *,
    rate_hz: float = 1000.0,
    command_timeout_s: float = 0.02,
    trace: Trace | None = None,
    remote_mode: str = "direct",
) -> dict[str, Any]:
    """Strokes the default scene for seconds with a simulated impedance device over a
    real session; returns the summary (RTT percentiles in µs, max_force_n, contacts:
    ticks in contact, packet counters, energy_j: the rendered force's net work,
    remote_mode, and for a local model the model version it ended on). remote_mode
    "local_model" renders the force on the device from the models the commands carry
    (DeviceSession.render), "direct" the force each command carries. Fills trace when
    given."""
    seconds = check.positive(seconds, "seconds")
    rate_hz = check.limited(rate_hz, "rate_hz", "rate_hz")
    hand = HandSpec(path=stroke_path(seconds), **DEMO_HAND)
    start = STROKE_CYCLE[0][1:]
    device = SimImpedanceDevice(hand, DeviceSpec(start=start, **DEMO_DEVICE), rate_hz)
    info = client.open_session(
        "impedance",
        max_force=DEMO_DEVICE["max_force"],
        rate_hz=rate_hz,
        start=start,
        remote_mode=remote_mode,
    )
    contacts = 0
    max_force = 0.0
    ticks = round(seconds * rate_hz)
    with DeviceSession(info) as session:
        ticker = Ticker(rate_hz)
        for k in range(ticks):
            t = k / rate_hz
            sample = device.sample(t)
            command = session.exchange(
                sample.position,
                sample.velocity,
                held_force=sample.force,
                timeout_s=command_timeout_s,
            )
            in_contact = False
            if session.local is not None:
                # the device's own rendering, command or not
                rendered = session.render(sample.position, sample.velocity, dt=1.0 / rate_hz)
                device.accept(rendered.force)
                in_contact = rendered.contact
            elif command is not None:
                # (a lost command: the device keeps rendering what it had)
                device.accept(command.force)
                in_contact = command.contact
            contacts += in_contact
            held = device.held_force
            max_force = max(max_force, float(np.linalg.norm(held)))
            if trace is not None:
                trace.t.append(t)
                trace.position.append(sample.position.tolist())
                trace.force.append(held.tolist())
                trace.contact.append(bool(in_contact))
            device.advance(t)
            ticker.wait()
        summary = _loss_summary(session, ticker)
        model_version = session.local.model_version if session.local is not None else 0
    return {
        "seconds": seconds,
        "ticks": ticks,
        **summary,
        "max_force_n": round(max_force, 4),
        "contacts": contacts,
        "energy_j": device.energy_j,
        "remote_mode": remote_mode,
        "model_version": model_version,
    }


def run_latency_bench(
    client: Client, seconds: float, *, rate_hz: float = 1000.0, command_timeout_s: float = 0.02
) -> dict[str, Any]:
    """Round trips of a still impedance device in free space for seconds at rate_hz;
    returns the percentiles (µs) and packet counters."""
    seconds = check.positive(seconds, "seconds")
    rate_hz = check.limited(rate_hz, "rate_hz", "rate_hz")
    info = client.open_session("impedance", rate_hz=rate_hz, start=BENCH_POSITION)
    ticks = round(seconds * rate_hz)
    with DeviceSession(info) as session:
        ticker = Ticker(rate_hz)
        for _ in range(ticks):
            session.exchange(BENCH_POSITION, timeout_s=command_timeout_s)
            ticker.wait()
        summary = _loss_summary(session, ticker)
    return {"seconds": seconds, "rate_hz": rate_hz, "samples": len(session.rtt_ns), **summary}


def plot_trace(trace: Trace, path: str) -> None:
    """Draws force and position over time into an image file (matplotlib, Agg)."""
    import matplotlib.pyplot as plt

    figure = draw_trace(trace)
    figure.savefig(path, dpi=120)
    plt.close(figure)


def draw_trace(trace: Trace) -> Figure:
    """The figure of plot_trace: rendered force over time (the ticks in contact shaded
    grey, one band per run of them, labelled "contact") above device position (mm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(trace.t)
    force = np.asarray(trace.force).reshape(-1, 3)
    position = np.asarray(trace.position).reshape(-1, 3) * 1000
    figure, (force_axes, position_axes) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    for axis, name in enumerate("xyz"):
        force_axes.plot(t, force[:, axis], label=f"f_{name}")
        position_axes.plot(t, position[:, axis], label=name)
    force_axes.plot(t, np.linalg.norm(force, axis=1), "k", linewidth=0.8, label="|f|")
    # shade the ticks in contact
    force_axes.fill_between(
        t,
        0,
        1,
        where=np.asarray(trace.contact, dtype=bool),
        color="grey",
        alpha=0.15,
        transform=force_axes.get_xaxis_transform(),
        label="contact",
    )
    force_axes.set_ylabel("rendered force (N)")
    position_axes.set_ylabel("device position (mm)")
    position_axes.set_xlabel("time (s)")
    for axes in (force_axes, position_axes):
        axes.legend(loc="upper right", fontsize="small")
        axes.grid(True, alpha=0.3)
    force_axes.set_title("hapticd demo: a simulated hand strokes the default scene")
    figure.tight_layout()
    return figure
