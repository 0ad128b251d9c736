"""Obstacle layer: marking, ray-trace clearing, range/height filters, inf, rolling, clearing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import UnknownNameError
from navstack.core.msgs import Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap import (
    LayeredCostmap,
    ObservationSourceParams,
    ObstacleLayer,
    ObstacleLayerParams,
)

from .helpers import scan

SRC = {"max_obstacle_height": 2.0, "clearing": True, "marking": True,
       "obstacle_max_range": 5.0, "raytrace_max_range": 6.0}


def _costmap(track_unknown: bool = True, rolling: bool = False, size: int = 100,
             layer_kw: dict[str, object] | None = None, **src: object
             ) -> tuple[LayeredCostmap, ObstacleLayer]:
    lc = LayeredCostmap(size, size, 0.1, rolling_window=rolling,
                        track_unknown_space=track_unknown, footprint=Footprint.from_radius(0.1))
    kw: dict[str, object] = {"footprint_clearing_enabled": False, **(layer_kw or {})}
    params = ObstacleLayerParams(observation_sources="scan", **kw)
    layer = ObstacleLayer("obstacle_layer", params,
                          {"scan": ObservationSourceParams(**{**SRC, **src})})
    lc.add_plugin(layer)
    return lc, layer


def test_marks_endpoint_and_clears_ray() -> None:
    lc, layer = _costmap()
    layer.add_scan(scan([3.0]), Pose2D(2.05, 5.05, 0.0), 0.2, "scan")
    lc.update_map(2.05, 5.05, 0.0)
    row = lc.costmap.data[50]
    assert row[50] == 254  # end cell (5.05, 5.05)
    assert np.all(row[20:50] == 0)  # sensor cell up to the end cell: cleared
    assert row[51] == 255 and np.all(lc.costmap.data[49, 20:50] == 255)  # untouched


def test_new_ray_clears_previous_obstacle() -> None:
    lc, layer = _costmap()
    layer.add_scan(scan([1.5], stamp=0.0), Pose2D(2.05, 5.05, 0.0), 0.2, "scan")
    lc.update_map(2.05, 5.05, 0.0)
    assert lc.costmap.data[50, 35] == 254
    layer.add_scan(scan([3.0], stamp=0.1), Pose2D(2.05, 5.05, 0.0), 0.2, "scan")
    lc.update_map(2.05, 5.05, 0.0)
    assert lc.costmap.data[50, 35] == 0
    assert lc.costmap.data[50, 50] == 254
    assert np.argwhere(lc.costmap.data == 254).tolist() == [[50, 50]]


def test_diagonal_ray_cells() -> None:
    lc, layer = _costmap()
    layer.add_scan(scan([math.hypot(1.0, 1.0)], angle_min=math.pi / 4),
                   Pose2D(5.05, 5.05, 0.0), 0.0, "scan")
    lc.update_map(5.05, 5.05, 0.0)
    d = lc.costmap.data
    assert d[60, 60] == 254
    assert all(d[50 + i, 50 + i] == 0 for i in range(10))
    assert int((d == 0).sum()) == 10


def test_obstacle_max_range() -> None:
    lc, layer = _costmap(obstacle_max_range=2.0)
    layer.add_scan(scan([2.5, 1.9], angle_min=0.0, increment=math.pi / 2),
                   Pose2D(5.05, 5.05, 0.0), 0.2, "scan")
    lc.update_map(5.05, 5.05, 0.0)
    d = lc.costmap.data
    assert d[50, 75] == 255  # 2.5 m >= obstacle_max_range: not marked ...
    assert np.all(d[50, 50:75] == 0)  # ... but still cleared up to it
    assert d[69, 50] == 254  # 1.9 m: marked


def test_layer_height_limits() -> None:
    lc, layer = _costmap(layer_kw={"min_obstacle_height": 0.1, "max_obstacle_height": 1.0})
    pts = np.array([[3.05, 5.05, 0.05], [4.05, 5.05, 0.5], [6.05, 5.05, 1.5]], np.float32)
    layer.add_points(pts, (5.05, 5.05, 0.5), "scan")
    lc.update_map(5.05, 5.05, 0.0)
    d = lc.costmap.data
    assert d[50, 40] == 254
    # too low / too high: their rays clear, their end cells are neither cleared nor marked
    assert (d[50, 30], d[50, 60]) == (255, 255)
    assert np.all(d[50, 31:40] == 0) and np.all(d[50, 51:60] == 0)


def test_source_height_limits_drop_points() -> None:
    lc, layer = _costmap(min_obstacle_height=0.2, max_obstacle_height=0.4)
    pts = np.array([[3.05, 5.05, 0.1], [4.05, 5.05, 0.3], [6.05, 5.05, 0.5]], np.float32)
    layer.add_points(pts, (5.05, 5.05, 0.3), "scan")
    lc.update_map(5.05, 5.05, 0.0)
    d = lc.costmap.data
    assert d[50, 40] == 254
    assert d[50, 30] == 255 and d[50, 55] == 255  # filtered points neither mark nor clear


@pytest.mark.parametrize("inf_is_valid", [True, False])
def test_inf_ranges(inf_is_valid: bool) -> None:
    lc, layer = _costmap(inf_is_valid=inf_is_valid, raytrace_max_range=2.0)
    layer.add_scan(scan([1.0], stamp=0.0), Pose2D(5.05, 5.05, 0.0), 0.2, "scan")
    lc.update_map(5.05, 5.05, 0.0)
    assert lc.costmap.data[50, 60] == 254
    layer.add_scan(scan([math.inf], stamp=0.1), Pose2D(5.05, 5.05, 0.0), 0.2, "scan")
    lc.update_map(5.05, 5.05, 0.0)
    d = lc.costmap.data
    if inf_is_valid:  # a clearing-only ray of raytrace_max_range (20 cells)
        assert np.all(d[50, 50:70] == 0) and d[50, 70] == 255
        assert not np.any(d == 254)
    else:  # inf is dropped: nothing cleared, the obstacle stays
        assert d[50, 60] == 254 and d[50, 55] == 0


def test_rolling_window_keeps_obstacle_in_world() -> None:
    lc, layer = _costmap(track_unknown=False, rolling=True, size=60)
    layer.add_scan(scan([1.0], stamp=0.0), Pose2D(0.05, 0.05, 0.0), 0.2, "scan")
    lc.update_map(0.0, 0.0, 0.0)
    cm = lc.costmap
    assert (cm.origin_x, cm.origin_y) == (-3.0, -3.0)
    assert cm.world_to_map(1.05, 0.05) == (40, 30) and cm.cost_at_world(1.05, 0.05) == 254
    layer.add_scan(scan([math.inf], stamp=0.1), Pose2D(0.55, -0.45, 0.0), 0.2, "scan")
    lc.update_map(0.5, -0.5, 0.0)
    assert (cm.origin_x, cm.origin_y) == pytest.approx((-2.5, -3.5))
    assert cm.world_to_map(1.05, 0.05) == (35, 35) and cm.cost_at_world(1.05, 0.05) == 254
    assert np.argwhere(cm.data == 254).tolist() == [[35, 35]]


def _two_obstacles() -> tuple[LayeredCostmap, ObstacleLayer]:
    lc, layer = _costmap(track_unknown=False)
    layer.add_scan(scan([0.5, 2.0], increment=math.pi, stamp=0.0), Pose2D(5.05, 5.05, 0.0),
                   0.2, "scan")
    lc.update_map(5.05, 5.05, 0.0)
    layer.add_scan(scan([math.inf], stamp=0.1), Pose2D(5.05, 5.05, 0.0), 0.2, "scan")
    assert lc.costmap.data[50, 55] == 254 and lc.costmap.data[50, 30] == 254
    return lc, layer


def test_clear_around_and_except_region() -> None:
    lc, _ = _two_obstacles()
    lc.clear_around((5.05, 5.05), 2.0)
    lc.update_map(5.05, 5.05, 0.0)
    assert lc.costmap.data[50, 55] == 0 and lc.costmap.data[50, 30] == 254
    lc, _ = _two_obstacles()
    lc.clear_except_region((5.05, 5.05), 2.0)
    lc.update_map(5.05, 5.05, 0.0)
    assert lc.costmap.data[50, 55] == 254 and lc.costmap.data[50, 30] == 0
    lc, _ = _two_obstacles()
    lc.clear_all()
    lc.update_map(5.05, 5.05, 0.0)
    assert not np.any(lc.costmap.data)


def test_footprint_clearing() -> None:
    lc, layer = _costmap(track_unknown=False, layer_kw={"footprint_clearing_enabled": True})
    lc.set_footprint(Footprint.from_polygon([[0.3, 0.3], [0.3, -0.3], [-0.3, -0.3],
                                             [-0.3, 0.3]]))
    pts = np.array([[5.05, 5.15, 0.5], [5.65, 5.05, 0.5]], np.float32)
    layer.add_points(pts, (5.05, 5.05, 0.5), "scan")
    lc.update_map(5.05, 5.05, 0.0)
    assert lc.costmap.data[51, 50] == 0  # under the robot: cleared
    assert lc.costmap.data[50, 56] == 254


def test_expected_update_rate_and_unknown_source() -> None:
    lc, layer = _costmap(expected_update_rate=0.5)
    layer.add_scan(scan([1.0], stamp=10.0), Pose2D(5.05, 5.05, 0.0), 0.2, "scan")
    assert lc.is_current(10.4) and not lc.is_current(10.6)
    with pytest.raises(UnknownNameError, match="did you mean 'scan'"):
        layer.add_scan(scan([1.0]), Pose2D(0.0, 0.0, 0.0), 0.2, "scna")


def test_observation_persistence() -> None:
    lc, layer = _costmap(track_unknown=False, clearing=False, observation_persistence=1.0)
    layer.add_points(np.array([[6.05, 5.05, 0.5]]), (5.05, 5.05, 0.5), "scan", stamp=0.0)
    layer.add_points(np.array([[4.05, 5.05, 0.5]]), (5.05, 5.05, 0.5), "scan", stamp=0.5)
    lc.update_map(5.05, 5.05, 0.0, now=0.6)
    assert lc.costmap.data[50, 60] == 254 and lc.costmap.data[50, 40] == 254
    assert [o.stamp for o in layer.buffers["scan"].observations(1.2)] == [0.5]


def test_unmapped_padding_widens_what_the_map_does_not_explain() -> None:
    """A return on a mapped wall is marked in its cell (Nav2); a return in space the map
    knows to be free is marked as a disc of unmapped_padding; one next to unknown space
    (a wall a SLAM map has not published) is explained, so it is not widened."""
    from navstack.costmap import StaticLayer

    from .helpers import grid

    lc = LayeredCostmap(100, 100, 0.1, track_unknown_space=True,
                        footprint=Footprint.from_radius(0.1))
    static = lc.add_plugin(StaticLayer())
    assert isinstance(static, StaticLayer)
    m = np.zeros((100, 100), dtype=np.int8)
    m[:, 80] = 100  # a wall along x = 8.0..8.1
    m[:, 90:] = -1  # unknown from x = 9.0
    static.set_map(grid(m, 0.1))
    params = ObstacleLayerParams(observation_sources="scan", footprint_clearing_enabled=False,
                                 unmapped_padding=0.25, unmapped_distance=0.15)
    layer = ObstacleLayer("obstacle_layer", params,
                          {"scan": ObservationSourceParams(**{**SRC,
                                                              "obstacle_max_range": 9.0,
                                                              "raytrace_max_range": 9.0})})
    lc.add_plugin(layer)
    # three beams from (2.05, 5.05): a person at x = 5.05 (free space), the wall's face at
    # x = 8.05, a return at x = 8.95 beside the unknown part of the map
    layer.add_scan(scan([3.0, 6.0 / math.cos(0.1), 6.9 / math.cos(0.2)], angle_min=0.0),
                   Pose2D(2.05, 5.05, 0.0), 0.2, "scan")
    lc.update_map(2.05, 5.05, 0.0)
    data = layer.costmap.data
    lethal = {(int(c), int(r)) for r, c in np.argwhere(data == 254)}
    person = {(50 + dx, 50 + dy) for dx in (-2, -1, 0, 1, 2) for dy in (-2, -1, 0, 1, 2)
              if dx * dx + dy * dy <= 6}  # cell centres within 0.25 m
    assert person <= lethal  # the disc around the person
    wall_y = int((5.05 + 6.0 * math.tan(0.1)) / 0.1)
    assert (80, wall_y) in lethal and (79, wall_y) not in lethal  # the wall: its cell only
    far = (2.05 + 6.9, 5.05 + 6.9 * math.tan(0.2))
    cx, cy = int(far[0] / 0.1), int(far[1] / 0.1)
    assert (cx, cy) in lethal and (cx - 1, cy) not in lethal  # beside unknown: explained
    assert len(lethal) == len(person) + 2
