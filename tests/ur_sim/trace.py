"""A bounded record of what the simulated controller did: one row per period and a list
of events, each stamped with controller time (s since the simulator started, the RTDE
timestamp) and host time (time.monotonic() of this machine, which another process on the
same machine can compare with its own time.monotonic())."""

from __future__ import annotations

import json
from collections import deque
from typing import IO

ROW_FIELDS = ("t", "host_time", "x", "y", "z", "vx", "vy", "vz", "target", "stopped", "mode")


class Trace:
    """Rows (tuples in ROW_FIELDS order) and events (dicts), each kept up to a capacity;
    the oldest are dropped first."""

    def __init__(self, row_capacity: int, event_capacity: int = 20000) -> None:
        self.rows: deque[tuple] = deque(maxlen=row_capacity)
        self.events: deque[dict] = deque(maxlen=event_capacity)

    def add_row(self, row: tuple) -> None:
        self.rows.append(row)

    def add_event(self, t: float, host_time: float, event: str, /, **details) -> None:
        self.events.append({**details, "t": round(t, 6), "host_time": host_time, "event": event})

    def snapshot(self, since_host_time: float | None = None, last: int | None = None) -> dict:
        """Rows and events as JSON-ready data, optionally only those at or after
        since_host_time, and at most the last `last` rows."""
        rows = list(self.rows)
        events = list(self.events)
        if since_host_time is not None:
            rows = [r for r in rows if r[1] >= since_host_time]
            events = [e for e in events if e["host_time"] >= since_host_time]
        if last is not None:
            rows = rows[-last:] if last > 0 else []
        return {"fields": list(ROW_FIELDS), "rows": [_row_json(r) for r in rows], "events": events}

    def write_json_lines(self, stream: IO[str]) -> None:
        """One JSON object a line: every row as {"row": {...}}, then every event as
        {"event": {...}}."""
        for row in list(self.rows):
            stream.write(
                json.dumps({"row": dict(zip(ROW_FIELDS, _row_json(row), strict=True))}) + "\n"
            )
        for event in list(self.events):
            stream.write(json.dumps({"event": event}) + "\n")


def _row_json(row: tuple) -> list:
    t, host, x, y, z, vx, vy, vz, target, stopped, mode = row
    return [round(t, 6), host, x, y, z, vx, vy, vz, list(target) if target else None, stopped, mode]
