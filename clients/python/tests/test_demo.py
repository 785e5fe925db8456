"""The demo's pieces that need no server: its stroke path, the round-trip summary and
the plot."""

import math

import numpy as np

from hapticd.demo import STROKE_CYCLE, Trace, plot_trace, stroke_path
from hapticd.device import summarize_rtt


def test_the_stroke_repeats_to_cover_the_run():
    path = stroke_path(5.0)
    times = [point[0] for point in path]
    assert times[0] == 0 and times[-1] >= 5.0
    assert all(b > a for a, b in zip(times, times[1:], strict=False))
    # each cycle presses below the floor and reaches past the box's face at x = 0.10
    assert min(point[3] for point in path) < 0 and max(point[1] for point in path) > 0.10
    assert path[: len(STROKE_CYCLE)] == STROKE_CYCLE


def test_round_trip_percentiles_in_microseconds():
    summary = summarize_rtt(list(range(1000, 1_001_000, 1000)))
    assert summary.samples == 1000
    assert summary.p50_us == np.percentile(np.arange(1, 1001), 50)
    assert summary.max_us == 1000
    assert math.isnan(summarize_rtt([]).p99_us)


def test_the_plot_is_a_png(tmp_path):
    trace = Trace()
    for k in range(100):
        trace.t.append(k / 1000)
        trace.position.append([0.0, 0.0, 0.01 - k * 1e-4])
        trace.force.append([0.0, 0.0, max(0.0, k * 1e-4 - 0.01) * 2000])
        trace.contact.append(k > 100)
    path = tmp_path / "plot.png"
    plot_trace(trace, str(path))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
