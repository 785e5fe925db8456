"""The controller's period clock: calls on_tick once per period at absolute deadlines
(start + k * period on time.monotonic), never sleep(period), so lateness does not add up.

    late by up to MAX_CATCHUP_TICKS periods -> the missed ticks run back to back, each with
                                               its own k (outputs keep one period apart)
    late by more (the process was stopped,   -> a stall: the missed ticks are skipped and the
    SIGSTOP, or starved)                        next tick carries skipped = how many, so the
                                                controller time jumps like a real controller's
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

MAX_CATCHUP_TICKS = 25

TickFn = Callable[[int, float, int], None]  # (k, nominal host time, skipped ticks before k)


def run_periodic(
    period_s: float, stop: threading.Event, on_tick: TickFn, start_host_time: float
) -> None:
    """Run until stop is set. Tick k is due at start_host_time + k * period_s."""
    next_k = 0
    while not stop.is_set():
        due = int((time.monotonic() - start_host_time) / period_s)
        if due - next_k > MAX_CATCHUP_TICKS:
            # a stall: skip to the tick due now
            on_tick(due, start_host_time + due * period_s, due - next_k)
            next_k = due + 1
        else:
            # on time, or a little late: run every tick due (none if woken early)
            while next_k <= due:
                on_tick(next_k, start_host_time + next_k * period_s, 0)
                next_k += 1
        delay = start_host_time + next_k * period_s - time.monotonic()
        if delay > 0.0:
            time.sleep(delay)
