"""Reference points a new scan sees through (moved objects) leave its scan match."""

from __future__ import annotations

import math

import numpy as np

from navstack.mapping.free_space import seen_through
from navstack.mapping.slam import LaserGeometry, SlamMapper
from navstack.mapping.slam_params import SlamParams

ANGLES = np.linspace(-math.pi, math.pi, 360, endpoint=False)


def _ring(radius: float) -> np.ndarray:
    return np.full(360, radius)


def test_points_in_front_of_the_returns_are_seen_through() -> None:
    ranges = _ring(5.0)  # a round room of radius 5 m around the sensor at (1, 2)
    pose = np.array([1.0, 2.0, 0.3])
    points = np.array([[3.0, 2.0],     # 2 m out: the beam to it returned at 5 m
                       [5.95, 2.0],    # on the wall (4.95 m, within the margin)
                       [7.5, 2.0],     # behind the wall: not observed
                       [1.0, 5.0]])    # 3 m out, straight up
    assert seen_through(ranges, ANGLES, 0.1, 20.0, pose, points, 0.1).tolist() == [
        True, False, False, True]


def test_beams_without_a_return_are_no_evidence() -> None:
    ranges = _ring(5.0)
    ranges[:6] = ranges[-5:] = np.inf  # no return around bearing 180 deg (an open door)
    ranges[265:276] = 25.0             # bearing 90 deg: beyond range_max
    points = np.array([[-2.0, 0.0], [0.0, 2.0], [2.0, 0.0]])
    mask = seen_through(ranges, ANGLES, 0.1, 20.0, np.zeros(3), points, 0.1)
    assert mask.tolist() == [False, False, True]


def test_a_single_far_neighbour_beam_does_not_clear_a_point() -> None:
    """The free reach of a beam is the shortest of it and its neighbours: a beam that
    grazes past a wall corner does not remove the corner seen on the next beam."""
    ranges = _ring(5.0)
    ranges[180] = 2.0   # bearing 0: something at 2 m
    ranges[181] = 9.0   # the next beam slips past it
    point = np.array([[2.0 * math.cos(ANGLES[181]), 2.0 * math.sin(ANGLES[181])]])
    assert not seen_through(ranges, ANGLES, 0.1, 20.0, np.zeros(3), point, 0.1)[0]


def test_partial_field_of_view_keeps_points_outside_it() -> None:
    angles = np.linspace(-math.pi / 2, math.pi / 2, 181)
    ranges = np.full(181, 5.0)
    points = np.array([[-2.0, 0.0], [2.0, 0.0]])  # behind the sensor, in front of it
    assert seen_through(ranges, angles, 0.1, 20.0, np.zeros(3), points, 0.1).tolist() == [
        False, True]


def test_a_person_the_robot_follows_does_not_pull_the_match() -> None:
    """Corridor 2 m wide; a person (a disc of radius 0.3 m: many close points) walks ahead
    and moves 0.25 m while the robot drives 0.5 m (the office run, seed 1: a step matched
    0.11 m short behind a walker).  Closed behind the robot at x = -3 (the person hides
    the far end at x = 6), the wall fixes x and the step is exact; open behind (beyond
    the lidar's range) only the person fixes x: without the free-space test the match
    follows the person, with it the person's old points leave the match (the few at
    its side it cannot see through keep a few centimetres of pull)."""
    laser = LaserGeometry(ANGLES, 0.1, 20.0)

    def scan(x: float, person: float, back: float) -> np.ndarray:
        c, s = np.cos(ANGLES), np.sin(ANGLES)
        with np.errstate(divide="ignore"):
            side = np.where(s > 0, 1.0 / s, np.where(s < 0, -1.0 / s, np.inf))
            end = np.where(c > 0, (6.0 - x) / c, np.where(c < 0, (back - x) / c, np.inf))
        r = np.minimum(side, end)
        r[r >= 20.0] = np.inf
        b = c * (person - x)  # ray-circle intersection with the person
        disc = b * b - ((person - x) ** 2 - 0.09)
        hit = (disc >= 0) & (b > 0)
        r[hit] = np.minimum(r[hit], b[hit] - np.sqrt(disc[hit]))
        return r

    step = {}
    for back in (-3.0, -40.0):
        for margin in (0.2, 0.0):
            mapper = SlamMapper(SlamParams(dynamic_point_margin=margin,
                                           minimum_time_interval=0.0,
                                           do_loop_closing=False), laser)
            mapper.process_scan(scan(0.0, 1.0, back), (0.0, 0.0, 0.0), 0.0)
            mapper.process_scan(scan(0.5, 1.25, back), (0.5, 0.0, 0.0), 1.0)
            step[back, margin] = mapper.poses()[1, 0]
    assert abs(step[-3.0, 0.2] - 0.5) < 0.01
    assert abs(step[-40.0, 0.2] - 0.5) < 0.05
    # margin 0 (slam_toolbox): the person's motion is taken off the step
    assert step[-40.0, 0.0] < 0.3
