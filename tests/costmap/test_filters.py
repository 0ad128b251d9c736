"""Keepout and speed filters (Nav2 costmap filters)."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.costmap import KeepoutFilter, LayeredCostmap, SpeedFilter
from navstack.costmap.costmap_filter import (
    SPEED_FILTER_ABSOLUTE,
    SPEED_FILTER_PERCENT,
    CostmapFilterInfo,
)
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
        f.set_mask(f.mask, CostmapFilterInfo(0, "/mask", 1.0, 2.0))  # type: ignore[arg-type]


def _speed(info: CostmapFilterInfo) -> tuple[LayeredCostmap, SpeedFilter]:
    lc = LayeredCostmap(10, 10, 0.5)
    f = SpeedFilter()
    lc.add_filter(f)
    mask = np.array([[0, 30, 90], [-1, 10, 100]], np.int8)
    f.set_mask(grid(mask, 1.0), info)
    return lc, f


def test_speed_limit_percent() -> None:
    lc, f = _speed(CostmapFilterInfo(SPEED_FILTER_PERCENT, "/mask", 0.0, 1.0))
    assert f.speed_limit_at(1.5, 0.5) == (30.0, True)
    assert f.speed_limit_at(0.5, 0.5) is None  # 0: no limit
    assert f.speed_limit_at(0.5, 1.5) is None  # -1: unknown
    assert f.speed_limit_at(5.0, 5.0) is None  # off the mask
    lc.update_map(2.5, 1.5, 0.0)
    assert f.current_speed_limit == (100.0, True)
    _, g = _speed(CostmapFilterInfo(SPEED_FILTER_PERCENT, "/mask", 20.0, 1.0))
    assert g.speed_limit_at(1.5, 0.5) == (50.0, True)
    assert g.speed_limit_at(2.5, 0.5) is None  # 110 % is out of [0, 100]: no limit


def test_speed_limit_absolute() -> None:
    _, f = _speed(CostmapFilterInfo(SPEED_FILTER_ABSOLUTE, "/mask", 0.1, 0.01))
    limit = f.speed_limit_at(1.5, 1.5)
    assert limit is not None and limit[0] == pytest.approx(0.2) and limit[1] is False
    _, g = _speed(CostmapFilterInfo(SPEED_FILTER_ABSOLUTE, "/mask", -1.0, 0.01))
    assert g.speed_limit_at(1.5, 0.5) is None  # negative speed: no limit
    with pytest.raises(ConfigError, match="got filter type 0"):
        g.set_mask(g.mask, CostmapFilterInfo(0))  # type: ignore[arg-type]
