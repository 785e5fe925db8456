"""The UR bridge's motion limits: the base frame's transform is a rigid motion and its
inverse; the limiter never exceeds its speed or acceleration, stops at a goal without
overshooting it, and never leaves the workspace, on random goals against a brute-force
check."""

import math

import numpy as np
import pytest

from hapticd.errors import LocalError
from hapticd.ur_motion import BasePose, MotionLimiter, Workspace

DT = 0.002


def test_the_base_pose_is_a_rigid_motion_and_to_base_undoes_it():
    half = math.sqrt(0.5)
    base = BasePose((1.0, 2.0, 3.0), (half, 0.0, 0.0, half))  # 90° about z
    assert base.to_scene((1.0, 0.0, 0.0)) == pytest.approx([1.0, 3.0, 3.0])
    assert base.direction_to_scene((1.0, 0.0, 0.0)) == pytest.approx([0.0, 1.0, 0.0])
    rng = np.random.default_rng(3)
    for _ in range(50):
        p = rng.normal(size=3)
        assert base.to_base(base.to_scene(p)) == pytest.approx(p)


def test_a_bad_base_pose_is_refused():
    with pytest.raises(LocalError, match="unit quaternion"):
        BasePose((0, 0, 0), (2.0, 0.0, 0.0, 0.0))
    with pytest.raises(LocalError, match="axis y"):
        Workspace(low=(0, 1, 0), high=(1, 1, 1))


def test_the_limiter_reaches_a_far_goal_at_its_speed_and_stops_on_it():
    ws = Workspace.around((0, 0, 0), 1.0)
    limiter = MotionLimiter((0, 0, 0), max_speed=0.25, max_accel=1.0, workspace=ws)
    goal = np.array([0.3, 0.0, 0.0])
    positions = [limiter.step(goal, DT) for _ in range(int(3 / DT))]
    speeds = np.linalg.norm(np.diff(positions, axis=0), axis=1) / DT
    assert speeds.max() <= 0.25 + 1e-9
    assert max(p[0] for p in positions) <= 0.3 + 1e-12  # never past the goal
    assert positions[-1] == pytest.approx(goal, abs=1e-9)


def test_random_goals_keep_every_limit():
    rng = np.random.default_rng(11)
    ws = Workspace(low=(-0.2, -0.2, 0.0), high=(0.2, 0.2, 0.3))
    limiter = MotionLimiter((0, 0, 0.1), max_speed=0.3, max_accel=2.0, workspace=ws)
    previous_v = np.zeros(3)
    previous_p = limiter.position.copy()
    goal = np.zeros(3)
    for i in range(5000):
        if i % 250 == 0:
            goal = rng.uniform(-0.4, 0.4, 3)  # sometimes outside the workspace
        p = limiter.step(goal, DT)
        v = (p - previous_p) / DT
        assert ws.contains(p)
        assert np.linalg.norm(v) <= 0.3 + 1e-9
        # speeding up or turning is limited; only slowing down along the way, or the
        # workspace's wall, may stop it harder
        change = v - previous_v
        on_wall = np.any(np.isclose(p, ws.low)) or np.any(np.isclose(p, ws.high))
        if np.linalg.norm(change) > 2.0 * DT + 1e-9 and not on_wall:
            assert np.dot(v, previous_v) >= 0
            assert np.linalg.norm(v) <= np.linalg.norm(previous_v) + 1e-9
        previous_v, previous_p = v, p


def test_a_goal_coming_to_rest_is_never_overshot():
    # the avatar stops on a wall at x = 0.05 while the arm is on its way
    ws = Workspace.around((0, 0, 0), 1.0)
    limiter = MotionLimiter((0, 0, 0), max_speed=0.25, max_accel=1.0, workspace=ws)
    for i in range(int(2 / DT)):
        avatar_x = min(0.25 * i * DT, 0.05)
        p = limiter.step((avatar_x, 0, 0), DT)
        assert p[0] <= 0.05 + 1e-12


def test_the_start_must_be_inside_the_workspace():
    with pytest.raises(LocalError, match="outside the workspace"):
        MotionLimiter((1.0, 0, 0), 0.1, 1.0, Workspace.around((0, 0, 0), 0.5))
    with pytest.raises(LocalError, match="max_speed"):
        MotionLimiter((0, 0, 0), 0.0, 1.0, Workspace.around((0, 0, 0), 0.5))
