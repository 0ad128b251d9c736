"""DWB critics scored directly on hand-made trajectory batches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.dwb import DWBLocalPlanner, DWBParams, TrajectoryBatch
from navstack.control.dwb.critics import (
    CRITICS,
    BaseObstacleCritic,
    CriticContext,
    GoalDistCritic,
    OscillationCritic,
    PathDistCritic,
    PreferForwardCritic,
    RotateBeforeStartCritic,
    RotateToGoalCritic,
    TwirlingCritic,
)
from navstack.control.dwb.trajectory_generator import LimitedAccelGenerator
from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D, Twist2D
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D

from .scenes import empty_costmap, straight_path

DWB = DWBParams()
ORIGIN, STILL, GOAL = Pose2D(), Twist2D(), Pose2D(3.0, 0.0, 0.0)


def _ctx(pose: Pose2D = ORIGIN, velocity: Twist2D = STILL, goal: Pose2D = GOAL,
         plan: np.ndarray | None = None, costmap: Costmap2D | None = None, now: float = 0.0,
         batch: TrajectoryBatch | None = None) -> CriticContext:
    plan = straight_path().as_array() if plan is None else plan
    return CriticContext(pose, velocity, goal, plan, costmap or empty_costmap(), now, batch)


def _batch(commands: list[list[float]], pose: Pose2D = ORIGIN,
           velocity: Twist2D = STILL) -> TrajectoryBatch:
    return LimitedAccelGenerator().generate(pose, velocity, np.array(commands, float))


def _make(cls: type, **section: float) -> object:
    return cls(cls.__name__, cls.make_params(dict(section)), DWB)


def test_registry_accepts_nav2_names() -> None:
    for name in ("PathAlign", "PathAlignCritic", "dwb_critics::PathAlignCritic"):
        assert CRITICS.canonical(name) == "PathAlign"
    assert CRITICS.canonical("navstack::RotateBeforeStartCritic") == "RotateBeforeStart"


def test_oscillation_rejects_flip_back_until_robot_moves() -> None:
    critic = _make(OscillationCritic)
    assert isinstance(critic, OscillationCritic)
    batch = _batch([[0.1, 0, 0], [-0.1, 0, 0], [0.0, 0, 0.3]])
    ctx = _ctx()
    critic.prepare(ctx)
    critic.debrief(Twist2D(0.1, 0, 0), ctx)
    critic.debrief(Twist2D(-0.1, 0, 0), ctx)  # forward -> backward: flip recorded
    assert critic.score(batch, ctx).tolist() == [-1.0, 0.0, 0.0]  # forward again: oscillating
    moved = _ctx(pose=Pose2D(-0.04, 0, 0))
    critic.prepare(moved)
    critic.debrief(Twist2D(-0.1, 0, 0), moved)  # 0.04 m < oscillation_reset_dist 0.05
    assert critic.score(batch, moved)[0] == -1.0
    moved = _ctx(pose=Pose2D(-0.06, 0, 0))
    critic.prepare(moved)
    critic.debrief(Twist2D(-0.1, 0, 0), moved)  # moved 0.06 m: flags reset
    assert critic.score(batch, moved).tolist() == [0.0, 0.0, 0.0]


def test_oscillation_tracks_rotation_only_when_not_driving() -> None:
    critic = _make(OscillationCritic)
    assert isinstance(critic, OscillationCritic)
    ctx = _ctx()
    critic.prepare(ctx)
    critic.debrief(Twist2D(0.2, 0, 0.5), ctx)
    critic.debrief(Twist2D(0.2, 0, -0.5), ctx)  # driving: theta flips are not tracked
    assert np.all(critic.score(_batch([[0.0, 0, 0.5]]), ctx) == 0.0)
    critic.debrief(Twist2D(0.0, 0, 0.5), ctx)
    critic.debrief(Twist2D(0.0, 0, -0.5), ctx)  # in place: flip tracked
    assert critic.score(_batch([[0.0, 0, 0.5], [0.0, 0, -0.2]]), ctx).tolist() == [-1.0, 0.0]
    critic.prepare(_ctx(pose=Pose2D(0, 0, 0.25)))  # turned 0.25 rad > 0.2: reset
    critic.debrief(Twist2D(0.0, 0, -0.5), _ctx())
    assert critic.score(_batch([[0.0, 0, 0.5]]), ctx).tolist() == [0.0]


def test_rotate_to_goal_phases() -> None:
    critic = _make(RotateToGoalCritic)
    assert isinstance(critic, RotateToGoalCritic)
    goal = Pose2D(1.0, 0.0, math.pi / 2)
    batch = _batch([[0.1, 0, 0], [0.0, 0, 0.3], [0.0, 0, -0.3]])
    far = _ctx(pose=Pose2D(0.0, 0.0, 0.0), goal=goal)
    critic.prepare(far)
    assert critic.score(batch, far).tolist() == [0.0, 0.0, 0.0]
    # inside the window but still fast: only slower samples, scored speed^2*5 + yaw error
    fast = _ctx(pose=Pose2D(0.8, 0.0, 0.0), velocity=Twist2D(0.26, 0, 0), goal=goal)
    critic.prepare(fast)
    s = critic.score(_batch([[0.26, 0, 0], [0.1, 0, 0]]), fast)
    assert s[0] == -1.0 and s[1] == pytest.approx(0.1 ** 2 * 5 + math.pi / 2)
    # slow enough: only rotations are legal; the one toward the goal yaw scores lower
    slow = _ctx(pose=Pose2D(0.8, 0.0, 0.0), velocity=Twist2D(0.1, 0, 0), goal=goal)
    critic.prepare(slow)
    s = critic.score(batch, slow)
    assert s[0] == -2.0
    assert s[1] == pytest.approx(math.pi / 2 - 0.3 * 1.7)
    assert s[2] == pytest.approx(math.pi / 2 + 0.3 * 1.7)
    # latched: leaving the window does not bring translation back until reset()
    critic.prepare(far)
    assert critic.score(batch, far)[0] == -2.0
    critic.reset()
    critic.prepare(far)
    assert critic.score(batch, far)[0] == 0.0


def test_prefer_forward_and_twirling() -> None:
    batch = _batch([[-0.1, 0, 0], [0.05, 0, 0.1], [0.05, 0, 0.5], [0.2, 0, 0.3]])
    pf = _make(PreferForwardCritic)
    assert isinstance(pf, PreferForwardCritic)
    np.testing.assert_allclose(pf.score(batch, _ctx()), [1.0, 1.0, 5.0, 3.0])
    tw = _make(TwirlingCritic)
    assert isinstance(tw, TwirlingCritic) and tw.get_scale() == 0.0
    np.testing.assert_allclose(tw.score(batch, _ctx()), [0.0, 0.1, 0.5, 0.3])


def test_base_obstacle_scores_last_or_sum_and_rejects() -> None:
    cm = empty_costmap()
    cm.data[50, 52] = 100  # cell under x in [0.1, 0.15)
    cm.data[50, 54] = 40   # x in [0.2, 0.25)
    # 0.125 m/s for 1.7 s in 5 steps: poses at x = 0, .0425, .085, .1275, .17, .2125, .2125
    batch = _batch([[0.125, 0.0, 0.0]])
    last = _make(BaseObstacleCritic)
    summed = _make(BaseObstacleCritic, sum_scores=True)
    assert isinstance(last, BaseObstacleCritic) and isinstance(summed, BaseObstacleCritic)
    assert last.score(batch, _ctx(costmap=cm)).tolist() == [40.0]
    assert summed.score(batch, _ctx(costmap=cm)).tolist() == [100.0 + 40.0 + 40.0]
    cm.data[50, 53] = LETHAL_OBSTACLE
    assert last.score(batch, _ctx(costmap=cm)).tolist() == [-2.0]  # collision
    cm.data[50, 53] = NO_INFORMATION
    assert last.score(batch, _ctx(costmap=cm)).tolist() == [-3.0]  # unknown space
    off = _batch([[0.26, 0.0, 0.0]], pose=Pose2D(2.4, 0.0, 0.0))
    assert last.score(off, _ctx(costmap=cm)).tolist() == [-1.0]  # off grid


def test_base_obstacle_max_cost_keeps_a_clearance_band() -> None:
    cm = empty_costmap()
    cm.data[50, 53] = 220  # x in [0.15, 0.2): inflated, below inscribed
    batch = _batch([[0.125, 0.0, 0.0]])
    nav2 = _make(BaseObstacleCritic)
    band = _make(BaseObstacleCritic, max_cost=200)
    assert isinstance(nav2, BaseObstacleCritic) and isinstance(band, BaseObstacleCritic)
    assert nav2.score(batch, _ctx(costmap=cm)).tolist() == [0.0]  # Nav2: only >= 253
    assert band.score(batch, _ctx(costmap=cm)).tolist() == [-2.0]  # above max_cost
    # starting inside the band the robot may drive out through it (lethal still rejects)
    cm.data[50, 50:53] = 220
    assert band.score(batch, _ctx(costmap=cm)).tolist() == [0.0]
    with pytest.raises(ConfigError, match="max_cost"):
        BaseObstacleCritic.make_params({"max_cost": 300})


def test_path_dist_scores_end_distance_and_rejects_unreachable() -> None:
    cm = empty_costmap()
    plan = straight_path(2.0, y=0.3).as_array()  # plan 6 cells to the left of the robot
    batch = _batch([[0.2, 0.0, 0.0], [0.2, 0.0, 0.5]])
    critic = _make(PathDistCritic)
    assert isinstance(critic, PathDistCritic)
    ctx = _ctx(plan=plan, costmap=cm, batch=batch)
    assert critic.prepare(ctx)
    s = critic.score(batch, ctx)
    assert s[0] == 6.0 and 0.0 <= s[1] < 6.0  # turning left ends nearer the plan
    # a wall between robot and plan: the robot's side is unreachable from the plan
    cm.data[53, :] = LETHAL_OBSTACLE
    ctx = _ctx(plan=plan, costmap=cm, batch=batch)
    critic.prepare(ctx)
    assert critic.score(batch, ctx).tolist() == [-3.0, -3.0]  # unreachable area
    assert critic.reasons[2] == "unreachable area"


def test_goal_dist_uses_last_plan_pose_on_the_map() -> None:
    cm = empty_costmap(40)  # 2 m x 2 m: the plan leaves the map at x = 1.0
    batch = _batch([[0.2, 0.0, 0.0]])
    critic = _make(GoalDistCritic)
    assert isinstance(critic, GoalDistCritic)
    ctx = _ctx(costmap=cm, batch=batch)
    assert critic.prepare(ctx)
    # local goal in cell x = 39 (x = 0.95 m); trajectory end x = 0.34 m -> cell 26
    assert critic.score(batch, ctx).tolist() == [39.0 - 26.0]
    cm.data[:] = NO_INFORMATION
    assert not critic.prepare(_ctx(costmap=cm, batch=batch))


def test_rotate_before_start_turns_in_place_first() -> None:
    critic = _make(RotateBeforeStartCritic)
    assert isinstance(critic, RotateBeforeStartCritic)
    plan = straight_path(2.0).as_array()
    start = Pose2D(0.0, 0.0, -1.2)  # facing 1.2 rad right of the path
    batch = _batch([[0.1, 0, 0.3], [0.0, 0, 0.3], [0.0, 0, -0.3]], pose=start)
    ctx = _ctx(pose=start, plan=plan)
    critic.prepare(ctx)
    s = critic.score(batch, ctx)
    assert s[0] == -2.0
    assert s[1] == pytest.approx(1.2 - 0.3 * 1.7) and s[2] == pytest.approx(1.2 + 0.3 * 1.7)
    aligned = _ctx(pose=Pose2D(0.0, 0.0, -0.5), plan=plan)  # within 0.785 rad: done for good
    critic.prepare(aligned)
    assert critic.score(batch, aligned).tolist() == [0.0, 0.0, 0.0]
    critic.prepare(ctx)
    assert critic.score(batch, ctx).tolist() == [0.0, 0.0, 0.0]


def test_rotate_before_start_in_the_controller() -> None:
    dwb = DWBLocalPlanner({"critics": ["RotateBeforeStart", "BaseObstacle", "PathAlign",
                                       "PathDist", "GoalDist"]})
    cmd = dwb.compute(Pose2D(0.0, 0.0, math.pi / 2), Twist2D(), straight_path(), empty_costmap())
    assert cmd.vx == 0.0 and cmd.wz < 0.0
