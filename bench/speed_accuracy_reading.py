"""The reading beside the speed-accuracy chart (bench/results/speed_accuracy.md): the
cheapest representation for a tolerance, the scene's own choice checked against that
rule, and hapticd's fastest exact path against every peer at equal accuracy."""

from __future__ import annotations

from typing import Any

from speed_accuracy_results import Row

QUERY_NAMES = {
    "closest_point": "closest point",
    "first_hit": "first hit",
    "force_point": "point avatar force",
    "force_sphere": "sphere avatar force",
}
# Two errors count as equal accuracy within this ratio (float peers round a little more).
EQUAL_ACCURACY = 1.01


def prose(text: str) -> str:
    """A paragraph written across source lines, as one line of Markdown."""
    return " ".join(text.split())


INTRODUCTION = [
    prose("""- Surfaces: a sphere (R = 50 mm) and a torus (R = 50 mm, r = 20 mm) with analytic
    ground truth; tessellations of 80, 1,280, 20,480, 327,680 and 1,310,720 triangles (levels
    0-4). The torus has no analytic primitive in hapticd (its shapes are sphere, box, capsule,
    plane, convex, mesh), so it has no primitive row; its convex hull is wrong by design (it
    fills the hole)."""),
    prose("""- Inputs, fixed seed, the same for every implementation: 2,000 points within 3 mm of
    the surface (both sides); 2,000 segments from 4 mm outside through the surface to 12 mm
    inside, within 60 degrees of the normal; 64 contact sites pressed 1-2 mm in."""),
    prose("""- Errors (the largest over the inputs; p99 and median in the CSV): closest point, the
    error of the unsigned distance, m; first hit, the distance from the true first hit, m (a
    miss counts the distance to the segment's end and is counted in `misses`); forces,
    |f - k d n| after 20 settling ticks, N."""),
    prose("""- Time: the lower median over 3-9 repetitions of the batch, per query; forces: per
    tick of a RenderSession held still in contact (the tick's whole pipeline). Slow rows (the
    hull at the finest levels) are timed on fewer inputs (`queries` column)."""),
]
SCENE_CHECK = prose("""For each tessellation, `scene::ChooseMeshRepresentation` proves a bound
between the mesh and each cheaper candidate (fitted sphere, box, capsule, hull). Given the
mesh, the rule picks, among the candidates within the tolerance and the mesh itself, the one
this chart measured cheapest for each query; the scene picks the first of a fitted sphere, box
or capsule within the tolerance, else the mesh (the hull only when a client pins it).""")
AIM = prose("""Same inputs, same tessellations, one run. hapticd's fastest exact path: the
faster of the native BVH and the Embree backend on the same mesh (raw float Embree is not
exact and is left out), or the analytic primitive against a peer's primitive. Times are
net of the same call on a trivial input (raw time in brackets): for the peers' distances,
their Python call on their cheapest pair (a point and a small sphere 1 m apart); for first
hits, on both sides, the same segments moved off the surface so that each misses at its
first box (embreex: 10 m off, outside Embree's root; hapticd: 0.3 m off, within the
Embree backend's trust bound), which takes each side's fixed cost per call (for embreex,
the binding's too) out of both. hapticd's distances are as measured.""")
AIM_EQUAL_ACCURACY = prose("""The aim's own terms: for each peer row, the fastest of
hapticd's exact rows on the same surface and query, whatever the representation, whose
largest error is no larger (within 1%). Where the analytic primitive exists it is that
(the scene's rule picks it too); the torus has none, so its comparisons are mesh against
mesh.""")
NOTES = [
    prose("""- Peers answer only what they offer: coal and python-fcl the distance (a point as a
    radius-0 sphere; their OBBRSS BVH, and their sphere primitive), embreex the first hit (float
    rays). No peer renders haptic forces, so the force panels hold hapticd alone."""),
    prose("""- python-fcl's distance returns -1 for overlapping shapes; it runs with
    `enable_signed_distance`, whose penetration depth for a point inside its sphere is
    approximate."""),
    prose("""- Mesh forces err mostly in direction: without force shading (off by default in
    the avatar settings, and here) the force follows the facet normal, whose angle to the true
    normal shrinks only as 1/sqrt(triangles), while the distance error shrinks as
    1/triangles."""),
    prose("""- Timings are from a shared 2-core machine where other builds may run: a row is
    the median of its repetitions, but one row can still vary 2-3x between runs when other
    work shares the cores (the load average is in the run line above). Trust ratios larger
    than that; neighbouring levels show the noise."""),
]


