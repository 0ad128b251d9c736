"""Occupancy grids and costmaps as palette PNG images for the dashboard.

An ``OccupancyGrid`` (int8, 0..100 occupancy / cost, -1 unknown; row 0 at the grid origin)
becomes an 8-bit palette PNG whose top row is the grid's last row, so the image reads
north-up like the map and the browser can draw it with one ``drawImage``.  The palette
does the colouring, so encoding is one vectorised cast and a zlib pass (Pillow).

Colours follow RViz's conventions: the ``map`` scheme (free white, occupied black,
unknown grey) and the ``costmap`` scheme (free transparent, rising cost blue -> red,
lethal/inscribed -- every cell at 100 after Nav2's cost-to-occupancy scaling -- purple,
unknown transparent).
"""

from __future__ import annotations

import io
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from navstack.core.msgs import OccupancyGrid

Scheme = Literal["map", "costmap"]
UNKNOWN_INDEX = 255
"""Palette index of unknown cells (int8 -1 viewed as uint8)."""


def _map_palette() -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    rgb = np.zeros((256, 3), np.uint8)
    occ = np.arange(101)
    rgb[:101] = (254 - np.round(occ * 254 / 100)).astype(np.uint8)[:, None]
    rgb[101:] = (205, 205, 205)
    alpha = np.full(256, 255, np.uint8)
    return rgb, alpha


def _costmap_palette() -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    rgb = np.zeros((256, 3), np.uint8)
    alpha = np.zeros(256, np.uint8)
    f = (np.arange(1, 100) - 1) / 98.0  # cost 1 pure blue .. 99 pure red
    rgb[1:100, 0] = np.round(255 * f)
    rgb[1:100, 2] = np.round(255 * (1.0 - f))
    alpha[1:100] = np.round(40 + 110 * f)
    rgb[100] = (200, 0, 200)
    alpha[100] = 150
    return rgb, alpha


_PALETTES = {"map": _map_palette(), "costmap": _costmap_palette()}


def palette(scheme: Scheme) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """``(rgb (256, 3), alpha (256,))`` of a scheme, indexed by the cell value as uint8."""
    return _PALETTES[scheme]


def grid_png(grid: OccupancyGrid, scheme: Scheme) -> bytes:
    """The grid as a north-up palette PNG (width = ``info.width``, height = ``info.height``)."""
    data = np.asarray(grid.data)
    if data.ndim != 2 or data.size == 0:
        raise ValueError(f"cannot draw an empty or non-2D grid (shape {data.shape})")
    index = np.ascontiguousarray(np.flipud(data.astype(np.int8).view(np.uint8)))
    index = np.where(index > 100, UNKNOWN_INDEX, index).astype(np.uint8)
    rgb, alpha = palette(scheme)
    img = Image.frombytes("P", (index.shape[1], index.shape[0]), index.tobytes())
    img.putpalette(rgb.reshape(-1).tolist())
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=False, compress_level=6,
             transparency=alpha.tobytes())
    return buf.getvalue()
