"""Footprint parameters and footprint cost."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.costmap import Costmap2D, footprint_cost, footprint_costs, make_footprint
from navstack.costmap.footprint import FootprintError, polygon_cells

SQUARE = [[0.2, 0.2], [0.2, -0.2], [-0.2, -0.2], [-0.2, 0.2]]


def _map() -> Costmap2D:
    return Costmap2D(20, 20, 0.1)


def test_make_footprint() -> None:
    fp = make_footprint("[[0.2, 0.1], [0.2, -0.1], [-0.2, -0.1], [-0.2, 0.1]]",
                        footprint_padding=0.01)
    np.testing.assert_allclose(fp.polygon, [[0.21, 0.11], [0.21, -0.11], [-0.21, -0.11],
                                            [-0.21, 0.11]])
    assert fp.inscribed_radius == pytest.approx(0.11)
    disk = make_footprint("[]", robot_radius=0.22, footprint_padding=0.01)
    assert disk.radius == pytest.approx(0.23)
    with pytest.raises(FootprintError) as err:
        make_footprint("[[1, 2]]x")
    assert str(err.value) == ("footprint: footprint '[[1, 2]]x' is not a list of [x, y] pairs "
                              "(use e.g. '[[0.2, 0.15], [0.2, -0.15], [-0.2, -0.15], "
                              "[-0.2, 0.15]]')")


def test_cells_under_square() -> None:
    xs, ys = polygon_cells(_map(), np.array(SQUARE) + np.array([1.05, 1.05]))
    cells = set(zip(xs.tolist(), ys.tolist(), strict=True))
    assert cells == {(x, y) for x in range(8, 13) for y in range(8, 13)}


def test_footprint_cost_known_layout() -> None:
    cm = _map()
    at = (1.05, 1.05, 0.0)  # the square covers cells 8..12 in x and y
    cm.data[10, 10] = 100  # interior cell under the robot centre
    assert footprint_cost(cm, at, SQUARE) == 100
    cm.data[12, 9] = 200  # on the outline
    assert footprint_cost(cm, at, SQUARE) == 200
    cm.data[5, 5] = 254  # elsewhere
    assert footprint_cost(cm, at, SQUARE) == 200
    assert footprint_cost(cm, (0.65, 0.65, 0.0), SQUARE) == 254
    cm.data[11, 11] = 255
    assert footprint_cost(cm, at, SQUARE) == 255  # unknown under the robot
    cm.data[11, 12] = 254
    assert footprint_cost(cm, at, SQUARE) == 254  # lethal beats unknown
    assert footprint_cost(cm, (0.1, 1.0, 0.0), SQUARE) == 254  # vertex off the map


def test_rotated_and_batched() -> None:
    cm = _map()
    cm.data[12, 12] = 50  # square corner cell; outside the 45 deg diamond (|x|+|y| > 0.283)
    cm.data[10, 13] = 60  # holds the diamond's vertex (1.333, 1.05); outside the square
    square, diamond = (1.05, 1.05, 0.0), (1.05, 1.05, math.pi / 4)
    assert footprint_cost(cm, square, SQUARE) == 50
    assert footprint_cost(cm, diamond, SQUARE) == 60
    poses = np.array([square, diamond, [0.1, 0.1, 0.0], [1.55, 1.55, 0.0]])
    batch = footprint_costs(cm, poses, SQUARE)
    assert batch.tolist() == [50, 60, 254, 0]
