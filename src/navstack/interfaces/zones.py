"""Measure a simulated run against its costmap filter zones (keepout and speed).

The zones are the masks the stack's filter info servers publish
(:mod:`navstack.navigation.costmap_filter_servers`), read the way the filters read them:

* a **keepout zone** is every mask cell the keepout filter makes LETHAL (mask value 100);
  every global plan on ``/plan`` is checked pose by pose (``plan_poses_inside``), and the
  robot's true body -- its footprint polygon filled with points 0.25 m apart -- at every
  sample (``body_samples_inside``);
* a **speed zone** is every mask cell with the same limit ``base + multiplier * v``
  (mask 0 and out-of-range values are "no limit", as in the speed filter).  At every
  sample the *footprint centre* (the centroid of the robot's footprint polygon, placed
  at the simulator's true pose) is looked up; while it lies in a zone the simulator's
  true forward speed ``|vx|`` (base_link, the cart's speedometer) counts for that zone.
  A percent limit caps ``limit / 100 * max_vel_x`` of the robot profile.

Samples are the simulator's ``/ground_truth`` messages (50 Hz on the shipped robots), so
measuring does not change the run; a robot without ground truth is sampled every
``period`` seconds of simulated time instead.

Nav2 applies the limit where ``base_link`` is; the footprint centre of a car-like robot
is ahead of it, so a zone that must be met with the body needs the speed filter's path
lookahead (see ``docs/costmap_filters.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import OccupancyGrid, Odometry, Path
from navstack.core.polygon import points_in_polygon, polygon_area
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.costmap.costmap_filter import (
    KEEPOUT_FILTER,
    SPEED_FILTER_ABSOLUTE,
    SPEED_FILTER_PERCENT,
    filter_values,
)
from navstack.costmap.keepout_filter import mask_to_costs
from navstack.interfaces.plots import ZoneOverlay
from navstack.navigation.costmap_filter_servers import topic_name
from navstack.runtime.bus import QoS

if TYPE_CHECKING:
    from navstack.interfaces.stack import NavStack

BODY_GRID_M = 0.25
"""Spacing of the points that stand for the robot's body in the keepout check [m]."""


