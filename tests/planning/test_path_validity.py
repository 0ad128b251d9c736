"""is_path_valid (Nav2 IsPathValid rules), path curvature and minimum turning radius."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import InvalidMessage
from navstack.core.msgs import Path, Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D
from navstack.costmap.layer import CostmapLayer
from navstack.costmap.layered_costmap import LayeredCostmap
from navstack.planning.path_validity import is_path_valid, min_turning_radius, path_curvature


def _line(n: int = 41, y: float = 1.03, x0: float = 0.03) -> Path:
    """Poses every 0.05 m along y = const from x = x0 (pose i in cell column i for x0 0.03)."""
    x = x0 + 0.05 * np.arange(n)
    return Path.from_array(np.column_stack((x, np.full(n, y), np.zeros(n))), frame_id="map")


def _costmap() -> Costmap2D:
    return Costmap2D(60, 60, 0.05)  # 3 m x 3 m


def test_free_path_is_valid() -> None:
    r = is_path_valid(_line(), _costmap())
    assert r.is_valid and bool(r)
    assert (r.first_invalid_index, r.reason, r.invalid_indices) == (-1, "", ())
    assert r.checked == (0, 41)


def test_first_lethal_pose_is_reported() -> None:
    cm = _costmap()
    cm.data[20, 12] = 254  # pose 12 (x = 0.625) on row 20 (y = 1.025)
    cm.data[20, 30] = 254
    r = is_path_valid(_line(), cm)
    assert not r.is_valid
    assert r.first_invalid_index == 12 and r.invalid_indices == (12,)
    assert r.reason == "pose 12 at (0.63, 1.03) cell is in a lethal obstacle (cost 254)"
    r_all = is_path_valid(_line(), cm, stop_at_first_collision=False)
    assert r_all.invalid_indices == (12, 30)


def test_inscribed_and_max_cost_rules() -> None:
    cm = _costmap()
    cm.data[20, 5] = 253
    r = is_path_valid(_line(), cm, max_cost=254)
    assert r.first_invalid_index == 5  # point check: inscribed is always invalid
    assert r.reason == ("pose 5 at (0.28, 1.03) is in the inscribed band (cost 253): the robot "
                        "would touch an obstacle")
    fp = Footprint.from_polygon([[0.01, 0.01], [-0.01, 0.01], [-0.01, -0.01], [0.01, -0.01]])
    assert is_path_valid(_line(), cm, footprint=fp, max_cost=254).is_valid
    assert is_path_valid(_line(), cm, footprint=fp).first_invalid_index == 5  # default 253
    cm.data[20, 5] = 180
    r = is_path_valid(_line(), cm, max_cost=150)
    assert r.reason == "pose 5 at (0.28, 1.03) cell cost 180 is at or above max_cost 150"


def test_footprint_check_sees_obstacles_beside_the_path() -> None:
    cm = _costmap()
    cm.data[23, 20] = 254  # x in [1.0, 1.05), y in [1.15, 1.2): beside the path
    path = _line(21, x0=0.43)
    assert is_path_valid(path, cm).is_valid  # the centre never touches it
    fp = Footprint.from_polygon([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]])
    r = is_path_valid(path, cm, footprint=fp)
    # pose i at x = 0.43 + 0.05 i: the square's right edge x + 0.2 first reaches column 20
    # (x >= 1.0) at i = 8; at i = 7 it ends in column 19
    assert r.first_invalid_index == 8
    assert r.reason == ("pose 8 at (0.83, 1.03) footprint touches a lethal obstacle or leaves "
                        "the costmap (cost 254)")


def test_unknown_space_and_outside_map() -> None:
    cm = _costmap()
    cm.data[20, 7] = 255
    assert is_path_valid(_line(), cm).is_valid  # unknown is free by default
    r = is_path_valid(_line(), cm, consider_unknown_as_obstacle=True)
    assert r.reason == ("pose 7 at (0.38, 1.03) cell is in unknown space and "
                        "consider_unknown_as_obstacle is true")
    r = is_path_valid(_line(70), _costmap())
    assert r.first_invalid_index == 60
    assert r.reason == "pose 60 at (3.03, 1.03) is outside the costmap (counted as lethal)"


def test_check_starts_at_robot_and_stops_after_lookahead() -> None:
    cm = _costmap()
    cm.data[20, 3] = 254  # behind the robot
    cm.data[20, 30] = 254  # 1.0 m ahead of pose 10
    robot = Pose2D(0.53, 1.03)  # closest pose 10
    r = is_path_valid(_line(), cm, robot_pose=robot, max_lookahead_distance=0.98)
    assert r.is_valid and r.checked == (10, 30)  # poses 10..29: 0.95 m, pose 30 is past 0.98
    r = is_path_valid(_line(), cm, robot_pose=robot, max_lookahead_distance=1.0)
    assert r.checked == (10, 31) and r.first_invalid_index == 30
    assert is_path_valid(_line(), cm).first_invalid_index == 3


def test_layer_check_and_errors() -> None:
    layered = LayeredCostmap(60, 60, 0.05)
    layer = layered.add_plugin(CostmapLayer("obstacle_layer"))
    assert isinstance(layer, CostmapLayer)
    layer.costmap.data[20, 8] = 254  # only in the layer, not yet in the master grid
    assert is_path_valid(_line(), layered).is_valid
    assert is_path_valid(_line(), layered, layer_name="obstacle_layer").first_invalid_index == 8
    with pytest.raises(InvalidMessage, match="needs a LayeredCostmap"):
        is_path_valid(_line(), _costmap(), layer_name="obstacle_layer")
    odom = Path.from_array(_line().as_array(), frame_id="odom")
    with pytest.raises(InvalidMessage) as err:
        is_path_valid(odom, _costmap())
    assert str(err.value) == ("path is in frame 'odom' but the costmap is in 'map'; transform "
                              "the path before checking it")
    r = is_path_valid(Path(), _costmap())
    assert (r.is_valid, r.reason) == (False, "the path has no poses")


def test_curvature_of_a_circle_is_exact() -> None:
    th = np.linspace(0.0, 1.5, 31)
    left = np.column_stack((2.0 * np.sin(th), 2.0 - 2.0 * np.cos(th)))
    k = path_curvature(left)
    assert k[0] == k[-1] == 0.0
    np.testing.assert_allclose(k[1:-1], 0.5, atol=1e-12)
    right = left * np.array([1.0, -1.0])
    np.testing.assert_allclose(path_curvature(right)[1:-1], -0.5, atol=1e-12)
    assert min_turning_radius(left) == pytest.approx(2.0, abs=1e-12)


def test_min_turning_radius_of_straight_then_arc() -> None:
    s = np.arange(0.0, 1.0, 0.1)
    straight = np.column_stack((s, np.zeros_like(s)))
    th = np.linspace(0.0, math.pi / 2, 20)
    arc = np.column_stack((1.0 + 1.5 * np.sin(th), 1.5 - 1.5 * np.cos(th)))
    xyt = np.column_stack((np.vstack((straight, arc)), np.zeros(len(s) + len(th))))
    path = Path.from_array(xyt, frame_id="map")
    assert min_turning_radius(path) == pytest.approx(1.5, rel=1e-9)
    assert min_turning_radius(straight) == math.inf
    cusp = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.3]])  # reversal at pose 1
    np.testing.assert_array_equal(path_curvature(cusp), [0.0, 0.0, 0.0])
