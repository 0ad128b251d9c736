"""DWBLocalPlanner: commands on known scenes, failures, plan pruning, parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.dwb import (
    DWBLocalPlanner,
    DWBParams,
    InvalidPlan,
    NoLegalTrajectories,
)
from navstack.control.dwb.critics import ObstacleFootprintCritic, PathAlignCritic
from navstack.core.errors import ConfigError, NoValidControl
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, Costmap2D

from .scenes import empty_costmap, left_arc, straight_path


def test_straight_path_drives_forward() -> None:
    dwb = DWBLocalPlanner()
    cmd = dwb.compute(Pose2D(), Twist2D(0.2, 0.0, 0.0), straight_path(), empty_costmap())
    assert cmd.vx > 0.2 and cmd.vy == 0.0 and abs(cmd.wz) < 0.02
    best = dwb.last_evaluation.best_trajectory  # type: ignore[union-attr]
    assert best is not None and np.all(np.abs(best[:, 1]) < 0.01)


def test_path_to_the_left_turns_left() -> None:
    dwb = DWBLocalPlanner()
    cmd = dwb.compute(Pose2D(), Twist2D(0.1, 0.0, 0.1), left_arc(1.0), empty_costmap())
    assert cmd.vx > 0.0 and cmd.wz > 0.15


def test_path_to_the_right_turns_right() -> None:
    arc = left_arc(1.0).as_array() * np.array([1.0, -1.0, -1.0])
    cmd = DWBLocalPlanner().compute(Pose2D(), Twist2D(0.1, 0.0, -0.1),
                                    Path.from_array(arc, frame_id="odom"), empty_costmap())
    assert cmd.wz < -0.15


def _box_costmap(x0: float = 0.35, x1: float = 0.55, half_width: float = 0.3) -> Costmap2D:
    """Lethal box ``x0 <= x <= x1``, ``|y| <= half_width``; inscribed 0.15 m, inflated 0.5 m."""
    cm = empty_costmap()
    c = np.arange(cm.size_x) * cm.resolution + cm.origin_x + cm.resolution / 2
    X, Y = np.meshgrid(c, c)
    dx = np.maximum(np.maximum(x0 - X, X - x1), 0.0)
    dy = np.maximum(np.abs(Y) - half_width, 0.0)
    d = np.hypot(dx, dy)
    cm.data[:] = np.where(d == 0.0, LETHAL_OBSTACLE,
                          np.where(d <= 0.15, INSCRIBED_INFLATED_OBSTACLE,
                                   np.where(d < 0.5, 252 * np.exp(-3.0 * (d - 0.15)), 0)))
    return cm


def _trajectory_costs(cm: Costmap2D, traj: np.ndarray) -> np.ndarray:
    mx = ((traj[:, 0] - cm.origin_x) / cm.resolution).astype(int)
    my = ((traj[:, 1] - cm.origin_y) / cm.resolution).astype(int)
    return cm.data[my, mx]


def test_obstacle_ahead_is_avoided() -> None:
    cm = _box_costmap()  # inscribed ring starts 0.2 m ahead of the robot
    dwb = DWBLocalPlanner()
    cmd = dwb.compute(Pose2D(), Twist2D(0.2, 0.0, 0.0), straight_path(), cm)
    ev = dwb.last_evaluation
    assert ev is not None and ev.best_trajectory is not None
    assert _trajectory_costs(cm, ev.best_trajectory).max() < INSCRIBED_INFLATED_OBSTACLE
    # every sample that would reach the ring (vx * 1.7 s > 0.2 m) was rejected as a collision
    fast = np.nonzero(ev.velocities[:, 0] > 0.2 / 1.7 + 0.01)[0]
    assert len(fast) == 14 * 21  # vx samples 0.133..0.26 m/s, every wz sample
    assert {ev.rejection_reason(int(i)) for i in fast} == {"BaseObstacle (collision)"}
    assert cmd.vx < 0.2 / 1.7


def test_obstacle_beside_the_path_is_passed() -> None:
    cm = _box_costmap(0.9, 1.3, 0.1)
    cm.data[:, :] = np.where(np.arange(cm.size_y)[:, None] < 50, cm.data, 0)  # keep y < 0 half
    dwb = DWBLocalPlanner()
    path = Path.from_array(np.array([[x, 0.35 * np.sin(np.pi * min(max(x - 0.5, 0), 1.2) / 1.2),
                                      0.0] for x in np.arange(0.0, 2.5, 0.05)]), frame_id="odom")
    pose, vel = Pose2D(), Twist2D()
    for k in range(120):
        cmd = dwb.compute(pose, vel, path, cm, k * 0.05)
        ev = dwb.last_evaluation
        assert ev is not None and ev.best_trajectory is not None
        assert _trajectory_costs(cm, ev.best_trajectory).max() < INSCRIBED_INFLATED_OBSTACLE
        th = pose.theta + cmd.wz * 0.05
        pose = Pose2D(pose.x + cmd.vx * math.cos(pose.theta) * 0.05,
                      pose.y + cmd.vx * math.sin(pose.theta) * 0.05, th)
        vel = cmd
    assert pose.x > 1.5  # drove past the box without entering its inscribed ring


def test_fully_blocked_raises_with_critic_breakdown() -> None:
    cm = empty_costmap()
    cm.data[:, 51:63] = INSCRIBED_INFLATED_OBSTACLE
    cm.data[:, 54:60] = LETHAL_OBSTACLE
    dwb = DWBLocalPlanner()
    with pytest.raises(NoValidControl) as err:
        dwb.compute(Pose2D(), Twist2D(0.2, 0.0, 0.0), straight_path(), cm)
    assert str(err.value) == ("no valid trajectory: all 420 samples rejected: "
                              "420 by BaseObstacle (collision)")
    assert isinstance(err.value, NoLegalTrajectories)
    assert err.value.rejections == {("BaseObstacle", "collision"): 420}


def test_breakdown_names_several_critics() -> None:
    cm = empty_costmap()
    cm.data[:, 51:] = LETHAL_OBSTACLE  # wall right in front of the robot
    dwb = DWBLocalPlanner({"critics": ["RotateToGoal", "BaseObstacle"]})
    # at the goal, rolling at 0.2 m/s: zero speed is out of reach this cycle (window
    # [0.075, 0.26]), so RotateToGoal keeps only the 21 slowest samples, which hit the wall
    with pytest.raises(NoLegalTrajectories) as err:
        dwb.compute(Pose2D(0.0, 0.0, 0.0), Twist2D(0.2, 0.0, 0.0), straight_path(0.0), cm)
    assert str(err.value) == ("no valid trajectory: all 420 samples rejected: "
                              "399 by RotateToGoal (translation near goal), "
                              "21 by BaseObstacle (collision)")


def test_at_goal_with_wrong_heading_rotates_toward_goal_yaw() -> None:
    plan = straight_path(1.0)  # goal (1, 0) facing +x
    for yaw, sign in ((-0.8, 1.0), (1.0, -1.0), (2.9, -1.0), (-2.9, 1.0)):
        dwb = DWBLocalPlanner()
        cmd = dwb.compute(Pose2D(1.05, 0.05, yaw), Twist2D(), plan, empty_costmap())
        assert cmd.vx == 0.0 and cmd.vy == 0.0
        assert math.copysign(1.0, cmd.wz) == sign and abs(cmd.wz) == pytest.approx(0.16)


def test_speed_limit_caps_forward_speed() -> None:
    cm, path = empty_costmap(), straight_path()
    dwb = DWBLocalPlanner()

    def fastest_sample_and_command(limit: float, percentage: bool) -> tuple[float, float]:
        dwb.set_speed_limit(limit, percentage)
        cmd = dwb.compute(Pose2D(), Twist2D(0.26, 0.0, 0.0), path, cm)
        assert dwb.last_evaluation is not None
        return float(dwb.last_evaluation.velocities[:, 0].max()), cmd.vx

    # (cell-quantised distance scores tie over a few samples; the first, slowest, wins)
    top, vx = fastest_sample_and_command(50.0, True)
    assert top == pytest.approx(0.13) and 0.5 * top < vx <= top
    top, vx = fastest_sample_and_command(0.1, False)
    assert top == pytest.approx(0.1) and 0.5 * top < vx <= top
    top, vx = fastest_sample_and_command(0.0, False)
    assert top == pytest.approx(0.26) and 0.5 * top < vx <= top


def test_plan_pruning_drops_passed_poses_for_good() -> None:
    dwb = DWBLocalPlanner()
    dwb.set_plan(straight_path(6.0))
    cm = empty_costmap(200)
    plan = dwb.transform_global_plan(Pose2D(3.0, 0.0, 0.0), cm)
    # passed part kept back to 2 m behind, forward part up to 2 m ahead
    assert plan[0, 0] == pytest.approx(1.05) and plan[-1, 0] == pytest.approx(5.0)
    # the robot is back at the start, but the pruned part is gone
    plan = dwb.transform_global_plan(Pose2D(0.0, 0.0, 0.0), cm)
    assert plan[0, 0] == pytest.approx(1.05)
    dwb.set_plan(straight_path(6.0))  # a new plan starts over
    assert dwb.transform_global_plan(Pose2D(0.0, 0.0, 0.0), cm)[0, 0] == 0.0


def test_replacing_the_plan_far_along_it_keeps_working() -> None:
    cm = empty_costmap(200)
    dwb = DWBLocalPlanner()
    path = straight_path(8.0)
    dwb.compute(Pose2D(), Twist2D(), path, cm)
    # the same plan re-expressed after a small frame correction: a new plan for DWB
    shifted = Path.from_array(path.as_array() + np.array([0.0, 0.002, 0.0]), frame_id="odom")
    cm.update_origin(4.5 - 5.0, -5.0)  # rolling window follows the robot
    cmd = dwb.compute(Pose2D(4.5, 0.0, 0.0), Twist2D(0.2, 0.0, 0.0), shifted, cm)
    assert cmd.vx > 0.2
    assert dwb.last_evaluation is not None
    assert dwb.last_evaluation.transformed_plan[0, 0] == pytest.approx(2.55)


def test_plan_far_from_robot_is_invalid() -> None:
    dwb = DWBLocalPlanner()
    with pytest.raises(InvalidPlan, match="left the path"):
        dwb.compute(Pose2D(0.0, 2.4, 0.0), Twist2D(), straight_path(1.0), empty_costmap())


def test_empty_or_missing_plan_is_invalid() -> None:
    with pytest.raises(InvalidPlan, match="zero poses"):
        DWBLocalPlanner().compute(Pose2D(), Twist2D(), Path(), empty_costmap())
    with pytest.raises(InvalidPlan, match="no plan"):
        DWBLocalPlanner().compute(Pose2D(), Twist2D(), None, empty_costmap())


def test_plan_in_another_frame_is_refused() -> None:
    with pytest.raises(InvalidPlan, match="frame 'map' but the costmap is in 'odom'"):
        DWBLocalPlanner().compute(Pose2D(), Twist2D(), straight_path(frame="map"),
                                  empty_costmap())


def test_nav2_layout_parameters_load() -> None:
    params = DWBParams.from_mapping({
        "plugin": "dwb_core::DWBLocalPlanner", "max_vel_x": 0.5, "transform_tolerance": 0.2,
        "critics": ["RotateToGoal", "BaseObstacle", "PathAlign", "PathDist", "GoalDist"],
        "PathAlign.scale": 16.0, "PathAlign.forward_point_distance": 0.1,
        "GoalDist": {"scale": 12.0, "aggregation_type": "Sum"},
    })
    dwb = DWBLocalPlanner(params)
    align = dwb.critics[2]
    assert isinstance(align, PathAlignCritic)
    assert align.params.scale == 16.0 and align.params.forward_point_distance == 0.1
    assert dwb.critics[4].params.aggregation_type == "sum"
    assert dwb.critics[1].params.scale == 0.02  # BaseObstacle default
    assert dwb.generator.limits.max_vel_x == 0.5


def test_bad_critic_configuration_is_a_config_error() -> None:
    with pytest.raises(ConfigError,
                       match=r"critics\.PathAlgn: unknown dwb critic plugin 'PathAlgn'"):
        DWBLocalPlanner({"critics": ["PathAlgn"]})
    with pytest.raises(ConfigError, match=r"PathAlign\.forward_pont_distance: unknown key"):
        DWBLocalPlanner({"critics": ["PathAlign"], "PathAlign.forward_pont_distance": 0.1})
    with pytest.raises(ConfigError, match="not in critics"):
        DWBParams.from_mapping({"critics": ["PathDist"], "critic_params": {"GoalDist": {}}})
    with pytest.raises(ConfigError, match="needs the robot footprint"):
        DWBLocalPlanner({"critics": ["ObstacleFootprint"]})


def test_renamed_critic_with_class_key() -> None:
    dwb = DWBLocalPlanner({"critics": ["Obst", "PathDist"],
                           "Obst.class": "dwb_critics::ObstacleFootprintCritic"},
                          footprint=Footprint.from_radius(0.15))
    assert isinstance(dwb.critics[0], ObstacleFootprintCritic) and dwb.critics[0].name == "Obst"
    cmd = dwb.compute(Pose2D(), Twist2D(0.2, 0.0, 0.0), straight_path(), _box_costmap())
    ev = dwb.last_evaluation
    assert ev is not None and ev.best_trajectory is not None and cmd.vx > 0.0


def test_debug_trajectory_details_scores_everything_and_agrees() -> None:
    cm = _box_costmap()
    fast, full = DWBLocalPlanner(), DWBLocalPlanner({"debug_trajectory_details": True})
    args = (Pose2D(), Twist2D(0.2, 0.0, 0.0), straight_path(), cm)
    assert fast.compute(*args) == full.compute(*args)
    ev_fast, ev_full = fast.last_evaluation, full.last_evaluation
    assert ev_fast is not None and ev_full is not None
    active = ev_full.critic_scales != 0.0
    assert not np.isnan(ev_full.raw_scores[active]).any()
    assert np.isnan(ev_fast.raw_scores[active]).any()  # rejected samples were dropped
    np.testing.assert_array_equal(ev_fast.rejected_by, ev_full.rejected_by)
    np.testing.assert_array_equal(ev_fast.totals, ev_full.totals)
    best = ev_full.best_index
    scores = ev_full.critic_scores(best)
    assert ev_full.totals[best] == pytest.approx(
        sum(scores[n] * s for n, s in zip(ev_full.critic_names, ev_full.critic_scales,
                                          strict=True) if s != 0.0))


def test_robot_inside_the_inscribed_band_drives_out() -> None:
    """A robot whose cell is inscribed (a SLAM correction moved the wall beside it by a
    cell) may still drive out along the plan: the distance critics' wave reaches its
    cell.  It used to stop at the inscribed cells, and every sample was rejected as
    "unreachable area", so the robot stood there until the goal failed."""
    cm = empty_costmap()
    rows = np.arange(cm.size_y) * cm.resolution + cm.origin_y + cm.resolution / 2
    wall = np.where(rows < -0.15, LETHAL_OBSTACLE,
                    np.where(rows < 0.05, INSCRIBED_INFLATED_OBSTACLE,
                             np.where(rows < 0.5, 200, 0)))
    cm.data[:] = wall[:, None].astype(np.uint8)
    assert cm.data[50, 50] == INSCRIBED_INFLATED_OBSTACLE  # the robot's cell
    path = Path.from_array(np.array([[x, min(0.4, x), 0.0] for x in np.arange(0.0, 2.0, 0.05)]),
                           frame_id="odom")
    dwb = DWBLocalPlanner()
    cmd = dwb.compute(Pose2D(0.0, 0.0, 0.5), Twist2D(), path, cm)
    assert cmd.vx > 0.0
    best = dwb.last_evaluation.best_trajectory  # type: ignore[union-attr]
    assert best is not None and best[-1, 1] > 0.0  # away from the wall
