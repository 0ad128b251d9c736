"""Small costmaps and a shared robot for the Hybrid-A* tests."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D
from navstack.costmap.inflation_kernel import cell_distance, cost_lut

RES = 0.1
ORIGIN = (-3.0, -3.0)
ROBOT = Footprint.from_polygon([[0.25, 0.2], [0.25, -0.2], [-0.25, -0.2], [-0.25, 0.2]])
INFLATION = (0.55, 5.0)  # inflation_radius [m], cost_scaling_factor


def costmap(occupied: NDArray[np.bool_], footprint: Footprint = ROBOT) -> Costmap2D:
    """Lethal cells where ``occupied[my, mx]``, inflated with the InflationLayer's cost
    table (exact squared cell distances from scipy's EDT, so the tests need not compile
    the costmap's numba kernel)."""
    r = cell_distance(INFLATION[0], RES)
    lut = cost_lut(r, RES, footprint.inscribed_radius, INFLATION[1])
    d2 = np.rint(ndimage.distance_transform_edt(~occupied) ** 2).astype(np.int64)
    data = lut[np.minimum(d2, r * r + 1)]
    return Costmap2D.from_array(data, RES, *ORIGIN)


def cell(x: float, y: float) -> tuple[int, int]:
    """Cell ``(mx, my)`` of a world point on these maps."""
    return int((x - ORIGIN[0]) / RES), int((y - ORIGIN[1]) / RES)


def empty(width_m: float = 16.0, height_m: float = 6.0) -> Costmap2D:
    return costmap(np.zeros((round(height_m / RES), round(width_m / RES)), dtype=bool))


def wall() -> Costmap2D:
    """12 m x 9 m room; a 0.2 m wall at x = 3 m rises from the bottom edge to y = 2.5 m."""
    occ = np.zeros((90, 120), dtype=bool)
    x0, y1 = cell(3.0, 2.5)
    occ[:y1, x0:x0 + 2] = True
    return costmap(occ)


def dead_end() -> Costmap2D:
    """An 8 m corridor (1 m wide, y in [-0.5, 0.5], closed at x = 8 m) off a 3 m x 9 m hall
    (x in [-3, 0])."""
    occ = np.zeros((90, 160), dtype=bool)
    xa, yb = cell(0.0, -0.5)
    xe, yt = cell(8.0, 0.5)
    occ[:yb, xa:] = True          # below the corridor
    occ[yt:, xa:] = True          # above the corridor
    occ[:, xe:] = True            # the dead end
    return costmap(occ)
