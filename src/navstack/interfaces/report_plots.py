"""PNG figures of ``navstack report``: speed and |w| over time, trajectory over the map."""

from __future__ import annotations

from pathlib import Path as FsPath

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Pose2D
from navstack.interfaces.plots import plot_trajectory
from navstack.interfaces.report_data import BagData

FloatArray = NDArray[np.float64]


def _goal_lines(ax: plt.Axes, data: BagData) -> None:
    for g in data.goals:
        if g.end is not None:
            ax.axvline(g.end, color="tab:gray", lw=0.8, ls="--")
            ax.annotate(f"goal {g.index} {g.status.lower()}", (g.end, 1.0),
                        xycoords=("data", "axes fraction"), rotation=90, va="top",
                        ha="right", fontsize=7, color="tab:gray")


def plot_series(data: BagData, out: FsPath, *, angular: bool) -> FsPath:
    """Actual (trajectory twist) and commanded (``/cmd_vel``) speed or |w| over time."""
    fig, ax = plt.subplots(figsize=(10, 3.6))
    traj = data.trajectory
    if traj is not None and len(traj.t):
        actual = np.abs(traj.wz) if angular else traj.speed
        ax.plot(traj.t, actual, color="tab:red", lw=1.2, label=f"actual ({traj.topic})")
    if len(data.cmd_t):
        cmd = np.abs(data.cmd_wz) if angular else data.cmd_vx
        ax.plot(data.cmd_t, cmd, color="tab:blue", lw=0.8, alpha=0.7, label="commanded (/cmd_vel)")
    _goal_lines(ax, data)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|w| [rad/s]" if angular else "speed [m/s]")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


def _blank_grid(xy: FloatArray) -> OccupancyGrid:
    """An all-unknown grid around the trajectory when the bag has no map."""
    res = 0.05
    lo = (xy.min(axis=0) - 1.0) if len(xy) else np.array([-1.0, -1.0])
    hi = (xy.max(axis=0) + 1.0) if len(xy) else np.array([1.0, 1.0])
    w, h = (int(np.ceil(v)) for v in (hi - lo) / res)
    info = MapMetaData(0.0, res, w, h, Pose2D(float(lo[0]), float(lo[1]), 0.0).to_pose())
    return OccupancyGrid(Header(0.0, "map"), info, np.full((h, w), -1, np.int8))


def plot_map(data: BagData, out: FsPath) -> FsPath:
    """The executed trajectory, the global plans and the goals over ``/map``."""
    traj = data.trajectory
    xy = traj.xy if traj is not None else np.zeros((0, 2))
    grid = data.grid if data.grid is not None else _blank_grid(xy)
    goals = {f"goal {g.index}": g.xy for g in data.goals if g.xy is not None}
    source = traj.topic if traj is not None else "no trajectory"
    plot_trajectory(grid, xy, data.plans, goals, out,
                    title=f"{data.path.name}: trajectory from {source}")
    return out
