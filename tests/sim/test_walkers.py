"""Walkers yield to a standing robot, turn back, and never wait for it for good."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.msgs import Pose2D
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.world import MovingObstacle, World

DT = 0.02
PATH_END = (6.0, 2.0)


def corridor(phase: float, width: float | None = None) -> World:
    """An 8 m x 4 m floor; one walker (radius 0.3 m, 0.5 m/s) paces y = 2 from x 1 to x 6
    (pingpong), ``phase`` metres along at t = 0 (5.0: at the east end).  With ``width``
    walls (0.1 m) bound a corridor of that width around its path."""
    walker = MovingObstacle("walker", "circle", np.array([[1.0, 2.0], [*PATH_END]]), 0.5,
                            mode="pingpong", radius=0.3, phase=phase)
    occ = np.zeros((80, 160), dtype=bool)
    if width is not None:
        half = round(width / 2 / 0.05)
        occ[40 - half - 2: 40 - half, :] = True
        occ[40 + half: 40 + half + 2, :] = True
    return World(occ, 0.05, moving_obstacles=(walker,))


def stand(world: World, at: Pose2D, seconds: float) -> tuple[Simulator, np.ndarray]:
    """The TurtleBot3 standing still at ``at``; the walker's centre at every step."""
    sim = Simulator(world, load_robot("turtlebot3_waffle_pi"), seed=1, spawn=at)
    walker = world.moving_obstacles[0]
    centres = []
    for _ in range(round(seconds / DT)):
        sim.step(DT)
        centres.append(walker.pose_in(sim.obstacle_clocks[0])[:2])
    return sim, np.array(centres)


def contact_bound(sim: Simulator) -> float:
    """Centre distance at which the walker's circle touches the robot's circumscribed one."""
    return sim.footprint.circumscribed_radius + 0.3


def test_walker_at_its_path_end_walks_past_a_robot_standing_beside_it() -> None:
    # the office standoff (explore_lite seed 2 / information gain seed 5): the walker at
    # the end of its path, the robot 0.28 m back along it and 0.58 m to the side, so every
    # step the walker can take (back along its path, either clock direction) closes in.
    # Before walkers stepped aside, it stood there for good.
    robot = Pose2D(PATH_END[0] - 0.28, PATH_END[1] - 0.58, 0.0)
    sim, centres = stand(corridor(phase=5.0), robot, 20.0)
    gaps = np.hypot(centres[:, 0] - robot.x, centres[:, 1] - robot.y)
    # it waited 4 s (turning back would close in too) ...
    assert np.abs(centres[: round(3.9 / DT)] - PATH_END).max() < 0.02
    # ... then stepped aside, away from the robot, and walked past it within 5 s more ...
    left = int(np.argmax(centres[:, 0] < PATH_END[0] - 1.5))
    assert centres[left, 0] < PATH_END[0] - 1.5 and left * DT < 9.0
    assert centres[:, 1].max() > PATH_END[1] + 0.4
    # ... never nearer than 0.05 m to the robot's circumscribed circle ...
    assert gaps.min() >= contact_bound(sim) + 0.05 - 1e-6
    assert sim.collisions == 0
    # ... and went back onto its path once clear of the robot
    assert centres[-1, 1] == pytest.approx(PATH_END[1], abs=1e-9)
    assert sim.obstacle_clocks[0] == pytest.approx(20.0 - 4.0, abs=0.05)  # held 4 s


def test_walker_never_walks_into_a_robot_on_its_path() -> None:
    # the robot stands on the path 1 m from its end: the walker cannot pass; coming from
    # the west it stops 0.6 m short, turns back after 4 s and paces the rest of its path
    robot = Pose2D(PATH_END[0] - 1.0, PATH_END[1], math.pi / 2)
    sim, centres = stand(corridor(phase=0.0), robot, 60.0)
    gaps = np.hypot(centres[:, 0] - robot.x, centres[:, 1] - robot.y)
    assert gaps.min() >= contact_bound(sim) + 0.05 + 0.6 - 0.02
    assert centres[:, 0].max() < robot.x
    assert centres[:, 0].min() == pytest.approx(1.0, abs=0.02)  # it went back to x = 1
    assert sim.collisions == 0


@pytest.mark.parametrize("dead_end", [False, True])
def test_walker_with_no_way_past_makes_room(dead_end: bool) -> None:
    # a 1 m corridor: the robot stands on the path 0.8 m from the walker at its end and
    # the walls leave no room to pass it (office explore_lite seed 1: a robot facing the
    # walker at the corridor's west end).  The walker backs away beyond its path end, to
    # the edge of the robot's yield radius, so the robot has room to move; in a dead end
    # it backs up to the wall and holds there.  It never touches the robot or a wall.
    robot = Pose2D(PATH_END[0] - 0.8, PATH_END[1], 0.0)
    world = corridor(phase=5.0, width=1.0)
    if dead_end:
        world.occupied[:, 128:130] = True  # a wall at x = 6.4 .. 6.5
    sim, centres = stand(world, robot, 20.0)
    gaps = np.hypot(centres[:, 0] - robot.x, centres[:, 1] - robot.y)
    assert gaps.min() >= contact_bound(sim) + 0.05 - 1e-6
    assert np.all(np.abs(centres[:, 1] - PATH_END[1]) + 0.3 <= 0.5)  # body off the walls
    after = centres[round(8.0 / DT):]
    if dead_end:
        assert np.all(after[:, 0] + 0.3 <= 6.4 + 1e-9)
        assert np.all(after[:, 0] > PATH_END[0])  # backed up against the wall
    else:
        first = int(np.argmax(gaps > 1.15))
        assert 4.0 < first * DT < 8.0  # waited 4 s, then made room
    assert sim.collisions == 0


def test_walkers_replay_identically() -> None:
    robot = Pose2D(PATH_END[0] - 0.28, PATH_END[1] - 0.58, 0.0)
    _, first = stand(corridor(phase=5.0), robot, 12.0)
    _, second = stand(corridor(phase=5.0), robot, 12.0)
    assert np.array_equal(first, second)
