"""Keepout filter and the mask value conversion (Nav2 costmap filters)."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import CostmapFilterInfo, Pose2D
from navstack.costmap import KeepoutFilter, LayeredCostmap
from navstack.costmap.costmap_filter import SPEED_FILTER_PERCENT, filter_values
from navstack.costmap.keepout_filter import KeepoutFilterParams, mask_to_costs

from .helpers import grid


def _keepout(**kw: object) -> tuple[LayeredCostmap, KeepoutFilter]:
    lc = LayeredCostmap(20, 20, 0.1)
    f = KeepoutFilter(params=KeepoutFilterParams(**kw))
    lc.add_filter(f)
    mask = np.zeros((10, 10), np.int8)
    mask[2:4, 2:4] = 100
    mask[6, 6] = 50
    mask[8, 8] = -1
    f.set_mask(grid(mask, 0.1, origin=(0.5, 0.5)))
    return lc, f


def test_keepout_marks_lethal_and_copies_intermediate_costs() -> None:
    lc, _ = _keepout()
    lc.update_map(0.1, 0.1, 0.0)
    d = lc.costmap.data
    assert np.argwhere(d == 254).tolist() == [[7, 7], [7, 8], [8, 7], [8, 8]]
    assert d[11, 11] == 127  # round(50 * 254 / 100)
    assert d[13, 13] == 0  # unknown mask cell: master untouched
    assert int((d > 0).sum()) == 5


def test_keepout_mask_conversion_and_override() -> None:
    assert mask_to_costs(np.array([-1, 0, 1, 50, 99, 100], np.int8)).tolist() == [
        255, 0, 3, 127, 251, 254]
    lc, _ = _keepout(override_lethal_cost=True, lethal_override_cost=240)
    lc.update_map(0.75, 0.75, 0.0)  # robot inside the keepout zone
    assert lc.costmap.data[7, 7] == 240
    lc.update_map(0.1, 0.1, 0.0)
    assert lc.costmap.data[7, 7] == 254


def test_keepout_rejects_scaled_filter_info() -> None:
    _, f = _keepout()
    with pytest.raises(ConfigError, match=r"needs base 0\.0 and multiplier 1\.0"):
        f.set_filter_info(CostmapFilterInfo(type=0, base=1.0, multiplier=2.0))
    with pytest.raises(ConfigError, match=r"got filter type 1 \(speed limit in percent"):
        f.set_filter_info(CostmapFilterInfo(type=SPEED_FILTER_PERCENT))


def test_filter_values_are_base_plus_multiplier_times_mask_value() -> None:
    info = CostmapFilterInfo(type=SPEED_FILTER_PERCENT, base=100.0, multiplier=-1.0)
    out = filter_values(np.array([0, 1, 70, 100, -1], np.int8), info)
    assert out[:4].tolist() == [100.0, 99.0, 30.0, 0.0]
    assert np.isnan(out[4])  # unknown stays unknown


def test_keepout_cells_are_lethal_in_the_master_grid_with_mask_in_another_frame() -> None:
    lc = LayeredCostmap(40, 40, 0.1, origin=(-1.0, -1.0), frame_id="odom")
    f = KeepoutFilter()
    lc.add_filter(f)
    mask = np.zeros((20, 20), np.int8)
    mask[5:10, 5:10] = 100  # a 0.5 m zone at map (0.5..1.0, 0.5..1.0)
    f.set_mask(grid(mask, 0.1), CostmapFilterInfo(), mask_in_costmap=Pose2D(-0.5, -0.5, 0.0))
    lc.update_map(0.0, 0.0, 0.0)
    lethal = np.argwhere(lc.costmap.data == 254)
    # map (0.5..1.0) is odom (0.0..0.5): costmap cells 10..14 on both axes
    assert lethal.min(axis=0).tolist() == [10, 10] and lethal.max(axis=0).tolist() == [14, 14]
    assert len(lethal) == 25
    # localization moves the map 0.3 m in +x: the zone is rewritten where it now is
    f.set_mask_in_costmap(Pose2D(-0.2, -0.5, 0.0))
    lc.update_map(0.0, 0.0, 0.0)
    lethal = np.argwhere(lc.costmap.data == 254)
    assert lethal.min(axis=0).tolist() == [10, 13] and lethal.max(axis=0).tolist() == [14, 17]
    assert len(lethal) == 25
