"""Escape's choice of move: away from the obstacle, along a box until past its end."""

from __future__ import annotations

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
