"""Closed loop: MPPI drives a kinematic base (integrated here) along plans to the goal."""

from __future__ import annotations

import math

import numpy as np

from navstack.control.mppi import MPPIController, golf_cart_mppi_params
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE
from navstack.costmap.footprint import footprint_cost
from tests.control.mppi.helpers import (
    add_box,
    costmap,
    curved_plan,
    drive,
    footprint_rect,
    inflate_costmap,
    straight_plan,
)


def _max_cross_track(plan: np.ndarray, run_poses: list) -> float:
    return max(float(np.min(np.hypot(plan[:, 0] - p.x, plan[:, 1] - p.y))) for p in run_poses)


def test_diff_drive_follows_straight_and_curved_paths_to_the_goal() -> None:
    cm = costmap()
    for plan, max_time in ((straight_plan(3.0), 12.0), (curved_plan(), 14.0)):
        ctrl = MPPIController({"shift_control_sequence": True})
        run = drive(ctrl, plan, cm, dt=0.05, max_time=max_time)
        assert run.reached_at is not None, f"stopped at {run.final}"
        assert math.hypot(run.final.x - plan[-1, 0], run.final.y - plan[-1, 1]) <= 0.25
        assert _max_cross_track(plan, run.poses) < 0.1
        # 0.5 m/s top speed: no faster than the plan length allows, not crawling either
        length = float(np.sum(np.hypot(*np.diff(plan[:, :2], axis=0).T)))
        assert (length - 0.25) / 0.5 < run.reached_at < 2.5 * length / 0.5
        assert max(c.vx for c in run.commands) <= 0.5 + 1e-9


def test_omni_reaches_the_goal() -> None:
    plan = straight_plan(2.0)
    run = drive(MPPIController({"motion_model": "Omni"}), plan, costmap(), dt=0.05,
                max_time=12.0)
    assert run.reached_at is not None
    assert max(abs(c.vy) for c in run.commands) <= 0.5 + 1e-9


def test_obstacle_beside_the_path_is_never_touched() -> None:
    fp = footprint_rect(0.4, 0.3)
    cm = costmap()
    add_box(cm, 1.2, 0.3, 1.6, 0.7)  # 0.15 m of clearance for the robot's side
    inflate_costmap(cm, fp.inscribed_radius, 0.55, 3.0)
    collision = {"consider_footprint": True, "inflation_radius": 0.55,
                 "cost_scaling_factor": 3.0}
    ctrl = MPPIController({"CostCritic": collision}, footprint=fp)
    plan = straight_plan(3.0)
    run = drive(ctrl, plan, cm, dt=0.05, max_time=14.0)
    assert run.reached_at is not None
    worst = max(footprint_cost(cm, (p.x, p.y, p.theta), fp) for p in run.poses)
    assert worst < INSCRIBED_INFLATED_OBSTACLE


def test_ackermann_golf_cart_respects_the_turning_radius() -> None:
    params = golf_cart_mppi_params()
    params.pop("plugin")
    ctrl = MPPIController(params)
    plan = curved_plan(radius=8.0, straight=6.0, ds=0.1)
    cm = costmap(size_m=40.0, resolution=0.1, origin=-20.0)
    run = drive(ctrl, plan, cm, dt=0.1, max_time=40.0)
    assert run.reached_at is not None
    for cmd in run.commands:
        assert abs(cmd.wz) <= abs(cmd.vx) / 5.0 + 1e-12
        assert cmd.vy == 0.0
    assert max(c.vx for c in run.commands) > 1.0  # it does drive like a cart
    assert _max_cross_track(plan, run.poses) < 0.3
