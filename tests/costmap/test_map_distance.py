"""MapDistance: the local ``beyond`` query answers exactly as the whole-map transform."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose, Quaternion
from navstack.costmap.map_distance import MapDistance


def _grid(values: np.ndarray, res: float, origin: tuple[float, float, float]) -> OccupancyGrid:
    v = np.asarray(values, dtype=np.int8)
    info = MapMetaData(0.0, res, v.shape[1], v.shape[0],
                       Pose(Point(origin[0], origin[1], 0.0), Quaternion.from_yaw(origin[2])))
    return OccupancyGrid(Header(0.0, "map"), info, v)


@pytest.mark.parametrize("origin", [(0.0, 0.0, 0.0), (-1.3, 2.1, 0.4)])
def test_beyond_matches_the_transform(origin: tuple[float, float, float]) -> None:
    rng = np.random.default_rng(4)
    values = np.zeros((60, 80), dtype=np.int8)
    values[rng.random(values.shape) < 0.02] = 100
    values[rng.random(values.shape) < 0.01] = -1
    values[rng.random(values.shape) < 0.01] = 70  # occupied (>= 65)
    values[rng.random(values.shape) < 0.01] = 50  # free
    reference = MapDistance()
    reference.update(_grid(values, 0.05, origin))
    ox, oy, _ = origin
    xy = np.column_stack((rng.uniform(ox - 3.0, ox + 6.0, 4000),
                          rng.uniform(oy - 3.0, oy + 5.0, 4000)))
    dist = reference.at(xy)
    assert (dist == 0.0).sum() > 100 and np.isfinite(dist).all() and dist.max() > 0.2
    # thresholds on cell-distance boundaries (1, sqrt 2, 2, sqrt 5, ... cells) and between
    for d in (0.0, 0.05, 0.05 * np.sqrt(2.0), 0.1, 0.05 * np.sqrt(5.0), 0.15, 0.17, 0.3):
        md = MapDistance()  # a fresh map each time: the disc lookups, not the transform
        md.update(_grid(values, 0.05, origin))
        np.testing.assert_array_equal(md.beyond(xy[:20], float(d)), dist[:20] > d)
        assert md._distance is None, f"d={d}: 20 points computed the whole-map transform"
        np.testing.assert_array_equal(md.beyond(xy, float(d)), dist > d, err_msg=f"d={d}")
    assert reference.beyond(xy, -0.1).all()


def test_beyond_on_a_map_that_stays_computes_the_transform_once() -> None:
    """A static map asked many times switches to the transform (one lookup per point);
    a new map goes back to the discs."""
    rng = np.random.default_rng(7)
    values = np.zeros((200, 200), dtype=np.int8)
    values[rng.random(values.shape) < 0.03] = 100
    md = MapDistance()
    md.update(_grid(values, 0.05, (0.0, 0.0, 0.0)))
    xy = rng.uniform(0.0, 10.0, (200, 2))
    first = md.beyond(xy, 0.2)
    assert md._distance is None
    answers = [md.beyond(xy, 0.2) for _ in range(40)]
    assert md._distance is not None, "the discs kept looking after 40 x 200 x 49 cells"
    for a in answers:
        np.testing.assert_array_equal(a, first)
    np.testing.assert_array_equal(first, md.at(xy) > 0.2)
    md.update(_grid(values, 0.05, (0.0, 0.0, 0.0)))
    np.testing.assert_array_equal(md.beyond(xy, 0.2), first)
    assert md._distance is None


def test_beyond_without_explained_cells_and_before_a_map() -> None:
    md = MapDistance()
    with pytest.raises(RuntimeError, match="before update"):
        md.beyond(np.zeros((1, 2)), 0.1)
    assert md.distance is None
    md.update(_grid(np.zeros((10, 10)), 0.1, (0.0, 0.0, 0.0)))
    xy = np.array([[0.55, 0.55], [-1.0, 0.5], [0.95, 0.05]])
    np.testing.assert_array_equal(md.beyond(xy, 0.2), [True, False, True])
    np.testing.assert_array_equal(md.at(xy), [np.inf, 0.0, np.inf])
