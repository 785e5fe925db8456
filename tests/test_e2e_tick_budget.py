"""End to end, the tick work budget (--tick-work-budget): on a real hapticd process over
real UDP, a device pushed through a stack of triangles that no BVH can split, or into a
convex hull of 82k faces, gets its commands flagged overrun (the last safe force, the
avatar held), each counted in its telemetry, while a second session pressing a box
beside it renders k d on every state and never overruns. A budget out of range is
refused by name."""

import subprocess

import hapticd
import numpy as np
import pytest
import trimesh
from server_process import running_server

TRIANGLES = 20000
BUDGET = 2000


def unsplittable_stack(n):
    """n different triangles in the plane z = 0.05 at x = -1, all with one bounding box."""
    apex_x = np.linspace(-1.1, -0.9, n)
    vertices = np.concatenate(
        [[[-1.1, -0.1, 0.05], [-0.9, -0.1, 0.05]], np.stack([apex_x, np.full(n, 0.1), np.full(n, 0.05)], 1)]
    )
    triangles = np.stack([np.zeros(n, int), np.ones(n, int), np.arange(n) + 2], 1)
    return vertices, triangles


class BesideABox:
    """A light session pressing 2 mm into a box at the origin, and a heavy one going from
    heavy_start down to heavy_end z (x, y fixed) and staying there, one state each in
    turn: 100 states on the way, 200 at the end. The commands of both, the server's
    stats after them, and the light session's counters."""

    def __init__(self, client, heavy_start, heavy_end_z):
        heavy_info = client.open_session("impedance", start=heavy_start)
        light_info = client.open_session("impedance", start=(0.01, 0.02, 0.12))
        self.light_commands, self.heavy_commands = [], []
        with hapticd.DeviceSession(heavy_info) as heavy, hapticd.DeviceSession(light_info) as light:
            light_path = np.concatenate([np.linspace(0.12, 0.098, 100), np.full(200, 0.098)])
            heavy_path = np.concatenate([np.linspace(heavy_start[2], heavy_end_z, 100), np.full(200, heavy_end_z)])
            for light_z, heavy_z in zip(light_path, heavy_path, strict=True):
                self.light_commands.append(light.exchange((0.01, 0.02, light_z), timeout_s=1.0))
                self.heavy_commands.append(heavy.exchange((heavy_start[0], heavy_start[1], heavy_z), timeout_s=1.0))
            stats = client.stats()
        self.light_counters = light.counters
        by_id = {s.session_id: s for s in stats.sessions}
        self.light_telemetry = by_id[light_info.session_id]
        self.heavy_telemetry = by_id[heavy_info.session_id]

    def check_the_light_session(self):
        """Every state answered, and the light session renders k d without an overrun."""
        assert all(c is not None for c in self.light_commands + self.heavy_commands), "a state went unanswered"
        assert not any(c.overrun for c in self.light_commands)
        assert self.light_commands[-1].force[2] == pytest.approx(2000 * 0.002, rel=0.01)
        assert self.light_counters.lost == 0
        assert self.light_telemetry.tick_overruns == 0


def scene_with_a_box(client):
    client.clear_scene()
    client.add_box("box", (0.05, 0.05, 0.05), position=(0, 0, 0.05), material={"stiffness": 2000})


def test_a_session_in_a_pathological_spot_overruns_alone(bin_dir):
    with running_server(bin_dir, "--log-level", "warning", "--tick-work-budget", str(BUDGET)) as server:
        with hapticd.connect(server.tcp, timeout_s=30) as client:
            scene_with_a_box(client)
            vertices, triangles = unsplittable_stack(TRIANGLES)
            client.add_mesh("stack", vertices, triangles, "mesh", material={"stiffness": 2000})
            # the heavy device goes down through the stack and stays below it
            run = BesideABox(client, (-1, 0.02, 0.07), 0.04)
    run.check_the_light_session()
    overruns = [c for c in run.heavy_commands if c.overrun]
    assert len(overruns) > 100
    # the proxy never got through: the held avatar stays above the stack's plane
    assert all(c.avatar[2] >= 0.05 for c in overruns)
    # every flagged command is a counted overrun; ticks the server makes on its own while
    # a state is late (the watchdog's) may overrun too, unanswered
    assert len(overruns) <= run.heavy_telemetry.tick_overruns <= run.heavy_telemetry.ticks


def test_a_session_inside_a_hull_of_many_faces_overruns_alone(bin_dir):
    # A sphere of 81,920 triangles pinned as its convex hull: a point inside asks every
    # face which is nearest (a unit of work per eight), more than the default budget
    # holds; the hull's queries once went unmetered, and each such tick held up the
    # realtime thread for every session.
    sphere = trimesh.creation.icosphere(subdivisions=6, radius=0.05)
    assert len(sphere.faces) == 81920
    with running_server(bin_dir, "--log-level", "warning") as server:
        with hapticd.connect(server.tcp, timeout_s=30) as client:
            scene_with_a_box(client)
            client.add_mesh("hull", sphere.vertices, sphere.faces, "convex", position=(-1, 0, 0.1),
                            material={"stiffness": 2000})
            # the heavy device goes from above the hull to its centre and stays there
            run = BesideABox(client, (-1, 0.002, 0.2), 0.1)
    run.check_the_light_session()
    # outside the hull the heavy session renders; once its device is inside, every tick overruns
    assert not any(c.overrun for c in run.heavy_commands[:40])
    assert all(c.overrun for c in run.heavy_commands[-150:])
    assert run.heavy_telemetry.tick_overruns >= 150


@pytest.mark.parametrize("value", ["99", "10000001", "many"])
def test_a_budget_out_of_range_is_refused_by_name(bin_dir, value):
    result = subprocess.run(
        [str(bin_dir / "hapticd"), "--tick-work-budget", value], capture_output=True, text=True, timeout=10
    )
    assert result.returncode == 2
    assert "--tick-work-budget" in result.stderr and value in result.stderr
