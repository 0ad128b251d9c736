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


def test_primary_parameters_are_validated_with_the_key() -> None:
    with pytest.raises(ConfigError, match=r"FollowPath.desired_linear_vl: unknown key"):
        RotationShimParams.from_mapping({**SECTION, "desired_linear_vl": 0.3},
                                        key_path="FollowPath")
    with pytest.raises(ConfigError, match=r"FollowPath.primary_controller: required key"):
        RotationShimParams.from_mapping({"angular_dist_threshold": 0.5},
                                        key_path="FollowPath")
