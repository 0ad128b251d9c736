"""Conditions for missions: what a forward camera could see.

``TargetInView`` is the coverage search's early-stop condition until the perception
issue detects real markers: a target counts as seen when it lies inside the camera's
horizontal field of view, within ``max_range``, with no occupied ``/map`` cell on the line
of sight.  The camera's geometry comes from the robot profile's ``camera`` section
(:class:`CameraGeometry`); the robot pose from TF.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.missions.context import MissionContext
from navstack.runtime.bus import LATCHED

__all__ = ["CameraGeometry", "TargetInView", "line_of_sight"]


@dataclass(frozen=True)
class CameraGeometry:
    """Horizontal field of view [rad], range [m] and mount (x, y, yaw) in base_link."""

    horizontal_fov: float = 1.085595
    max_range: float = 3.0
    mount_x: float = 0.0
    mount_y: float = 0.0
    mount_yaw: float = 0.0

    def pose(self, robot: Pose2D) -> Pose2D:
        return robot.compose(Pose2D(self.mount_x, self.mount_y, self.mount_yaw))


def line_of_sight(grid: OccupancyGrid, a: tuple[float, float], b: tuple[float, float],
                  occupied_threshold: int = 65) -> bool:
    """True when no cell of ``grid`` at or above ``occupied_threshold`` lies on the
    segment from ``a`` to ``b`` (sampled every half cell; the end cell is not checked, so
    a target on an obstacle's face is visible)."""
    info = grid.info
    data = np.asarray(grid.data).reshape(info.height, info.width)
    res = info.resolution
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    n = max(2, math.ceil(length / (0.5 * res)))
    t = np.linspace(0.0, 1.0, n)[:-1]
    xs = a[0] + t * (b[0] - a[0])
    ys = a[1] + t * (b[1] - a[1])
    cols = np.floor((xs - info.origin.position.x) / res).astype(np.int64)
    rows = np.floor((ys - info.origin.position.y) / res).astype(np.int64)
    inside = (rows >= 0) & (rows < info.height) & (cols >= 0) & (cols < info.width)
    end = (math.floor((b[1] - info.origin.position.y) / res),
           math.floor((b[0] - info.origin.position.x) / res))
    not_end = (rows != end[0]) | (cols != end[1])
    keep = inside & not_end
    return not bool(np.any(data[rows[keep], cols[keep]] >= occupied_threshold))


class TargetInView:
    """Stop condition: one of ``targets`` [(x, y) in the map frame] is in view."""

    def __init__(self, ctx: MissionContext, targets: Sequence[tuple[float, float]],
                 camera: CameraGeometry, map_topic: str = "/map") -> None:
        self.ctx = ctx
        self.targets = [(float(x), float(y)) for x, y in targets]
        self.camera = camera
        self.map_topic = map_topic
        self.seen: tuple[float, float] | None = None

    def __call__(self) -> str | None:
        pose = self.ctx.robot_pose()
        grid = self.ctx.latest(self.map_topic, OccupancyGrid, LATCHED)
        if pose is None or grid is None:
            return None
        cam = self.camera.pose(pose)
        for i, (tx, ty) in enumerate(self.targets):
            d = math.hypot(tx - cam.x, ty - cam.y)
            bearing = math.atan2(ty - cam.y, tx - cam.x) - cam.theta
            bearing = math.atan2(math.sin(bearing), math.cos(bearing))
            if (d <= self.camera.max_range and abs(bearing) <= self.camera.horizontal_fov / 2
                    and line_of_sight(grid, (cam.x, cam.y), (tx, ty))):
                self.seen = (tx, ty)
                return (f"target {i + 1} at ({tx:.2f}, {ty:.2f}) seen from "
                        f"({pose.x:.2f}, {pose.y:.2f}), {d:.2f} m away")
        return None
