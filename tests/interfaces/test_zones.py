"""Zone measurement helpers of the demo report (navstack.interfaces.zones)."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose
from navstack.interfaces.zones import (
    body_points,
    footprint_centroid,
    mask_values,
    zone_lines,
    zones_respected,
)

CART = np.array([[2.65, 0.6], [2.65, -0.6], [-0.25, -0.6], [-0.25, 0.6]])


def test_footprint_centroid_of_the_cart_and_a_triangle() -> None:
    assert footprint_centroid(CART) == pytest.approx((1.2, 0.0))
    assert footprint_centroid(CART[::-1]) == pytest.approx((1.2, 0.0))  # either winding
    tri = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    assert footprint_centroid(tri) == pytest.approx((1.0, 1.0))


def test_body_points_cover_the_footprint() -> None:
    pts = body_points(CART, 0.25)
    assert pts[:4].tolist() == CART.tolist()
    inner = pts[4:]
    assert inner[:, 0].min() >= -0.25 and inner[:, 0].max() <= 2.65
    assert np.abs(inner[:, 1]).max() <= 0.6
    assert len(inner) == 12 * 5  # x -0.25, 0.0, ..., 2.5 (12) by y -0.6, ..., 0.4 (5)


def test_mask_values_at_map_points() -> None:
    data = np.arange(6, dtype=np.int8).reshape(2, 3)
    grid = OccupancyGrid(Header(0.0, "map"),
                         MapMetaData(0.0, 0.5, 3, 2, Pose(Point(1.0, 1.0, 0.0))), data)
    xy = np.array([[1.1, 1.1], [2.4, 1.9], [0.9, 1.1], [1.6, 2.1]])
    assert mask_values(grid, xy).tolist() == [0, 5, -1, -1]


def _summary(plan_in: int = 0, body_in: int = 0, speed: float = 0.75) -> dict[str, object]:
    return {"keepout": [{"name": "k", "cells": 10, "plans": 3, "plan_poses_inside": plan_in,
                         "body_samples_inside": body_in}],
            "speed": [{"name": "s", "limit": 30.0, "unit": "%", "cap_m_s": 0.75,
                       "samples_inside": 40, "max_speed_inside_m_s": speed}]}


def test_zones_respected_within_the_five_percent_tolerance() -> None:
    assert zones_respected(_summary())
    assert zones_respected(_summary(speed=0.7875))
    assert not zones_respected(_summary(speed=0.79))
    assert not zones_respected(_summary(plan_in=1))
    assert not zones_respected(_summary(body_in=1))
    assert zone_lines(_summary(speed=0.79)) == [
        "keepout zone (k, 10 cells): 0 of the poses of 3 plans inside, body inside in 0 "
        "samples",
        "speed zone 30 % (s): max true speed inside 0.790 m/s, cap 0.750 m/s (+5%), 40 "
        "samples inside"]
    assert zone_lines(None) == []
