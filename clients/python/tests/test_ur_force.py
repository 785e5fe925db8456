"""The UR bridge's force filter: a push passes (shrunk by the deadband, smoothed), noise
and slow drift inside the deadband never move the avatar, a push is never absorbed into
the bias, and bad input is refused by name."""

import math

import numpy as np
import pytest

from hapticd.errors import LocalError
from hapticd.ur_force import ForceFilter, ForceFilterSettings, shrink

DT = 0.002


def settle(f, reading, seconds):
    out = None
    for _ in range(int(seconds / DT)):
        out = f.update(reading, DT)
    return out


def test_shrink_is_continuous_and_keeps_the_direction():
    assert shrink(np.array([0.0, 0.0, 2.9]), 3.0).tolist() == [0, 0, 0]
    assert shrink(np.array([3.0, 4.0, 0.0]), 3.0) == pytest.approx([1.2, 1.6, 0.0])
    # just past the edge: just above zero (no step)
    assert np.linalg.norm(shrink(np.array([0.0, 0.0, 3.0001]), 3.0)) == pytest.approx(1e-4)


def test_a_steady_push_comes_through_less_the_deadband():
    f = ForceFilter(ForceFilterSettings(deadband_n=3.0, cutoff_hz=20.0))
    out = settle(f, (0.0, 0.0, -20.0), 1.0)
    assert out == pytest.approx([0.0, 0.0, -17.0], abs=1e-6)
    # the push never became bias: it was above the deadband from the first sample
    assert f.bias.tolist() == [0.0, 0.0, 0.0]


def test_the_low_pass_has_its_time_constant():
    settings = ForceFilterSettings(deadband_n=0.0, cutoff_hz=10.0, bias_time_constant_s=math.inf)
    f = ForceFilter(settings)
    tau = 1 / (2 * math.pi * 10.0)
    steps = 40
    out = settle(f, (10.0, 0.0, 0.0), steps * DT)
    assert out[0] == pytest.approx(10 * (1 - math.exp(-steps * DT / tau)), rel=1e-9)


def test_noise_inside_the_deadband_gives_exactly_zero():
    rng = np.random.default_rng(1)
    f = ForceFilter(ForceFilterSettings(deadband_n=3.0))
    for _ in range(2000):
        assert f.update(rng.normal(0.0, 0.7, 3), DT).tolist() == [0.0, 0.0, 0.0]


def test_slow_drift_is_followed_and_never_moves_the_avatar():
    # 0.5 N/s for 20 s: 10 N of drift, over three times the deadband
    f = ForceFilter(ForceFilterSettings(deadband_n=3.0, bias_time_constant_s=2.0))
    for i in range(int(20 / DT)):
        drift = 0.5 * i * DT
        assert f.update((0.0, drift, 0.0), DT).tolist() == [0.0, 0.0, 0.0]
    assert f.bias[1] == pytest.approx(10.0, abs=1.2)  # lag: rate * tau = 1 N


def test_a_push_on_top_of_a_bias_is_the_push():
    f = ForceFilter(ForceFilterSettings(deadband_n=2.0), bias=(0.0, 0.0, 8.0))
    out = settle(f, (0.0, 0.0, 8.0 - 12.0), 1.0)
    assert out == pytest.approx([0.0, 0.0, -10.0], abs=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [({"deadband_n": -1.0}, "deadband_n"), ({"cutoff_hz": 0.0}, "cutoff_hz"),
     ({"bias_time_constant_s": -2.0}, "bias_time_constant_s")],
)  # fmt: skip
def test_bad_settings_are_refused_by_name(kwargs, named):
    with pytest.raises(LocalError, match=named):
        ForceFilterSettings(**kwargs)


def test_a_non_finite_reading_is_refused():
    f = ForceFilter(ForceFilterSettings())
    with pytest.raises(LocalError, match="force reading"):
        f.update((0.0, math.nan, 0.0), DT)
