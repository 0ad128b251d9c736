"""RotationShimController: rotate toward a new path first, then the primary controller."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.rotation_shim import RotationShimController, RotationShimParams
from navstack.core.errors import ConfigError, NoValidControl
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from navstack.costmap.footprint import polygon_cells

SECTION = {"primary_controller": "nav2_regulated_pure_pursuit_controller::"
                                 "RegulatedPurePursuitController",
           "angular_dist_threshold": 0.785, "rotate_to_heading_angular_vel": 1.5,
           "max_angular_accel": 2.0, "desired_linear_vel": 0.4}


def shim(**extra: object) -> RotationShimController:
    params = RotationShimParams.from_mapping({**SECTION, **extra}, key_path="FollowPath")
    return RotationShimController(params, footprint=Footprint.from_radius(0.2))


def costmap() -> Costmap2D:
    return Costmap2D(100, 100, 0.05, -2.5, -2.5, "odom")


def straight(heading: float, n: int = 40) -> Path:
    s = np.arange(n) * 0.05
    xy = np.column_stack((s * math.cos(heading), s * math.sin(heading), np.full(n, heading)))
    return Path.from_array(xy, "odom")


def test_path_behind_rotates_in_place_then_hands_over() -> None:
    c = shim()
    cm, path = costmap(), straight(math.pi / 2)
    pose, wz = Pose2D(0.0, 0.0, 0.0), 0.0
    turning = 0
    for _ in range(60):
        cmd = c.compute(pose, Twist2D(0.0, 0.0, wz), path, cm)
        if cmd.vx == 0.0 and c.rotating:
            turning += 1
            assert cmd.wz > 0.0 and abs(cmd.wz - wz) <= 2.0 / 20.0 + 1e-9  # accel limit
            wz = cmd.wz
            pose = Pose2D(0.0, 0.0, pose.theta + wz / 20.0)
        else:
            break
    assert turning > 5 and not c.rotating
    assert abs(pose.theta - math.pi / 2) < 0.785  # handed over within the threshold
    assert cmd.vx > 0.0  # the primary (RPP) drives
    # the same plan again: no rotation even if the heading drifts past the threshold
    assert c.compute(Pose2D(0.0, 0.0, -0.9), Twist2D(), path, cm).vx > 0.0 or not c.rotating


def test_rotation_into_a_lethal_cell_is_refused() -> None:
    c = shim()
    cm = costmap()
    square = Footprint.from_polygon([[0.3, 0.1], [0.3, -0.1], [-0.1, -0.1], [-0.1, 0.1]])
    c.footprint = square
    mx, my = cm.world_to_map(0.0, 0.25)  # type: ignore[misc]
    cm.data[my, mx] = LETHAL_OBSTACLE  # the long nose would sweep through it
    with pytest.raises(NoValidControl, match="potential collision"):  # turning at 1.5 rad/s
        c.compute(Pose2D(0.0, 0.0, 0.0), Twist2D(0.0, 0.0, 1.5), straight(math.pi / 2), cm)
    assert c.compute(Pose2D(0.0, 0.0, 0.0), Twist2D(0.0, 0.0, -1.5),
                     straight(-math.pi / 2), cm).wz < 0.0  # the other way is free


def test_a_round_robot_turns_next_to_a_lethal_cell() -> None:
    # lethal cells that only the rotated polygon approximation of the 0.2 m disc would
    # touch: the disc does not move when it turns (Nav2 checks a round robot by its
    # centre cost), so the turn is allowed
    c = shim()
    cm = costmap()
    assert c.footprint is not None
    poly = c.footprint.polygon
    at_rest = set(zip(*polygon_cells(cm, poly), strict=True))
    turned: set[tuple[int, int]] = set()
    for th in np.linspace(0.0, 0.4, 9):
        rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        turned |= set(zip(*polygon_cells(cm, poly @ rot.T), strict=True))
    grazing = turned - at_rest
    assert grazing  # the polygon's vertices do sweep new cells
    for mx, my in grazing:
        cm.data[my, mx] = LETHAL_OBSTACLE
    cmd = c.compute(Pose2D(0.0, 0.0, 0.0), Twist2D(), straight(math.pi / 2), cm)
    assert c.rotating and cmd.vx == 0.0 and cmd.wz > 0.0
    c.footprint = Footprint.from_polygon(poly)  # the same outline as a polygon robot
    with pytest.raises(NoValidControl, match="potential collision"):
        shim_polygon = shim()
        shim_polygon.footprint = c.footprint
        shim_polygon.compute(Pose2D(0.0, 0.0, 0.0), Twist2D(), straight(math.pi / 2), cm)


def test_primary_parameters_are_validated_with_the_key() -> None:
    with pytest.raises(ConfigError, match=r"FollowPath.desired_linear_vl: unknown key"):
        RotationShimParams.from_mapping({**SECTION, "desired_linear_vl": 0.3},
                                        key_path="FollowPath")
    with pytest.raises(ConfigError, match=r"FollowPath.primary_controller: required key"):
        RotationShimParams.from_mapping({"angular_dist_threshold": 0.5},
                                        key_path="FollowPath")
