"""sample_window's fast paths give exactly the cells points_to_cells gives."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.msgs import MapMetaData, Point, Pose, Pose2D, Quaternion
from navstack.costmap.grid_sampling import points_to_cells, sample_window, window_centres


def _reference(values: np.ndarray, info: MapMetaData, origin: tuple[float, float],
               res: float, window: tuple[int, int, int, int],
               t: Pose2D | None) -> tuple[np.ndarray, np.ndarray]:
    x0, y0, x1, y1 = window
    pts = window_centres(origin[0], origin[1], res, x0, y0, x1, y1)
    col, row, inside = points_to_cells(pts, info, t)
    out = np.zeros(len(pts), values.dtype)
    out[inside] = values[row[inside], col[inside]]
    return out.reshape(y1 - y0, x1 - x0), inside.reshape(y1 - y0, x1 - x0)


@pytest.mark.parametrize("yaw, t", [
    (0.0, None), (0.0, Pose2D(-7.0253, -6.9801, 0.0)),  # axis-aligned: per row / column
    (0.0, Pose2D(-7.0253, -6.9801, -0.00283)), (0.3, None),  # rotated: numba kernel
    (0.3, Pose2D(1.5, -2.25, 2.0))])
def test_sample_window_matches_points_to_cells(yaw: float, t: Pose2D | None) -> None:
    rng = np.random.default_rng(4)
    values = rng.integers(0, 255, size=(37, 53), dtype=np.uint8)
    info = MapMetaData(0.0, 0.5, 53, 37, Pose(Point(-3.0, 1.25, 0.0), Quaternion.from_yaw(yaw)))
    window = (3, 5, 250, 180)
    got = sample_window(values, info, -12.3, -4.1, 0.1, window, t)
    want = _reference(values, info, (-12.3, -4.1), 0.1, window, t)
    assert np.array_equal(got[1], want[1]) and want[1].sum() > 1000
    assert np.array_equal(got[0], want[0])
    assert got[0].dtype == np.uint8
