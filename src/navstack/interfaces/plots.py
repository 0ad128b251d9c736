"""Matplotlib figures for reports: executed trajectory and plans over the map."""

from __future__ import annotations

from pathlib import Path as FsPath

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import OccupancyGrid


def plot_trajectory(grid: OccupancyGrid, trajectory: NDArray[np.float64],
                    plans: list[NDArray[np.float64]], goals: dict[str, tuple[float, float]],
                    out: FsPath, title: str = "") -> None:
    """Draw the map, every global plan (thin), the executed path (thick) and the goals."""
    info = grid.info
    o = info.origin.position
    extent = (o.x, o.x + info.width * info.resolution, o.y, o.y + info.height * info.resolution)
    img = np.where(grid.data == 100, 0.15, np.where(grid.data < 0, 0.6, 1.0))
    fig, ax = plt.subplots(figsize=(10, 10 * info.height / max(info.width, 1) + 0.8))
    ax.imshow(img, origin="lower", extent=extent, cmap="gray", vmin=0, vmax=1)
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
