"""The person's force at a UR arm's tool, cleaned before it drives an admittance avatar.

A wrist force–torque sensor is not a clean force: it reads ~10 N offsets when the wrist
turns and drifts with temperature (URRD#294, #670), and its noise is a few newtons. An
admittance avatar integrates whatever it is given, so an offset is a push that never
ends: the arm creeps. ForceFilter makes three corrections, in this order:

- bias: subtracted; it follows the reading slowly (time constant bias_time_constant_s)
  while the corrected force is inside the deadband, which is when nobody pushes, so slow
  drift is tracked and a real push (above the deadband) is never absorbed;
- deadband: the force's magnitude shrunk by deadband_n (a continuous map: no step at the
  edge), so noise and the tracker's lag do not move the arm;
- low-pass: first order at cutoff_hz, against sensor noise (it adds 1/(2π f) of lag:
  8 ms at 20 Hz, small beside a servo lookahead of 30 ms and more).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hapticd._validate import FloatArray
from hapticd.errors import LocalError


@dataclass(frozen=True)
class ForceFilterSettings:
    """deadband_n (N, >= 0), cutoff_hz (Hz, > 0; inf: no low-pass), bias_time_constant_s
    (s, > 0; inf: the bias never follows)."""

    deadband_n: float = 3.0
    cutoff_hz: float = 20.0
    bias_time_constant_s: float = 2.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.deadband_n) and self.deadband_n >= 0):
            raise LocalError(f"deadband_n is {self.deadband_n!r}; it must be finite and >= 0")
        if not self.cutoff_hz > 0:
            raise LocalError(f"cutoff_hz is {self.cutoff_hz!r}; it must be > 0")
        if not self.bias_time_constant_s > 0:
            raise LocalError(
                f"bias_time_constant_s is {self.bias_time_constant_s!r}; it must be > 0"
            )


def shrink(force: FloatArray, deadband_n: float) -> FloatArray:
    """force with its magnitude reduced by deadband_n (zero inside the deadband)."""
    magnitude = float(np.linalg.norm(force))
    if magnitude <= deadband_n:
        return np.zeros(3)
    return force * ((magnitude - deadband_n) / magnitude)


class ForceFilter:
    """The filter of the module's docstring, one call of update() per sample."""

    def __init__(self, settings: ForceFilterSettings, bias: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        self.settings = settings
        self.bias = np.array(bias, dtype=float).reshape(3)
        self._smoothed = np.zeros(3)

    def update(self, reading: ArrayLike, dt: float) -> FloatArray:
        """The cleaned force for a raw reading (N) taken dt s after the previous one."""
        raw = np.asarray(reading, dtype=float).reshape(3)
        if not np.all(np.isfinite(raw)):
            raise LocalError(f"the force reading is {raw.tolist()!r}; it must be finite")
        if not dt > 0:
            raise LocalError(f"dt is {dt!r}; it must be > 0")
        s = self.settings
        corrected = raw - self.bias
        if np.linalg.norm(corrected) <= s.deadband_n:
            self.bias += corrected * (1.0 - math.exp(-dt / s.bias_time_constant_s))
        shrunk = shrink(raw - self.bias, s.deadband_n)
        alpha = 1.0 - math.exp(-2.0 * math.pi * s.cutoff_hz * dt)
        self._smoothed += alpha * (shrunk - self._smoothed)
        return self._smoothed.copy()
