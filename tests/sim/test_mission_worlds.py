"""The mission worlds: the TurtleBot course arena and the exploration regression worlds.

Each world's point is checked on its raster: the arena's gaps are wide enough for the
TurtleBot3 Waffle Pi and all its free space is one region; the regression worlds hold
the situation they are named after (a start cell inside the wall's inscribed band, a
gap narrower than the robot with free space behind it, a closed corridor).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from navstack.sim.robot import load_robot
from navstack.sim.world import World
from navstack.sim.worlds import load_world


def _clearance(w: World) -> np.ndarray:
    return ndimage.distance_transform_edt(~w.occupied, sampling=w.resolution)


def _region(w: World, clearance: np.ndarray, radius: float) -> np.ndarray:
    """Cells where a disc of ``radius`` fits, connected to the spawn."""
    lab, _ = ndimage.label(clearance > radius)
    spawn = lab[w.world_to_cell(w.spawn.x, w.spawn.y)]
    assert spawn > 0
    return lab == spawn


def test_arena_is_the_course_size_and_open_for_the_turtlebot() -> None:
    w = load_world("arena")
    x0, y0, x1, y1 = w.bounds
    assert (x1 - x0, y1 - y0) == (4.0, 4.0)
    free = ~w.occupied
    interior = free.sum() * w.resolution ** 2
    assert 12.0 < interior < 15.5  # ~15 m^2 course minus walls and obstacles
    # the padded Waffle Pi half-width (0.153 + 0.05) fits everywhere free space is wide,
    # and every waypoint is in that one region
    tb = load_robot("turtlebot3_waffle_pi")
    half_width = float(np.max(np.abs(np.asarray(tb.footprint)[:, 1]))) + 0.05
    region = _region(w, _clearance(w), half_width)
    for name, p in w.waypoints.items():
        assert region[w.world_to_cell(p.x, p.y)], name
    # only thin pockets (< 0.3 m) are out of it: 90 % of the free area is within 0.3 m
    near = ndimage.distance_transform_edt(~region, sampling=w.resolution) <= 0.3
    assert (near & free).sum() >= 0.98 * free.sum()


def test_facing_wall_start_is_inside_the_inscribed_band() -> None:
    w = load_world("explore_facing_wall")
    tb = load_robot("turtlebot3_waffle_pi")
    clearance = _clearance(w)[w.world_to_cell(w.spawn.x, w.spawn.y)]
    inscribed = float(np.min(np.abs(np.asarray(tb.footprint)))) + 0.05  # padded
    assert clearance < inscribed + 0.1          # the planner refuses this start
    assert abs(w.spawn.theta) < 1e-9            # facing the east wall
    body_front = w.spawn.x + float(np.max(np.asarray(tb.footprint)[:, 0]))
    assert 0.05 < 3.9 - body_front < 0.15       # but not touching it


def test_narrow_door_is_narrower_than_the_robot_with_space_behind() -> None:
    w = load_world("explore_narrow_door")
    tb = load_robot("turtlebot3_waffle_pi")
    width = float(np.ptp(np.asarray(tb.footprint)[:, 1]))
    row = w.occupied[w.world_to_cell(2.0, 3.0)[0]]
    gap = np.flatnonzero(~row[1:-1]) + 1
    assert 0 < len(gap) * w.resolution < width
    clearance = _clearance(w)
    room = _region(w, clearance, width / 2)
    behind = ~w.occupied & (np.arange(w.height)[:, None] > w.world_to_cell(0, 3.1)[0])
    assert behind.sum() * w.resolution ** 2 > 4.0   # a room the robot cannot enter
    assert not (room & behind).any()


def test_dead_end_corridor_is_closed_and_turnable() -> None:
    w = load_world("explore_dead_end")
    tb = load_robot("turtlebot3_waffle_pi")
    corners = np.asarray(tb.footprint)
    circumscribed = float(np.max(np.hypot(corners[:, 0], corners[:, 1])))
    clearance = _clearance(w)
    r, c = w.world_to_cell(7.0, 1.5)
    assert 0.35 < clearance[r, c] < 0.45                  # 0.8 m wide at the far end
    assert clearance[r, c] > circumscribed                # the robot can turn round
    assert w.occupied[r, w.world_to_cell(7.45, 1.5)[1]]  # and it is closed
    _, n = ndimage.label(~w.occupied)
    assert n == 1  # one free region: the corridor is reached only from the room
