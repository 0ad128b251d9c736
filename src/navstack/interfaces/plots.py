"""Matplotlib figures for reports: executed trajectory and plans over the map."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path as FsPath

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import OccupancyGrid


@dataclass(frozen=True)
class ZoneOverlay:
    """Cells ``(height, width)`` of a mask raster (``grid``'s geometry) drawn as a zone."""

    grid: OccupancyGrid
    cells: NDArray[np.bool_]
    label: str
    colour: tuple[float, float, float]


def plot_trajectory(grid: OccupancyGrid, trajectory: NDArray[np.float64],
                    plans: list[NDArray[np.float64]], goals: dict[str, tuple[float, float]],
                    out: FsPath, title: str = "",
                    zones: Sequence[ZoneOverlay] = ()) -> None:
    """Draw the map, the zones (translucent), every global plan (thin), the executed path
    (thick) and the goals."""
    info = grid.info
    o = info.origin.position
    extent = (o.x, o.x + info.width * info.resolution, o.y, o.y + info.height * info.resolution)
    img = np.where(grid.data == 100, 0.15, np.where(grid.data < 0, 0.6, 1.0))
    fig, ax = plt.subplots(figsize=(10, 10 * info.height / max(info.width, 1) + 0.8))
    ax.imshow(img, origin="lower", extent=extent, cmap="gray", vmin=0, vmax=1)
    for zone in zones:
        zi = zone.grid.info
        if zone.grid.info.origin.to_pose2d().theta != 0.0 or not zone.cells.any():
            continue  # only axis-aligned masks are drawn
        zo = zi.origin.position
        rgba = np.zeros((*zone.cells.shape, 4))
        rgba[zone.cells] = (*zone.colour, 0.35)
        ax.imshow(rgba, origin="lower", interpolation="nearest",
                  extent=(zo.x, zo.x + zi.width * zi.resolution, zo.y,
                          zo.y + zi.height * zi.resolution))
        ax.plot([], [], "s", color=zone.colour, alpha=0.5, ms=10, label=zone.label)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    for i, plan in enumerate(plans):
        if len(plan):
            ax.plot(plan[:, 0], plan[:, 1], "-", color="tab:blue", lw=0.8, alpha=0.5,
                    label="global plans" if i == 0 else None)
    if len(trajectory):
        ax.plot(trajectory[:, 0], trajectory[:, 1], "-", color="tab:red", lw=2.0,
                label="executed trajectory")
        ax.plot(trajectory[0, 0], trajectory[0, 1], "o", color="tab:green", ms=8, label="start")
    for name, (x, y) in goals.items():
        ax.plot(x, y, "*", color="tab:orange", ms=14)
        ax.annotate(name, (x, y), textcoords="offset points", xytext=(6, 6), fontsize=9)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
