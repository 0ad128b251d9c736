"""The golf cart demo on a shortened campus route (issue 6, acceptance 4).

``navstack demo --robot golf_cart`` runs Goal_2 -> Goal_4 -> Goal_5 -> Goal_1 with Smac
Hybrid-A* and MPPI; this test drives its first two legs through :func:`run_demo` (the
same world, robot and Nav2 parameter file): out of the spawn corner to the road between
library and lab, then across campus to the east road, arriving heading north.  The
Goal_4 leg is the one that used to fail: Reeds-Shepp analytic expansions ended the plan
with an unpenalised reverse into the goal that MPPI (tuned to prefer forward) never
drove, so the cart circled the goal and hit the fence.  Every plan must therefore be
forward-only (no cusp), and every goal must be reached within the goal checker's
tolerances without a collision or a recovery.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path as FsPath

import numpy as np
import yaml

from navstack.control.mppi.path_handler import first_inversion_end
from navstack.core.msgs import Path
from navstack.interfaces.demo import demo_setup, run_demo
from navstack.interfaces.stack import NavStack
from navstack.navigation.waypoint_follower import load_waypoints

ROUTE = ("Goal_2", "Goal_4")


def _short_route(tmp_path: FsPath) -> FsPath:
    """The packaged campus waypoints with ``order`` cut to :data:`ROUTE`."""
    data = yaml.safe_load(demo_setup("golf_cart").waypoints.read_text())
    data["order"] = list(ROUTE)
    out = tmp_path / "campus_short.yaml"
    out.write_text(yaml.safe_dump(data))
    return out


def test_golf_cart_reaches_two_campus_goals_forward_without_collision(tmp_path: FsPath) -> None:
    waypoints_file = _short_route(tmp_path)
    goal = dict(load_waypoints(waypoints_file))[ROUTE[-1]].pose
    goal_yaw = 2.0 * math.atan2(goal.orientation.z, goal.orientation.w)
    plans: list[np.ndarray] = []
    stacks: list[NavStack] = []

    def attach(stack: NavStack) -> Callable[[], None]:
        stacks.append(stack)
        stack.runtime.bus.subscribe("/plan", Path, lambda p: plans.append(p.as_array()))
        return lambda: None

    report = run_demo(tmp_path / "out", seed=1, robot="golf_cart",
                      waypoints_file=waypoints_file, goal_timeout_s=120.0,
                      show_progress=False, attach=attach)

    assert [(g["name"], g["status"], g["reason"]) for g in report["goals"]] == [
        (name, "SUCCEEDED", "") for name in ROUTE]
    assert report["collisions"] == 0
    # measured from the cart's outline; the full route keeps 1.2 m from walls and walkers
    assert 0.5 < report["min_clearance_m"] < 3.0
    assert report["success"] is True
    assert [g["recoveries"] for g in report["goals"]] == [0, 0]
    # the controller server's goal checker: 0.5 m / 0.3 rad (golf_cart_nav2_params.yaml)
    assert all(g["min_goal_dist_m"] <= 0.5 for g in report["goals"])
    pose = stacks[0].sim.sim.pose
    assert math.hypot(pose.x - goal.position.x, pose.y - goal.position.y) <= 0.5
    assert abs(math.remainder(pose.theta - goal_yaw, 2.0 * math.pi)) <= 0.3
    # DUBIN search: every plan the cart was given drives forward only
    assert plans
    assert all(first_inversion_end(p[:, :2]) == len(p) for p in plans)
    assert (tmp_path / "out" / "report.json").is_file()
    # the cart cannot turn in place: its parameter file drops Spin from the recoveries
    assert stacks[0].navigator.tree_params.recovery_behaviors == (
        "clear_costmaps", "wait", "backup")
