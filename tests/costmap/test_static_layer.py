"""Static layer: trinary translation, master resize, resampling, frames."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.msgs import Pose2D
from navstack.costmap import LayeredCostmap, StaticLayer
from navstack.costmap.static_layer import translate_occupancy

from .helpers import grid

VALUES = np.array([[-1, 0, 50, 99, 100]], np.int8)


@pytest.mark.parametrize(("track", "expected"), [(True, [255, 0, 0, 0, 254]),
                                                 (False, [0, 0, 0, 0, 254])])
def test_trinary_translation_through_the_costmap(track: bool, expected: list[int]) -> None:
    lc = LayeredCostmap(5, 1, 1.0, track_unknown_space=track)
    layer = lc.add_plugin(StaticLayer())
    assert isinstance(layer, StaticLayer)
    layer.set_map(grid(VALUES, 1.0))
    lc.update_map(0.0, 0.0, 0.0)
    assert lc.costmap.data[0].tolist() == expected


def test_scaled_translation_and_threshold() -> None:
    out = translate_occupancy(VALUES, trinary_costmap=False, track_unknown_space=True)
    assert out[0].tolist() == [255, 0, 127, 251, 254]  # int(v / 100 * 254)
    low = translate_occupancy(VALUES, lethal_cost_threshold=50, track_unknown_space=True)
    assert low[0].tolist() == [255, 0, 254, 254, 254]
    minus_one = translate_occupancy(VALUES, unknown_cost_value=-1, track_unknown_space=True)
    assert minus_one[0].tolist() == [255, 0, 0, 0, 254]


def test_global_costmap_takes_the_map_extent() -> None:
    lc = LayeredCostmap(10, 10, 0.1)
    layer = lc.add_plugin(StaticLayer())
    assert isinstance(layer, StaticLayer)
    m = np.zeros((30, 40), np.int8)
    m[5, 7] = 100
    layer.set_map(grid(m, 0.05, origin=(-1.0, 2.0)))
    cm = lc.costmap
    assert (cm.size_x, cm.size_y, cm.resolution, cm.origin_x, cm.origin_y) == (
        40, 30, 0.05, -1.0, 2.0)
    lc.update_map(0.0, 2.5, 0.0)
    assert np.argwhere(cm.data == 254).tolist() == [[5, 7]]


def test_rolling_window_resamples_nearest() -> None:
    m = np.zeros((20, 20), np.int8)  # 0.1 m cells, obstacle cell covers [0.5, 0.6) x [0.3, 0.4)
    m[3, 5] = 100
    lc = LayeredCostmap(40, 40, 0.05, rolling_window=True)
    layer = lc.add_plugin(StaticLayer())
    assert isinstance(layer, StaticLayer)
    layer.set_map(grid(m, 0.1))
    lc.update_map(1.0, 1.0, 0.0)  # window [0, 2) x [0, 2) at 0.05 m
    assert (lc.costmap.origin_x, lc.costmap.origin_y) == (0.0, 0.0)
    assert sorted(map(tuple, np.argwhere(lc.costmap.data == 254).tolist())) == [
        (6, 10), (6, 11), (7, 10), (7, 11)]


def test_map_in_another_frame() -> None:
    m = np.zeros((10, 10), np.int8)
    m[2, 3] = 100  # map-frame cell centre (0.35, 0.25)
    lc = LayeredCostmap(20, 20, 0.1, origin=(-1.0, -1.0), frame_id="odom",
                        rolling_window=True)
    layer = lc.add_plugin(StaticLayer())
    assert isinstance(layer, StaticLayer)
    layer.set_map(grid(m, 0.1), map_in_costmap=Pose2D(-0.5, 0.0, 0.0))
    lc.update_map(0.0, 0.0, 0.0)
    assert lc.costmap.cost_at_world(-0.15, 0.25) == 254
    assert int((lc.costmap.data == 254).sum()) == 1
