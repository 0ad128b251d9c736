"""Escape's choice of move: away from the obstacle, along a box until past its end."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from navstack.core.msgs import MapMetaData, OccupancyGrid, Point, Pose, Pose2D
from navstack.missions.explore import Escape


def grid_with(boxes: list[tuple[float, float, float, float]]) -> OccupancyGrid:
    """6 x 6 m at 0.05 m, origin (-3, -3); ``boxes`` (xmin, ymin, xmax, ymax) occupied."""
    data = np.zeros((120, 120), np.int8)
    for x0, y0, x1, y1 in boxes:
        data[round((y0 + 3) / 0.05):round((y1 + 3) / 0.05),
             round((x0 + 3) / 0.05):round((x1 + 3) / 0.05)] = 100
    info = MapMetaData(resolution=0.05, width=120, height=120,
                       origin=Pose(position=Point(-3.0, -3.0, 0.0)))
    return OccupancyGrid(info=info, data=data)


def escape() -> Escape:
    ctx: Any = object()  # _choose_move reads only the map
    return Escape(ctx, circumscribed_radius=0.3)


def test_beside_a_box_it_drives_along_the_box_until_past_its_end() -> None:
    # a 1 m box 0.15 m to the robot's left, ending 0.6 m ahead; a wall 0.4 m behind
    grid = grid_with([(-0.4, 0.15, 0.6, 0.6), (-0.75, -2.0, -0.4, 2.0)])
    e = escape()
    pose = Pose2D(0.0, 0.0, 0.0)
    dist, bearing = e._nearest_obstacle(grid, pose)
    assert dist == pytest.approx(0.15, abs=0.03) and bearing > 0.5
    forward, distance = e._choose_move(grid, pose, dist, bearing)
    assert forward
    # clear by 0.3 m once the centre is 0.3 m past the box's end (0.6 + 0.3 = 0.9 m)...
    end = e._nearest_obstacle(grid, Pose2D(distance - e.margin, 0.0, 0.0))[0]
    assert end >= 0.3 and distance == pytest.approx(0.85 + e.margin, abs=0.06)


def test_facing_a_wall_it_backs_up_and_a_refused_way_is_not_repeated() -> None:
    grid = grid_with([(0.2, -2.0, 0.5, 2.0)])
    e = escape()
    pose = Pose2D(0.0, 0.0, 0.0)
    dist, bearing = e._nearest_obstacle(grid, pose)
    forward, distance = e._choose_move(grid, pose, dist, bearing)
    assert not forward and distance == pytest.approx(0.1 + e.margin, abs=0.03)
    e.refused, e.flip_refused_forward, e.flip = "/backup", False, True  # as update() sets
    forward2, _ = e._choose_move(grid, pose, dist, bearing)
    assert forward2  # nothing better forward: the fallback turns to the other way


class _Ctx:
    """What Escape.update reads once its attempts are used up."""

    def __init__(self, grid: OccupancyGrid, pose: Pose2D) -> None:
        self.grid, self.pose, self.now = grid, pose, 10.0
        self.events: list[str] = []
        self.failures: list[str] = []

    def latest(self, *_: Any) -> OccupancyGrid:
        return self.grid

    def robot_pose(self) -> Pose2D:
        return self.pose

    def pose_in(self, frame: str) -> Pose2D:
        return self.pose

    def log(self, text: str) -> None:
        self.events.append(text)

    def fail(self, behaviour: str, reason: str) -> None:
        self.failures.append(f"{behaviour}: {reason}")


def test_a_best_effort_escape_goes_on_where_no_spot_is_clear() -> None:
    from py_trees.common import Status

    # a 0.5 m gap: no pose in it is 0.3 m clear of both sides
    grid = grid_with([(-2.0, 0.25, 2.0, 1.0), (-2.0, -1.0, 2.0, -0.25)])
    for required, status in ((True, Status.FAILURE), (False, Status.SUCCESS)):
        ctx: Any = _Ctx(grid, Pose2D(0.0, 0.0, 0.0))
        e = Escape(ctx, circumscribed_radius=0.3, required=required)
        e.tries = e.attempts
        assert e.update() is status
        assert bool(ctx.failures) is required
        assert required or ctx.events[-1].endswith("(needs 0.30 m to turn); going on")


def test_lethal_cells_of_the_local_costmap_count_in_its_own_frame() -> None:
    # the map is clear; the local costmap (odom, 1 m east of map) has a wall 0.2 m ahead
    # of the robot (lethal 100) and inflation (99) around it that is not an obstacle
    clear_map = grid_with([])
    local = grid_with([(1.2, -2.0, 1.5, 2.0)])
    data = np.asarray(local.data).reshape(120, 120).copy()
    data[:, round((1.1 + 3) / 0.05):round((1.2 + 3) / 0.05)] = 99
    local = OccupancyGrid(info=local.info, data=data)
    e = escape()
    map_pose, odom_pose = Pose2D(0.0, 0.0, 0.0), Pose2D(1.0, 0.0, 0.0)
    assert e._nearest_all(clear_map, map_pose, [])[0] == math.inf
    dist, bearing = e._nearest_all(clear_map, map_pose, [(local, odom_pose)])
    assert dist == pytest.approx(0.2, abs=0.03) and abs(bearing) < 0.2
    forward, distance = e._choose_move(clear_map, map_pose, dist, bearing,
                                       [(local, odom_pose)])
    assert not forward and distance == pytest.approx(0.1 + e.margin, abs=0.03)


class _Handle:
    def __init__(self, action: str, goal: Any) -> None:
        from navstack.runtime.actions import GoalStatus

        self.action, self.goal, self.done = action, goal, True
        self.result: Any = type("R", (), {"status": GoalStatus.FAILED,
                                          "error_msg": "collision ahead"})()


class _Client:
    def __init__(self, action: str, sent: list[_Handle]) -> None:
        self.action, self.sent = action, sent

    def send_goal(self, goal: Any) -> _Handle:
        self.sent.append(_Handle(self.action, goal))
        return self.sent[-1]


def test_wedged_between_two_obstacles_it_turns_away_from_the_nearer() -> None:
    """Office, information gain, seed 2: a turn in place left the robot 0.12 m from an
    obstacle ahead-left with another behind; BackUp and DriveOnHeading were both refused
    for good.  Once both straight moves are refused, the escape asks for a turn away
    from the nearest obstacle (the behaviour server refuses one that would hit), then
    straight moves again, the next turn the other way."""
    from dataclasses import replace

    from navstack.core.msgs import Header

    # a box 0.12 m ahead-left of the robot, a wall 0.2 m behind it
    grid = grid_with([(0.05, 0.12, 0.6, 0.6), (-0.75, -2.0, -0.35, 2.0)])
    grid = replace(grid, header=Header(100.0, "map"))
    ctx: Any = _Ctx(grid, Pose2D(0.0, 0.0, 0.0))
    sent: list[_Handle] = []
    ctx.backup = _Client("/backup", sent)
    ctx.drive_on_heading = _Client("/drive_on_heading", sent)
    ctx.spin = _Client("/spin", sent)
    ctx.feedback = lambda *a, **k: None
    e = Escape(ctx, circumscribed_radius=0.3, local_costmap_topic=None)
    e.initialise()
    for _ in range(12):
        if e.update().name != "RUNNING":
            break
    actions = [h.action for h in sent]
    assert actions[:2] in (["/backup", "/drive_on_heading"], ["/drive_on_heading", "/backup"])
    assert actions[2] == "/spin" and sent[2].goal.target_yaw == pytest.approx(-0.5)
    assert any("both straight moves refused: turning -29 deg" in x for x in ctx.events)
    # that turn refused too: straight moves again, and the next turn is the other way
    assert sorted(actions[3:]) == ["/backup", "/drive_on_heading"]
    assert len(sent) == e.attempts and e.spin_sign == 1.0