def describe(row: Row) -> str:
    level = "" if row.level < 0 else f" L{row.level} ({row.triangles:,} tri)"
    backend = "" if row.representation != "mesh" else f", {row.backend}"
    return f"{row.representation}{level}{backend}"


def error_in_metres(row: Row, stiffness: float) -> float:
    """Force errors as the depth that would give them (|f error| / k)."""
    return row.error_max / stiffness if row.error_unit == "N" else row.error_max


def fastest(rows: list[Row], net: bool = False) -> Row | None:
    """The row of least time per query (net: less its trivial call, as peers compare)."""
    return min(rows, key=lambda r: r.net_time_ns if net else r.time_ns) if rows else None


def net_and_raw(row: Row) -> str:
    """A row's time per query net of its trivial call, and the raw time where they differ."""
    if row.overhead_ns > 0:
        return f"{row.net_time_ns:,.0f} ns ({row.time_ns:,.0f} raw)"
    return f"{row.time_ns:,.0f} ns"


class Reading:
    def __init__(
        self, rows: list[Row], choices: list[dict[str, str]], manifest: dict[str, Any]
    ) -> None:
        self.rows = rows
        self.choices = choices
        self.stiffness = float(manifest["stiffness"])
        self.tolerances = [float(t) for t in manifest["tolerances"]]
        self.surfaces = [s["name"] for s in manifest["surfaces"]]
        self.lines: list[str] = []

    def hapticd(
        self,
        query: str,
        surface: str,
        representation: str,
        level: int | None = None,
        exact: bool = True,
    ) -> list[Row]:
        return [
            r
            for r in self.rows
            if r.implementation == "hapticd"
            and r.query == query
            and r.surface == surface
            and r.representation == representation
            and (level is None or r.level == level)
            and (r.exact or not exact)
        ]

    def cheapest_within(
        self, query: str, surface: str, tolerance: float, net: bool = False
    ) -> Row | None:
        """hapticd's fastest exact row whose largest error is within the tolerance."""
        fits = [
            r
            for r in self.rows
            if r.exact
            and r.query == query
            and r.surface == surface
            and error_in_metres(r, self.stiffness) <= tolerance
        ]
        return fastest(fits, net)

    def rule_table(self) -> None:
        out = self.lines
        out += [
            "## Which representation renders a tolerance at the lowest cost",
            "",
            prose(f"""The cheapest of hapticd's exact rows whose largest error against the
            analytic surface is within the tolerance (forces: |force error| / k, k =
            {self.stiffness:g} N/m, so 1e-3 N is 0.5 um of depth)."""),
            "",
            "| tolerance | surface | " + " | ".join(QUERY_NAMES.values()) + " |",
            "|---|---|" + "---|" * len(QUERY_NAMES),
        ]
        hull_picked = False
        for tolerance in self.tolerances:
            for surface in self.surfaces:
                cells = []
                for query in QUERY_NAMES:
                    best = self.cheapest_within(query, surface, tolerance)
                    hull_picked |= best is not None and best.representation == "hull"
                    cells.append(
                        "none of the five levels"
                        if best is None
                        else f"{describe(best)}: {best.time_ns:,.0f} ns"
                    )
                out.append(f"| {tolerance:g} m | {surface} | " + " | ".join(cells) + " |")
        hull = (
            "the convex hull where it is within the tolerance and cheaper than that mesh"
            if hull_picked
            else "the convex hull never: wherever it is as accurate, the mesh is cheaper"
        )
        out += [
            "",
            prose(f"""The rule this follows: the analytic primitive wherever the surface is one
            (exact, and the cheapest); otherwise the coarsest tessellation whose error is within
            the tolerance, on the faster backend; {hull}."""),
            "",
        ]

    def candidate_costs(
        self, query: str, surface: str, level: int, bounds: dict[str, float], tolerance: float
    ) -> dict[str, Row | None]:
        """The representations the scene may choose for this tessellation at this tolerance,
        with hapticd's measured row for each (None: not measured)."""
        costs: dict[str, Row | None] = {
            "mesh": fastest(self.hapticd(query, surface, "mesh", level))
        }
        if bounds.get("sphere", float("inf")) <= tolerance:
            costs["sphere"] = fastest(self.hapticd(query, surface, "primitive"))
        for kind in ("box", "capsule"):
            if bounds.get(kind, float("inf")) <= tolerance:
                costs[kind] = None
        if bounds.get("convex", float("inf")) <= tolerance:
            costs["convex"] = fastest(self.hapticd(query, surface, "hull", level))
        return costs

    def scene_check(self) -> None:
        out = self.lines
        bounds: dict[tuple[str, int], dict[str, float]] = {}
        for c in self.choices:
            if c["tolerance"] == "pinned":
                bounds.setdefault((c["surface"], int(c["level"])), {})[c["chosen"]] = float(
                    c["error_bound"]
                )
        out += [
            "## The scene's own choice against that rule",
            "",
            SCENE_CHECK,
            "",
            "| surface | level | tolerance | scene's choice | rule: "
            + " | rule: ".join(QUERY_NAMES.values())
            + " | match |",
            "|---|---|---|---|" + "---|" * len(QUERY_NAMES) + "---|",
        ]
        matches = total = 0
        mismatches: list[str] = []
        unmeasured: set[str] = set()
        for c in self.choices:
            if c["tolerance"] == "pinned":
                continue
            surface, level, tolerance = c["surface"], int(c["level"]), float(c["tolerance"])
            cells = []
            agree = True
            for query in QUERY_NAMES:
                costs = self.candidate_costs(
                    query, surface, level, bounds.get((surface, level), {}), tolerance
                )
                measured = {k: r for k, r in costs.items() if r is not None}
                pick = min(measured, key=lambda k: measured[k].time_ns)
                unmeasured.update(k for k, r in costs.items() if r is None)
                cells.append(f"{pick} ({measured[pick].time_ns:,.0f} ns)")
                total += 1
                if pick == c["chosen"]:
                    matches += 1
                else:
                    agree = False
                    chosen = measured.get(c["chosen"])
                    chosen_cost = f"{chosen.time_ns:,.0f} ns" if chosen else "unmeasured"
                    mismatches.append(
                        f"{surface} L{level} at {tolerance:g} m, {QUERY_NAMES[query]}: the scene "
                        f"keeps the {c['chosen']} ({chosen_cost}), the {pick} costs "
                        f"{measured[pick].time_ns:,.0f} ns"
                    )
            out.append(
                f"| {surface} | {level} | {tolerance:g} m | {c['chosen']} | "
                + " | ".join(cells)
                + f" | {'yes' if agree else '**no**'} |"
            )
        out += [
            "",
            f"**Check: {matches} of {total} (tessellation, tolerance, query) cases match.**",
        ]
        if unmeasured:
            out += [
                "",
                prose(f"""A fitted {" and ".join(sorted(unmeasured))} was also within the
                tolerance in some cases; this chart does not measure it, so the rule above
                leaves it out (where it fits here, so does the sphere, which the scene
                prefers)."""),
            ]
        if mismatches:
            out += ["", "Where they differ:", ""] + [f"- {m}" for m in mismatches]
        out.append("")

    def aim(self) -> None:
        out = self.lines
        out += [
            "## Aim: hapticd's fastest exact path at or ahead of every peer at equal accuracy",
            "",
            AIM,
            "",
            "| query | surface | representation | hapticd fastest exact, net (raw) | error | peer "
            "| peer net (raw) | peer error | hapticd / peer | verdict |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        behind: list[str] = []
        # where behind: hapticd's raw float Embree 3 against the peer (net), the engine alone
        engine: list[float] = []
        compared = 0
        peers = sorted(
            (r for r in self.rows if r.implementation != "hapticd"),
            key=lambda r: (r.query, r.surface, r.level, r.implementation),
        )
        for peer in peers:
            ours = fastest(
                self.hapticd(
                    peer.query,
                    peer.surface,
                    peer.representation,
                    peer.level if peer.representation == "mesh" else None,
                ),
                net=True,
            )
            if ours is None:
                continue
            compared += 1
            equal = ours.error_max <= peer.error_max * EQUAL_ACCURACY + 1e-15
            ratio = ours.net_time_ns / peer.net_time_ns
            ahead = ratio <= 1.0
            verdict = "ahead" if ahead else "**behind**"
            if not equal:
                verdict += " (hapticd less accurate)"
            if not ahead:
                raw = fastest(
                    self.hapticd(peer.query, peer.surface, "mesh", peer.level, exact=False),
                    net=True,
                )
                context = ""
                if raw is not None and raw.backend == "embree_raw":
                    context = f"; hapticd's own raw float Embree 3 on it: {net_and_raw(raw)}"
                    engine.append(raw.net_time_ns / peer.net_time_ns)
                behind.append(
                    f"{QUERY_NAMES[peer.query]}, {peer.surface} {describe(peer)}: hapticd "
                    f"{net_and_raw(ours)} ({ours.backend}) vs {peer.implementation} "
                    f"{net_and_raw(peer)}{context}"
                )
            out.append(
                f"| {QUERY_NAMES[peer.query]} | {peer.surface} | {describe(peer)} | {ours.backend} "
                f"{net_and_raw(ours)} | {ours.error_max:.3g} | {peer.implementation} | "
                f"{peer.net_time_ns:,.0f} ({peer.time_ns:,.0f}) ns | {peer.error_max:.3g} | "
                f"{ratio:.2f} | {verdict} |"
            )
        if behind:
            out += ["", f"Same representation: **behind in {len(behind)} of {compared}**:", ""]
            out += [f"- {b}" for b in behind]
            if engine:
                slower = sum(ratio > 1.0 for ratio in engine)
                out += [
                    "",
                    prose(f"""The float engine alone, before any exact decision: hapticd's raw
                    float Embree 3 (Debian's) on the same rays, against the peer's Embree, is
                    {min(engine):.2f}-{max(engine):.2f} times its time, slower in {slower} of these
                    {len(engine)}. Where it is slower, no exact path through Debian's Embree can
                    draw level (it would decide exactly in less time than Embree decides in
                    float); only a traversal of hapticd's own that is faster than Embree 3's
                    could."""),
                ]
        else:
            out += ["", f"Same representation: at or ahead in all {compared}."]
        out.append("")
        self.aim_at_equal_accuracy(peers)

    def aim_at_equal_accuracy(self, peers: list[Row]) -> None:
        """Each peer row against hapticd's fastest exact row of any representation that is
        at least as accurate: the chart's Pareto reading of the aim."""
        out = self.lines
        out += [
            "### At equal accuracy, any representation",
            "",
            AIM_EQUAL_ACCURACY,
            "",
            "| query | surface | peer | peer net | peer error "
            "| hapticd fastest as accurate, net (raw) | its error | hapticd / peer | verdict |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        behind = 0
        for peer in peers:
            ours = self.cheapest_within(
                peer.query, peer.surface, peer.error_max * EQUAL_ACCURACY + 1e-15, net=True
            )
            if ours is None:
                behind += 1
                verdict, ours_text, error_text, ratio_text = (
                    "**behind** (none as accurate)",
                    "-",
                    "-",
                    "-",
                )
            else:
                ratio = ours.net_time_ns / peer.net_time_ns
                behind += ratio > 1.0
                verdict = "ahead" if ratio <= 1.0 else "**behind**"
                ours_text = f"{describe(ours)}: {net_and_raw(ours)}"
                error_text, ratio_text = f"{ours.error_max:.3g}", f"{ratio:.2f}"
            out.append(
                f"| {QUERY_NAMES[peer.query]} | {peer.surface} | {peer.implementation} "
                f"{describe(peer)} | {peer.net_time_ns:,.0f} ns | {peer.error_max:.3g} | "
                f"{ours_text} | {error_text} | {ratio_text} | {verdict} |"
            )
        if behind:
            out += ["", f"**Aim missed: at equal accuracy, behind in {behind} of {len(peers)}.**"]
        else:
            out += ["", f"**Aim met: at equal accuracy, at or ahead in all {len(peers)}.**"]
        out.append("")


def headline(reading: Reading) -> list[str]:
    """A few numbers from the finest tessellation and the primitive."""
    lines = ["## Headline (finest tessellation, 1.3M triangles, and the primitive)", ""]
    for surface in reading.surfaces:
        for query in QUERY_NAMES:
            rows = [
                r
                for r in reading.rows
                if r.query == query
                and r.surface == surface
                and (r.representation == "primitive" or r.level == 4)
            ]
            if not rows:
                continue
            parts = [
                f"{r.implementation if r.implementation != 'hapticd' else ''}"
                f"{' ' if r.implementation != 'hapticd' else ''}{describe(r)} {r.time_ns:,.0f} ns"
                f" (err {r.error_max:.2g} {r.error_unit})"
                for r in sorted(rows, key=lambda r: r.time_ns)
            ]
            lines.append(f"- {surface}, {QUERY_NAMES[query]}: " + "; ".join(parts))
    return lines + [""]


def hull_note(reading: Reading) -> list[str]:
    """How the hull's cost grows with its size, from its slowest rows."""
    hulls = [
        r for r in reading.rows if r.implementation == "hapticd" and r.representation == "hull"
    ]
    if not hulls:
        return []
    slowest = max(hulls, key=lambda r: r.time_ns)
    return [
        prose(f"""- The convex hull's queries grow with its size (GJK hill-climbs over its
        vertices outside; inside, every face is tried): the slowest, {slowest.query} on the
        {slowest.surface}'s {slowest.triangles:,}-face hull, takes {slowest.time_ns / 1e6:.1f} ms,
        more than a 1 kHz tick. The scene never chooses the hull by itself, only when a
        client pins it.""")
    ]


def write_reading(
    rows: list[Row],
    choices: list[dict[str, str]],
    manifest: dict[str, Any],
    machine: str,
    embree_force_calls: list[str],
) -> str:
    reading = Reading(rows, choices, manifest)
    out = reading.lines
    out += [
        "# Speed against accuracy",
        "",
        f"Run: {machine}. Reproduce with `bash bench/run_speed_accuracy.sh`; chart "
        "`speed_accuracy.png`, every row in `speed_accuracy.csv`.",
        "",
        *INTRODUCTION,
        "- Forces with the Embree backend: the force library calls "
        + (
            ", ".join(f"`embree::{c}`" for c in embree_force_calls)
            if embree_force_calls
            else "no Embree function"
        )
        + " (everything else in a tick is native).",
        "",
    ]
    out += headline(reading)
    reading.rule_table()
    reading.scene_check()
    reading.aim()
    out += ["## Notes", "", *NOTES, *hull_note(reading), ""]
    return "\n".join(out)
