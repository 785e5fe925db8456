"""The rows of the speed-accuracy CSVs (bench/speed_accuracy.cc and
bench/speed_accuracy_peers.py write the same columns) and what the chart and its
reading compute from them."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Row:
    """One CSV row of either program."""

    query: str
    surface: str
    representation: str
    level: int
    triangles: int
    implementation: str
    backend: str
    queries: int
    reps: int
    time_ns: float
    time_ns_min: float
    overhead_ns: float
    error_unit: str
    error_max: float
    error_p99: float
    error_median: float
    misses: int
    note: str

    @property
    def series(self) -> tuple[str, str, str]:
        return (self.implementation, self.representation, self.backend)

    @property
    def net_time_ns(self) -> float:
        """Time per query less its trivial call (overhead_ns), never below 1 ns."""
        return max(self.time_ns - self.overhead_ns, 1.0)

    @property
    def exact(self) -> bool:
        """hapticd's exact paths: everything but raw (unconfirmed float) Embree."""
        return self.implementation == "hapticd" and self.backend != "embree_raw"


def read_rows(path: Path) -> list[Row]:
    with path.open(newline="") as file:
        rows = []
        for record in csv.DictReader(file):
            rows.append(
                Row(
                    query=record["query"],
                    surface=record["surface"],
                    representation=record["representation"],
                    level=int(record["level"]),
                    triangles=int(record["triangles"]),
                    implementation=record["implementation"],
                    backend=record["backend"],
                    queries=int(record["queries"]),
                    reps=int(record["reps"]),
                    time_ns=float(record["time_ns"]),
                    time_ns_min=float(record["time_ns_min"]),
                    overhead_ns=float(record["overhead_ns"]),
                    error_unit=record["error_unit"],
                    error_max=float(record["error_max"]),
                    error_p99=float(record["error_p99"]),
                    error_median=float(record["error_median"]),
                    misses=int(record["misses"]),
                    note=record["note"],
                )
            )
        return rows


def write_rows(rows: list[Row], path: Path) -> None:
    columns = list(Row.__dataclass_fields__)
    with path.open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([getattr(row, c) for c in columns])


def pareto_front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The points no other point beats in both time and error, by rising time."""
    front: list[tuple[float, float]] = []
    for time_ns, error in sorted(points):
        if not front or error < front[-1][1]:
            front.append((time_ns, error))
    return front


def read_choices(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))
