"""Speed filter (Nav2 ``SpeedFilter``): limits at the robot, announcements, lookahead."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import CostmapFilterInfo
from navstack.costmap import LayeredCostmap, SpeedFilter, SpeedFilterParams
from navstack.costmap.costmap_filter import SPEED_FILTER_ABSOLUTE, SPEED_FILTER_PERCENT
from navstack.costmap.speed_filter import NO_SPEED_LIMIT, closest_segment, lookahead_distance

from .helpers import grid

PERCENT = CostmapFilterInfo(type=SPEED_FILTER_PERCENT)


def _speed(info: CostmapFilterInfo, **params: object) -> tuple[LayeredCostmap, SpeedFilter]:
    lc = LayeredCostmap(10, 10, 0.5)
    f = SpeedFilter(params=SpeedFilterParams(**params))
    lc.add_filter(f)
    mask = np.array([[0, 30, 90], [-1, 10, 100]], np.int8)
    f.set_mask(grid(mask, 1.0), info)
    return lc, f


def test_speed_limit_percent_at_points() -> None:
    _, f = _speed(PERCENT)
    assert f.speed_limit_at(1.5, 0.5) == 30.0
    assert f.speed_limit_at(0.5, 0.5) == NO_SPEED_LIMIT  # mask 0: no limit
    assert f.speed_limit_at(0.5, 1.5) is None  # -1: cannot be read
    assert f.speed_limit_at(5.0, 5.0) is None  # off the mask: cannot be read
    assert f.speed_limit_at(2.5, 1.5) == 100.0
    _, g = _speed(CostmapFilterInfo(type=SPEED_FILTER_PERCENT, base=20.0, multiplier=1.0))
    assert g.speed_limit_at(1.5, 0.5) == 50.0
    assert g.speed_limit_at(2.5, 0.5) == NO_SPEED_LIMIT  # 110 % is out of [0, 100]


def test_speed_limit_absolute_at_points() -> None:
    _, f = _speed(CostmapFilterInfo(type=SPEED_FILTER_ABSOLUTE, base=0.1, multiplier=0.01))
    assert f.speed_limit_at(1.5, 1.5) == pytest.approx(0.2)
    assert f.percentage is False
    _, g = _speed(CostmapFilterInfo(type=SPEED_FILTER_ABSOLUTE, base=-1.0, multiplier=0.01))
    assert g.speed_limit_at(1.5, 0.5) == NO_SPEED_LIMIT  # negative speed: no limit
    with pytest.raises(ConfigError, match=r"got filter type 0 \(keepout"):
        g.set_filter_info(CostmapFilterInfo(type=0))


def test_limit_is_announced_once_per_change_and_removed_on_leaving() -> None:
    lc, f = _speed(PERCENT)
    lc.update_map(0.5, 0.5, 0.0)  # mask 0: no limit, nothing changed
    assert f.pop_speed_limit() is None
    lc.update_map(1.5, 0.5, 0.0)  # into the 30 % cell
    assert f.pop_speed_limit() == (30.0, True)
    lc.update_map(1.6, 0.6, 0.0)  # same limit: nothing new to announce
    assert f.pop_speed_limit() is None
    lc.update_map(0.5, 1.5, 0.0)  # unknown cell: the previous limit stays (Nav2)
    assert f.speed_limit == 30.0 and f.pop_speed_limit() is None
    lc.update_map(0.4, 0.4, 0.0)  # back on a 0 cell: the limit is removed
    assert f.pop_speed_limit() == (NO_SPEED_LIMIT, True)
    assert f.speed_limit == NO_SPEED_LIMIT


def test_lookahead_distance_follows_braking_distance() -> None:
    assert lookahead_distance(2.0, -0.5, 0.3, 5.0) == pytest.approx(4.0)
    assert lookahead_distance(0.1, -0.5, 0.3, 5.0) == 0.3
    assert lookahead_distance(4.0, -0.5, 0.3, 5.0) == 5.0
    assert lookahead_distance(1.0, 0.0, 0.3, 5.0) == 5.0  # max_decel >= 0: max_lookahead
    with pytest.raises(ConfigError, match="max_lookahead must be >= min_lookahead"):
        SpeedFilterParams.from_mapping({"min_lookahead": 2.0, "max_lookahead": 1.0})


def test_closest_segment_searches_forward_from_start() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0]])
    assert closest_segment(path, 1.4, 0.1) == 1
    assert closest_segment(path, 1.4, 0.9) == 3
    assert closest_segment(path, 0.1, 0.1) == 0
    assert closest_segment(path, 0.1, 0.1, start=2) == 3  # segments before 2 are skipped
    assert closest_segment(path[:1], 5.0, 5.0) == 0


def _corridor() -> tuple[LayeredCostmap, SpeedFilter]:
    """A 20 m x 1 m mask: a 30 % zone over x 10..14 (mask 70 with base 100, mult -1)."""
    lc = LayeredCostmap(40, 4, 0.5)
    f = SpeedFilter(params=SpeedFilterParams(enable_path_lookahead=True, max_decel=-0.5,
                                             min_lookahead=1.0, max_lookahead=6.0))
    lc.add_filter(f)
    mask = np.zeros((2, 40), np.int8)
    mask[:, 20:28] = 70
    f.set_mask(grid(mask, 0.5),
               CostmapFilterInfo(type=SPEED_FILTER_PERCENT, base=100.0, multiplier=-1.0))
    x = np.arange(0.0, 20.0, 0.25)
    f.set_path(np.column_stack((x, np.full_like(x, 0.5))))
    return lc, f


def test_lookahead_brakes_before_the_zone_and_holds_the_distance() -> None:
    lc, f = _corridor()
    f.set_robot_speed(2.0)  # looks 2^2 / (2 * 0.5) = 4 m ahead
    lc.update_map(5.0, 0.5, 0.0)  # zone 5 m ahead: not yet
    assert f.pop_speed_limit() is None
    lc.update_map(6.5, 0.5, 0.0)  # zone 3.5 m ahead: limit now
    assert f.pop_speed_limit() == (30.0, True)
    # sampled from the closest segment's first pose (6.25) for 4 m along the plan
    assert f.lookahead_point is not None and f.lookahead_point[0] == pytest.approx(10.25)
    f.set_robot_speed(0.5)  # slower: 0.25 m braking distance, but the 4 m are held
    lc.update_map(7.0, 0.5, 0.0)
    assert f.speed_limit == 30.0
    lc.update_map(12.0, 0.5, 0.0)  # inside: the limit is the robot's own
    assert f.speed_limit == 30.0 and f.pop_speed_limit() is None
    lc.update_map(14.5, 0.5, 0.0)  # out, nothing slower ahead: the limit is removed
    assert f.pop_speed_limit() == (NO_SPEED_LIMIT, True)


def test_lookahead_without_plan_uses_the_robot_pose_only() -> None:
    lc, f = _corridor()
    f.set_path(None)
    f.set_robot_speed(2.0)
    lc.update_map(8.0, 0.5, 0.0)
    assert f.pop_speed_limit() is None
    lc.update_map(10.2, 0.5, 0.0)
    assert f.pop_speed_limit() == (30.0, True)
