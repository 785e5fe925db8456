"""The demo's pieces that need no server: its stroke path, the round-trip summary and
the plot."""

import math
import random

import matplotlib.pyplot as plt
import pytest

from hapticd.demo import STROKE_CYCLE, Trace, draw_trace, plot_trace, stroke_path
from hapticd.device import summarize_rtt


def test_the_stroke_repeats_to_cover_the_run():
    path = stroke_path(5.0)
    times = [point[0] for point in path]
    assert times[0] == 0 and times[-1] >= 5.0
    assert all(b > a for a, b in zip(times, times[1:], strict=False))
    # each cycle presses below the floor and reaches past the box's face at x = 0.10
    assert min(point[3] for point in path) < 0 and max(point[1] for point in path) > 0.10
    assert path[: len(STROKE_CYCLE)] == STROKE_CYCLE


def percentile_by_hand(values, p):
    """The linear-interpolation percentile written out: sort, take rank p/100 * (n - 1),
    and interpolate between the two neighbours around it."""
    ordered = sorted(values)
    rank = p / 100 * (len(ordered) - 1)
    below = math.floor(rank)
    above = min(below + 1, len(ordered) - 1)
    return ordered[below] + (rank - below) * (ordered[above] - ordered[below])


@pytest.mark.parametrize(
    ("rtt_ns", "expected_us"),
    [
        # 1, 2, ..., 1000 us: rank 499.5 lies between 500 and 501, and so on
        (list(range(1000, 1_001_000, 1000)), (500.5, 900.1, 990.01, 999.001, 1000.0)),
        # unordered; ranks 1, 1.8, 1.98, 1.998 over 1, 2, 3 us
        ([3000, 1000, 2000], (2.0, 2.8, 2.98, 2.998, 3.0)),
        # one round trip is every percentile
        ([7500], (7.5, 7.5, 7.5, 7.5, 7.5)),
        # two: interpolated between them
        ([0, 10_000], (5.0, 9.0, 9.9, 9.99, 10.0)),
    ],
)
def test_round_trip_percentiles_are_exact_on_hand_computed_cases(rtt_ns, expected_us):
    summary = summarize_rtt(rtt_ns)
    got = (summary.p50_us, summary.p90_us, summary.p99_us, summary.p999_us, summary.max_us)
    assert summary.samples == len(rtt_ns)
    assert got == pytest.approx(expected_us, rel=1e-12, abs=1e-12)


def test_round_trip_percentiles_agree_with_the_hand_written_oracle():
    rng = random.Random(11)
    for _ in range(200):
        rtt_ns = [rng.randrange(0, 5_000_000) for _ in range(rng.randrange(1, 300))]
        summary = summarize_rtt(rtt_ns)
        values_us = [v / 1000 for v in rtt_ns]
        for p, got in ((50, summary.p50_us), (90, summary.p90_us), (99, summary.p99_us)):
            assert got == pytest.approx(percentile_by_hand(values_us, p), rel=1e-12, abs=1e-9)
        assert summary.p999_us == pytest.approx(percentile_by_hand(values_us, 99.9), abs=1e-9)
        assert summary.max_us == max(values_us)


def test_no_round_trips_summarize_as_nan():
    summary = summarize_rtt([])
    assert summary.samples == 0
    assert all(math.isnan(v) for v in (summary.p50_us, summary.p99_us, summary.max_us))


def contact_trace():
    """100 ticks of 1 ms in contact on ticks 20-39 and 70-89."""
    trace = Trace()
    for k in range(100):
        in_contact = 20 <= k < 40 or 70 <= k < 90
        trace.t.append(k / 1000)
        trace.position.append([0.0, 0.0, 0.01 - k * 1e-4])
        trace.force.append([0.0, 0.0, 2.0 if in_contact else 0.0])
        trace.contact.append(in_contact)
    return trace


def test_the_plot_shades_each_run_of_contact():
    figure = draw_trace(contact_trace())
    force_axes = figure.axes[0]
    shading = [c for c in force_axes.collections if c.get_label() == "contact"]
    assert len(shading) == 1
    # one band per run, spanning its first to its last tick, floor to ceiling of the axes
    bands = [path.vertices for path in shading[0].get_paths()]
    assert len(bands) == 2
    spans = sorted((band[:, 0].min(), band[:, 0].max()) for band in bands)
    assert spans == [pytest.approx((0.020, 0.039)), pytest.approx((0.070, 0.089))]
    for band in bands:
        assert band[:, 1].min() == 0 and band[:, 1].max() == 1
    plt.close(figure)


def test_the_plot_is_a_png(tmp_path):
    path = tmp_path / "plot.png"
    plot_trace(contact_trace(), str(path))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