def footprint_centroid(polygon: NDArray[np.float64]) -> tuple[float, float]:
    """Area centroid of a simple polygon ``(N, 2)`` (its mean vertex if degenerate)."""
    p = np.asarray(polygon, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    area = polygon_area(p)
    if area < 1e-12:
        return float(p[:, 0].mean()), float(p[:, 1].mean())
    sign = 1.0 if cross.sum() > 0 else -1.0
    cx = float(np.sum((p[:, 0] + q[:, 0]) * cross) / (6.0 * area * sign))
    cy = float(np.sum((p[:, 1] + q[:, 1]) * cross) / (6.0 * area * sign))
    return cx, cy


def body_points(polygon: NDArray[np.float64], spacing: float = BODY_GRID_M
                ) -> NDArray[np.float64]:
    """The polygon's vertices plus grid points ``spacing`` apart inside it (body frame)."""
    p = np.asarray(polygon, dtype=np.float64)
    lo, hi = p.min(axis=0), p.max(axis=0)
    xs = np.arange(lo[0], hi[0] + 1e-9, spacing)
    ys = np.arange(lo[1], hi[1] + 1e-9, spacing)
    gx, gy = np.meshgrid(xs, ys)
    grid = np.column_stack((gx.ravel(), gy.ravel()))
    return np.vstack((p, grid[points_in_polygon(grid, p)]))


def _cells(grid: OccupancyGrid, xy: NDArray[np.float64]
           ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]:
    """``(row, col, on_mask)`` of map-frame points ``(N, 2)`` in the mask raster."""
    info = grid.info
    o = info.origin.to_pose2d()
    c, s = math.cos(o.theta), math.sin(o.theta)
    dx, dy = xy[:, 0] - o.x, xy[:, 1] - o.y
    col = np.floor((c * dx + s * dy) / info.resolution).astype(np.int64)
    row = np.floor((-s * dx + c * dy) / info.resolution).astype(np.int64)
    ok = (col >= 0) & (col < info.width) & (row >= 0) & (row < info.height)
    return row, col, ok


def mask_values(grid: OccupancyGrid, xy: NDArray[np.float64]) -> NDArray[np.int16]:
    """Mask values at map-frame points ``(N, 2)`` (-1 off the mask)."""
    row, col, ok = _cells(grid, xy)
    out = np.full(len(xy), -1, np.int16)
    out[ok] = np.asarray(grid.data)[row[ok], col[ok]]
    return out


@dataclass
class _Zone:
    """Cells of one mask that form a zone, with a map-frame bounding box for a quick
    "nowhere near" test."""

    name: str
    grid: OccupancyGrid
    cells: NDArray[np.bool_] = field(init=False, repr=False)
    box: tuple[float, float, float, float] = field(init=False)

    def _set_cells(self, cells: NDArray[np.bool_]) -> None:
        self.cells = cells
        info = self.grid.info
        rows, cols = np.nonzero(cells)
        if len(rows) == 0:
            self.box = (math.inf, math.inf, -math.inf, -math.inf)
            return
        corners = np.array([[cols.min(), rows.min()], [cols.max() + 1, rows.min()],
                            [cols.min(), rows.max() + 1], [cols.max() + 1, rows.max() + 1]],
                           dtype=np.float64) * info.resolution
        world = info.origin.to_pose2d().transform_points(corners)
        lo, hi = world.min(axis=0), world.max(axis=0)
        self.box = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def near(self, x: float, y: float, radius: float) -> bool:
        """Whether a disc of ``radius`` about ``(x, y)`` can reach the zone."""
        x0, y0, x1, y1 = self.box
        return x0 - radius <= x <= x1 + radius and y0 - radius <= y <= y1 + radius

    def inside(self, xy: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether map-frame points ``(N, 2)`` lie in the zone."""
        row, col, ok = _cells(self.grid, xy)
        out = np.zeros(len(xy), dtype=np.bool_)
        out[ok] = self.cells[row[ok], col[ok]]
        return out


@dataclass
class KeepoutZone(_Zone):
    """The cells a keepout filter makes LETHAL (mask value 100)."""

    plans: int = 0
    plan_poses_inside: int = 0
    body_samples_inside: int = 0

    def __post_init__(self) -> None:
        data = np.asarray(self.grid.data, np.int8)
        self._set_cells(np.asarray(mask_to_costs(data) == LETHAL_OBSTACLE))


@dataclass
class SpeedZone(_Zone):
    """The cells of one speed limit."""

    limit: float = 0.0
    percentage: bool = True
    cap_m_s: float = 0.0
    mask_values: tuple[int, ...] = ()
    samples_inside: int = 0
    max_speed_inside: float = 0.0

    def __post_init__(self) -> None:
        self._set_cells(np.isin(np.asarray(self.grid.data), self.mask_values))


@dataclass
class ZoneMonitor:
    """Samples a running :class:`NavStack` against its zones; see the module docstring."""

    stack: NavStack
    period: float = 0.02
    keepout: list[KeepoutZone] = field(default_factory=list)
    speed: list[SpeedZone] = field(default_factory=list)

    def __post_init__(self) -> None:
        servers = self.stack.filter_servers
        max_speed = abs(float(self.stack.robot.kinematics.max_vel_x))
        for name, server in servers.info_servers.items():
            p = server.params
            grid = servers.mask_for(name)
            if p.type == KEEPOUT_FILTER:
                self.keepout.append(KeepoutZone(name, grid))
            elif p.type in (SPEED_FILTER_PERCENT, SPEED_FILTER_ABSOLUTE):
                self.speed.extend(_speed_zones(name, grid, server.info, max_speed))
        polygon = self.stack.sim.sim.footprint.polygon
        self._centre = np.array(footprint_centroid(polygon))
        self._body = body_points(polygon)
        self._reach = float(np.max(np.hypot(self._body[:, 0], self._body[:, 1])))
        if self:
            bus = self.stack.runtime.bus
            bus.subscribe(topic_name("plan"), Path, self._on_plan)
            truth = self.stack.robot.sensors.ground_truth
            if truth.enabled and truth.frame_id == "map":
                # the simulator's own truth samples: measuring does not perturb the run
                bus.subscribe(topic_name(truth.topic), Odometry, self._on_truth,
                              QoS(depth=100))
            else:
                self.stack.runtime.scheduler.create_timer(self.period, self.sample,
                                                          first_at=self.stack.now)

    def __bool__(self) -> bool:
        return bool(self.keepout or self.speed)

    def _on_plan(self, plan: Path) -> None:
        xy = plan.as_array()[:, :2]
        for zone in self.keepout:
            zone.plans += 1
            zone.plan_poses_inside += int(np.count_nonzero(zone.inside(xy)))

    def _on_truth(self, odom: Odometry) -> None:
        p = odom.pose.pose
        self.measure(p.position.x, p.position.y, p.orientation.yaw,
                     odom.twist.twist.linear.x)

    def sample(self) -> None:
        """Sample the simulator's true state now (when it publishes no ground truth)."""
        sim = self.stack.sim
        sim.advance()
        s = sim.sim.state
        self.measure(s.x, s.y, s.yaw, s.vx)

    def measure(self, x: float, y: float, yaw: float, vx: float) -> None:
        """One sample: true pose of base_link in the map frame and forward speed."""
        c, si = math.cos(yaw), math.sin(yaw)
        rot = np.array([[c, -si], [si, c]])
        body: NDArray[np.float64] | None = None
        for k in self.keepout:
            if k.near(x, y, self._reach):
                body = self._body @ rot.T + (x, y) if body is None else body
                k.body_samples_inside += int(bool(k.inside(body).any()))
        cx, cy = rot @ self._centre + (x, y)
        for z in self.speed:
            if z.near(cx, cy, 0.0) and z.inside(np.array([[cx, cy]]))[0]:
                z.samples_inside += 1
                z.max_speed_inside = max(z.max_speed_inside, abs(vx))

    def summary(self) -> dict[str, Any]:
        """The figures for the demo report."""
        return {
            "keepout": [{"name": k.name, "cells": int(k.cells.sum()), "plans": k.plans,
                         "plan_poses_inside": k.plan_poses_inside,
                         "body_samples_inside": k.body_samples_inside} for k in self.keepout],
            "speed": [{"name": z.name, "limit": z.limit,
                       "unit": "%" if z.percentage else "m/s",
                       "cap_m_s": round(z.cap_m_s, 4), "samples_inside": z.samples_inside,
                       "max_speed_inside_m_s": round(z.max_speed_inside, 4)}
                      for z in self.speed],
            "sample_period_s": self.period,
        }


def _speed_zones(name: str, grid: OccupancyGrid, info: Any, max_speed: float
                 ) -> list[SpeedZone]:
    values = np.unique(np.asarray(grid.data))
    values = values[values > 0]
    limits = filter_values(values, info)
    percentage = info.type == SPEED_FILTER_PERCENT
    by_limit: dict[float, list[int]] = {}
    for v, limit in zip(values.tolist(), limits.tolist(), strict=True):
        top = 100.0 if percentage else math.inf
        if 0.0 < limit <= top:
            by_limit.setdefault(float(limit), []).append(int(v))
    zones = []
    for limit, vals in sorted(by_limit.items()):
        cap = limit / 100.0 * max_speed if percentage else limit
        zones.append(SpeedZone(name, grid, limit=limit, percentage=percentage, cap_m_s=cap,
                               mask_values=tuple(vals)))
    return zones


SPEED_TOLERANCE = 0.05
"""A speed zone is respected while the measured speed stays within cap * (1 + this)."""


def zones_respected(summary: dict[str, Any]) -> bool:
    """No plan pose and no body sample in a keepout zone; every speed zone within its
    cap + :data:`SPEED_TOLERANCE`."""
    keep = all(k["plan_poses_inside"] == 0 and k["body_samples_inside"] == 0
               for k in summary.get("keepout", []))
    speed = all(z["max_speed_inside_m_s"] <= z["cap_m_s"] * (1.0 + SPEED_TOLERANCE)
                for z in summary.get("speed", []))
    return keep and speed


def zone_lines(summary: dict[str, Any] | None) -> list[str]:
    """One human-readable line per zone (demo output and report.md)."""
    if not summary:
        return []
    lines = [f"keepout zone ({k['name']}, {k['cells']} cells): {k['plan_poses_inside']} of "
             f"the poses of {k['plans']} plans inside, body inside in "
             f"{k['body_samples_inside']} samples" for k in summary.get("keepout", [])]
    for z in summary.get("speed", []):
        limit = f"{z['limit']:g} {z['unit']}"
        lines.append(f"speed zone {limit} ({z['name']}): max true speed inside "
                     f"{z['max_speed_inside_m_s']:.3f} m/s, cap {z['cap_m_s']:.3f} m/s "
                     f"(+{SPEED_TOLERANCE:.0%}), {z['samples_inside']} samples inside")
    return lines


def zone_overlays(monitor: ZoneMonitor) -> list[ZoneOverlay]:
    """The zones for :func:`~navstack.interfaces.plots.plot_trajectory`."""
    out = [ZoneOverlay(k.grid, k.cells, "keepout zone", (0.85, 0.1, 0.1))
           for k in monitor.keepout]
    for z in monitor.speed:
        unit = "%" if z.percentage else " m/s"
        out.append(ZoneOverlay(z.grid, z.cells, f"speed zone {z.limit:g}{unit}",
                               (1.0, 0.6, 0.0)))
    return out
